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
