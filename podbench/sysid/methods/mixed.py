"""Mixed-response method (§3.4, Eqs. 3.50–3.64).

Three responses ``a``, ``b``, ``c``, each to its own initial displacement, initial velocity
and load, identify per POM ``i`` (POMs ``U`` of case ``a``, Eq. 3.50) a displacement POC
history, a velocity POC history and a diagonal kernel ``c_ii``; these predict the response
to any combination of a new initial displacement, initial velocity and load.

Solution procedure (the dissertation leaves it loosely specified; this is the MATLAB's
elimination, written out). For each mode ``i`` let ``D = ᵃσ_{i,disp} v_{i,disp}`` and
``V = ᵃσ_{i,vel} v_{i,vel}`` be case ``a``'s scaled displacement and velocity histories. By
Eqs. 3.58–3.61 the other cases' POVs are fixed multiples of ``a``'s::

    r_bd = u_iᵀw0_b / u_iᵀw0_a,  r_cd = u_iᵀw0_c / u_iᵀw0_a,
    r_bv = u_iᵀv0_b / u_iᵀv0_a,  r_cv = u_iᵀv0_c / u_iᵀv0_a,

so Eqs. 3.55–3.57 read (``Q̌_a`` etc. the convolution matrices of the modal forces, Eq. 3.40)::

    v̂_a =      D +      V + Q̌_a c
    v̂_b = r_bd D + r_bv V + Q̌_b c
    v̂_c = r_cd D + r_cv V + Q̌_c c.

Eliminating ``D`` (b − r_bd·a, c − r_cd·a) and then ``V`` with
``R = (r_cv − r_cd)/(r_bv − r_bd)``::

    [(Q̌_c − r_cd Q̌_a) − R (Q̌_b − r_bd Q̌_a)] c = (v̂_c − r_cd v̂_a) − R (v̂_b − r_bd v̂_a)
    V = [(v̂_b − r_bd v̂_a) − (Q̌_b − r_bd Q̌_a) c] / (r_bv − r_bd)
    D = v̂_a − V − Q̌_a c.

The first line is one scalar deconvolution (its matrix is the convolution matrix of the
combined force ``q_c − r_cd q_a − R (q_b − r_bd q_a)``) solved with the chosen solver.
Eqs. 3.62–3.63 (unit POC histories) only split ``D`` and ``V`` into POV × POC
(``povs_disp_``, ``pocs_disp_``, …); they do not change predictions.

Prediction (superposition): ``W̃ = U [D ∘ s_d + V ∘ s_v + c * q̃]`` with, per mode,

* ``s_d = u_iᵀw̃0 / u_iᵀw0_a`` (the ratio of Eq. 3.58; identical to the MATLAB's
  ``u_iᵀw̃0 / D[0]`` because ``D[0] = u_iᵀw0_a`` when ``W_a[:, 0] = w0_a`` and the forces
  start at zero);
* ``s_v``, chosen by ``velocity_scaling``:
  ``"finite_difference"`` (default): ``u_iᵀẇ̃0 / V̇(0)`` with ``V̇(0) ≈ (V[1] − V[0])/Δt``
  (Eq. 3.64, the text's and the appendix MATLAB's scaling); biased by the one-sided
  difference (error of order ``ω Δt``);
  ``"ratio"``: ``u_iᵀẇ̃0 / u_iᵀẇ0_a``, the ratio implied by Eqs. 3.60–3.61; exact under the
  method's assumptions (podbench's option, not the text's).

Which training sets to use: §3.4 asks only for "three distinct sets … separate combinations"
whose equations "may be solved"; :mod:`podbench.methods.mixed_design` measures that from the
training records (:func:`~podbench.methods.mixed_design.design_conditioning`).
"""

from __future__ import annotations

from typing import cast

import numpy as np

from podbench.errors import DimensionError, IllConditionedError, InputError
from podbench.sysid.deconvolution import convolution_product, convolve
from podbench.sysid.methods.base import (
    ENERGY,
    MAX_GROWTH,
    N_MODES,
    SOLVER_PARAMS,
    TOL,
    ArrayForm,
    PODMethod,
    as_int_list,
    check_energy,
    check_max_growth,
    check_n_modes,
    check_new_force,
    check_profile,
    check_tol,
    make_method_solver,
    select_basis,
    solve_deconvolution,
)
from podbench.sysid.methods.forced import MultipleLoad
from podbench.sysid.methods.free import MDS
from podbench.sysid.methods.superposition import Superposition
from podbench.sysid.params import Options

__all__ = ["MixedResponse", "refuse_measured_inputs", "check_measured_inputs"]

_SCALINGS = ("ratio", "finite_difference")


def refuse_measured_inputs(record) -> str:
    """Why MR cannot identify from a record driven from rest by measured inputs."""
    return (f"MR: {getattr(record, 'name', 'record')}: the mixed-response method identifies "
            "Φ11, Φ12 from free responses (initial displacement and velocity) beside forced "
            "ones; a record driven from rest by measured inputs has no initial condition to "
            "identify them from. Use ML")


def check_measured_inputs(record) -> None:
    """Raise MR's refusal of a record driven from rest by measured inputs."""
    raise InputError(refuse_measured_inputs(record))


class MixedResponse(PODMethod):
    """Mixed-response method (§3.4, Eqs. 3.50–3.64); see the module docstring for the
    exact solution procedure.

    Assumes diagonal ``Φ11``, ``Φ12`` and ``C`` in the POM basis (identity-proportional
    mass, light proportional damping), like POVR and SL.

    Parameters
    ----------
    n_modes : int, optional
        Number of POMs of case ``a``; default from ``energy`` (or ``basis.shape[1]``).
    energy : float
        Cumulative energy fraction (Eq. 2.3, σ-based) when ``n_modes`` is None (0.99).
    solver : str
        Deconvolution solver: ``"auto"`` (default: exact on clean data, ``"subspace"`` on
        noisy data, :class:`~podbench.deconvolution.Auto`), ``"ls"`` (the dissertation's) or
        ``"tls"`` (dense); ``"block"``, ``"fft"``, ``"cgls"`` (structured); see
        :mod:`podbench.deconvolution`.
    solver_options : dict, optional
        Keyword options of the solver.
    velocity_scaling : {"ratio", "finite_difference"}
        How a new initial velocity scales the velocity histories (module docstring);
        default ``"finite_difference"`` (Eq. 3.64, as the text and its MATLAB).
    tol : float
        Guard (default 1e-6): ``fit`` raises :class:`IllConditionedError` if
        ``|u_iᵀw0_a| <= tol·‖w0_a‖`` or ``|u_iᵀv0_a| <= tol·‖v0_a‖`` (division in
        Eqs. 3.58–3.61), if ``|r_bv − r_bd| <= tol·max(1, |r_bv|, |r_bd|)`` (cases ``a`` and
        ``b`` mix displacement and velocity in the same proportion, so ``D`` and ``V``
        cannot be separated), if the combined force is ``<= tol`` times the sum of the
        three modal-force norms, or (finite differences) if ``|V̇(0)| <= tol·|u_iᵀv0_a|``.

    max_growth : float
        ``fit`` raises :class:`IllConditionedError` when a deconvolution amplifies the data
        by more than this, ``‖A‖‖X‖/‖B‖ > max_growth`` (default 1e8, the ``"block"``
        solver's own limit; :func:`~podbench.methods.base.amplification`): the kernel
        would be amplified noise or model error (e.g. one record with random forces, whose
        convolution matrix is ill-conditioned). The value reached is
        ``solver_info_["amplification"]``.

    Attributes
    ----------
    modes_ : (m, k) ndarray
        POMs of case ``a``.
    povs_, pocs_ : (k,), (n, k) ndarray
        POVs and POC histories of case ``a``.
    disp_histories_, vel_histories_ : (k, n) ndarray
        ``D`` and ``V`` per mode (in), case ``a``'s parts due to its initial displacement
        and initial velocity.
    povs_disp_, povs_vel_ : (k,) ndarray
        ``ᵃσ_{i,disp} = ‖D_i‖``, ``ᵃσ_{i,vel} = ‖V_i‖`` (Eqs. 3.62–3.63).
    pocs_disp_, pocs_vel_ : (n, k) ndarray
        Unit histories ``v_{i,disp}``, ``v_{i,vel}``.
    kernel_ : (k, k, n) ndarray
        Diagonal ``C(t_s) = kernel_[:, :, s]`` (in/(lbf·s)).
    pov_ratios_ : (k, 4) ndarray
        Columns ``r_bd, r_bv, r_cd, r_cv`` (Eqs. 3.58–3.61).
    velocity_derivative_ : (k,) ndarray
        ``V̇(0) ≈ (V[1] − V[0])/Δt`` (Eq. 3.64, in/s), for comparison with
        ``u_iᵀv0_a`` (``initial_velocity_coordinates_``).
    initial_displacement_coordinates_, initial_velocity_coordinates_ : (k,) ndarray
        ``u_iᵀw0_a`` (in) and ``u_iᵀv0_a`` (in/s).
    fit_residual_ : float
        Relative residual of the per-mode deconvolutions.
    velocity_scaling_ : str
        The ``velocity_scaling`` used by ``predict`` (fixed at ``fit``).
    dt_ : float
    n_modes_ : int
    """

    abbreviation = "MR"
    excitation_kind = "mixed"
    n_records = (3, 3)
    #: The dissertation's array form: ``fit([Wa, Wb, Wc], w0=…, v0=…, F=…, dt=…)``,
    #: ``predict(w0=…, v0=…, F=…)`` (:mod:`podbench.sysid.methods.arrays`).
    array_form = ArrayForm(keywords=("w0", "v0", "F", "dt"), sets=True,
                           target_keywords=("w0", "v0", "F"))
    _parameter_constraints = {"n_modes": N_MODES, "energy": ENERGY, **SOLVER_PARAMS,
                              "velocity_scaling": [Options(*_SCALINGS)], "tol": TOL,
                              "max_growth": MAX_GROWTH}

    def __init__(self, *, n_modes=None, energy=0.99, solver="auto", solver_options=None,
                 velocity_scaling="finite_difference", tol=1e-6, max_growth=1e8):
        self.n_modes = n_modes
        self.energy = energy
        self.solver = solver
        self.solver_options = solver_options
        self.velocity_scaling = velocity_scaling
        self.tol = tol
        self.max_growth = max_growth

    def required_fields(self) -> tuple[str, ...]:
        return ("W", "F", "w0", "v0", "dt")

    def refusal(self, records) -> str | None:
        """Records driven by measured inputs that are not forces at the outputs: no initial
        condition, no modal force."""
        for r in records:
            if r.u is not None and not r.collocated:
                return refuse_measured_inputs(records[0])
        return None

    def coupled_twin(self):
        """MDS (displacements) + MDS (velocities) + ML, summed: the coupled counterpart of
        each of MR's three parts (each needs its own training records, one per mode)."""

        return Superposition(parts=(
            MDS(excitation="displacement", n_modes=self.n_modes),
            MDS(excitation="velocity", n_modes=self.n_modes),
            MultipleLoad(n_modes=self.n_modes, solver=self.solver,
                         solver_options=self.solver_options),
        ))

    def _fit(self, records, basis) -> None:
        """Cases ``a``, ``b``, ``c``: each record holds ``W`` (in), its own initial
        displacement ``w0`` (in) and velocity ``v0`` (in/s), its load ``F`` (lbf, first
        sample at ``t = 0``) and ``dt`` (s)."""
        Ws = [r.W for r in records]
        w0s, v0s, Fs = ([cast(np.ndarray, getattr(r, f)) for r in records]
                        for f in ("w0", "v0", "F"))
        self._identify(Ws, w0s, v0s, Fs, records[0].dt, basis)

    def _identify(self, Ws, w0s, v0s, Fs, dt, basis) -> None:
        n_modes = check_n_modes(self.n_modes)
        energy = check_energy(self.energy)
        solver = make_method_solver(self.solver, self.solver_options)
        tol = check_tol(self.tol)
        n = Ws[0].shape[1]
        if self.velocity_scaling == "finite_difference" and n < 2:
            raise DimensionError(
                "Parameter `W`: velocity_scaling='finite_difference' needs at least 2 samples"
            )
        U, povs, pocs = select_basis(Ws[0], n_modes, basis, energy=energy)
        k = U.shape[1]
        Vh = np.stack([U.T @ Wj for Wj in Ws])  # 3 × k × n
        Q = np.stack([U.T @ Fj for Fj in Fs])  # 3 × k × n
        D0 = U.T @ np.column_stack(w0s)  # k × 3
        V0 = U.T @ np.column_stack(v0s)
        ratios, den, R = _pov_ratios(D0, V0, w0s[0], v0s[0], tol)
        parts = _separate(Vh, Q, ratios, den, R, dt, tol, solver,
                          check_max_growth(self.max_growth))
        D, V, kernel, infos, res2, rhs2 = parts
        vdot = (V[:, 1] - V[:, 0]) / dt if n >= 2 else np.full(k, np.nan)
        if self.velocity_scaling == "finite_difference":
            bad = np.abs(vdot) <= tol * np.abs(V0[:, 0])
            if np.any(bad):
                raise IllConditionedError(
                    f"MR: the finite-difference initial derivative (Eq. 3.64) of the velocity "
                    f"history is (nearly) zero for mode(s) {as_int_list(bad)}; use "
                    "velocity_scaling='ratio'"
                )
        nD, nV = np.linalg.norm(D, axis=1), np.linalg.norm(V, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.pocs_disp_ = np.where(nD > 0, D.T / nD, 0.0)
            self.pocs_vel_ = np.where(nV > 0, V.T / nV, 0.0)
        self.povs_disp_, self.povs_vel_ = nD, nV
        self.solver_ = solver
        self.solver_info_ = infos
        self._set_basis(U, povs, pocs, dt)
        self.disp_histories_ = D
        self.vel_histories_ = V
        self.kernel_ = kernel
        self.pov_ratios_ = np.column_stack(ratios)
        self.velocity_derivative_ = vdot
        self.initial_displacement_coordinates_ = D0[:, 0]
        self.initial_velocity_coordinates_ = V0[:, 0]
        self.fit_residual_ = float(np.sqrt(res2 / rhs2)) if rhs2 > 0 else float(np.sqrt(res2))
        self.velocity_scaling_ = self.velocity_scaling

    def _predict(self, record) -> np.ndarray:
        """Response (in, ``(m, n')``, the superposition of the three parts) to any
        combination of the target's new initial displacement ``w0`` (in), velocity ``v0``
        (in/s) and load ``F`` (lbf, ``n' <= n`` samples; sets the length of the prediction,
        default ``n``); ``dt``, if given, must equal the training one. The array form
        ``predict(w0=…, v0=…, F=…)`` gives them as keywords."""
        rec = self._target_record(record, "record", fields=False)  # any of w0, v0, F
        w0, v0, F = rec.w0, rec.v0, rec.F
        if w0 is None and v0 is None and F is None:
            raise InputError("MR.predict: give at least one of `w0`, `v0`, `F`")
        U = self.modes_
        m, k, n = U.shape[0], self.n_modes_, self.kernel_.shape[2]
        if F is not None:
            F = check_new_force(F, m, n, "F")
            n = F.shape[1]
        out = np.zeros((k, n))
        if w0 is not None:
            s = (U.T @ check_profile(w0, m, "w0")) / self.initial_displacement_coordinates_
            out += self.disp_histories_[:, :n] * s[:, None]
        if v0 is not None:
            a = U.T @ check_profile(v0, m, "v0")
            if self.velocity_scaling_ == "finite_difference":
                s = a / self.velocity_derivative_
            else:
                s = a / self.initial_velocity_coordinates_
            out += self.vel_histories_[:, :n] * s[:, None]
        if F is not None:
            idx = np.arange(k)
            out += convolve(self.kernel_[idx, idx], U.T @ F, self.dt_)
        return U @ out


def _pov_ratios(D0, V0, w0a, v0a, tol: float):
    """The POV ratios ``(r_bd, r_bv, r_cd, r_cv)`` of Eqs. 3.58–3.61, ``r_bv − r_bd`` and
    ``R = (r_cv − r_cd)/(r_bv − r_bd)``; IllConditionedError where a division is unsafe."""
    k = D0.shape[0]
    for name, coords, x in (("w0", D0, w0a), ("v0", V0, v0a)):
        scale = float(np.linalg.norm(x))
        bad = np.abs(coords[:, 0]) <= tol * scale
        if np.any(bad):
            raise IllConditionedError(
                f"MR: |u_iᵀ{name}_a| <= tol·‖{name}_a‖ = {tol * scale:.3g} for mode(s) "
                f"{as_int_list(bad)} (tol = {tol:g}); the POV ratios of Eqs. 3.58–3.61 "
                f"divide by it: case a needs a nonzero {name} with a share in every mode"
            )
    r_bd, r_cd = D0[:, 1] / D0[:, 0], D0[:, 2] / D0[:, 0]
    r_bv, r_cv = V0[:, 1] / V0[:, 0], V0[:, 2] / V0[:, 0]
    den = r_bv - r_bd
    bad = np.abs(den) <= tol * np.maximum.reduce([np.ones(k), abs(r_bv), abs(r_bd)])
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise IllConditionedError(
            f"MR: r_bv − r_bd = {den[i]:.3g} (≈ 0) for mode(s) {as_int_list(bad)}: cases a "
            "and b excite this mode with initial displacement and velocity in the same "
            "proportion, so the displacement and velocity histories cannot be separated; "
            "choose case b's initial conditions differently"
        )
    return (r_bd, r_bv, r_cd, r_cv), den, (r_cv - r_cd) / den


def _separate(Vh, Q, ratios, den, R, dt: float, tol: float, solver, max_growth: float):
    """Per mode, the kernel ``c_ii`` (one scalar deconvolution of the combined force) and
    case a's displacement and velocity histories ``D``, ``V`` (module docstring).

    Returns ``(D, V, kernel, infos, res2, rhs2)``: ``D``, ``V`` (k, n), the diagonal kernel
    (k, k, n), the solver's diagnostics per mode and the squared residual and right-hand
    side of the deconvolutions."""
    r_bd, _, r_cd, _ = ratios
    k, n = Vh.shape[1], Vh.shape[2]
    kernel = np.zeros((k, k, n))
    D = np.empty((k, n))
    V = np.empty((k, n))
    res2, rhs2 = 0.0, 0.0
    infos = []
    for i in range(k):
        qa, qb, qc = Q[0, i], Q[1, i], Q[2, i]
        qba = qb - r_bd[i] * qa
        g = (qc - r_cd[i] * qa) - R[i] * qba
        fscale = np.linalg.norm(qa) + np.linalg.norm(qb) + np.linalg.norm(qc)
        if fscale == 0 or np.linalg.norm(g) <= tol * fscale:
            raise IllConditionedError(
                f"MR: mode {i + 1}: the combined modal force q_c − r_cd q_a − R (q_b − r_bd "
                f"q_a) is (nearly) zero (norm {np.linalg.norm(g):.3g}, modal forces "
                f"{fscale:.3g}); the loads cannot be separated from the initial conditions"
            )
        yb = Vh[1, i] - r_bd[i] * Vh[0, i]
        rhs = (Vh[2, i] - r_cd[i] * Vh[0, i]) - R[i] * yb
        c, info = solve_deconvolution(solver, [g[None]], rhs, dt, max_growth,
                                      f"MR mode {i + 1}")
        infos.append(info)
        res2 += float(np.sum((convolution_product([g[None]], c, dt) - rhs) ** 2))
        rhs2 += float(np.sum(rhs**2))
        kernel[i, i] = c
        V[i] = (yb - convolve(c, qba, dt)) / den[i]
        D[i] = Vh[0, i] - V[i] - convolve(c, qa, dt)
    return D, V, kernel, infos, res2, rhs2
