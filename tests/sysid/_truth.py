"""Independent truth for the method tests: a tiny dense Newmark integrator and test systems.

Deliberately independent of ``podbench.dynamics`` (written separately), so that the method
tests do not share a bug with the simulator they will later be compared against.

Why Newmark (average acceleration) and not an exact discretization: the methods are exact
for *any* linear time-invariant one-step map, because

* a free response is ``x_j = Aᵈʲ x_0`` with the initial state linear in ``w0`` (or ``ẇ0``),
  so ``W[:, j] = Φ_j w0`` holds exactly for some matrices ``Φ_j`` (MDS, POVR's premise);
* a forced response from rest is ``w_j = Σ_{p≥1} G_{j−p} f_p`` when ``f_0 = 0``, i.e. a
  causal discrete convolution (Eq. 3.39 with ``c[p] = G_p/Δt``; ``G_0 = βΔt² M_eff⁻¹ ≠ 0``,
  so the kernel has a direct term).

If ``f_0 ≠ 0`` the Newmark start brings ``f_0`` in through the initial acceleration
``a_0 = M⁻¹ f_0``, whose coefficient is not ``G_j``: the forced methods then see a response
that is not an exact convolution. The tests measure that error on purpose.

Units: the systems below are in inch, lbf, second (masses lbf·s²/in, stiffness lbf/in).
"""

from __future__ import annotations

import numpy as np

BETA, GAMMA = 0.25, 0.5  # average acceleration (trapezoidal rule), unconditionally stable


def newmark(M, C, K, dt, n, *, w0=None, v0=None, F=None):
    """Linear Newmark average acceleration for ``M q'' + C q' + K q = f``.

    Parameters
    ----------
    M, C, K : (d, d) array_like
        Dense mass, damping and stiffness matrices.
    dt : float
        Time step (s); sample ``j`` is at ``t_j = j·dt``.
    n : int
        Number of samples (column 0 is the initial state).
    w0, v0 : (d,) array_like, optional
        Initial displacement (in) and velocity (in/s); zero by default.
    F : (d, n) array_like, optional
        Force at every DOF and sample (lbf); zero by default.

    Returns
    -------
    W, Wd : (d, n) ndarray
        Displacements and velocities.
    """
    M, C, K = (np.asarray(X, dtype=float) for X in (M, C, K))
    d = M.shape[0]
    w = np.zeros(d) if w0 is None else np.asarray(w0, dtype=float).copy()
    v = np.zeros(d) if v0 is None else np.asarray(v0, dtype=float).copy()
    F = np.zeros((d, n)) if F is None else np.asarray(F, dtype=float)
    a = np.linalg.solve(M, F[:, 0] - C @ v - K @ w)
    Meff_inv = np.linalg.inv(M + GAMMA * dt * C + BETA * dt**2 * K)
    W, Wd = np.zeros((d, n)), np.zeros((d, n))
    W[:, 0], Wd[:, 0] = w, v
    for j in range(1, n):
        wp = w + dt * v + (0.5 - BETA) * dt**2 * a
        vp = v + (1.0 - GAMMA) * dt * a
        a = Meff_inv @ (F[:, j] - C @ vp - K @ wp)
        w = wp + BETA * dt**2 * a
        v = vp + GAMMA * dt * a
        W[:, j], Wd[:, j] = w, v
    return W, Wd


def chain_stiffness(d: int, k: float) -> np.ndarray:
    """Fixed-free chain of ``d`` masses joined by springs ``k`` (lbf/in)."""
    K = 2 * k * np.eye(d) - k * np.eye(d, k=1) - k * np.eye(d, k=-1)
    K[-1, -1] = k
    return K


def coupled_chain(d: int = 5):
    """A chain that violates the diagonal assumptions of POVR, SL and MR.

    Consistent-type (non-diagonal) mass matrix and non-proportional damping (one strong
    dashpot at the free end plus a light one at the root). Returns ``(M, C, K)``.
    """
    m = 1.0
    M = m * (np.eye(d) * 2 / 3 + (np.eye(d, k=1) + np.eye(d, k=-1)) / 6)
    M[-1, -1] = m / 3 + m / 3  # keep it well away from singular
    K = chain_stiffness(d, 1.0e4)
    C = np.zeros((d, d))
    C[-1, -1] = 8.0
    C[0, 0] = 1.0
    return M, C, K


def ideal_chain(d: int = 5, zeta: float = 0.002):
    """A chain that meets POVR/SL/MR's assumptions: identity mass, light Rayleigh damping.

    ``C = α M + β K`` with ``α, β`` giving damping ratio ``zeta`` at the first and last
    natural frequencies. Returns ``(M, C, K)``.
    """
    M = np.eye(d)
    K = chain_stiffness(d, 1.0e4)
    w = np.sqrt(np.linalg.eigvalsh(K))
    w1, w2 = w[0], w[-1]
    alpha = 2 * zeta * w1 * w2 / (w1 + w2)
    beta = 2 * zeta / (w1 + w2)
    return M, alpha * M + beta * K, K


def eigenmodes(M, K) -> np.ndarray:
    """Mass-normalized eigenvectors of ``K φ = ω² M φ`` (orthonormal when ``M = I``)."""
    from scipy.linalg import eigh

    return eigh(K, M)[1]


def pulse(d: int, n: int, dof: int, *, amplitude: float = 100.0, start: int = 1,
          width: int = 5) -> np.ndarray:
    """Rectangular pulse (lbf) on one DOF, samples ``start … start+width−1`` (F[:, 0] = 0
    by default, as podbench's pulses)."""
    F = np.zeros((d, n))
    F[dof, start : start + width] = amplitude
    return F


def smooth_load(d: int, n: int, rng, *, amplitude: float = 100.0) -> np.ndarray:
    """A random load on every DOF: a short random smooth history per DOF with ``F[:, 0] = 0``."""
    t = np.arange(n)
    F = np.zeros((d, n))
    for i in range(d):
        c = rng.uniform(5, n / 3)
        wdt = rng.uniform(2, 8)
        F[i] = amplitude * rng.standard_normal() * np.exp(-(((t - c) / wdt) ** 2))
    F[:, 0] = 0.0
    return F


def rel_err(W_pred, W_true) -> float:
    """``‖Ŵ − W‖_F / ‖W‖_F``."""
    return float(np.linalg.norm(W_pred - W_true) / np.linalg.norm(W_true))
