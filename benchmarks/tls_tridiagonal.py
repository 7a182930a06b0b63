"""A prototype, not adopted: the appendix TLS's secular equation on ``sytrd``'s tridiagonal.

``bordered.gram_eigh`` factors ``A = XᵀX = H T Hᵀ`` (``sytrd``) and ``T = Z diag(μ) Zᵀ``
(``stevd``); the secular equation then needs ``β = ZᵀHᵀb``. Here ``stevd`` is left out:
``μ`` by ``sterf`` (eigenvalues only), and ``g(λ) = c − λ − b̃ᵀ(T − λ)⁻¹b̃`` (``b̃ = Hᵀb``)
by tridiagonal solves (one LAPACK ``gtsv`` on the block-diagonal matrix of every
``T − λ_j``), the roots bracketed by interlacing, each discarded eigenvector of ``G`` from
``(λ_j − T)⁻¹b̃``, one application of ``H`` at the end. Timed and checked against the
current route and the full SVD by ``python benchmarks/tls_route.py --tridiagonal``.

Why it is not adopted (measured there): it is less accurate and slower. It cannot deflate:
Chapter 5's ``XᵀX`` has eigenvalues ``0 ± ε‖A‖`` (the forces' smooth pulses: σ down to
~1e-17 σ_1) whose components of ``b̃`` are round-off; the current route removes them
(``|β_k| <= 8ε‖G‖``, Dongarra–Sorensen) before it brackets roots, and works in ``δ = λ − μ_p``
of the nearer pole, but a solve with ``T − λ`` near such a pole amplifies the round-off by
``1/|λ − μ|``. On the linear beam's 5 % systems the kept counts are the same and ``h`` is
1e-7…1e-5 from the full SVD's (the current route 1e-12…1.6e-8); on the synthetic systems
the discarded direction that carries ``y`` (``1 − ΣV² ≈ 1``, a root within ``8ε‖G‖`` of
the cluster) is lost. Its roots cost more than the ``stevd`` saved: Newton on ``δ·g``
without the two-pole model takes more steps, each a length-``M`` solve.
"""

from __future__ import annotations

import hashlib

import numpy as np
import scipy.linalg

from podbench.sysid.deconvolution.bordered import (
    _DEFLATE,
    _EPS,
    _MAX_STEPS,
    FactoredQ,
    _split,
    gram_matrix,
    tridiagonalize,
)


class GramTridiagonal:
    """``A = XᵀX = H T Hᵀ`` by LAPACK's ``sytrd``, kept as ``T``'s diagonal and
    subdiagonal, ``H``'s reflectors and ``T``'s eigenvalues ``μ`` (ascending, by ``sterf``:
    no eigenvectors). :func:`tridiagonal_tls` solves the appendix's TLS from it; the
    secular equation is evaluated by tridiagonal solves with ``T − λ`` (module docstring of
    :func:`tridiagonal_tls`). ``secular_memo`` keeps each right-hand side's roots."""

    def __init__(self, reflectors: np.ndarray, tau: np.ndarray, diag: np.ndarray,
                 off: np.ndarray, mu: np.ndarray):
        self.H = FactoredQ(reflectors, tau, np.eye(0))
        self.diag, self.off, self.mu = diag, off, mu
        self.secular_memo: dict = {}

    def h(self, x: np.ndarray, trans: str = "N") -> np.ndarray:
        """``H x`` (``"N"``) or ``Hᵀx`` (``"T"``)."""
        return self.H._h(x, trans)


def gram_tridiagonal(G: np.ndarray) -> GramTridiagonal:
    """``sytrd`` of ``A = XᵀX`` (formed as ``bordered.gram_eigh`` forms it) and ``T``'s
    eigenvalues by LAPACK ``sterf`` (``O(M²)``, no eigenvectors)."""
    refl, d, e, tau = tridiagonalize(gram_matrix(G))
    mu, info = scipy.linalg.lapack.dsterf(d, e)
    if info != 0:
        raise scipy.linalg.LinAlgError(f"LAPACK dsterf did not converge (info={info})")
    return GramTridiagonal(refl, tau, d, e, mu)


def _shifted_solves(diag: np.ndarray, off: np.ndarray, lam: np.ndarray,
                    rhs: np.ndarray) -> np.ndarray:
    """``(T − λ_j)⁻¹ rhs`` for every ``λ_j`` (rows), ``T`` symmetric tridiagonal: one LAPACK
    ``gtsv`` (LU with partial pivoting) on the block-diagonal matrix of the ``T − λ_j``
    (the blocks are uncoupled, so each row is what its own solve gives). A zero pivot (``λ``
    an eigenvalue of ``T`` in floating point) moves that ``λ`` up one ulp."""
    lam = np.array(lam, dtype=float)
    m, M = lam.size, diag.size
    if m == 0:
        return np.zeros((0, M))
    coupling = np.zeros((m, M))
    coupling[:, :-1] = off
    coupling = coupling.reshape(-1)[:-1]
    for _ in range(8):
        dd = (diag[None, :] - lam[:, None]).reshape(-1)
        _, _, _, x, info = scipy.linalg.lapack.dgtsv(coupling, dd, coupling,
                                                     np.tile(rhs, m)[:, None])
        if info == 0:
            return x.reshape(m, M)
        if info < 0:
            raise RuntimeError(f"LAPACK dgtsv failed (info={info})")
        j = (info - 1) // M
        lam[j] = np.nextafter(lam[j], np.inf)
    raise scipy.linalg.LinAlgError("LAPACK dgtsv: T − λ singular in floating point")


def _secular_values(sec: dict, lam: np.ndarray) -> tuple:
    """``(g, g′, U)`` at each ``λ``: ``U = (T − λ)⁻¹b̃`` (rows), ``g = c − λ − b̃ᵀU``,
    ``g′ = −1 − ‖U‖²``."""
    U = _shifted_solves(sec["diag"], sec["off"], lam, sec["bt"])
    return sec["c"] - lam - U @ sec["bt"], -1.0 - np.einsum("ij,ij->i", U, U), U


def _tri_secular_of(tri: GramTridiagonal, b: np.ndarray, c: float, scale: float) -> dict:
    """The secular equation of ``[[scale·A, b], [bᵀ, c]]`` on ``T`` (``b̃ = Hᵀb``, the poles
    ``scale·μ``, the bounds of its roots), kept on ``tri`` with the roots found so far
    (keyed by the bytes of ``scale``, ``b``, ``c``)."""
    h = hashlib.sha256()
    for arr in (np.array([scale, c], dtype=float), b):
        h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
    key = h.hexdigest()
    memo = tri.secular_memo
    if key in memo:
        return memo[key]
    bt = tri.h(np.asarray(b, dtype=float), "T")
    mu = tri.mu * scale
    nb = float(np.linalg.norm(bt))
    norm = max(float(np.max(np.abs(mu))), abs(c), nb)
    sec = {"diag": tri.diag * scale, "off": tri.off * scale, "mu": mu, "bt": bt,
           "c": float(c), "norm": norm,
           "low": min(float(mu[0]), c) - nb - _EPS * norm,
           "high": max(float(mu[-1]), c) + nb + _EPS * norm,
           "lam": np.zeros(0), "s2": np.zeros(0), "U": np.zeros((0, mu.size))}
    memo[key] = sec
    return sec


def _tri_brackets(sec: dict, idx: np.ndarray) -> tuple:
    """Root ``j`` of ``G = [[A, b], [bᵀ, c]]`` lies in ``(μ_{j−1}, μ_j)`` (Cauchy
    interlacing; ``μ_{−1}``, ``μ_M`` the bounds ``low``, ``high``) where ``g`` falls from
    ``+∞`` to ``−∞``: ``g`` at the middle picks the root's half. Returns its origin (the
    half's pole, ``low``/``high`` are none) and the bracket ``(lo, hi)`` of ``δ = λ − origin``."""
    mu = sec["mu"]
    M = mu.size
    left = np.concatenate([[sec["low"]], mu])[idx]
    right = np.concatenate([mu, [sec["high"]]])[idx]
    mid = 0.5 * (left + right)
    g_mid = _secular_values(sec, mid)[0]
    a = np.where(g_mid > 0, mid, left)  # the root lies in (a, b)
    b = np.where(g_mid > 0, right, mid)
    use_right = ((g_mid > 0) | (idx == 0)) & (idx < M)
    origin = np.where(use_right, right, left)
    return origin, a - origin, b - origin


def _tri_iterate(sec: dict, origin: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """``δ`` of each root ``origin + δ`` in ``(lo, hi)``: Newton's method on ``F(δ) =
    δ·g(origin + δ)`` (smooth at the pole ``origin``: ``F(0) = β_p²``; ``F′ = g + δ g′``),
    a step that leaves the bracket, is not half the one before or is not finite halving the
    bracket instead (``bordered._split``); done when the step or the bracket is below the
    resolution of ``λ``. Each root is iterated on its own (its rows of the solves)."""
    lo, hi = lo.copy(), hi.copy()
    delta = _split(lo, hi)
    last = np.full(origin.size, np.inf)
    floor = _EPS * sec["norm"]
    open_ = np.arange(origin.size)
    for _ in range(4 * _MAX_STEPS):
        if open_.size == 0:
            break
        d = delta[open_]
        g, gp, _ = _secular_values(sec, origin[open_] + d)
        right = g > 0  # g decreases: the root lies to the right
        l0 = np.where(right, np.maximum(lo[open_], d), lo[open_])
        h0 = np.where(right, hi[open_], np.minimum(hi[open_], d))
        lo[open_], hi[open_] = l0, h0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            new = d - d * g / (g + d * gp)
        res = 2.0 * _EPS * np.maximum(np.abs(origin[open_] + d), _EPS * floor)
        step = np.abs(new - d)
        done = (step <= res) | (g == 0)
        bad = (~((new > l0) & (new < h0)) | (step > 0.5 * last[open_])) & ~done
        new = np.where(bad, _split(l0, h0), np.where(done, d, new))
        last[open_] = np.abs(new - d)
        delta[open_] = new
        done |= h0 - l0 <= res
        open_ = open_[~done]
    return delta


def _tri_roots(sec: dict, start: int, stop: int) -> tuple:
    """Roots ``start … stop − 1`` of the secular equation (ascending) with their weights:
    ``(λ, s², U)``, ``U`` the rows ``(λ − T)⁻¹b̃`` (the eigenvector ``[H u; 1]`` of ``G``
    scaled by ``s``, ``s² = 1/(1 + ‖u‖²)``). Near its pole ``u`` is mostly the pole's
    eigenvector of ``T`` with ``‖u‖ ≈ |β_p|/|δ|``: where ``|δ|`` and ``|δ|·‖u‖`` are both
    ``<= 8ε‖G‖`` the root is
    ``A``'s eigenvalue with no weight on ``y`` to working precision (the deflation of
    ``bordered.secular``): ``s = 0``. Kept in ``sec``; only new roots are computed."""
    have = sec["lam"].size
    if stop > have:
        idx = np.arange(have, stop)
        origin, lo, hi = _tri_brackets(sec, idx)
        delta = _tri_iterate(sec, origin, lo, hi)
        lam = origin + delta
        U = -_shifted_solves(sec["diag"], sec["off"], lam, sec["bt"])
        u2 = np.einsum("ij,ij->i", U, U)
        # |β_p| ≈ |δ|·‖u‖ (u is mostly the pole's eigenvector near it): deflated when small
        small = _DEFLATE * _EPS * sec["norm"]
        with np.errstate(over="ignore", invalid="ignore"):
            silent = (np.abs(delta) <= small) & ~(np.abs(delta) * np.sqrt(u2) > small)
        U[silent] = 0.0
        s2 = np.where(silent, 0.0, 1.0 / (1.0 + u2))
        sec["lam"] = np.concatenate([sec["lam"], lam])
        sec["s2"] = np.concatenate([sec["s2"], s2])
        sec["U"] = np.vstack([sec["U"], U])
    return sec["lam"][start:stop], sec["s2"][start:stop], sec["U"][start:stop]


def _tri_largest(sec: dict) -> float:
    """``λ_1``, the largest eigenvalue of ``G`` (root ``M``), kept in ``sec``."""
    if "_lam1" not in sec:
        M = sec["mu"].size
        origin, lo, hi = _tri_brackets(sec, np.array([M]))
        sec["_lam1"] = float((origin + _tri_iterate(sec, origin, lo, hi))[0])
    return sec["_lam1"]


def tridiagonal_tls(tri: GramTridiagonal, b: np.ndarray, c: float, tol: float, nrow: int,
                    scale: float = 1.0, min_den: float = 0.0) -> tuple:
    """The appendix's ``tlsdeconv`` as ``bordered.bordered_tls``, ``(h, r, den)``, for
    ``X·√scale`` (``A = scale·XᵀX``), from the tridiagonal reduction ``A = H T Hᵀ`` alone
    (``GramTridiagonal``): the secular equation
    ``g(λ) = c − λ − b̃ᵀ(T − λ)⁻¹b̃`` (``b̃ = Hᵀb``) is evaluated by one tridiagonal solve
    per ``λ`` (``O(M)``), its roots bracketed by ``T``'s eigenvalues (interlacing), the
    count below the cut ``λ_1/tol²`` is ``#{μ < cut} + [g(cut) < 0]`` (the inertia of
    ``G − cut``: that of ``A − cut`` and the sign of the Schur complement ``g(cut)``), and
    each discarded eigenvector of ``G`` is ``s·[H u; 1]`` with ``u = (λ − T)⁻¹b̃``, so
    ``h = −H Σ_j s_j² u_j / Σ_j s_j²``: one application of ``H``. ``min_den`` as
    ``bordered.bordered_tls``."""
    sec = _tri_secular_of(tri, b, float(c), float(scale))
    M = sec["mu"].size
    thr = _tri_largest(sec) / (tol * tol)
    d = int(np.count_nonzero(sec["mu"] < thr))
    if d < M and _secular_values(sec, np.array([thr]))[0][0] < 0:
        d += 1
    _, s2, U = _tri_roots(sec, 0, d)
    while float(s2.sum()) < min_den and d < M:  # the largest root stays kept
        step = min(max(8, d // 8), M - d)
        _, s2n, _ = _tri_roots(sec, d, d + step)
        need = int(np.searchsorted(np.cumsum(s2n), min_den - float(s2.sum()))) + 1
        d += min(need, step)
        _, s2, U = _tri_roots(sec, 0, d)
    den = float(s2.sum())
    r = min(M + 1 - d, nrow)
    if den <= 0:
        return np.zeros(M), r, den
    return -tri.h((s2[:, None] * U).sum(axis=0)) / den, r, den
