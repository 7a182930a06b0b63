"""Exact structured solver ``"block"``: block forward substitution on Eq. 3.43 / 3.48.

Never forms ``A``: divide and conquer with FFT updates, ``O(k³ n log² n)``, after shifting
past leading zero force samples; equals ``"ls"`` when the load cases are as many as the modes
and the first nonzero force sample is nonsingular; refuses ill-conditioned systems.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from podbench.core.validation import condition_number
from podbench.errors import IllConditionedError, InputError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.params import COUNT, NON_NEGATIVE, POSITIVE

__all__ = ["BlockSubstitution", "block_substitution"]


def _forward_substitution(G: np.ndarray, Y: np.ndarray, leaf: int) -> np.ndarray:
    """Solve ``Σ_{p≤s} G[β, s−p] X[β, p] = Y[β, s]`` (s = 0 … n−1) for ``b`` systems at once,
    each with a square invertible ``G[β, 0]``: ``G`` ``(b, n, k, k)``, ``Y`` ``(b, n, k, r)``,
    returns ``X`` ``(b, n, k, r)``. One system is a batch of one (:func:`_block`); several are
    the leave-one-record-out folds of a prediction band (:meth:`BlockSubstitution.solve_many`),
    solved in one Python-level pass.

    Divide and conquer: solve the first half, subtract its contribution to the second half
    with one FFT convolution, solve the second half; blocks of ``leaf`` samples are solved by
    plain block forward substitution. ``O(b k²r n log² n)`` operations, ``O(b k(k + r) n)``
    memory. The FFT of ``G[:, 0 : 2h]`` is shared by every node of half-length ``h``.

    The sum over a block's earlier samples is an ``einsum`` for one system and one matrix
    product per system for a batch: the two products the single and the batched solvers
    used before they were merged, so that every solution keeps its bits. The product on
    one system would be 1.5–2.5× faster on ML's systems but moves the last bits of every
    ``block`` solve, and with them values of the committed tables that lie on a rounding
    boundary (docs/noise.md); an ``einsum`` on a batch keeps every bit too but was 2.7×
    slower or more.
    """
    b, n, k, _ = G.shape
    r = Y.shape[3]
    n_pad = leaf
    while n_pad < n:
        n_pad *= 2
    Gp = np.zeros((b, n_pad, k, k))
    Gp[:, :n] = G
    Yp = np.zeros((b, n_pad, k, r))
    Yp[:, :n] = Y
    X = np.zeros((b, n_pad, k, r))
    G0inv = np.linalg.inv(G[:, 0])
    Gflip = Gp[:, leaf - 1 : 0 : -1] if leaf > 1 else Gp[:, :0]  # G[leaf−1], …, G[1]
    # side by side for a batch, (b, k, (leaf−1)·k): column p·k + j is G[leaf−1−p][:, j]
    Gcat = np.ascontiguousarray(Gflip.transpose(0, 2, 1, 3)).reshape(b, k, -1)
    spectra: dict[int, np.ndarray] = {}

    def solve_leaf_one(lo: int) -> None:  # b = 1, on the system's own 2-D views
        X1, Y1, inv1, flip1 = X[0], Yp[0], G0inv[0], Gflip[0]
        for t in range(leaf):
            rhs = Y1[lo + t]
            if t:  # Σ_{p<t} G[t−p] X[lo+p]; flip1[leaf−1−t:] is G[t], …, G[1]
                rhs = rhs - np.einsum("pij,pjr->ir", flip1[leaf - 1 - t :], X1[lo : lo + t])
            X1[lo + t] = inv1 @ rhs

    def solve_leaf_many(lo: int) -> None:
        for t in range(leaf):
            rhs = Yp[:, lo + t]
            if t:  # the same sum as one product per system
                rhs = rhs - Gcat[:, :, (leaf - 1 - t) * k :] @ \
                    X[:, lo : lo + t].reshape(b, t * k, r)
            X[:, lo + t] = G0inv @ rhs

    solve_leaf = solve_leaf_one if b == 1 else solve_leaf_many

    def solve_range(lo: int, length: int) -> None:
        if length == leaf:
            solve_leaf(lo)
            return
        h = length // 2
        solve_range(lo, h)
        Gh = spectra.get(h)
        if Gh is None:
            Gh = spectra[h] = scipy.fft.rfft(Gp[:, : 2 * h], 2 * h, axis=1)
        # conv[t] = Σ_{p<h} G[t−p] X[lo+p] without wrap-around for t in [h, 2h)
        conv = scipy.fft.irfft(Gh @ scipy.fft.rfft(X[:, lo : lo + h], 2 * h, axis=1), 2 * h,
                               axis=1)
        Yp[:, lo + h : lo + 2 * h] -= conv[:, h:]
        solve_range(lo + h, h)

    solve_range(0, n_pad)
    return X[:, :n]


def block_substitution(
    Q_list,
    B,
    dt: float,
    *,
    zero_tol: float = 0.0,
    max_cond: float = 1e8,
    max_growth: float = 1e8,
    leaf: int = 32,
) -> np.ndarray:
    """Exact structured solve of Eq. 3.43 / 3.48 by block forward substitution (``"block"``).

    Equals the dense minimum-norm least-squares solution (``"ls"``) whenever the load cases
    are as many as the modes and the first nonzero force sample ``G[d]`` is nonsingular
    (``G[s]`` is the ``n_cases × k`` matrix of modal-force samples at ``t_s``, row ``j`` =
    load case ``j``), without forming the ``n_cases·n × k·n`` matrix.

    **Leading zero samples (the guard on the first-sample matrix).** A podbench pulse starts
    at sample 1, so ``G[0] = 0`` and the diagonal block of Eq. 3.48 is singular. If the first
    ``d`` samples are zero (exactly, or ``‖G[s]‖_F <= zero_tol·max_s ‖G[s]‖_F``), the
    equations of samples ``0 … d−1`` contain no unknown and are dropped (their data are
    left as residual, as least squares does), the others are shifted by ``d``::

        Y[d + s] = Δt Σ_{p≤s} G[d + s − p] X[p],   s = 0 … n−d−1,

    a lower-triangular block-Toeplitz system with first block ``G[d]``, solved exactly; the
    last ``d`` lags ``X[n−d … n−1]`` never meet a nonzero force sample and are set to zero,
    the minimum-norm choice. With exact zeros (``zero_tol = 0``, the default) this *is* the
    dense minimum-norm solution; ``zero_tol > 0`` also drops small leading samples (e.g. the
    noise on a force's ``t = 0`` sample), a regularization that changes the problem.

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case (lbf); one (1, n) array for SL and MR.
    B : (n_cases·n,) or (n_cases·n, r) array_like
        Stacked scaled POC histories (in).
    dt : float
        Sampling interval Δt (s).
    zero_tol : float
        Relative size below which leading force samples count as zero (default 0: exact).
    max_cond : float
        :class:`IllConditionedError` if the condition number of ``G[d]`` exceeds it
        (default 1e8), e.g. load cases that do not start on the same sample.
    max_growth : float
        :class:`IllConditionedError` if ``‖A‖·‖X‖/‖B‖`` exceeds it (default 1e8,
        ``‖A‖`` bounded by ``Δt Σ_s ‖G[s]‖_F``): forward substitution amplified the data
        by more than that (a first force sample tiny compared with later ones, e.g. noise).
    leaf : int
        Samples per directly substituted block (default 32; affects speed only).

    Returns
    -------
    (k·n,) or (k·n, r) ndarray
        ``C̄`` (Eq. 3.42), as :func:`least_squares` on the dense matrix would return.
    """
    system = ConvolutionSystem(Q_list, B, dt)
    X, _ = _block(system, **BlockSubstitution(zero_tol=zero_tol, max_cond=max_cond,
                                             max_growth=max_growth, leaf=leaf)._params())
    return system.stack(X)


def _block(system: ConvolutionSystem, zero_tol: float, max_cond: float, max_growth: float,
           leaf: int):
    """:func:`block_substitution` on a validated system: kernel samples ``(n, k, r)`` and the
    diagnostics (``shift``, ``condition`` of ``G[d]``, ``growth``)."""
    G, Y, dt = system.G, system.Y, system.dt
    n, n_cases, k = G.shape
    if n_cases != k:
        raise InputError(
            f"solver 'block': {n_cases} load case(s) for {k} mode(s); block forward "
            "substitution needs a square first-sample matrix (as many load cases as modes). "
            "Use 'cgls' (Tikhonov or plain least squares with FFT products) or 'ls' for "
            "an over-determined system"
        )
    d = system.leading_zeros(zero_tol)
    sv = np.linalg.svd(G[d], compute_uv=False)
    cond = condition_number(sv)
    if not cond <= max_cond:
        raise IllConditionedError(
            f"solver 'block': the first nonzero force-sample matrix G[{d}] (modal forces of "
            f"every load case at t = {d}·Δt) has condition number {cond:.3g} > max_cond = "
            f"{max_cond:g}; the load cases must start on the same sample with independent "
            "first samples. Use 'ls' (minimum-norm least squares) or a regularized solver "
            "('fft', 'cgls')"
        )
    r = Y.shape[2]
    X = np.zeros((n, k, r))
    with np.errstate(all="ignore"):
        X[: n - d] = _forward_substitution(G[None, d:], Y[None, d:], leaf)[0] / dt
        growth = _growth(G, Y, X, d, dt)
    if not (np.isfinite(growth) and growth <= max_growth):
        ratio = sv[-1] / np.sqrt(np.max(np.sum(G.reshape(n, -1) ** 2, axis=1)))
        how = f"by {growth:.3g}" if np.isfinite(growth) else "until it overflowed"
        raise IllConditionedError(
            f"solver 'block': forward substitution amplified the data {how} "
            f"(‖A‖‖X‖/‖B‖ > max_growth = {max_growth:g}): the triangular system is "
            f"ill-conditioned (smallest singular value of the first force sample G[{d}] is "
            f"{ratio:.3g} of the largest sample). With noisy forces use a regularized solver "
            "('fft' or 'cgls', Tikhonov; 'tls') or zero_tol to "
            "skip near-zero leading samples"
        )
    return X, {"shift": d, "condition": cond, "growth": growth}


def _growth(G: np.ndarray, Y: np.ndarray, X: np.ndarray, d: int, dt: float) -> float:
    """``‖A‖·‖X‖/‖B‖`` of a solution (``‖A‖`` bounded by ``Δt Σ_s ‖G[s]‖_F``, ``‖B‖`` over
    the equations after the shift ``d``): the quantity ``max_growth`` bounds."""
    n = G.shape[0]
    norm_a = dt * float(np.sum(np.sqrt(np.sum(G.reshape(n, -1) ** 2, axis=1))))
    norm_y = float(np.linalg.norm(Y[d:]))
    norm_x = float(np.linalg.norm(X))
    return norm_a * norm_x / norm_y if norm_y > 0 else (0.0 if norm_x == 0 else np.inf)


def _block_many(systems, zero_tol: float, max_cond: float, max_growth: float, leaf: int):
    """:func:`_block` on several systems of one shape, one ``Δt`` and one leading-zero
    count ``d``, solved together (one :func:`_forward_substitution`): a list of
    ``(kernel samples, diagnostics)``, each equal to :func:`_block`'s to round-off (the
    sums of a leaf are products here, an ``einsum`` there). None
    when they cannot be batched or one of them fails a check (the caller then solves them
    one by one, which raises that system's own error)."""
    first = systems[0]
    n, n_cases, k = first.G.shape
    if n_cases != k or any(s.G.shape != first.G.shape or s.Y.shape != first.Y.shape
                           or s.dt != first.dt for s in systems):
        return None
    shifts = {s.leading_zeros(zero_tol) for s in systems}
    if len(shifts) != 1:
        return None
    d = shifts.pop()
    conds = [condition_number(np.linalg.svd(s.G[d], compute_uv=False)) for s in systems]
    if not all(c <= max_cond for c in conds):
        return None
    X = np.zeros((len(systems), n, k, first.Y.shape[2]))
    out = []
    with np.errstate(all="ignore"):
        X[:, : n - d] = _forward_substitution(np.stack([s.G[d:] for s in systems]),
                                              np.stack([s.Y[d:] for s in systems]),
                                              leaf) / first.dt
        for s, Xs, cond in zip(systems, X, conds, strict=True):
            growth = _growth(s.G, s.Y, Xs, d, s.dt)
            if not (np.isfinite(growth) and growth <= max_growth):
                return None
            out.append((Xs, {"shift": d, "condition": cond, "growth": growth}))
    return out


class BlockSubstitution(Solver):
    """Exact block forward substitution (``"block"``), see :func:`block_substitution`.

    Parameters
    ----------
    zero_tol : float
        Relative size below which leading force samples count as zero (default 0: exact).
    max_cond : float
        Largest condition number of the first nonzero force-sample matrix ``G[d]``
        (default 1e8).
    max_growth : float
        Largest growth ``‖A‖·‖X‖/‖B‖`` (default 1e8).
    leaf : int
        Samples per directly substituted block (default 32; speed only).

    Notes
    -----
    Diagnostics: ``shift`` (``d``, leading samples shifted past), ``condition`` (of
    ``G[d]``), ``growth`` (``‖A‖·‖X‖/‖B‖``, ``‖A‖`` bounded by ``Δt Σ_s ‖G[s]‖_F`` and
    ``‖B‖`` over the equations after the shift, the quantity ``max_growth`` bounds).
    """

    name = "block"
    structured = True
    _parameter_constraints = {"zero_tol": [NON_NEGATIVE], "max_cond": [POSITIVE],
                              "max_growth": [POSITIVE], "leaf": [COUNT]}

    def __init__(self, *, zero_tol: float = 0.0, max_cond: float = 1e8,
                 max_growth: float = 1e8, leaf: int = 32):
        self.zero_tol = zero_tol
        self.max_cond = max_cond
        self.max_growth = max_growth
        self.leaf = leaf

    def _solve(self, system: ConvolutionSystem):
        p = self._params()
        X, info = _block(system, p["zero_tol"], p["max_cond"], p["max_growth"], p["leaf"])
        return system.stack(X), info

    def solve_many(self, systems) -> list:
        """Several systems of one shape (the leave-one-record-out folds of a prediction
        band) solved together by one batched forward substitution
        (:func:`_forward_substitution`); the same solutions and diagnostics as
        :meth:`solve` on each, to round-off. Systems that cannot be batched (shapes,
        ``Δt`` or leading zeros differ) or that fail a check are solved one by one."""
        systems = list(systems)
        self._validate_params()
        p = self._params()
        solved = _block_many(systems, p["zero_tol"], p["max_cond"], p["max_growth"],
                             p["leaf"]) if len(systems) > 1 and all(
            isinstance(s, ConvolutionSystem) for s in systems) else None
        if solved is None:
            return super().solve_many(systems)
        return [self._result(s, s.stack(X), info)
                for s, (X, info) in zip(systems, solved, strict=True)]
