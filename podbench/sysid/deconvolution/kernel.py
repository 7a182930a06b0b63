"""Kernel-based (empirical-Bayes) regularized deconvolution: ``"kernel"``.

Each kernel ``c_li`` (lags ``0 … n−1``) gets a Gaussian prior ``c_li ~ N(0, c_l P)`` with a
**DC** (diagonal/correlated) or **TC** (tuned/correlated) kernel (Pillonetto & De Nicolao
2010; Chen, Ohlsson & Ljung 2012)::

    DC:  P(p, q) = λ^{(p+q)/2} ρ^{|p−q|}          TC:  P(p, q) = λ^{max(p, q)}  (ρ = √λ),

the data ``y_l = A c_l + e_l``, ``e_l ~ N(0, σ_l² I)``, and the estimate is the posterior mean
``X = argmin ‖A X − B‖² + σ² Xᵀ P⁻¹ X``. The hyper-parameters — the shape ``(λ, ρ)`` shared
by all columns, the scale ``c_l`` and noise ``σ_l²`` per column of ``B`` — maximize the
marginal likelihood (the evidence) ``log p(y | λ, ρ, c, σ²)`` of the training data alone.

Modelling choices (state them when reading the numbers):

* the columns of ``A`` are first equilibrated per mode (block ``i`` divided by
  ``s_i = Δt‖q_i‖``), so the prior is on ``s_i c_li`` and does not depend on the modal
  forces' units; the scaling is undone afterwards;
* the beams are undamped, so their ML kernels (Eq. 3.39) do not decay: a decaying prior is
  a modelling choice. The evidence chooses ``λ`` (``λ → 1`` is allowed: DC becomes a
  stationary AR(1) smoothness prior with correlation ``ρ``); the exponential window of
  :mod:`podbench.conditioning` makes the kernels decay if one wants the prior to hold.

Computation. ``P = S Sᵀ`` with ``S = D_λ L_ρ`` (``L_ρ`` the Cholesky factor of the AR(1)
correlation, applied by a first-order recursion, ``O(n)``), so in the whitened variable
``c = S e`` the problem is ridge regression with ``γ_l = σ_l²/c_l``. The evidence is
evaluated on the first ``m = min(n, n_hyper)`` samples — an exact sub-system, since sample
``s`` depends only on lags ``≤ s`` — from the eigen-decomposition of ``Sᵀ A_mᵀ A_m S``
(``k·m × k·m``, ``O((k m)³)`` per shape), with ``γ_l`` and ``σ_l²`` profiled in closed form
/ by a 1-D search per column, and the shape by Nelder–Mead from a coarse grid. If ``m = n``
the solution is read from the same decomposition; otherwise the full system is solved with
the chosen hyper-parameters by conjugate gradients on the whitened normal equations with FFT
products (``O(k² n log n)`` per iteration, ``A`` never formed).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)
import scipy.fft
import scipy.linalg

from podbench.errors import InvalidParameterError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution._cg import coldot, fft_operators, pcg
from podbench.sysid.deconvolution.determined import StoppingRule
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.params import COUNT, FRACTION, POSITIVE, Options

__all__ = ["KernelRegularized", "kernel_matrix", "log_marginal_likelihood", "DEFAULT_N_HYPER"]

DEFAULT_N_HYPER = None
"""Default ``n_hyper`` of :class:`KernelRegularized`: ``None``, i.e. ``m = min(n, max(32,
MAX_HYPER_UNKNOWNS // k))`` samples for the evidence (the whole record if shorter)."""

MAX_HYPER_UNKNOWNS = 1024
"""Unknowns ``k·m`` of the evidence's eigen-decomposition with the default ``n_hyper``
(``O((k m)³)`` per shape tried: about 0.3 s at 1024 here)."""

_LAM_BOUNDS = (np.log(1e-6), np.log(0.5))    # a = log(1 − λ): λ from 0.5 to 1 − 1e-6
_RHO_BOUNDS = (np.log(1e-4), np.log(0.99))   # b = log(1 − ρ): ρ from 0.01 to 1 − 1e-4


def kernel_matrix(m: int, lam: float, rho: float) -> np.ndarray:
    """The DC kernel ``P(p, q) = λ^{(p+q)/2} ρ^{|p−q|}``, ``p, q = 0 … m−1`` (TC: ``ρ = √λ``).

    Returns
    -------
    (m, m) ndarray
    """
    p = np.arange(m)
    return lam ** ((p[:, None] + p[None, :]) / 2) * rho ** np.abs(p[:, None] - p[None, :])


def _factor(m: int, lam: float, rho: float) -> np.ndarray:
    """``S`` (m × m, lower triangular) with ``S Sᵀ = kernel_matrix(m, λ, ρ)``."""
    p = np.arange(m)
    diff = p[:, None] - p[None, :]
    L = np.where(diff >= 0, rho ** np.maximum(diff, 0), 0.0)
    L[:, 1:] *= np.sqrt(1.0 - rho**2)
    return lam ** (p / 2)[:, None] * L


def _apply_S(E: np.ndarray, lam: float, rho: float) -> np.ndarray:
    """``S E`` along axis 0 (E (n, …)) by the AR(1) recursion."""
    g = np.sqrt(1.0 - rho**2)
    E = E.copy()
    E[0] /= g
    U = scipy.signal.lfilter([g], [1.0, -rho], E, axis=0)
    w = lam ** (np.arange(E.shape[0]) / 2)
    return U * w.reshape((-1,) + (1,) * (E.ndim - 1))


def _apply_St(V: np.ndarray, lam: float, rho: float) -> np.ndarray:
    """``Sᵀ V`` along axis 0."""
    g = np.sqrt(1.0 - rho**2)
    w = lam ** (np.arange(V.shape[0]) / 2)
    W = V * w.reshape((-1,) + (1,) * (V.ndim - 1))
    U = scipy.signal.lfilter([g], [1.0, -rho], W[::-1], axis=0)[::-1].copy()
    U[0] /= g
    return U


def _shape(kernel: str, a: float, b: float) -> tuple[float, float]:
    lam = 1.0 - np.exp(a)
    rho = np.sqrt(lam) if kernel == "tc" else 1.0 - np.exp(b)
    return float(lam), float(rho)


def _scales(system: ConvolutionSystem) -> np.ndarray:
    """Column equilibration ``s_i = Δt ‖G[:, :, i]‖_F`` (1 for an all-zero mode)."""
    s = system.dt * np.sqrt(np.sum(system.G**2, axis=(0, 1)))
    return np.where(s > 0, s, 1.0)


def _quadratic(yy: float, d: np.ndarray, z2: np.ndarray, g: float) -> float:
    """``Q = yᵀ(I + ΦΦᵀ/γ)⁻¹y = yy − Σ z²/(d + γ)`` without its cancellation.

    Written as ``r⊥ + Σ z² γ/(d(d + γ))`` over the well-determined directions (``d`` above
    ``1e-12·max d``), ``r⊥ = yy − Σ z²/d`` the least-squares residual (clamped at 0), minus
    ``Σ z²/(d + γ)`` over the others — the same number in exact arithmetic. The direct form
    subtracts two nearly equal numbers when the system is square (``r⊥ = 0``, ML with as many
    load cases as modes) and γ is small: its round-off sign then decided, machine by machine
    (measured: another CPU with two BLAS threads), whether the profile found the
    noise level or fell to ``Q = 0``, a noise floor of 0 on 2 %-noisy records.
    """
    dmax = float(d.max()) if d.size else 0.0
    big = d > 1e-12 * dmax if dmax > 0 else np.zeros(d.shape, dtype=bool)
    r_perp = max(yy - float(np.sum(z2[big] / d[big])), 0.0)
    return (r_perp + float(np.sum(z2[big] * g / (d[big] * (d[big] + g))))
            - float(np.sum(z2[~big] / (d[~big] + g))))


DECOMPOSE_CACHE_BYTES = 256 * 2**20
"""Bytes of shape decompositions ``(d, V, S)`` kept per process (:meth:`_Evidence.decompose`,
least recently used out). They depend on the forces and the shape only, not on the
responses: a fit's refits on the same forces with other responses (a prediction band's
noise refits, ``"auto"``'s evidence test on each) try the same shapes — the 25 starts of
the grid, and mostly the same Nelder–Mead path — and get them back, bit for bit."""

_DECOMPOSED: OrderedDict = OrderedDict()


class _Evidence:
    """The profiled evidence of the first ``m`` samples, for shapes ``(λ, ρ)``."""

    def __init__(self, system: ConvolutionSystem, m: int, scale: np.ndarray):
        sub = ConvolutionSystem([q[:, :m] for q in system.Q_list],
                                system.Y[:m].transpose(1, 0, 2).reshape(-1, system.n_rhs),
                                system.dt)
        A = sub.dense() / np.repeat(scale, m)[None, :]
        self.k, self.m = system.k, m
        self.N = A.shape[0]
        y = sub._B2
        self.gram = A.T @ A
        self.h = A.T @ y  # (k·m, r)
        self.yy = np.sum(y**2, axis=0)  # (r,)
        self.evaluations = 0
        self._key = hashlib.sha256(np.ascontiguousarray(self.gram).tobytes()).hexdigest()

    def decompose(self, lam: float, rho: float):
        """``(d, V, S)``: eigenpairs of ``Sᵀ AᵀA S`` (block-diagonal ``S``); kept per process
        (:data:`DECOMPOSE_CACHE_BYTES`, keyed by the bytes of ``AᵀA`` and the shape), read
        only."""
        self.evaluations += 1
        key = (self._key, self.k, self.m, float(lam).hex(), float(rho).hex())
        hit = _DECOMPOSED.get(key)
        if hit is not None:
            _DECOMPOSED.move_to_end(key)
            return hit
        k, m = self.k, self.m
        S = _factor(m, lam, rho)
        G4 = self.gram.reshape(k, m, k, m)
        H = np.einsum("pa,ipjq,qb->iajb", S, G4, S, optimize=True).reshape(k * m, k * m)
        d, V = scipy.linalg.eigh(H, overwrite_a=True, check_finite=False)
        out = (np.maximum(d, 0.0), V, S)
        for arr in out:
            arr.flags.writeable = False
        _DECOMPOSED[key] = out
        total = sum(a.nbytes for entry in _DECOMPOSED.values() for a in entry)
        while total > DECOMPOSE_CACHE_BYTES and len(_DECOMPOSED) > 1:
            total -= sum(a.nbytes for a in _DECOMPOSED.popitem(last=False)[1])
        return out

    def project(self, V, S):
        k, m = self.k, self.m
        Sh = np.einsum("pa,ipr->iar", S, self.h.reshape(k, m, -1)).reshape(k * m, -1)
        return V.T @ Sh  # z (k·m, r)

    def profile(self, d, z):
        """Per column: the best ``log γ`` and ``−2 log L`` (σ² profiled out)."""
        N = self.N
        z2 = z**2
        dmax = float(d.max()) if d.size and d.max() > 0 else 1.0
        grid = np.log(dmax) + np.linspace(np.log(1e-14), np.log(1e2), 65)

        def f(lg, col):
            g = np.exp(lg)
            Q = _quadratic(self.yy[col], d, z2[:, col], g)
            Q = max(Q, 1e-300 * max(self.yy[col], 1e-300))
            # Q = yᵀ(I + ΦΦᵀ/γ)⁻¹y; σ² = Q/N profiled out (constants N(1 + log 2π) dropped)
            return N * np.log(Q / N) + np.sum(np.log1p(d / g))

        out_lg, out_f = [], []
        for col in range(z.shape[1]):
            vals = [f(lg, col) for lg in grid]
            i = int(np.argmin(vals))
            lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
            res = scipy.optimize.minimize_scalar(f, bounds=(lo, hi), args=(col,),
                                                 method="bounded",
                                                 options={"xatol": 1e-4})
            out_lg.append(float(res.x))
            out_f.append(float(res.fun))
        return np.array(out_lg), np.array(out_f)


def _noise_and_scale(ev: _Evidence, d, z, lg):
    """``σ_l²`` and ``c_l`` at the profiled optimum of each column."""
    g = np.exp(lg)
    Q = np.array([_quadratic(ev.yy[c], d, z[:, c] ** 2, g[c]) for c in range(z.shape[1])])
    sigma2 = np.maximum(Q, 0.0) / ev.N
    return sigma2, sigma2 / g


def log_marginal_likelihood(system: ConvolutionSystem, *, lam: float, rho: float, c,
                            sigma2, n_hyper: int | None = None) -> float:
    """``log p(B | λ, ρ, c, σ²)`` of :class:`KernelRegularized`'s model, by dense Cholesky.

    An independent evaluation (``O((n_cases m)³)``) of the evidence the solver maximizes, on
    the first ``m = min(n, n_hyper)`` samples with the equilibrated columns.

    Parameters
    ----------
    system : ConvolutionSystem
    lam, rho : float
        Kernel shape (DC; for TC pass ``rho = √lam``).
    c, sigma2 : float or (r,) array_like
        Prior scale and noise variance per column of ``B``.
    """
    m = system.n if n_hyper is None else min(system.n, int(n_hyper))
    scale = _scales(system)
    sub = ConvolutionSystem([q[:, :m] for q in system.Q_list],
                            system.Y[:m].transpose(1, 0, 2).reshape(-1, system.n_rhs),
                            system.dt)
    A = sub.dense() / np.repeat(scale, m)[None, :]
    P = kernel_matrix(m, lam, rho)
    APAt = np.zeros((A.shape[0], A.shape[0]))
    for i in range(system.k):
        Ai = A[:, i * m:(i + 1) * m]
        APAt += Ai @ P @ Ai.T
    c = np.broadcast_to(np.asarray(c, float), (system.n_rhs,))
    sigma2 = np.broadcast_to(np.asarray(sigma2, float), (system.n_rhs,))
    total = 0.0
    for col in range(system.n_rhs):
        Sig = c[col] * APAt + sigma2[col] * np.eye(A.shape[0])
        L = np.linalg.cholesky(Sig)
        w = scipy.linalg.solve_triangular(L, sub._B2[:, col], lower=True)
        total += -0.5 * (w @ w) - np.sum(np.log(np.diag(L))) - 0.5 * A.shape[0] * np.log(
            2 * np.pi)
    return float(total)


class KernelRegularized(Solver):
    """Kernel-based regularized deconvolution with empirical-Bayes hyper-parameters
    (``"kernel"``; see the module docstring for the model and the cost).

    Parameters
    ----------
    kernel : {"dc", "tc"}
        Prior covariance shape: DC ``λ^{(p+q)/2} ρ^{|p−q|}`` (default) or TC ``λ^{max(p,q)}``.
    n_hyper : int, optional
        Samples on which the evidence is maximized (default: ``min(n, max(32, 1024 // k))``,
        :data:`MAX_HYPER_UNKNOWNS`); when shorter than the record the full system is then
        solved by conjugate gradients with the chosen hyper-parameters.
    lam, rho, gamma : float, optional
        Fix the shape ``λ``, the correlation ``ρ`` (DC only) or ``γ = σ²/c`` (all columns)
        instead of maximizing the evidence over them (for tests and oracle studies).
    tol : float
        Relative tolerance of the conjugate-gradient solve (only when ``n > n_hyper``),
        on the normal-equation residual (default 1e-6).
    max_iter : int
        Its iteration limit (the iterate is returned, ``converged`` false, if reached).

    Notes
    -----
    Diagnostics (``info``): ``lam``, ``rho``, ``gamma`` (geometric mean over columns),
    ``c``, ``sigma2`` (geometric means), ``noise_floor`` and ``noise_floor_min``
    (``σ_l/rms(y_l)``, largest and smallest over the columns), ``log_evidence``
    (``log p(B)``, summed over columns), ``evaluations`` (shapes
    tried), ``n_hyper`` (the ``m`` used), ``iterations`` and ``converged`` (CG, 0 / True
    when ``m = n``), ``reg_rule`` = ``"evidence"``.
    """

    name = "kernel"
    stopping = StoppingRule(gain=1.7e4, power=1.0, roundoff=3.3e-6, residual_gain=7.2e6,
                            residual_power=1.0, residual_roundoff=3.4e-5)
    """Its conjugate gradients stop at a relative residual ``tol``: the rule of ``cgls``'s
    CG core (the same kind of test; not measured on its own: 15–100 s a fit)."""
    structured = True
    _parameter_constraints = {"kernel": [Options("dc", "tc")], "n_hyper": [None, COUNT],
                              "lam": [None, FRACTION], "rho": [None, FRACTION],
                              "gamma": [None, POSITIVE], "tol": [POSITIVE], "max_iter": [COUNT]}

    def __init__(self, *, kernel: str = "dc", n_hyper: int | None = DEFAULT_N_HYPER,
                 lam: float | None = None, rho: float | None = None,
                 gamma: float | None = None, tol: float = 1e-6, max_iter: int = 2000):
        self.kernel = kernel
        self.n_hyper = n_hyper
        self.lam = lam
        self.rho = rho
        self.gamma = gamma
        self.tol = tol
        self.max_iter = max_iter

    def _validate_params(self) -> None:
        super()._validate_params()
        if self.rho is not None and self.kernel == "tc":
            raise InvalidParameterError(
                "Parameter `rho`: the TC kernel has no separate rho (ρ = √λ)", param="rho")

    # ------------------------------------------------------------------ hyper-parameters
    def _hyper(self, system: ConvolutionSystem, scale: np.ndarray):
        m = self._n_hyper(system)
        ev = _Evidence(system, m, scale)
        kernel = self.kernel

        def to_ab(lam, rho):
            return np.log(1 - lam), np.log(1 - rho)

        def objective(ab):
            lam, rho = _shape(kernel, *ab)
            if self.lam is not None:
                lam = float(self.lam)
                rho = np.sqrt(lam) if kernel == "tc" else rho
            if self.rho is not None:
                rho = float(self.rho)
            d, V, S = ev.decompose(lam, rho)
            z = ev.project(V, S)
            if self.gamma is not None:
                lg = np.full(z.shape[1], np.log(self.gamma))
                N = ev.N
                fvals = []
                for col in range(z.shape[1]):
                    g = self.gamma
                    Q = _quadratic(ev.yy[col], d, z[:, col] ** 2, g)
                    fvals.append(N * np.log(max(Q, 1e-300) / N) + np.sum(np.log1p(d / g)))
                f = np.array(fvals)
            else:
                lg, f = ev.profile(d, z)
            return float(np.sum(f)), (lam, rho, d, V, S, z, lg)

        free_lam = self.lam is None
        free_rho = kernel == "dc" and self.rho is None
        a0 = np.log(1 - self.lam) if self.lam is not None else None
        b0 = np.log(1 - self.rho) if self.rho is not None else None
        cache = {}

        def fun(x):
            a = x[0] if free_lam else a0
            b = (x[-1] if free_rho else b0) if kernel == "dc" else 0.0
            key = (round(float(a), 10), round(float(b if b is not None else 0), 10))
            if key not in cache:
                cache[key] = objective((a, b if b is not None else 0.0))
            return cache[key][0]

        bounds = ([_LAM_BOUNDS] if free_lam else []) + ([_RHO_BOUNDS] if free_rho else [])
        if bounds:
            axes = [np.linspace(lo, hi, 5) for lo, hi in bounds]
            starts = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(bounds), -1).T
            vals = [fun(x) for x in starts]
            x0 = starts[int(np.argmin(vals))]
            scipy.optimize.minimize(fun, x0, method="Nelder-Mead", bounds=bounds,
                                    options={"xatol": 1e-3, "fatol": 1e-3, "maxfev": 40})
            best = min(cache, key=lambda k_: cache[k_][0])
        else:
            fun(np.zeros(0))
            best = next(iter(cache))
        f, (lam, rho, d, V, S, z, lg) = cache[best]
        return ev, f, lam, rho, d, V, S, z, lg

    # ------------------------------------------------------------------ solve
    def _n_hyper(self, system: ConvolutionSystem) -> int:
        if self.n_hyper is None:
            return min(system.n, max(32, MAX_HYPER_UNKNOWNS // system.k))
        return min(system.n, int(self.n_hyper))

    def hyperparameters(self, system: ConvolutionSystem) -> dict:
        """Maximize the evidence on the first ``m`` samples (no full solve).

        Returns
        -------
        dict
            ``info`` keys of the solver (``lam``, ``rho``, ``gamma``, ``c``, ``sigma2``,
            ``noise_floor``, ``log_evidence``, ``evaluations``, ``n_hyper``) and, under the
            private key ``"_state"``, what :meth:`_solve` needs to finish.
        """
        self._validate_params()
        r = system.n_rhs
        scale = _scales(system)
        ev, f, lam, rho, d, V, S, z, lg = self._hyper(system, scale)
        sigma2, c = _noise_and_scale(ev, d, z, lg)
        floors = np.sqrt(sigma2 * ev.N / np.maximum(ev.yy, 1e-300))
        return {"reg_rule": "evidence", "kernel": self.kernel, "lam": lam, "rho": rho,
                "gamma": float(np.exp(np.mean(lg))),
                "c": float(np.exp(np.mean(np.log(np.maximum(c, 1e-300))))),
                "sigma2": float(np.exp(np.mean(np.log(np.maximum(sigma2, 1e-300))))),
                "noise_floor": float(np.max(floors)), "noise_floor_min": float(np.min(floors)),
                "log_evidence": float(-0.5 * (np.sum(f) + r * ev.N * (1 + np.log(2 * np.pi)))),
                "evaluations": ev.evaluations, "n_hyper": ev.m,
                "_state": (scale, ev.m, lam, rho, d, V, S, z, np.exp(lg))}

    def _solve(self, system: ConvolutionSystem, hyper: dict | None = None):
        n, k, r = system.n, system.k, system.n_rhs
        info = dict(self.hyperparameters(system) if hyper is None else hyper)
        scale, m, lam, rho, d, V, S, z, g = info.pop("_state")
        if m == n:
            E = V @ (z / (d[:, None] + g[None, :]))  # whitened (k·m, r)
            Xb = np.einsum("pa,iar->pir", S, E.reshape(k, m, r))  # (n, k, r)
            info.update(iterations=0, converged=True)
        else:
            Xb, it, conv = self._cg(system, scale, lam, rho, g)
            info.update(iterations=it, converged=conv)
        Xb = Xb / scale[None, :, None]
        return system.stack(Xb), info

    def _cg(self, system, scale, lam, rho, g):
        """Preconditioned CG on the whitened normal equations ``(SᵀAᵀAS + γ_l I) e = SᵀAᵀy``
        (per column ``γ_l``). Preconditioner: the same operator for the circulant
        embeddings, ``|Ŝ(ω)|² Ĝ(ω)ᴴĜ(ω) + γ_l I`` with ``Ŝ(ω) = √(1−ρ²)/(1 − ρe^{−iω})`` the
        AR(1) filter (exact up to the record's ends when ``λ^n ≈ 1``), inverted per
        frequency and column (stored in complex64)."""
        G, Y, dt = system.G, system.Y, system.dt
        n, n_cases, k = G.shape
        r = Y.shape[2]
        N = scipy.fft.next_fast_len(2 * n - 1, real=True)
        Gh = dt * scipy.fft.rfft(G / scale[None, None, :], N, axis=0)
        A_fft, At_fft, GhT = fft_operators(Gh, N, n)
        w = 2 * np.pi * np.arange(Gh.shape[0]) / N
        s2 = (1.0 - rho**2) / np.abs(1.0 - rho * np.exp(-1j * w)) ** 2
        H = s2[:, None, None] * (GhT.conj() @ Gh)  # (F, k, k)
        eye = np.eye(k)
        Minv = np.stack([np.linalg.inv(H + gl * eye) for gl in g], axis=1).astype(np.complex64)

        def A(E):
            return A_fft(_apply_S(E, lam, rho))

        def At(Z):
            return _apply_St(At_fft(Z), lam, rho)

        def precond(R):  # R (n, k, r)
            Rh = scipy.fft.rfft(R, N, axis=0)  # (F, k, r)
            Zh = np.einsum("frij,fjr->fir", Minv, Rh)
            return scipy.fft.irfft(Zh, N, axis=0)[:n]

        R = At(np.asarray(Y))
        E, _, it, active = pcg(lambda P: At(A(P)) + g * P, precond, np.zeros((n, k, r)), R,
                               self.tol**2 * coldot(R, R), self.max_iter)
        return _apply_S(E, lam, rho), it, not bool(np.any(active))
