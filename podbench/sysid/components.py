"""Identification of a component's interface kernel from its records (Chapter 6).

A component tested on its own: the force ``g`` applied at its interface DOFs (p load cells)
and the response ``y`` there (p accelerometers, or displacements). Its discrete kernel
(:mod:`podbench.dynamics.coupling`'s convention, no ``Δt`` factor)::

    y[n] = Σ_k H[k] g[n−k]                 (time-invariant)
    y[n] = Σ_k H[n, k] g[n−k]              (time-varying)

is found with the deconvolution solvers of :mod:`podbench.sysid.deconvolution`, whose
convolution ``y[s] = Δt Σ_{p≤s} G[s−p] X[p]`` has lag 0 (an accelerometer's direct
feedthrough ``H[0] ≠ 0``; the pole models of ``"realization"``/``"subspace"`` carry it as
their ``D`` term): ``H[k] = Δt X[k]ᵀ``.

**Time-varying kernels** from few records: the kernel is expanded over ``B`` smooth functions
of the time at which the force acts, ``H[n, k] = Σ_b φ_b[n−k] Θ_b[k]`` (Legendre
polynomials on the record: a smoothness prior on the time variation). Then
``y[n] = Σ_b Σ_k Θ_b[k] (φ_b g)[n−k]`` is an ordinary convolution with ``B·p`` inputs
``φ_b g`` and the same solvers apply unchanged: a record of ``n`` samples gives ``n``
equations for every output, whatever ``B``, so the number of records needed no longer grows
with the kernel's length (a lag-by-lag, time-by-time fit needs at least ``L`` records). ``B``
is chosen by hold-out over the records (every other record fits, the rest predict), or
given. Records must share the component's clock (record sample ``j`` at the component's
time ``t_j``).

Records start at rest with ``g`` sampled from the first sample on (the convolution model is
exact only from rest). Units: force lbf, acceleration in/s² (or displacement in), s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial import legendre

from podbench.errors import DimensionError, InputError
from podbench.sysid.deconvolution import ConvolutionSystem, make_solver, solve
from podbench.sysid.statespace import era_realization, realize

__all__ = ["KernelFit", "identify_kernel", "identify_lagged", "lagged_matrix",
           "interface_system", "temporal_basis", "kernel_realization", "BASIS_CANDIDATES",
           "KERNEL_RANK_TOL", "EXACT_RANK_TOL"]

BASIS_CANDIDATES = (1, 3, 5, 7, 9, 11, 13, 17, 21)
"""Numbers of temporal functions tried by the hold-out rule of a time-varying kernel."""
LAG_CANDIDATES = (1, 3, 10)
"""Kernel lengths tried by the hold-out rule of :func:`identify_lagged`."""


@dataclass
class KernelFit:
    """An identified kernel: ``kernel`` (L, p, p) or (n_t, L, p, p), an optional state-space
    ``realization`` ``(A, B, C, D)`` of a time-invariant one (``H[0] = D``,
    ``H[k] = C A^{k−1} B``), and ``info`` (the solver's diagnostics, the basis size)."""

    kernel: np.ndarray
    realization: tuple | None = None
    info: dict = field(default_factory=dict)


def temporal_basis(n: int, n_basis: int) -> np.ndarray:
    """Legendre polynomials ``P_0 … P_{B−1}`` on the samples ``0 … n−1`` mapped to [−1, 1],
    (B, n)."""
    x = np.linspace(-1.0, 1.0, n)
    return np.array([legendre.legval(x, np.eye(n_basis)[b]) for b in range(n_basis)])


def _check_records(forces, responses):
    F = [np.atleast_2d(np.asarray(f, dtype=float)) for f in forces]
    Y = [np.atleast_2d(np.asarray(y, dtype=float)) for y in responses]
    if not F or len(F) != len(Y):
        raise InputError(f"identify_kernel: expected as many force as response records "
                         f"(at least one), got {len(F)} and {len(Y)}")
    shape = F[0].shape
    for i, (f, y) in enumerate(zip(F, Y, strict=True)):
        if f.shape != shape or y.shape != shape:
            raise DimensionError(f"identify_kernel: record {i}: force {f.shape} and response "
                                 f"{y.shape} must both be {shape} (p channels × n samples)")
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(y))):
            raise InputError(f"identify_kernel: record {i} contains NaN or Inf")
    return F, Y


def interface_system(forces, responses, dt: float, basis: np.ndarray | None = None
                     ) -> ConvolutionSystem:
    """The convolution system of the records: inputs ``g`` (or ``φ_b g`` for every row of
    ``basis``), outputs ``y``."""
    F, Y = _check_records(forces, responses)
    if basis is not None:
        F = [np.vstack([phi[None, :] * f for phi in basis]) for f in F]
    B = np.vstack([y.T for y in Y])
    return ConvolutionSystem(F, B, dt)


def _kernel_from(X: np.ndarray, dt: float, p: int, basis: np.ndarray | None, n_lags: int
                 ) -> np.ndarray:
    """Solver blocks X (n, k, r) → H (L, p, p) or (n_t, L, p, p)."""
    if basis is None:
        return dt * X[:n_lags].transpose(0, 2, 1)
    nb, n = basis.shape
    Th = dt * X[:n_lags].reshape(n_lags, nb, p, p).transpose(0, 1, 3, 2)  # (L, b, out, in)
    H = np.zeros((n, n_lags, p, p))
    for k in range(n_lags):
        # H[t, k] = Σ_b φ_b[t − k] Θ_b[k] for t ≥ k
        H[k:, k] = np.einsum("bt,bij->tij", basis[:, :n - k], Th[k])
    return H


def _holdout_basis(forces, responses, dt, solver, options, candidates, n_lags):
    """The basis size whose fit on the even records best predicts the odd ones."""
    F, Y = _check_records(forces, responses)
    fit_i, test_i = list(range(0, len(F), 2)), list(range(1, len(F), 2))
    errors = {}
    den = sum(float(np.sum(Y[i] ** 2)) for i in test_i) or 1.0
    for nb in candidates:
        basis = temporal_basis(F[0].shape[1], nb)
        system = interface_system([F[i] for i in fit_i], [Y[i] for i in fit_i], dt, basis)
        X = system.blocks(make_solver(solver, options).solve(system).X)
        test = interface_system([F[i] for i in test_i], [Y[i] for i in test_i], dt, basis)
        Xc = X.copy()
        Xc[n_lags:] = 0.0
        pred = test.matvec(test.stack(Xc))
        errors[nb] = float(np.sum((pred - test.B) ** 2)) / den
    best = min(errors, key=lambda b: (errors[b], b))
    return best, errors


#: Relative singular-value cut of :func:`kernel_realization`'s Hankel matrix: directions with
#: ``σ_i ≤ KERNEL_RANK_TOL·σ_1`` are round-off of the kernel, not dynamics, and the order is
#: capped below them: the identified kernel moves by about 1e-13 (relative) between CPUs'
#: round-off, so singular values below about 1e-12 are set by round-off and realizing them
#: gives spurious poles that differ from CPU to CPU. The cut sits well above that movement and
#: below the smallest singular value the substructuring study keeps (its measurement:
#: docs/noise.md, "Measurements moved from the source").
#: Its price: real modes whose Hankel singular values a short window at fine sampling puts
#: below the cut are dropped too (the chain's exact kernel: 6 of 8 states, 0.37 % coupled),
#: so :func:`identify_kernel` realizes a pole solver's own model instead and keeps this cut
#: for kernels that come without one.
KERNEL_RANK_TOL = 1e-10

#: The cut for a kernel exact to double precision (a Newmark kernel): only the Hankel's
#: round-off floor (measured 9e-17 of σ_1 on the 5-DOF chain's exact kernels, 100 block
#: rows, whose last two of ten singular values lie there).
EXACT_RANK_TOL = 1e-15


def kernel_realization(H: np.ndarray, order: int, *, blocks: int | None = None,
                       rank_tol: float = EXACT_RANK_TOL) -> tuple:
    """``(A, B, C, D)`` realizing the kernel ``H`` (L, p, p) by ERA at ``order``, or at the
    numerical rank of its Hankel matrix where that is smaller (singular values above
    ``rank_tol`` of the largest: the state dimension the kernel's digits determine;
    :data:`EXACT_RANK_TOL` for a kernel exact to double precision, :data:`KERNEL_RANK_TOL`
    for an identified one), poles outside the unit circle pulled onto it (an identified
    growing mode is noise). The order used is ``A.shape[0]``."""
    L, p, _ = H.shape
    D = H[0].copy()
    if order <= 0:
        return np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), D
    s = blocks or max(order, min((L - 1) // 2, 100))
    P, sv, Qt, H1 = era_realization(H, s)
    rank = int(np.sum(sv > rank_tol * sv[0])) if sv.size and sv[0] > 0 else 0
    order = min(order, rank)
    if order <= 0:
        return np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), D
    A, B, C, D = realize(P, sv, Qt, H1, D, order)
    lam, V = np.linalg.eig(A)
    big = np.abs(lam) > 1.0
    if np.any(big):
        lam = np.where(big, lam / np.abs(lam), lam)
        A = np.real(V @ np.diag(lam) @ np.linalg.inv(V))
    return A, B, C, D


def identify_kernel(forces: Sequence, responses: Sequence, dt: float, *, n_lags: int,
                    solver="subspace", options: dict | None = None,
                    time_varying: bool = False, n_basis: int | str = "auto",
                    candidates: Sequence[int] = BASIS_CANDIDATES,
                    realization_order: int | str | None = "solver") -> KernelFit:
    """The interface kernel of a component from its records.

    Parameters
    ----------
    forces, responses : sequences of (p, n) arrays
        Interface force (lbf) and response of every record, from rest.
    dt : float
        Sampling interval (s).
    n_lags : int
        Kernel length kept (≤ n).
    solver, options
        A deconvolution solver (name or instance, :func:`make_solver`).
    time_varying : bool
        Expand the kernel over a temporal basis (module docstring).
    n_basis : int or "auto"
        Basis size; ``"auto"``: hold-out over records (needs 2 records; with one, 5).
    realization_order : int, "solver" or None
        Time-invariant kernels: also give a state-space realization (the component's memory
        beyond ``n_lags``; the order used is ``info["realization_order"]``). ``"solver"``
        (default): the solver's own model where its solution is one (``"realization"``,
        ``"subspace"``: poles and residues, realized exactly,
        :attr:`~podbench.deconvolution.SolverResult.realization`; ``info["realization"]`` is
        ``"solver"``), otherwise ERA on the kernel at the solver's chosen order
        (``info["order"]``); an int: ERA at that order. ERA's order is capped at the
        numerical rank of the kernel's Hankel matrix (:func:`kernel_realization`;
        ``info["realization"]`` is ``"era"``). None: no realization.

        Why the solver's model first: it is the model the records were fitted to, and
        realizing it is exact, while ERA re-identifies it from ``n_lags`` lags and must drop
        the directions its Hankel matrix cannot tell from round-off (at fine sampling, real
        modes: the 5-DOF chain's exact acceleration kernel at Δt = 1e-4 s has Hankel
        singular values 1 … 6.7e-12, 1.3e-14 over 100 block rows; capped at 1e-10 its ERA
        model keeps 6 of 8 states and couples to the beam 3.7e-3 off the assembled truth,
        against 1.9e-7 to 2.2e-6 with 8, by CPU).
    """
    F, Y = _check_records(forces, responses)
    p, n = F[0].shape
    if not 1 <= n_lags <= n:
        raise InputError(f"identify_kernel: n_lags must lie in 1..{n}, got {n_lags}")
    info: dict = {"n_records": len(F)}
    basis = None
    if time_varying:
        if n_basis == "auto":
            if len(F) >= 2:
                nb, errs = _holdout_basis(F, Y, dt, solver, options, candidates, n_lags)
                info["basis_holdout"] = {int(b): e for b, e in errs.items()}
            else:
                nb = 5
        else:
            nb = int(n_basis)
        info["n_basis"] = nb
        basis = temporal_basis(n, nb)
    system = interface_system(F, Y, dt, basis)
    result = make_solver(solver, options).solve(system)
    info.update({k: v for k, v in result.info.items() if np.isscalar(v) or v is None})
    H = _kernel_from(system.blocks(result.X), dt, p, basis, n_lags)
    real = None
    if not time_varying and realization_order is not None:
        if realization_order == "solver" and result.realization is not None:
            A, Bm, Cm, Dm = result.realization  # X[p]ᵀ = C A^{p−1} B; H = Δt Xᵀ
            real = (A, Bm, dt * Cm, dt * Dm)
            info["realization"] = "solver"
        else:
            order = info.get("order") if realization_order == "solver" else realization_order
            if isinstance(order, (int, np.integer)):
                real = kernel_realization(H, int(order), rank_tol=KERNEL_RANK_TOL)
                info["realization"] = "era"
        if real is not None:
            info["realization_order"] = int(real[0].shape[0])
    return KernelFit(kernel=H, realization=real, info=info)


def lagged_matrix(forces, n_lags: int, basis: np.ndarray) -> np.ndarray:
    """Regressors of a lag-limited time-varying kernel: rows (record, sample), columns
    (lag k, function b, input i) holding ``φ_b[n−k] g_i[n−k]`` (zero before the record)."""
    cols = []
    for k in range(n_lags):
        for phi in basis:
            for i in range(forces[0].shape[0]):
                c = []
                for f in forces:
                    u = phi * f[i]
                    c.append(np.concatenate([np.zeros(k), u[:u.size - k]]))
                cols.append(np.concatenate(c))
    return np.column_stack(cols)


def _lagged_fit(F, Y, n_lags, nb, solver):
    basis = temporal_basis(F[0].shape[1], nb)
    A = lagged_matrix(F, n_lags, basis)
    rhs = np.vstack([y.T for y in Y])
    X = solve(A, rhs, solver=solver)
    return X, basis


def identify_lagged(forces: Sequence, responses: Sequence, *, n_lags: int | str = "auto",
                    n_basis: int | str = "auto", solver: str = "ls",
                    lag_candidates: Sequence[int] = LAG_CANDIDATES,
                    basis_candidates: Sequence[int] = BASIS_CANDIDATES) -> KernelFit:
    """A time-varying kernel ``H[n, k] = Σ_b φ_b[n−k] Θ_b[k]`` with few lags (``k < L``),
    by a dense solver of :mod:`podbench.sysid.deconvolution` (``"ls"`` or ``"tls"``) on the
    lag-limited regressors (:func:`lagged_matrix`): ``L·B·p`` unknowns per output, so a few
    records of ``n`` samples determine it. ``"auto"``: the ``(L, B)`` whose fit on the even
    records best predicts the odd ones (needs 2 records). Returns the kernel (n, L, p, p)."""
    F, Y = _check_records(forces, responses)
    p, n = F[0].shape
    info: dict = {"n_records": len(F)}
    Ls = list(lag_candidates) if n_lags == "auto" else [int(n_lags)]
    Bs = list(basis_candidates) if n_basis == "auto" else [int(n_basis)]
    if len(Ls) * len(Bs) > 1:
        if len(F) < 2:
            raise InputError("identify_lagged: the hold-out choice of lags and basis needs at "
                             "least 2 records; give n_lags and n_basis")
        fit_i, test_i = list(range(0, len(F), 2)), list(range(1, len(F), 2))
        Ft, Yt = [F[i] for i in test_i], [Y[i] for i in test_i]
        rt = np.vstack([y.T for y in Yt])
        errs = {}
        for L in Ls:
            for nb in Bs:
                X, basis = _lagged_fit([F[i] for i in fit_i], [Y[i] for i in fit_i], L, nb,
                                       solver)
                pred = lagged_matrix(Ft, L, basis) @ X
                errs[(L, nb)] = float(np.sum((pred - rt) ** 2) / np.sum(rt ** 2))
        L, nb = min(errs, key=lambda key: (errs[key], key[0] * key[1]))
        info["holdout"] = {f"L={a},B={b}": e for (a, b), e in errs.items()}
    else:
        L, nb = Ls[0], Bs[0]
    X, basis = _lagged_fit(F, Y, L, nb, solver)
    info.update({"n_lags": L, "n_basis": nb, "solver": solver})
    H = _kernel_from(X.reshape(L, nb * p, p), 1.0, p, basis, L)
    return KernelFit(kernel=H, realization=None, info=info)
