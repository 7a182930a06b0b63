"""Regularized structured total least squares of the (block) Toeplitz deconvolution (``"stls"``).

§3.5 of the dissertation motivates total least squares by errors in the force: "uncertainty
in force and displacement measurements result in errors in A and b, respectively" (after
Eq. 3.74), and solves Eq. 3.77 by the truncated SVD of ``[A | b]`` (``"tls"``). That
unstructured TLS perturbs every entry of the convolution matrix independently; the noise,
however, is on the ``n`` measured force samples, and the convolution matrix built from them
stays (block) Toeplitz. Structured TLS keeps that structure (Rosen, Park & Glick 1996,
*Total least norm formulation and solution for structured problems*, SIAM J. Matrix Anal.
Appl. 17; Mastronardi, Lemmerling & Van Huffel 2000, *Fast structured total least squares
algorithm for solving the basic deconvolution problem*, SIAM J. Matrix Anal. Appl. 22;
regularized: Pruessner & O'Leary 2003, *Blind deconvolution using a regularized structured
total least norm algorithm*, SIAM J. Matrix Anal. Appl. 24).

Problem. With the system of Eq. 3.48 (:class:`ConvolutionSystem`: ``G[s]`` the
``n_cases × k`` modal forces at ``t_s``, ``Y[s]`` the ``n_cases × r`` scaled POC histories,
``X[p]`` the ``k × r`` kernel at lag ``p``; one mode, ``k = r = 1``, is Eq. 3.43 of SL)::

    minimize over X, e   Σ_j ‖Y_j − Δt (G_j + ΔG_j(e)) ∗ X‖² / σ_Y,j²  +  ‖e‖²  +  λ² ‖X‖²

    ΔG_j[s] = σ_δ,j · e_j[s] D_jᵀ      (n × k, a correction of the force samples of case j)

* **Force channels.** ``D_j`` (``k × m_j``, orthonormal) spans the rows of the modal forces
  ``G_j`` of load case ``j`` (its numerical rank ``m_j``, singular values above
  ``rank_tol·σ_1``). A load measured on one force channel ``c`` gives
  ``G_j[s] = f_j[s] U[c, :]`` (Eq. 3.47), rank one: the correction is then one number per
  measured force sample, ``ΔG_j[s] ∝ δf_j[s] U[c, :]``, exactly how the noise of one force
  transducer enters the modal forces; the convolution matrix built from ``G + ΔG`` stays
  block Toeplitz. A force with more channels (or noise on every row of ``F``) gives
  ``m_j`` up to ``k``.
* **Weights** (the equal-relative-noise assumption of TLS, made per load case): the
  laboratory noise of podbench.noise is a level ``ε`` times each channel's RMS, on ``W`` and
  ``F`` alike. So the residual of case ``j`` is weighted by ``1/σ_Y,j`` with
  ``σ_Y,j = ‖Y_j‖_F / √(n r)`` (the RMS of its POC histories) and the force correction is
  measured in units of ``σ_δ,j = ρ ‖G_j‖_F / √(n m_j)`` (the RMS per force-channel sample),
  ``ρ = noise_ratio = ε_F/ε_W`` (default 1: the same relative level on the forces as on the
  responses, the TLS assumption; give the ratio of the per-channel levels if they are
  known; ``ρ = 0`` fixes the forces and the problem is Tikhonov least squares). ``ε``
  cancels; with Gaussian noise of these levels the first two terms are ``−2 log`` of the
  likelihood (up to ``ε²``).
* **Regularization.** ``λ = reg · max_ω σ_max(Δt Ĝ_w(ω))`` (``Ĝ_w``: the weighted forces,
  as :func:`cgls_fft`). ``reg = "gcv"`` (default) takes it from the data on the first step:
  the first step (``e = 0``) is Tikhonov least squares on the weighted system, solved by
  :func:`cgls_fft` with its generalized cross-validation (:func:`gcv_regularization`),
  which also gives the starting kernel ``X₀``. Never chosen from a target.

Iteration (structured total least norm, Gauss–Newton with step halving). At ``(X, e)`` the
residual ``R = Y_w − Δt (G_w + ΔG_w(e)) ∗ X`` is linear in each of ``X`` and ``e``; the step
``(ΔX, Δe)`` solves the linear least-squares problem ::

    minimize ‖R − J_X ΔX − J_e Δe‖² + ‖e + Δe‖² + λ² ‖X + ΔX‖²,
    J_X ΔX = Δt (G_w + ΔG_w(e)) ∗ ΔX,    J_e Δe = Δt ΔG_w(Δe) ∗ X,

by LSQR (scipy.sparse.linalg.lsqr) on a :class:`~scipy.sparse.linalg.LinearOperator`: both
Jacobians and their transposes are FFT (cross-)convolutions, nothing ``n × n`` is formed
(``O((k² + k r) n log n)`` per product). The kernel block is right-preconditioned by the
circulant model of ``(J_XᵀJ_X + λ² I)^{-1/2}`` (per frequency ``(Δt² Ĝ_wᴴĜ_w + μ² I)^{-1/2}``,
``μ = λ``, or ``1e-6 max_ω σ_max`` if ``λ = 0``; the preconditioner of :func:`cgls_fft`, in its
square-root form), the force block by the circulant model of ``(J_eᵀJ_e + I)^{-1/2}`` per load
case (symbol ``(I + conj(Ĥ_j) Ĥ_jᵀ)^{-1/2}``, ``Ĥ_j = D_wjᵀ Δt X̂``). LSQR stops at
``inner_tol`` (default 1e-6, an inexact Gauss–Newton step) or ``inner_iter``. The step is
halved (at most 30 times) until the objective decreases.
Stopping rule: stop when a step lowers the objective by less than ``tol`` (relative, default
``1e-6``), when the objective is below ``(1e-14 ‖Y_w‖)²`` (a consistent system solved), when
no halved step lowers it, or after ``max_iter`` steps (default 30; the
iterate is returned with ``info["converged"] = False``).

Leading exact-zero force samples are shifted past as in :func:`block_substitution` (their
equations hold no unknown; the last lags are zero) and are not corrected (an exact zero is
not a noisy measurement).

Measured (docs/noise.md): **not better than** ``"cgls"`` on the beams. In SL and in ML with
as many load cases as modes the deconvolution is square (``k·n`` unknowns per column from
``k·n`` equations): least squares fits the records exactly, there is no redundancy from which
the force noise could be told apart, and the joint problem moves the regularization's misfit
into the forces (default GCV λ: ML error 0.46 against cgls's 0.068 at 1 % noise on the
beam_forced_noise set); with ``reg ≤ 1e-4`` it is about ``"cgls"``. With redundant equations
(a 2-DOF oscillator, four or eight load cases for two modes, tests) the force correction
lowers the kernel error below cgls's.
"""

from __future__ import annotations

import numpy as np
import scipy.fft
import scipy.linalg
import scipy.sparse.linalg

from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution.convolution import block_conv
from podbench.sysid.deconvolution.determined import StoppingRule
from podbench.sysid.deconvolution.system import ConvolutionSystem, first_sample
from podbench.sysid.deconvolution.tikhonov import (
    DEFAULT_TIKHONOV_REG,
    REG_NON_NEGATIVE,
    cgls_iterate,
    spectral_norm,
)
from podbench.sysid.params import COUNT, FRACTION, NON_NEGATIVE

__all__ = ["STLS", "DEFAULT_STLS_TOL", "DEFAULT_STLS_MAX_ITER"]

DEFAULT_STLS_TOL = 1e-6
"""Relative decrease of the STLS objective below which :class:`STLS` stops."""

DEFAULT_STLS_MAX_ITER = 30
"""Gauss–Newton steps of :class:`STLS` at most."""

_MAX_HALVINGS = 30


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a * a))) if a.size else 0.0


def _force_channels(G: np.ndarray, rank_tol: float):
    """Orthonormal bases ``D`` (n_cases, k, m) of the row spaces of each case's modal forces
    (zero columns pad a case of lower rank), ranks ``m_j`` and the per-sample RMS
    ``‖G_j‖_F/√(n m_j)``."""
    n, n_cases, k = G.shape
    bases, ranks, scales = [], [], []
    for j in range(n_cases):
        Gj = G[:, j, :]
        _, s, Vt = np.linalg.svd(Gj, full_matrices=False)
        m = int(np.count_nonzero(s > rank_tol * s[0])) if s.size and s[0] > 0 else 0
        bases.append(Vt[:m].T)
        ranks.append(m)
        scales.append(float(np.linalg.norm(Gj)) / np.sqrt(n * max(m, 1)))
    mmax = max(max(ranks), 1)
    D = np.zeros((n_cases, k, mmax))
    for j, B in enumerate(bases):
        D[j, :, : B.shape[1]] = B
    return D, ranks, np.array(scales)


class STLS(Solver):
    """Regularized structured total least squares (structured total least norm) of Eq. 3.43 /
    3.48 (``"stls"``); the problem, the weights and the iteration are in the module
    docstring (:mod:`podbench.deconvolution.stls`).

    Parameters
    ----------
    reg : float or "gcv"
        Relative Tikhonov parameter (``λ = reg · max_ω σ_max(Δt Ĝ_w(ω))``), >= 0, or
        ``"gcv"`` (default): generalized cross-validation on the first (Tikhonov least
        squares) step.
    noise_ratio : float
        ``ρ = ε_F / ε_W``, the ratio of the relative noise levels (per channel) of the forces
        and the responses, >= 0. Default 1 (equal relative noise, the TLS assumption); 0 fixes
        the forces (Tikhonov least squares, ``"cgls"`` on the weighted system).
    rank_tol : float
        Relative singular-value level for the number of force channels of a load case
        (default 1e-8), in (0, 1).
    tol : float
        Stop when a step lowers the objective by less than ``tol`` relative (default
        :data:`DEFAULT_STLS_TOL`), in (0, 1).
    max_iter : int
        Gauss–Newton steps at most (default :data:`DEFAULT_STLS_MAX_ITER`), >= 1.
    inner_iter : int
        LSQR iterations per step at most (default 500), >= 1.
    inner_tol : float
        LSQR's ``atol`` and ``btol`` (default 1e-6: an inexact Gauss–Newton step; the
        stopping rule is on the objective), in (0, 1).

    Notes
    -----
    Diagnostics: ``reg``, ``reg_rule`` (as :class:`CGLS`), ``iterations`` (LSQR iterations
    of all steps, the first step's conjugate-gradient iterations included), ``solves``
    (Gauss–Newton steps taken), ``shift``; and ``objective_start`` / ``objective`` (the
    weighted objective at ``X₀`` and at the result), ``force_correction`` (``‖ΔG‖_F/‖G‖_F``),
    ``force_channels`` (largest ``m_j``), ``converged``.
    """

    name = "stls"
    stopping = StoppingRule(gain=5.3, power=0.5, roundoff=1.3e-6, residual_gain=21.0,
                            residual_power=0.5, residual_roundoff=3.2e-2)
    """Its test on the decrease of the objective (quadratic in the iterate's error near the
    minimum: moves ∝ √tol), measured on Chapter 5's beams (docs/noise.md): numbers 5.3·√tol,
    the relative residual 21·√tol (a residual share of the objective as small as 8e-4)."""
    structured = True
    _parameter_constraints = {"reg": REG_NON_NEGATIVE, "noise_ratio": [NON_NEGATIVE],
                              "rank_tol": [FRACTION], "tol": [FRACTION], "max_iter": [COUNT],
                              "inner_iter": [COUNT], "inner_tol": [FRACTION]}

    def __init__(self, *, reg: float | str = DEFAULT_TIKHONOV_REG, noise_ratio: float = 1.0,
                 rank_tol: float = 1e-8, tol: float = DEFAULT_STLS_TOL,
                 max_iter: int = DEFAULT_STLS_MAX_ITER, inner_iter: int = 500,
                 inner_tol: float = 1e-6):
        self.reg = reg
        self.noise_ratio = noise_ratio
        self.rank_tol = rank_tol
        self.tol = tol
        self.max_iter = max_iter
        self.inner_iter = inner_iter
        self.inner_tol = inner_tol

    def _solve(self, system: ConvolutionSystem):
        p = self._params()
        X, info = _stls(system, p["reg"], p["noise_ratio"], p["rank_tol"], p["tol"],
                        p["max_iter"], p["inner_iter"], p["inner_tol"])
        return system.stack(X), info


def _stls(system: ConvolutionSystem, reg, rho: float, rank_tol: float, tol: float,
          max_iter: int, inner_iter: int, inner_tol: float):
    """The STLN iteration of the module docstring on a validated system: kernel samples
    ``(n, k, r)`` and the diagnostics."""
    G0, Y0, dt = system.G, system.Y, system.dt
    n_full, n_cases, k = G0.shape
    r = Y0.shape[2]
    d = first_sample(G0, 0.0)
    G, Y = G0[d:], Y0[d:]
    n = n_full - d

    # weights: σ_Y,j (RMS of case j's POC histories); a case without response gets the
    # largest other (or 1)
    sig_y = np.array([_rms(Y[:, j, :]) for j in range(n_cases)])
    fallback = float(sig_y.max()) if sig_y.max() > 0 else 1.0
    sig_y = np.where(sig_y > 0, sig_y, fallback)
    Gw = G / sig_y[None, :, None]
    Yw = Y / sig_y[None, :, None]
    D, ranks, sig_f = _force_channels(G, rank_tol)
    Dw = D * (rho * sig_f / sig_y)[:, None, None]  # ΔG_w[s, j] = Dw[j] e[s, j]

    # first step: Tikhonov least squares on the weighted system (λ by GCV unless given)
    wsys = ConvolutionSystem([Gw[:, j, :].T for j in range(n_cases)],
                             Yw.transpose(1, 0, 2).reshape(n_cases * n, r), dt)
    X, info0 = cgls_iterate(wsys, reg, 1e-10, 1000)
    stln = _Stln(Gw, Yw, Dw, dt, float(info0["reg"]))
    e = np.zeros((n, n_cases, D.shape[2]))
    R = stln.residual(X, e)
    phi = phi_start = stln.objective(R, X, e)
    lsqr_iter = 0
    steps = 0
    floor = (1e-14 * float(np.linalg.norm(Yw))) ** 2  # a consistent system is solved
    converged = rho == 0 or not np.any(Dw) or phi <= floor
    while not converged and steps < max_iter:
        dX, de, its = stln.step(X, e, R, inner_iter, inner_tol)
        lsqr_iter += its
        trial = stln.line_search(X, e, dX, de, phi)
        if trial is None:
            converged = True  # no descent along the step: at a stationary point
            break
        steps += 1
        decrease = (phi - trial[3]) / phi if phi > 0 else 0.0
        X, e, R, phi = trial
        if decrease <= tol or phi <= floor:
            converged = True

    correction = float(np.linalg.norm(stln.dG(e) * sig_y[None, :, None]))
    gnorm = float(np.linalg.norm(G))
    info = {
        "reg": float(info0["reg"]), "reg_rule": info0["reg_rule"], "shift": d,
        "iterations": int(info0["iterations"]) + lsqr_iter, "solves": steps,
        "objective_start": phi_start, "objective": phi,
        "force_correction": correction / gnorm if gnorm > 0 else 0.0,
        "force_channels": int(max(ranks)), "converged": bool(converged),
    }
    return np.concatenate([X, np.zeros((d, k, r))]), info


class _Stln:
    """The weighted STLN problem ``min ‖R‖² + ‖e‖² + λ²‖X‖²`` (module docstring) with FFT
    products: its residual, objective, Gauss–Newton step (LSQR, right-preconditioned) and
    line search."""

    def __init__(self, Gw, Yw, Dw, dt: float, reg: float):
        self.Gw, self.Yw, self.Dw, self.dt = Gw, Yw, Dw, dt
        self.n, self.n_cases, self.k = Gw.shape
        self.r, self.m = Yw.shape[2], Dw.shape[2]
        self.N = scipy.fft.next_fast_len(2 * self.n - 1, real=True)
        Gh0 = dt * self.fft(Gw)
        smax = spectral_norm(Gh0)
        self.lam = lam = reg * smax
        # right preconditioner of the kernel block: circulant (Δt² ĜᴴĜ + μ² I)^{-1/2}
        mu2 = lam**2 if lam > 0 else (1e-6 * smax) ** 2
        w_eig, V_eig = np.linalg.eigh(np.conj(Gh0).transpose(0, 2, 1) @ Gh0
                                      + mu2 * np.eye(self.k))
        self.Ph = (V_eig * (1.0 / np.sqrt(w_eig))[:, None, :]) @ np.conj(V_eig).transpose(0, 2, 1)

    def fft(self, a):
        return scipy.fft.rfft(a, self.N, axis=0)

    def ifft(self, a):
        return scipy.fft.irfft(a, self.N, axis=0)[:self.n]

    def dG(self, e_):  # (n, n_cases, m) -> (n, n_cases, k)
        return np.einsum("jkm,sjm->sjk", self.Dw, e_)

    def dGt(self, M):  # adjoint of dG: (n, n_cases, k) -> (n, n_cases, m)
        return np.einsum("jkm,sjk->sjm", self.Dw, M)

    def residual(self, X_, e_):
        return self.Yw - self.dt * block_conv(self.Gw + self.dG(e_), X_, self.N)

    def objective(self, R, X_, e_) -> float:
        return float(np.sum(R * R) + np.sum(e_ * e_) + self.lam**2 * np.sum(X_ * X_))

    def precond(self, Z):  # (n, k, r), symmetric
        return self.ifft(self.Ph @ self.fft(Z))

    def _force_precond(self, Xh):
        """Right preconditioner of the force block: per case the circulant model of
        (J_eᵀJ_e + I)^{-1/2}, symbol (I + conj(Ĥ_j) Ĥ_jᵀ)^{-1/2} with Ĥ_j = Dw_jᵀ Δt X̂."""
        Hh = np.einsum("jkm,fkl->fjml", self.Dw, Xh)  # (F, n_cases, m, r)
        Me = np.conj(Hh) @ Hh.transpose(0, 1, 3, 2) + np.eye(self.m)
        we, Ve = np.linalg.eigh(Me)
        Peh = (Ve * (1.0 / np.sqrt(we))[..., None, :]) @ np.conj(Ve).transpose(0, 1, 3, 2)

        def precond_e(E):  # (n, n_cases, m), symmetric
            return self.ifft((Peh @ self.fft(E)[..., None])[..., 0])

        return precond_e

    def step(self, X, e, R, inner_iter: int, inner_tol: float):
        """The Gauss–Newton step ``(dX, de)`` at ``(X, e)`` by LSQR, and its iterations."""
        n, n_cases, k, r, m, lam = self.n, self.n_cases, self.k, self.r, self.m, self.lam
        fft, ifft, precond = self.fft, self.ifft, self.precond
        nx, ne = n * k * r, n * n_cases * m
        Gch = self.dt * fft(self.Gw + self.dG(e))
        GchT = np.ascontiguousarray(Gch.transpose(0, 2, 1))
        Xh = self.dt * fft(X)  # (F, k, r)
        XhT = np.ascontiguousarray(Xh.transpose(0, 2, 1))  # (F, r, k)
        precond_e = self._force_precond(Xh)

        def matvec(v):
            z = v[:nx].reshape(n, k, r)
            de = precond_e(v[nx:].reshape(n, n_cases, m))
            xz = precond(z)
            out1 = ifft(Gch @ fft(xz)) + ifft(fft(self.dG(de)) @ Xh)
            return np.concatenate([out1.ravel(), de.ravel(), lam * xz.ravel()])

        def rmatvec(u):
            u1 = u[: n * n_cases * r].reshape(n, n_cases, r)
            u2 = u[n * n_cases * r: n * n_cases * r + ne].reshape(n, n_cases, m)
            u3 = u[n * n_cases * r + ne:].reshape(n, k, r)
            u1r = fft(u1[::-1])
            gx = ifft(GchT @ u1r)[::-1] + lam * u3  # J_Xᵀ u1 + λ u3
            ge = self.dGt(ifft(u1r @ XhT)[::-1]) + u2  # J_eᵀ u1 + u2
            return np.concatenate([precond(gx).ravel(), precond_e(ge).ravel()])

        op = scipy.sparse.linalg.LinearOperator(
            (n * n_cases * r + ne + nx, nx + ne), matvec=matvec, rmatvec=rmatvec,
            dtype=float)
        rhs = np.concatenate([R.ravel(), -e.ravel(), -lam * X.ravel()])
        sol = scipy.sparse.linalg.lsqr(op, rhs, atol=inner_tol, btol=inner_tol,
                                       iter_lim=inner_iter)
        dX = precond(sol[0][:nx].reshape(n, k, r))
        de = precond_e(sol[0][nx:].reshape(n, n_cases, m))
        return dX, de, int(sol[2])

    def line_search(self, X, e, dX, de, phi: float):
        """``(X, e, R, φ)`` at the first step ``t = 1, 1/2, …`` that lowers ``φ`` (None if
        none of :data:`_MAX_HALVINGS` does)."""
        t = 1.0
        for _ in range(_MAX_HALVINGS):
            Xt, et = X + t * dX, e + t * de
            Rt = self.residual(Xt, et)
            phit = self.objective(Rt, Xt, et)
            if phit < phi:
                return Xt, et, Rt, phit
            t *= 0.5
        return None
