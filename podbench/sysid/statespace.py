"""State-space realization from Markov parameters: the Eigensystem Realization Algorithm
(ERA; Juang & Pappa 1985, "Eq. 3" below is that paper's realization formula).

Shared by the ERA/OKID peer (:mod:`podbench.sysid.methods.peers.era`) and the
``realization`` and ``subspace`` deconvolution solvers
(:mod:`podbench.sysid.deconvolution.realization`), which realize a low-order model of a
pilot kernel; kept here, below both, so that the solvers do not depend on a method.
"""

from __future__ import annotations

import numpy as np

from podbench.errors import InputError


def era_realization(h, blocks: int):
    """Hankel SVD of ERA (Eq. 3): the factors from which every order is realized.

    Parameters
    ----------
    h : (L, k_out, k_in) ndarray
        Markov parameters ``h_0 … h_{L−1}`` with ``L ≥ 2·blocks + 1``.
    blocks : int
        Block rows = block columns ``s`` of the Hankel matrices.

    Returns
    -------
    P, sv, Qt, H1 : ndarrays
        ``H(0) = P diag(sv) Qt`` and the shifted Hankel matrix ``H(1)``.
    """
    L, k_out, k_in = h.shape
    s = blocks
    if L < 2 * s + 1:
        raise InputError(f"Parameter `blocks`: {s} block rows need {2 * s + 1} Markov "
                         f"parameters, got {L}")
    idx = np.arange(s)[:, None] + np.arange(s)[None, :]
    H0 = h[idx + 1].transpose(0, 2, 1, 3).reshape(s * k_out, s * k_in)
    H1 = h[idx + 2].transpose(0, 2, 1, 3).reshape(s * k_out, s * k_in)
    P, sv, Qt = np.linalg.svd(H0, full_matrices=False)
    return P, sv, Qt, H1


def realize(P, sv, Qt, H1, D,
            order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of order ``N`` from :func:`era_realization` (Eq. 3)."""
    k_out, k_in = D.shape
    N = order
    s_half = np.sqrt(sv[:N])
    PN = P[:, :N] / s_half  # P_N Σ^{-1/2}
    QN = Qt[:N].T / s_half
    A = PN.T @ H1 @ QN
    B = (Qt[:N, :k_in].T * s_half).T
    C = P[:k_out, :N] * s_half
    return A, B, C, D.copy()


SIMULATION_BLOCK = 128
"""Samples per block of :func:`simulate_blocks`."""


def _block_operators(A, B, C, L: int):
    """``O[j] = C A^j``, ``G[j] = A^j B`` for ``j < L`` and ``A^L``."""
    N = A.shape[0]
    O = np.empty((L, C.shape[0], N))
    G = np.empty((L, N, B.shape[1]))
    CA, AB, AL = C.astype(float), B.astype(float), np.eye(N)
    for j in range(L):
        O[j], G[j] = CA, AB
        CA, AB, AL = CA @ A, A @ AB, AL @ A
    return O, G, AL


def simulate_blocks(A, B, C, D, U_in, block: int = SIMULATION_BLOCK) -> np.ndarray:
    """Zero-state response of ``x_{j+1} = A x_j + B u_j``, ``y_j = C x_j + D u_j``, a
    block of ``L`` samples at a time.

    Within a block starting at sample ``bL`` the response is the free response of the
    block's initial state plus the block's own input through the first ``L`` Markov
    parameters, ``y_{bL+j} = C A^j x_{bL} + Σ_{i≤j} h_{j−i} u_{bL+i}`` (``h_0 = D``,
    ``h_i = C A^{i−1} B``), and the state advances by ``x_{(b+1)L} = A^L x_{bL} +
    Σ_i A^{L−1−i} B u_{bL+i}``: the same recursion as the sample-by-sample loop, as
    matrix products, so that a Python loop runs ``n/L + L`` steps instead of ``n``. Equal
    to the loop to round-off (the products are summed in another order).

    Parameters
    ----------
    A : (N, N) ndarray
    B : (N, k_in) ndarray
    C : (k_out, N) ndarray
    D : (k_out, k_in) ndarray
    U_in : (k_in, n) or (R, k_in, n) ndarray
        Inputs of one record, or of ``R`` records at once; ``x_0 = 0``.
    block : int
        Samples per block ``L`` (at most ``n``).

    Returns
    -------
    (k_out, n) or (R, k_out, n) ndarray
    """
    U_in = np.asarray(U_in, dtype=float)
    single = U_in.ndim == 2
    Us = U_in[None] if single else U_in
    R, m, n = Us.shape
    N, p = A.shape[0], C.shape[0]
    L = max(1, min(int(block), n))
    nb = -(-n // L)
    Ub = np.zeros((R, m, nb * L))
    Ub[:, :, :n] = Us
    Ub = Ub.reshape(R, m, nb, L).transpose(0, 2, 3, 1).reshape(R, nb, L * m)  # (i, m)
    with np.errstate(over="ignore", invalid="ignore"):
        O, G, AL = _block_operators(A, B, C, L)
        h = np.concatenate([np.asarray(D, dtype=float)[None], O[:L - 1] @ B])  # (L, p, m)
        lag = np.arange(L)[:, None] - np.arange(L)[None, :]  # j − i
        T = np.where((lag >= 0)[:, :, None, None], h[np.maximum(lag, 0)], 0.0)
        T = T.transpose(0, 2, 1, 3).reshape(L * p, L * m)  # rows (j, p), columns (i, m)
        K = G[::-1].transpose(1, 0, 2).reshape(N, L * m)  # A^{L−1−i} B
        Z = Ub @ K.T  # (R, nb, N): each block's input carried to the next block's state
        X = np.empty((R, nb, N))  # the blocks' initial states, as rows
        x = np.zeros((R, N))
        ALt = AL.T
        for b in range(nb):
            X[:, b] = x
            x = x @ ALt + Z[:, b]
        Y = X @ O.reshape(L * p, N).T + Ub @ T.T  # (R, nb, L·p)
    Y = Y.reshape(R, nb, L, p).transpose(0, 3, 1, 2).reshape(R, p, nb * L)[:, :, :n]
    return Y[0] if single else Y
