"""The appendix's TLS through the eigenvalues of ``XᵀX``: ``[X y]``'s Gram matrix bordered.

``tlsdeconv(y, X)`` (the dissertation's appendix; Eqs. 3.78–3.80) keeps the right singular
vectors of ``C = [X y]`` with ``σ_1/σ_i <= tol`` and returns
``h = Σ_kept V(n+1,i) V(1:n,i) / (1 − Σ_kept V(n+1,i)²)``. By the orthogonality of ``V``
the sums over the kept vectors are minus / one minus those over the discarded ones, the
eigenvectors of ``G = CᵀC`` below ``λ_1/tol²``. ``G`` is ``XᵀX = A`` bordered by
``b = Xᵀy`` and ``c = yᵀy``; with ``A = Q diag(μ) Qᵀ`` an eigenvector of ``G`` of eigenvalue
``λ`` (not one of ``μ``) is ``s·[Q β/(λ − μ); 1]``, ``β = Qᵀb``, where ``λ`` is a root of the
secular equation (Golub 1973)::

    g(λ) = c − λ + Σ_k β_k²/(λ − μ_k) = 0,        s² = 1/(1 + Σ_k β_k²/(λ − μ_k)²),

one root between consecutive ``μ_k`` (and one below ``μ_1``, one above ``μ_M``: ``λ_1``).
So ``h = −Q Σ_j s_j² β/(λ_j − μ) / Σ_j s_j²`` over the roots below ``λ_1/tol²``, and the
only cubic work is the eigendecomposition of ``A``, which every right-hand side, every
``tol``, every unit scale (``ρX``: ``ρ²μ``) and every refit on the same forces shares
(:func:`gram_eigh`, kept per process). ``Q`` is used only on vectors (``β = Qᵀb``, ``h``
from ``Qz``), so it is kept factored as ``Q = H Z``: ``H`` the Householder reflectors that
reduce ``A`` to tridiagonal ``T = HᵀAH`` (LAPACK ``sytrd``) and ``Z`` the eigenvectors of
``T`` (divide and conquer, ``stevd``): the same ``μ`` as ``syevd``'s, bit for bit, without
its back-transformation ``HZ`` (the largest dense product of the route). ``A`` and ``b``
come from correlations of the force samples (``X`` is block lower-triangular Toeplitz:
:func:`toeplitz_gram`), ``O(n²)``; the dense ``X`` is never formed.

Components with ``|β_k| <= 8 ε ‖G‖`` are deflated (Dongarra & Sorensen 1987): ``μ_k`` is
then an eigenvalue of ``G`` to working precision with no weight on ``y`` (``s = 0``), which
adds nothing to ``h`` and counts as discarded when below the cut. Each root is found in the
coordinate ``δ = λ − μ_p`` of its nearer pole ``p`` (Bunch, Nielsen & Sorensen 1978), by
Newton's method on ``δ·g`` (smooth at the pole) kept inside the root's bracket.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np
import scipy.linalg

__all__ = ["toeplitz_gram", "toeplitz_rmatvec", "gram_matrix", "tridiagonalize", "gram_eigh",
           "FactoredQ", "border", "secular", "bordered_tls", "convolution_svd",
           "EIGH_CACHE_SIZE", "SVD_CACHE_SIZE", "SECULAR_CACHE_SIZE"]

_EPS = np.finfo(float).eps
_DEFLATE = 8.0
"""Deflation: ``|β_k| <= _DEFLATE·ε·‖G‖`` (LAPACK ``dlaed2``'s rule)."""
_MAX_STEPS = 60


def toeplitz_gram(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``T(u)ᵀ T(v)`` for the lower-triangular Toeplitz matrices ``T(u)``, ``T(v)``
    (``T(u)[i, j] = u[i − j]``, ``n × n``) from lagged products, ``O(n²)``:
    ``(T(u)ᵀT(v))[j + l, j] = Σ_{m < n−j−l} u[m] v[m + l]`` (a reversed cumulative sum per
    lag ``l``), and the mirror with ``u`` and ``v`` exchanged above the diagonal. Each
    diagonal is written through a strided view of the flat array (element ``(j + l, j)`` is
    ``l·n + j·(n + 1)``, ``(i, i + l)`` is ``l + i·(n + 1)``), not by a gather of indices."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    n = u.size
    out = np.empty((n, n))
    flat = out.reshape(-1)
    for lag in range(n):
        m = n - lag
        flat[lag * n:lag * n + m * (n + 1):n + 1] = np.cumsum(u[:m] * v[lag:])[::-1]  # below
        flat[lag:lag + m * (n + 1):n + 1] = np.cumsum(u[lag:] * v[:m])[::-1]  # above
    return out


def toeplitz_rmatvec(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``T(u)ᵀ y``: ``(T(u)ᵀy)[i] = Σ_{m < n−i} u[m] y[m + i]``, a cross-correlation."""
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    n = u.size
    return np.correlate(y, u, mode="full")[n - 1:2 * n - 1]


EIGH_CACHE_SIZE = 8
"""Eigendecompositions of ``XᵀX`` kept per process (least recently used out). A study
solves many systems on the same forces: both of ML's right-hand sides, every ``tol`` and
unit scale of the same fit, the prediction band's noise refits (new responses, the same
forces in the same basis)."""

_CACHE: OrderedDict = OrderedDict()


def _key(G: np.ndarray, weights: np.ndarray | None) -> str:
    h = hashlib.sha256()
    for arr in (G, weights if weights is not None else np.zeros(0)):
        h.update(repr((arr.shape, arr.dtype.str)).encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


class FactoredQ:
    """The eigenvectors ``Q = H Z`` of ``A = XᵀX`` kept factored (module docstring): ``H``
    the product of the Householder reflectors of LAPACK's ``sytrd`` (lower storage: the
    reflector ``i`` below the subdiagonal of column ``i``), ``Z`` the eigenvectors of the
    tridiagonal ``T = HᵀAH``. ``Q @ z`` and ``Q.T @ b`` act on vectors (``O(M²)`` each);
    :meth:`dense` forms ``Q``."""

    def __init__(self, reflectors: np.ndarray, tau: np.ndarray, Z: np.ndarray,
                 transposed: bool = False):
        self._v, self._tau, self._Z, self._t = reflectors, tau, Z, transposed
        self.shape = Z.shape
        self.secular_memo: OrderedDict = OrderedDict()  # :func:`_secular_of`

    @property
    def T(self) -> FactoredQ:
        return FactoredQ(self._v, self._tau, self._Z, not self._t)

    def _h(self, x: np.ndarray, trans: str) -> np.ndarray:
        """``H x`` (``trans="N"``) or ``Hᵀx`` (``"T"``): ``H = diag(1, H̃)`` with ``H̃`` the
        QR-stored reflectors of ``sytrd`` (LAPACK ``ormtr``'s lower case, by ``ormqr``)."""
        out = np.array(x, dtype=float, copy=True).reshape(x.shape[0], -1)
        if out.shape[0] > 1:
            v = self._v[1:, :-1]
            lwork = max(1, 64 * out.shape[1])
            res, _, info = scipy.linalg.lapack.dormqr("L", trans, v, self._tau, out[1:],
                                                      lwork=lwork)
            if info != 0:
                raise RuntimeError(f"LAPACK dormqr failed (info={info})")
            out[1:] = res
        return out.reshape(x.shape)

    def __matmul__(self, x):
        x = np.asarray(x, dtype=float)
        if self._t:  # Qᵀx = Zᵀ(Hᵀx)
            return self._Z.T @ self._h(x, "T")
        return self._h(self._Z @ x, "N")

    def dense(self) -> np.ndarray:
        """``Q`` (or ``Qᵀ``) as an array."""
        Q = self._h(self._Z, "N")
        return Q.T if self._t else Q


def tridiagonalize(A: np.ndarray) -> tuple:
    """``(reflectors, d, e, tau)`` of LAPACK ``sytrd`` on the symmetric ``A`` (lower
    triangle, overwritten): ``A = H T Hᵀ``, ``T`` of diagonal ``d`` and subdiagonal ``e``."""
    lapack = scipy.linalg.lapack
    lwork = int(lapack.dsytrd_lwork(A.shape[0], lower=1)[0])
    refl, d, e, tau, info = lapack.dsytrd(A, lower=1, lwork=max(lwork, 1), overwrite_a=1)
    if info != 0:
        raise RuntimeError(f"LAPACK dsytrd failed (info={info})")
    return refl, d, e, tau


def _tridiagonal_eigh(A: np.ndarray) -> tuple:
    """``(μ, Q)`` of the symmetric ``A`` (ascending ``μ``, ``Q`` a :class:`FactoredQ`):
    ``sytrd`` then ``stevd`` (the steps of ``syevd`` but its back-transformation)."""
    refl, d, e, tau = tridiagonalize(A)
    mu, Z, info = scipy.linalg.lapack.dstevd(d, e, compute_v=1)
    if info != 0:
        raise scipy.linalg.LinAlgError(f"LAPACK dstevd did not converge (info={info})")
    return mu, FactoredQ(refl, tau, Z)


def gram_matrix(G: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``A = XᵀX`` (Fortran order) for the block convolution matrix ``X`` of the raw force
    samples ``G`` (``(n, n_cases, k)``, block ``(j, i)`` = ``T(G[:, j, i])``), column block
    ``i`` multiplied by ``weights[i]`` (default 1), from correlations (:func:`toeplitz_gram`)."""
    n, n_cases, k = G.shape
    A = np.zeros((k * n, k * n), order="F")
    for i in range(k):
        for i2 in range(i, k):
            blk = sum(toeplitz_gram(G[:, j, i], G[:, j, i2]) for j in range(n_cases))
            if weights is not None:
                blk = blk * (weights[i] * weights[i2])
            A[i * n:(i + 1) * n, i2 * n:(i2 + 1) * n] = blk
            if i2 != i:
                A[i2 * n:(i2 + 1) * n, i * n:(i + 1) * n] = blk.T
    return A


def gram_eigh(G: np.ndarray, weights: np.ndarray | None = None) -> tuple:
    """``(μ, Q)`` of ``A = XᵀX`` (ascending ``μ``) for the block convolution matrix ``X``
    of the raw force samples ``G`` (``(n, n_cases, k)``, block ``(j, i)`` = ``T(G[:, j, i])``)
    with its column block ``i`` multiplied by ``weights[i]`` (default 1): LAPACK's
    tridiagonal reduction and divide and conquer, ``Q`` kept factored (:class:`FactoredQ`:
    ``Q @ z``, ``Q.T @ b``); kept per process (:data:`EIGH_CACHE_SIZE`)."""
    key = _key(G, weights)
    hit = _CACHE.get(key)
    if hit is not None:
        _CACHE.move_to_end(key)
        return hit
    out = _tridiagonal_eigh(gram_matrix(G, weights))
    _CACHE[key] = out
    while len(_CACHE) > EIGH_CACHE_SIZE:
        _CACHE.popitem(last=False)
    return out


SVD_CACHE_SIZE = 4
"""Singular value decompositions of ``X`` kept per process (:func:`convolution_svd`)."""

_SVD_CACHE: OrderedDict = OrderedDict()


def convolution_svd(G: np.ndarray) -> tuple:
    """``(U, s, Vᵀ)`` of the block convolution matrix ``X`` of the raw force samples ``G``
    (``(n, n_cases, k)``, block ``(j, i)`` = ``T(G[:, j, i])``, no Δt), by LAPACK's divide
    and conquer (``gesdd``); kept per process (:data:`SVD_CACHE_SIZE`): a least-squares fit,
    its coupled twin and the band's noise refits solve the same ``X`` with other
    right-hand sides."""
    key = _key(G, None)
    hit = _SVD_CACHE.get(key)
    if hit is not None:
        _SVD_CACHE.move_to_end(key)
        return hit
    n, n_cases, k = G.shape
    X = np.zeros((n_cases * n, k * n))
    for j in range(n_cases):
        for i in range(k):
            X[j * n:(j + 1) * n, i * n:(i + 1) * n] = scipy.linalg.toeplitz(
                G[:, j, i], np.zeros(n))
    out = scipy.linalg.svd(X, full_matrices=False, lapack_driver="gesdd")
    _SVD_CACHE[key] = out
    while len(_SVD_CACHE) > SVD_CACHE_SIZE:
        _SVD_CACHE.popitem(last=False)
    return out


def border(G: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``b = Xᵀy`` for the block convolution matrix of :func:`gram_eigh` (``y`` stacked by
    load case, ``n_cases·n``)."""
    n, n_cases, k = G.shape
    b = np.zeros(k * n)
    for i in range(k):
        bi = sum(toeplitz_rmatvec(G[:, j, i], y[j * n:(j + 1) * n]) for j in range(n_cases))
        b[i * n:(i + 1) * n] = bi * (1.0 if weights is None else weights[i])
    return b


def _two_pole_step(R0, bp, bq, Dq, has_q, lo, hi):
    """The zero in ``(lo, hi)`` of ``R0 + β_p²/δ + β_q²/(D_q + δ)`` (``β_q = 0`` without
    ``q``): ``R0 δ² + (R0 D_q + β_p² + β_q²) δ + β_p² D_q = 0`` (cancellation-free)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        qb = R0 * Dq + bp + bq
        qc = bp * Dq
        disc = np.sqrt(np.maximum(qb * qb - 4.0 * R0 * qc, 0.0))
        t = -0.5 * (qb + np.copysign(disc, qb))
        r1, r2 = t / R0, qc / t  # the two roots
        one = -bp / R0  # without q: R0 + β_p²/δ = 0
    pick = np.where((r1 > lo) & (r1 < hi), r1, r2)
    return np.where(has_q, pick, one)


def _split(lo, hi):
    """The middle of each bracket: geometric where it spans more than a factor 16 on one
    side of 0 (a root close to its pole), else arithmetic."""
    a, b = np.abs(lo), np.abs(hi)
    same = (lo * hi > 0) & (np.maximum(a, b) > 16.0 * np.minimum(a, b))
    with np.errstate(invalid="ignore"):
        geo = np.sign(lo) * np.sqrt(a * b)
    return np.where(same, geo, 0.5 * (lo + hi))


def _brackets(c: float, mu: np.ndarray, beta2: np.ndarray, low: float, high: float,
              start: int = 0, stop: int | None = None):
    """Every root's interval ``(low, μ_0), (μ_0, μ_1), …, (μ_{K−1}, high)`` (or those of
    roots ``start … stop − 1``) as its origin pole ``p`` (the nearer end that is a pole),
    the other pole ``q`` (−1: none) and the bracket ``(lo, hi)`` of ``δ = λ − μ_p`` on the
    root's half of the interval."""
    K = mu.size
    stop = K + 1 if stop is None else min(stop, K + 1)
    idx = np.arange(start, stop)
    left = np.concatenate([[low], mu])[start:stop]
    right = np.concatenate([mu, [high]])[start:stop]
    mid = 0.5 * (left + right)
    g_mid = c - mid + (beta2[None, :] / (mid[:, None] - mu[None, :])).sum(axis=1)
    # the root is right of the middle where g(mid) > 0 (g decreases): origin the right
    # pole then, else the left one; the outer ends low and high are no poles
    use_right = ((g_mid > 0) | (idx == 0)) & (idx < K)
    p = np.where(use_right, idx, idx - 1)
    # the other pole of the model: the interval's other end, or for an outer interval the
    # pole next to its one pole (−1: none)
    q = np.where(use_right, idx - 1, idx)
    q = np.where(idx == 0, 1, np.where(idx == K, K - 2, q))
    q = np.where((q < 0) | (q >= K), -1, q)
    lo = np.where(use_right, np.where(g_mid > 0, mid, left) - right,
                  0.0)
    hi = np.where(use_right, 0.0, np.where(g_mid > 0, right, mid) - left)
    return p, q, lo, hi


def _roots(c, mu, beta2, p, q, lo, hi):
    """``δ`` of each root in ``(lo, hi)`` with its origin pole ``μ_p`` and the model's other
    pole ``μ_q`` (``q < 0``: none): each step solves ``g`` with every other pole's sum frozen
    at its current value (the two-pole model of Bunch, Nielsen & Sorensen: exact where the
    two poles dominate); a step that leaves the bracket, or one not half as long as the one
    before, splits the bracket instead (:func:`_split`). The roots still open are iterated
    alone."""
    lo, hi = lo.copy(), hi.copy()
    delta = _split(lo, hi)
    last = np.full(p.size, np.inf)  # the previous step's length
    open_ = np.arange(p.size)
    for _ in range(4 * _MAX_STEPS):
        if open_.size == 0:
            break
        has_q = q[open_] >= 0
        pp = p[open_]
        qq = np.where(has_q, q[open_], pp)
        rows = np.arange(open_.size)
        d = delta[open_]
        den = (mu[pp][:, None] - mu[None, :]) + d[:, None]
        den[rows, pp] = np.inf  # the two poles of the model leave the frozen sum
        den[rows, qq] = np.inf
        bp, bq = beta2[pp], np.where(has_q, beta2[qq], 0.0)
        Dq = np.where(has_q, mu[pp] - mu[qq], 1.0)
        R0 = c - mu[pp] - d + (beta2[None, :] / den).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = R0 + bp / d + np.where(has_q, bq / (Dq + d), 0.0)
        right = g > 0  # g decreases: the root lies to the right
        l0, h0 = np.where(right, np.maximum(lo[open_], d), lo[open_]), \
            np.where(right, hi[open_], np.minimum(hi[open_], d))
        lo[open_], hi[open_] = l0, h0
        new = _two_pole_step(R0, bp, bq, Dq, has_q, l0, h0)
        step = np.abs(new - d)
        done = (step <= 4.0 * _EPS * np.abs(d)) | (g == 0)
        slow = step > 0.5 * last[open_]
        bad = (~((new > l0) & (new < h0)) | slow) & ~done
        new = np.where(bad, _split(l0, h0), np.where(done, d, new))
        last[open_] = np.abs(new - d)
        delta[open_] = new
        done |= h0 - l0 <= 4.0 * _EPS * np.maximum(np.abs(l0), np.abs(h0))
        open_ = open_[~done]
    return delta


def _clusters(mu: np.ndarray, tol: float) -> np.ndarray:
    """Group index of each (ascending) ``μ``: a new group where the gap to the previous
    ``μ`` exceeds ``tol`` (poles that close are one pole to working precision)."""
    if mu.size == 0:
        return np.zeros(0, dtype=int)
    return np.concatenate([[0], np.cumsum(np.diff(mu) > tol)])


def secular(mu: np.ndarray, beta: np.ndarray, c: float) -> dict:
    """The secular equation of ``[[diag(μ), β], [βᵀ, c]]`` (``μ`` ascending), deflated:
    components with ``|β_k| <= 8ε‖G‖`` leave it (eigenvalue ``μ_k``, no weight on ``y``),
    and poles closer than ``8ε‖G‖`` are one pole (the mean of the cluster) carrying
    ``Σ β_k²`` (the others: eigenvalue there, no weight on ``y``; LAPACK ``dlaed2``'s two
    deflations). Returns what :func:`bordered_tls` needs, for any ``tol``."""
    beta2 = beta * beta
    norm = max(float(np.max(np.abs(mu))) if mu.size else 0.0, abs(c),
               float(np.sqrt(beta2.sum())))
    small = _DEFLATE * _EPS * norm
    keep = np.abs(beta) > small
    group = _clusters(mu[keep], small)
    n_groups = int(group[-1]) + 1 if group.size else 0
    poles = np.bincount(group, weights=mu[keep], minlength=n_groups) / \
        np.maximum(np.bincount(group, minlength=n_groups), 1)
    weights = np.bincount(group, weights=beta2[keep], minlength=n_groups)
    # every eigenvalue that carries no weight on y: the small-β μ's and all but one of each
    # cluster (at its pole)
    silent = np.concatenate([mu[~keep], np.repeat(poles, np.bincount(group,
                                                                     minlength=n_groups) - 1)])
    bound = float(np.sqrt(weights.sum()))
    return {"keep": keep, "group": group, "poles": poles, "weights": weights,
            "silent": silent, "c": float(c), "norm": norm,
            "low": (min(float(poles[0]), c) - bound - _EPS * norm) if n_groups else c,
            "high": (max(float(poles[-1]), c) + bound + _EPS * norm) if n_groups else c}


SECULAR_CACHE_SIZE = 8
"""Secular equations kept per :class:`FactoredQ` with the roots found so far
(:func:`_secular_of`): the ``tol`` rows of one fit solve the same ``(μ, β, c)`` and need the
same smallest roots, as many as each ``tol`` discards."""


def _secular_of(mu: np.ndarray, Q, b: np.ndarray, c: float) -> tuple:
    """``(β, sec)``: ``β = Qᵀb`` and :func:`secular` of ``(μ, β, c)``, kept on a
    :class:`FactoredQ` (:data:`SECULAR_CACHE_SIZE`, keyed by the bytes of ``μ``, ``b``,
    ``c``; so they leave with it); :func:`_largest` and :func:`_first_roots` keep their
    roots in ``sec``."""
    memo = getattr(Q, "secular_memo", None)
    if memo is None:
        beta = Q.T @ b
        return beta, secular(mu, beta, c)
    h = hashlib.sha256()
    for arr in (mu, b, np.array([c], dtype=float)):
        h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
    key = h.hexdigest()
    hit = memo.get(key)
    if hit is not None:
        memo.move_to_end(key)
        return hit
    beta = Q.T @ b
    memo[key] = (beta, secular(mu, beta, c))
    while len(memo) > SECULAR_CACHE_SIZE:
        memo.popitem(last=False)
    return memo[key]


def _largest(sec: dict) -> float:
    """``λ_1``: the root above the last pole (or ``c`` without one), or a silent μ above
    it (kept in ``sec``)."""
    if "_lam1" not in sec:
        sec["_lam1"] = _largest_root(sec)
    return sec["_lam1"]


def _largest_root(sec: dict) -> float:
    """:func:`_largest`, computed."""
    poles, w, c = sec["poles"], sec["weights"], sec["c"]
    top = c
    if poles.size:
        K = poles.size
        p, q, lo, hi = np.array([K - 1]), np.array([-1]), np.array([0.0]), \
            np.array([sec["high"] - poles[-1]])
        top = float(poles[-1] + _roots(c, poles, w, p, q, lo, hi)[0])
    return max([top, *sec["silent"].tolist()])


def _count_below(sec: dict, thr: float) -> int:
    """How many roots of the secular equation lie below ``thr``."""
    poles, w, c = sec["poles"], sec["weights"], sec["c"]
    m = int(np.count_nonzero(poles < thr))
    with np.errstate(divide="ignore", invalid="ignore"):
        g_thr = c - thr + np.sum(w / (thr - poles))
    return m + 1 if (m < poles.size and g_thr < 0) else m


def _first_roots(sec: dict, start: int, stop: int):
    """Roots ``start … stop − 1`` (ascending) as ``(p, δ)`` (origin pole, offset). The
    roots found so far are kept in ``sec``, and only the brackets of the new ones are
    formed: each bracket and each root is computed on its own (:func:`_brackets`,
    :func:`_roots`, row by row), so a root is the same number whichever call finds it."""
    poles, w, c = sec["poles"], sec["weights"], sec["c"]
    if stop <= start:
        return np.zeros(0, dtype=int), np.zeros(0)
    have = sec.setdefault("_delta", np.zeros(0)).size
    if stop > have:
        p, q, lo, hi = _brackets(c, poles, w, sec["low"], sec["high"], have, stop)
        sec["_p"] = np.concatenate([sec.get("_p", np.zeros(0, dtype=int)), p])
        sec["_delta"] = np.concatenate([sec["_delta"], _roots(c, poles, w, p, q, lo, hi)])
    return sec["_p"][start:stop], sec["_delta"][start:stop]


def _weights(sec: dict, beta: np.ndarray, p, delta):
    """``(s², x)`` of the eigenvectors at the roots ``μ_p + δ``: ``x_k = β_k/(λ − μ_k)`` over
    the components kept, ``s² = 1/(1 + ‖x‖²)``."""
    poles, g = sec["poles"], sec["group"]
    D = (poles[p][:, None] - poles[g][None, :]) + delta[:, None]  # λ_j − μ_k (kept k)
    x = beta[sec["keep"]][None, :] / D
    return 1.0 / (1.0 + np.sum(x * x, axis=1)), x


def bordered_tls(mu: np.ndarray, Q: np.ndarray, b: np.ndarray, c: float, tol: float,
                 nrow: int, sec: dict | None = None, min_den: float = 0.0) -> tuple:
    """The appendix's ``tlsdeconv`` from the eigendecomposition ``(μ, Q)`` of ``A = XᵀX``,
    ``b = Xᵀy`` and ``c = yᵀy`` (module docstring): ``(h, r, den)``, ``r`` the directions
    kept (``σ_1/σ_i <= tol`` and ``i <= nrow``, the rows of ``[X y]``) and ``den`` the
    TLS denominator ``1 − Σ_kept V(n+1,i)²``. ``sec``: :func:`secular` of ``(μ, Qᵀb, c)``
    when already known (it does not depend on ``tol``).

    ``min_den``: where the discarded directions carry less than that weight on ``y`` (the
    non-generic problem: ``den = 0`` divides by zero in the MATLAB, e.g. only the exact null
    directions of a clean force's ``X`` below the cut), the next smallest directions are
    discarded too, one at a time, until ``den`` reaches it (Van Huffel & Vandewalle 1991,
    §3.4; as :func:`~podbench.sysid.deconvolution.dense.truncated_tls`)."""
    M = mu.size
    if sec is None:
        beta, sec = _secular_of(mu, Q, b, c)
    else:
        beta = Q.T @ b
    thr = _largest(sec) / (tol * tol)
    poles = sec["poles"]
    z = np.zeros(M)
    if poles.size == 0:  # y orthogonal to X's range: [X y]'s eigenvalues are μ and c
        s2, cut = (np.array([1.0]), thr) if c < thr else (np.zeros(0), thr)
    else:
        d = _count_below(sec, thr)
        p, delta = _first_roots(sec, 0, d)
        s2, x = _weights(sec, beta, p, delta)
        cut = thr
        while float(s2.sum()) < min_den and d < poles.size:  # the largest root stays kept
            step = min(max(8, d // 8), poles.size - d)
            pn, dn = _first_roots(sec, d, d + step)
            s2n, xn = _weights(sec, beta, pn, dn)
            need = int(np.searchsorted(np.cumsum(s2n), min_den - float(s2.sum()))) + 1
            take = min(need, step)
            p, delta = np.concatenate([p, pn[:take]]), np.concatenate([delta, dn[:take]])
            s2, x = np.concatenate([s2, s2n[:take]]), np.vstack([x, xn[:take]])
            d += take
            cut = np.nextafter(float(poles[pn[take - 1]] + dn[take - 1]), np.inf)
        if x.size:
            z[sec["keep"]] = (s2[:, None] * x).sum(axis=0)
    n_discarded = s2.size + int(np.count_nonzero(sec["silent"] < cut))
    r = min(M + 1 - n_discarded, nrow)
    den = float(s2.sum())
    h = -(Q @ z) / den if den > 0 else np.zeros(M)
    return h, r, den
