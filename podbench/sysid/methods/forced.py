"""Forced-response methods (§3.3): single-load (SL) and multiple-load (ML).

Both take records whose inputs are forces at the output sensors (the dissertation's); ML
also takes measured inputs elsewhere (a base acceleration, ground motion: Chapter 6,
:mod:`podbench.sysid.methods.inputs`), where SL's diagonal assumption has no meaning and SL
refuses them with that reason; and measured inputs of a periodic excitation in steady
state (``inputs="periodic"``: the kernel over one period, :mod:`podbench.sysid.periodic`).

The structure starts at rest and the scaled POC histories are the convolution of a modal
impulse-response kernel ``C(t) = Φ12(t) M⁻¹`` (``k × k``) with the modal forces
``q = Uᵀ F`` (Eqs. 3.34–3.38). Time-sampled, with the Δt of Eq. 3.39 kept::

    v̂_l[s] = Δt Σ_i Σ_{p=0}^{s} c_{li}[p] q_i[s−p].

Sampling: column 0 of ``W`` and ``F`` is ``t = 0``. A response that starts at rest has
``W[:, 0] = 0`` and, with the pulses podbench uses, ``F[:, 0] = 0``; the convolution matrices
then have a zero diagonal and are singular, but the system is consistent and the
minimum-norm least-squares solution (``solver="ls"``) reproduces and predicts exactly. A
Newmark response to a force with ``F[:, 0] ≠ 0`` is *not* a causal convolution of this form
(Newmark brings ``f_0`` in through the initial acceleration), which shows as an error.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from podbench.core.records import Record, as_record, check_compatible, check_records, is_record
from podbench.core.validation import as_finite_array
from podbench.errors import DimensionError, IllConditionedError, InputError
from podbench.sysid.deconvolution import convolution_product, convolve, convolve_kernel
from podbench.sysid.deconvolution.lagged import lag_response
from podbench.sysid.methods.bands import diagonal_inconsistency, diagonal_split
from podbench.sysid.methods.base import (
    BASES,
    ENERGY,
    MAX_COND,
    MAX_GROWTH,
    N_MODES,
    SOLVER_PARAMS,
    TOL,
    ArrayForm,
    PODMethod,
    as_int_list,
    check_dt,
    check_energy,
    check_max_cond,
    check_max_growth,
    check_n_modes,
    check_tol,
    make_method_solver,
    modal_share_too_small,
    per_record_basis,
    select_basis,
    solve_deconvolution,
    solve_deconvolutions,
)
from podbench.sysid.methods.inputs import (
    LAG_GAIN,
    LAG_GRID,
    fit_fir,
    fit_whole,
    fold_kernels,
    given_basis,
    measured_basis,
)
from podbench.sysid.methods.pole_basis import fit_pole_basis, pilot_factors, pole_states
from podbench.sysid.params import Boolean, InstanceOf, Interval, Options, check_param
from podbench.sysid.periodic import (
    choose_lines,
    period_convolution,
    period_kernel,
    period_spectra,
    periodic_prediction,
    pooled_noise,
    pooled_response,
)

__all__ = ["SingleLoad", "MultipleLoad", "KERNEL_TAIL", "kernel_lags", "INPUTS"]

KERNEL_TAIL = 1e-6
"""The ``n_lags="auto"`` rule: the smallest ``L`` whose kernel tail carries at most this
fraction of the identified kernel's energy, ``Σ_{s≥L} ‖C(t_s)‖²_F <= KERNEL_TAIL ·
Σ_s ‖C(t_s)‖²_F`` (fixed in advance; it reads only the kernel fitted on the training records)."""



def kernel_lags(kernel: np.ndarray, tail: float = KERNEL_TAIL) -> int:
    """Number of lags ``L`` of the ``n_lags="auto"`` rule (:data:`KERNEL_TAIL`).

    Parameters
    ----------
    kernel : (k, k, n) ndarray
        Identified kernel ``C(t_s) = kernel[:, :, s]`` (in/(lbf·s)).
    tail : float
        Largest energy fraction left beyond ``L``.

    Returns
    -------
    int
        ``1 <= L <= n``.
    """
    e = np.sum(kernel.reshape(-1, kernel.shape[-1]) ** 2, axis=0)
    total = float(e.sum())
    if total == 0:
        return 1
    beyond = total - np.cumsum(e)  # beyond[L-1] = energy of samples L … n−1
    return int(np.flatnonzero(beyond <= tail * total)[0]) + 1


N_LAGS: list = [None, Options("auto"), Interval("integer", 1)]
INPUTS: list = [Options("auto", "modal", "measured")]
"""``inputs``: the modal forces ``Uᵀ F`` of forces at the output sensors (``"modal"``, the
dissertation's Eq. 3.47), the inputs as measured (``"measured"``, Chapter 6), or
``"auto"``: modal when every training record's inputs are forces at its output channels."""
ML_INPUTS: list = [Options("auto", "modal", "measured", "periodic")]
"""ML's ``inputs``: :data:`INPUTS` and ``"periodic"``, measured inputs of a periodic
excitation in steady state (the kernel over one period)."""

#: The dissertation's array forms: ``SingleLoad().fit(W, F, dt=…)``,
#: ``MultipleLoad().fit([W…], [F…], dt=…)``, ``predict(F_new)``.
_ONE_LOAD = ArrayForm(positional=("F",), keywords=("dt",), target="F")
_LOADS = ArrayForm(positional=("F",), keywords=("dt",), sets=True, target="F")


def not_at_the_outputs(method: str, rec: Record) -> str:
    """The reason a diagonal method (SL) cannot take ``rec``: its inputs are not forces at
    its output channels."""
    return (f"{method}: {rec.name}: the inputs ({rec.input_quantity} at channels "
            f"{', '.join(rec.input_channels or ())}) are not forces at the output channels "
            f"({', '.join(rec.output_channels or ())}); SL's diagonal assumption pairs each "
            "POM with its own modal force u_iᵀF, which base or ground inputs do not have. "
            "Use ML (the full kernel from the measured inputs)")


def _check_n_lags(n_lags):
    return check_param(n_lags, "n_lags", N_LAGS)


def _relative_residual(Qs, X, B, dt) -> float:
    """``‖A X − B‖ / ‖B‖`` with ``A`` the convolution matrix of ``Qs`` (never formed)."""
    AX = convolution_product(Qs, X, dt)
    nb = np.linalg.norm(B)
    return float(np.linalg.norm(AX - B) / nb) if nb > 0 else float(np.linalg.norm(AX))


class _ForcedMethod(PODMethod):
    """What SL and ML share: the new force of a record, the solver diagnostics."""

    n_lags: int | str | None
    kernel_: np.ndarray

    def _new_force(self, record):
        if not is_record(record):
            return record
        F = self._target_record(record).F
        if F is None:
            raise InputError(f"Parameter `record.F`: {type(self).__name__} predicts from the "
                             "force matrix F (lbf) at the output sensors; the record has none")
        return F


    def _truncate(self, kernel: np.ndarray) -> np.ndarray:
        """Apply ``n_lags``: the kernel set to zero from lag ``n_lags_`` on (in place)."""
        n_lags = _check_n_lags(self.n_lags)
        n = kernel.shape[2]
        if n_lags == "auto":
            n_lags = kernel_lags(kernel)
        elif n_lags is not None:
            n_lags = min(n_lags, n)
        if n_lags is not None:
            kernel[:, :, n_lags:] = 0.0
        self.n_lags_ = n_lags
        return kernel

    def _check_new_force(self, F) -> np.ndarray:
        """The new force matrix: ``m`` rows; at most ``n`` samples unless the kernel is
        truncated (``n_lags``), then any length (the kernel is zero beyond ``n_lags_``)."""
        F = as_finite_array(F, "F_new", ndim=2)
        m, n = self.modes_.shape[0], self.kernel_.shape[2]
        if F.shape[0] != m or F.shape[1] < 1:
            raise DimensionError(f"Parameter `F_new`: expected shape ({m}, n'), got {F.shape}")
        if F.shape[1] > n and getattr(self, "n_lags_", None) is None:
            raise DimensionError(
                f"Parameter `F_new`: {F.shape[1]} samples, expected n' <= {n} (the kernel was "
                f"identified from {n} samples and is unknown beyond); set `n_lags` (an int "
                "or 'auto') to truncate the kernel, which then predicts records of any length"
            )
        return F

    def _kernel_for(self, n_new: int) -> np.ndarray:
        """The kernel zero-padded to ``n_new`` samples (beyond ``n_lags_`` it is zero)."""
        kern = self.kernel_
        if n_new > kern.shape[2]:
            kern = np.concatenate([kern, np.zeros(kern.shape[:2] + (n_new - kern.shape[2],))],
                                  axis=2)
        return kern

    def _predict(self, record) -> np.ndarray:
        """Response (in, ``(m, n')``) to the target's new forces ``F`` (lbf; its ``dt``, if
        given, must equal the training one; ``n' <= n`` samples, any ``n'`` with
        ``n_lags``): ``W̃ = U Ṽ`` (Eq. 3.45) with the modal response of Eq. 3.44 (SL) or
        Eq. 3.49 (ML)."""
        F = self._check_new_force(self._new_force(record))
        return self.modes_ @ self._modal_response(self._kernel_for(F.shape[1]),
                                                  self.modes_.T @ F)

    def _modal_response(self, kernel: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The modal response ``(k, n')`` to the modal forces ``q``, by the method's rule."""
        raise NotImplementedError

    @property
    def diagnostics_(self) -> dict:
        """The base diagnostics and ``n_lags`` (when the kernel is truncated)."""
        out = super().diagnostics_
        if getattr(self, "n_lags_", None) is not None:
            out["n_lags"] = int(self.n_lags_)
        return out


class SingleLoad(_ForcedMethod):
    """Single-load method (§3.3.1, Eqs. 3.43–3.45).

    Assumes ``C(t)`` diagonal in the POM basis (identity-proportional mass, light
    proportional damping) and identifies each diagonal kernel from one load case by an
    independent scalar deconvolution ``v̂_i = Q̌_i c_ii`` (Eq. 3.43, ``Q̌_i`` from Eq. 3.40).
    A new load is predicted by ``ṽ_i = c_ii * q̃_i`` (Eq. 3.44) and ``W̃ = Σ u_i ṽ_iᵀ``
    (Eq. 3.45).

    Parameters
    ----------
    n_modes : int, optional
        Number of POMs; default from ``energy`` (or ``basis.shape[1]``).
    energy : float
        Cumulative energy fraction (Eq. 2.3, σ-based) when ``n_modes`` is None (0.99).
    solver : str
        Deconvolution solver name (:func:`podbench.deconvolution.available_solvers`):
        ``"auto"`` (default: the exact ``"block"``, else ``"ls"``, on data its noise test
        finds clean, the noise-robust ``"subspace"`` otherwise;
        :class:`~podbench.deconvolution.Auto`); ``"ls"`` (Eq. 3.76, the dissertation's dense
        least squares) or ``"tls"`` (Eqs. 3.78–3.80), dense; or a structured solver that
        never forms the convolution matrix: ``"block"`` (exact, equals ``"ls"`` for forces
        that start with zeros), ``"fft"`` or ``"cgls"`` (Tikhonov-regularized, for noisy
        data), ``"stls"`` (structured total least squares: the kernel and a correction of
        the force samples); all: :func:`podbench.deconvolution.available_solvers`.
    solver_options : dict, optional
        Keyword options of the solver (e.g. ``{"rcond": 1e-3}`` or
        ``{"noise_level": 1e-4}`` for ``"tls"``).
    tol : float
        ``fit`` raises :class:`IllConditionedError` if a modal force is too small to
        deconvolve: ``‖q_i‖ <= tol·‖F‖_F`` (default 1e-6; the load is orthogonal to a POM).
    max_growth : float
        ``fit`` raises :class:`IllConditionedError` when a deconvolution amplifies the data
        by more than this, ``‖A‖‖X‖/‖B‖ > max_growth`` (default 1e8, the ``"block"``
        solver's own limit; :func:`~podbench.methods.base.amplification`): the kernel
        would be amplified noise or model error (e.g. one record with random forces, whose
        convolution matrix is ill-conditioned). The value reached is
        ``solver_info_["amplification"]``.
    n_lags : None, int or "auto"
        Kernel truncation (beyond the dissertation): the identified kernel is set to zero
        from lag ``n_lags`` on, ``C(t_s) = 0`` for ``s >= n_lags``. ``"auto"``: the rule
        :data:`KERNEL_TAIL` on the fitted kernel. None (default, the dissertation's): no
        truncation. With a truncated kernel ``predict`` accepts records of any length
        (``Ṽ = Δt Σ_{p<n_lags} C(t_p) q̃[s−p]`` is defined for every ``s``); without it a
        record longer than the training ones is refused (the kernel is unknown beyond).

    Attributes
    ----------
    modes_ : (m, k) ndarray
    povs_ : (k,) ndarray
    pocs_ : (n, k) ndarray
    kernel_ : (k, k, n) ndarray
        ``C(t_s) = kernel_[:, :, s]`` (in/(lbf·s)); diagonal for SL; zero from ``n_lags_`` on.
    n_lags_ : int or None
        Lags kept (None: no truncation).
    fit_residual_ : float
        Relative residual of the deconvolutions, ``‖Q̌ c − v̂‖ / ‖v̂‖`` over all modes.
    dt_ : float
    n_modes_ : int
    """

    abbreviation = "SL"
    excitation_kind = "forced"
    n_records = (1, 1)
    array_form = _ONE_LOAD
    _parameter_constraints = {"n_modes": N_MODES, "energy": ENERGY, **SOLVER_PARAMS,
                              "tol": TOL, "max_growth": MAX_GROWTH, "n_lags": N_LAGS}

    def __init__(self, *, n_modes=None, energy=0.99, solver="auto", solver_options=None,
                 tol=1e-6, max_growth=1e8, n_lags=None):
        self.n_modes = n_modes
        self.energy = energy
        self.solver = solver
        self.solver_options = solver_options
        self.tol = tol
        self.max_growth = max_growth
        self.n_lags = n_lags

    def required_fields(self) -> tuple[str, ...]:
        return ("W", "F", "dt")

    def coupled_twin(self) -> MultipleLoad:
        """ML with the same solver (the full kernel ``C(t)`` instead of its diagonal)."""
        return MultipleLoad(n_modes=self.n_modes, solver=self.solver,
                            solver_options=self.solver_options, n_lags=self.n_lags)

    def refusal(self, records) -> str | None:
        """Inputs that are not forces at the output channels (a base acceleration, ground
        motion): SL's diagonal assumption pairs each POM with its own modal force."""
        for r in records:
            if r.u is not None and not r.collocated:
                return not_at_the_outputs("SL", r)
        return None

    def _fit(self, records, basis) -> None:
        """One forced response that starts at rest (``W`` in in, ``F`` in lbf at the same
        sensors and times, ``dt`` in s)."""
        rec = records[0]
        self._identify(rec.W, rec.F, rec.dt, basis)

    def _identify(self, W, F, dt, basis) -> None:
        n_modes = check_n_modes(self.n_modes)
        energy = check_energy(self.energy)
        solver = make_method_solver(self.solver, self.solver_options)
        tol = check_tol(self.tol)
        U, povs, pocs = select_basis(W, n_modes, basis, energy=energy)
        k, n = U.shape[1], W.shape[1]
        Vh = U.T @ W
        Q = U.T @ F
        # the training load's modal-force direction (its dominant left singular vector)
        self.force_pattern_ = np.linalg.svd(Q, full_matrices=False)[0][:, 0]
        scale = float(np.linalg.norm(F))
        if scale == 0:
            raise IllConditionedError("Parameter `F`: the force matrix is zero")
        bad = modal_share_too_small(np.linalg.norm(Q, axis=1), scale, tol)
        if np.any(bad):
            raise IllConditionedError(
                f"SL: the modal force of mode(s) {as_int_list(bad)} is too small to deconvolve "
                f"(‖u_iᵀF‖ <= tol·‖F‖ = {tol * scale:.3g}, tol = {tol:g}): the load is "
                "(nearly) orthogonal to the POM; use fewer modes or MultipleLoad"
            )
        kernel = np.zeros((k, k, n))
        num = 0.0
        infos = []
        for i in range(k):
            c, info = solve_deconvolution(solver, [Q[i : i + 1]], Vh[i], dt,
                                          check_max_growth(self.max_growth), f"SL mode {i + 1}")
            kernel[i, i] = c
            infos.append(info)
            num += float(np.sum((convolution_product([Q[i : i + 1]], c, dt) - Vh[i]) ** 2))
        nv = np.linalg.norm(Vh)
        self.solver_ = solver
        self.solver_info_ = infos
        self._set_basis(U, povs, pocs, dt)
        self.kernel_ = self._truncate(kernel)
        self.fit_residual_ = float(np.sqrt(num) / nv) if nv > 0 else float(np.sqrt(num))

    def diagonal_inconsistency(self, record) -> float:
        """How far the new load's modal forces ``UᵀF'`` are from the training load's
        pattern (:func:`~podbench.sysid.methods.bands.diagonal_inconsistency`): the
        model-form term of SL's band, which one record cannot cross-validate."""
        self._check_is_fitted()
        F = self._check_new_force(self._new_force(record))
        return diagonal_inconsistency(self.force_pattern_, self.modes_.T @ F)

    def diagonal_parts(self, record) -> tuple[np.ndarray, np.ndarray]:
        """``(Ŵ_⊥, T²)`` of :func:`~podbench.sysid.methods.bands.diagonal_split` for the
        new load: SL's response (in) to the part of ``UᵀF'`` outside the training load's
        modal pattern, and the squared response (in²) to each mode's share of that part
        applied in the training pattern (Eq. 3.44, which is exact on that pattern)."""
        self._check_is_fitted()
        F = self._check_new_force(self._new_force(record))
        kernel = self._kernel_for(F.shape[1])
        return diagonal_split(self.force_pattern_, self.modes_.T @ F,
                              lambda q: self.modes_ @ self._modal_response(kernel, q))

    def _modal_response(self, kernel: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``ṽ_i = c_ii * q̃_i`` (Eq. 3.44), the diagonal of the kernel only."""
        idx = np.arange(self.n_modes_)
        return convolve(kernel[idx, idx], q, self.dt_)


class MultipleLoad(_ForcedMethod):
    """Multiple-load method (§3.3.2, Eqs. 3.46–3.49), on forces at the sensors or on measured
    inputs elsewhere.

    With the POMs ``U`` (``m × k``) of the first load case, every case ``j`` gives scaled POC
    histories ``ʲV̂ = (Uᵀ ʲW)ᵀ`` (``n × k``, Eq. 3.46) and modal forces ``ʲq_i = u_iᵀ ʲF``
    (Eq. 3.47). The full kernel ``C̄`` (``k·n × k``, Eq. 3.42) solves the block system

        ``[¹V̂; ²V̂; …] = [ʲQ̌_i]_{j,i} C̄``   (Eq. 3.48, ``n_cases·n × k·n``),

    and a new load is predicted by ``Ṽ = [Q̃̌_1 … Q̃̌_k] C̄`` (Eq. 3.49), computed here as a
    fast convolution. No diagonal assumption: for a linear time-invariant system, ``k``
    equal to the number of sensors and forces whose first sample is zero the prediction is
    exact.

    Measured inputs elsewhere (``inputs="measured"``: a base acceleration, ground motion;
    Chapter 6): the kernel goes from the measured inputs ``u`` to the POC histories of the
    measured outputs, ``v[s] = Δt Σ_p H[p] u[s − p]``, ``ŷ = U v̂``
    (:mod:`podbench.sysid.methods.inputs`): records of different lengths train together,
    lag 0 is kept for acceleration outputs, and a truncated kernel is fitted by least
    squares with its lag count (and TC prior) chosen by leave-one-record-out.

    Parameters
    ----------
    n_modes : int, optional
        ``k``; default the number of load cases (or ``basis.shape[1]``). Must not exceed it;
        more load cases than modes give an over-determined system (an extension). On
        measured inputs the default is every output channel (no such bound: each record
        adds ``k·n`` equations for ``k·n_in`` unknowns per lag).
    solver : str
        ``"auto"`` (default: exact on clean data, ``"subspace"`` on noisy data,
        :class:`~podbench.deconvolution.Auto`), ``"ls"`` (the dissertation's) or ``"tls"``
        (dense); ``"block"`` (exact, as many load cases as modes), ``"fft"``, ``"cgls"``,
        ``"stls"`` (structured); see :mod:`podbench.deconvolution`. On measured inputs it
        solves the kernel over the whole record (``n_lags=None``).
    solver_options : dict, optional
        Keyword options of the solver.
    max_cond : float
        ``fit`` raises :class:`IllConditionedError` if the load cases are (nearly)
        linearly dependent: the condition number of the ``n_cases × k·n`` matrix whose row
        ``j`` is the flattened modal-force history ``ʲq`` exceeds ``max_cond``
        (default 1e10).
    max_growth : float
        ``fit`` raises :class:`IllConditionedError` when a deconvolution amplifies the data
        by more than this, ``‖A‖‖X‖/‖B‖ > max_growth`` (default 1e8, the ``"block"``
        solver's own limit; :func:`~podbench.methods.base.amplification`): the kernel
        would be amplified noise or model error (e.g. one record with random forces, whose
        convolution matrix is ill-conditioned). The value reached is
        ``solver_info_["amplification"]``.
    basis : {"first", "all"}
        Where the POMs come from when ``fit`` gets no ``basis=``: ``"first"`` (default, the
        dissertation's) the POMs of the first load case; ``"all"`` the leading POMs of all
        training records side by side, ``[¹W ²W …]`` (the peers' basis; beyond the
        dissertation). ``fit(…, basis=U)`` overrides both.
    n_lags : None, int or "auto"
        Kernel length (beyond the dissertation): ``C(t_s) = 0`` for ``s >= n_lags``. None
        (default, the dissertation's): the kernel over the whole record. Modal forces: the
        identified kernel is set to zero from lag ``n_lags`` on; ``"auto"``: the rule
        :data:`KERNEL_TAIL` on the fitted kernel. Measured inputs: a kernel of ``n_lags``
        lags fitted by least squares; ``"auto"``: the lag length from ``lag_grid`` with the
        smallest leave-one-record-out error, lengthened beyond the grid while that error
        keeps falling when the grid's longest is the best (long memories:
        :func:`~podbench.sysid.methods.inputs.fit_fir`). With a truncated kernel ``predict`` accepts
        records of any length (``Ṽ = Δt Σ_{p<n_lags} C(t_p) q̃[s−p]`` is defined for every
        ``s``); without it a record longer than the training ones is refused (the kernel is
        unknown beyond).
    lag_grid : tuple of float
        Lag lengths (s) ``n_lags="auto"`` chooses from on measured inputs
        (:data:`~podbench.sysid.methods.inputs.LAG_GRID`).
    prior : None, "tc" or (tau, gamma)
        Kernel regularization on measured inputs with a truncated kernel: the TC prior, its
        decay ``τ`` (s) and relative weight ``γ`` chosen from
        :data:`~podbench.sysid.methods.inputs.TC_GRID` by leave-one-record-out (``"tc"``)
        or given.
    feedthrough : "auto", True or False
        Keep lag 0 on measured inputs (``"auto"``: for acceleration outputs).
    kernel : {"fir", "poles"}
        Measured inputs with a truncated kernel: ``"fir"`` (default) the FIR kernel of
        ``n_lags`` lags; ``"poles"`` (a variant beyond the dissertation, for long memories)
        the kernel in a basis of decaying modes whose poles are realized from that FIR kernel
        (the pilot, ``theta_``), with every lag
        (:mod:`~podbench.sysid.methods.pole_basis`): ``predict`` runs its state space.
    pole_order : "auto" or int
        Realization order of the pilot whose stable poles form the basis (``kernel="poles"``):
        ``"auto"``, the lowest even order within 1 % of the best leave-one-record-out error
        up to :data:`~podbench.sysid.methods.pole_basis.MAX_POLE_ORDER` (with
        ``pole_refine``, then raised while the refined poles' error keeps falling); or
        given.
    pole_refine : bool
        ``kernel="poles"``: move the poles to the training records' least output error,
        the residues eliminated (variable projection,
        :func:`~podbench.sysid.methods.pole_basis.refine_poles`; default); False (a
        variant): the pilot's poles as realized.
    inputs : {"auto", "modal", "measured", "periodic"}
        :data:`ML_INPUTS`: the modal forces ``Uᵀ F`` of forces at the output sensors
        (``"modal"``), the inputs as measured (``"measured"``), or ``"auto"`` (default):
        modal when every training record's inputs are forces at its output channels.
        ``"periodic"``: measured inputs of a periodic excitation (a multisine repeated
        over periods of ``period`` samples) in steady state, and the kernel over one
        period — a circular convolution, i.e. the frequency response on the excited lines
        pooled over the records by least squares (:mod:`podbench.sysid.periodic`): every
        lag up to one period, the structure's whole memory, from the steady-state periods.
    period : int, optional
        Samples per period of the excitation; required with ``inputs="periodic"``.
    transient_periods : int
        Leading periods of every record left out of a periodic fit (the start-up).
    lines : "auto" or sequence of int
        The lines (DFT indices over one period) a periodic fit identifies: ``"auto"``, those
        whose input power summed over the training records is at least
        :data:`~podbench.sysid.periodic.LINE_THRESHOLD` × the strongest line's; or given.

    Attributes
    ----------
    modes_ : (m, k) ndarray
        POMs of the first load case (or of all, ``basis="all"``).
    povs_ : (k,) ndarray
    pocs_ : (n, k) ndarray
        Modal forces only.
    kernel_ : (k, k, n) or (k, n_in, L) ndarray
        Modal forces: ``C(t_s) = kernel_[:, :, s]`` (in/(lbf·s)); ``kernel_[l, i] = c_li``;
        zero from ``n_lags_`` on. Measured inputs: ``H[p] = kernel_[:, :, p − first_lag_]``
        in (output unit)/(input unit·s).
    Cbar_ : (k·n, k) ndarray
        ``C̄`` of Eq. 3.42 (as solved, before truncation; modal forces).
    n_lags_ : int or None
        Lags kept (None: no truncation).
    inputs_ : str
        ``"modal"`` or ``"measured"``: how this fit read its records' inputs.
    info_ : dict
        Measured inputs: ``n_lags``, ``first_lag``, ``cv_error`` and the prior's choice;
        periodic: ``n_lines``, ``f_min_Hz``, ``f_max_Hz``, ``period``, ``steady_periods``.
    lines_, frequencies_ : (L,) ndarray
        Periodic: the identified lines (DFT indices) and their frequencies (Hz).
    response_ : (k, n_in, L) complex ndarray
        Periodic: the frequency response in the POC coordinates (the DFT of ``Δt·kernel_``
        over one period on ``lines_``); ``kernel_`` is then (k, n_in, period).
    noise_variance_ : (k, L) ndarray
        Periodic: variance of ``response_`` from the spread over the periods (one input;
        NaN otherwise).
    condition_number_ : float
        Condition number of the load cases' modal-force histories (see ``max_cond``).
    fit_residual_ : float
        ``‖A C̄ − B‖ / ‖B‖`` of the block system.
    dt_ : float
    n_modes_ : int
    """

    abbreviation = "ML"
    excitation_kind = "forced"
    coupled = True
    array_form = _LOADS
    _parameter_constraints = {
        "n_modes": N_MODES, **SOLVER_PARAMS, "max_cond": MAX_COND, "max_growth": MAX_GROWTH,
        "basis": BASES, "n_lags": N_LAGS,
        "lag_grid": [InstanceOf((tuple, list), "a sequence of lag lengths (s)")],
        "prior": [None, Options("tc"), InstanceOf((tuple, list), "(tau_s, gamma) > 0")],
        "feedthrough": [Options("auto"), Boolean()], "inputs": ML_INPUTS,
        "period": [None, Interval("integer", 2)], "transient_periods": [Interval("integer", 0)],
        "lines": [Options("auto"), InstanceOf((tuple, list, np.ndarray),
                                              "a sequence of DFT line indices")],
        "kernel": [Options("fir", "poles")],
        "pole_order": [Options("auto"), Interval("integer", 1)], "pole_refine": [Boolean()]}

    def __init__(self, *, n_modes=None, solver="auto", solver_options=None, max_cond=1e10,
                 max_growth=1e8, basis="first", n_lags=None, lag_grid=LAG_GRID, prior=None,
                 feedthrough="auto", inputs="auto", period=None, transient_periods=1,
                 lines="auto", kernel="fir", pole_order="auto", pole_refine=True):
        # the dissertation's hyperparameters (§3.3.2), then the kernel's length and prior,
        # then a periodic excitation's
        self.n_modes, self.basis, self.inputs = n_modes, basis, inputs
        self.solver, self.solver_options = solver, solver_options
        self.max_cond, self.max_growth = max_cond, max_growth
        self.n_lags, self.lag_grid, self.prior = n_lags, lag_grid, prior
        self.feedthrough, self.kernel, self.pole_order = feedthrough, kernel, pole_order
        self.pole_refine = pole_refine
        self.period, self.transient_periods, self.lines = period, transient_periods, lines

    @property
    def records_per_mode(self) -> bool:  # type: ignore[override]
        """``k`` is bounded by the number of load cases (Eq. 3.48) with modal forces only."""
        return getattr(self, "inputs_", "modal") == "modal"

    def required_fields(self) -> tuple[str, ...]:
        """``W, F, dt`` (modal forces), ``u, y, dt`` (measured inputs); ``W, dt`` and inputs
        of either kind with ``inputs="auto"``."""
        return {"modal": ("W", "F", "dt"), "measured": ("u", "y", "dt"),
                "periodic": ("u", "y", "dt")}.get(self.inputs, ("W", "dt"))

    def refusal(self, records) -> str | None:
        """Free responses (no inputs); modal forces asked of inputs elsewhere."""
        return self._inputs_refusal(records)

    def command_line_params(self, records, *, solver: str = "auto", n_modes=None,
                            period: int | None = None) -> dict:
        """``--solver`` on measured inputs names the kernel: ``auto`` (the TC prior with three
        or more training records, else none), ``ls`` (no prior), ``tc`` (the TC prior),
        each a truncated kernel with its lags by leave-one-record-out; any other name is a
        deconvolution solver for the kernel over the whole record. On forces at the outputs
        it is the deconvolution solver, as for every method. On a periodic excitation
        (``inputs="periodic"``) only ``auto``: the kernel over one period is solved per line.

        Measured inputs whose training files carry a ``period`` (samples per period of a
        periodic excitation in steady state, the F-16 multisines) with ``--solver auto`` and
        ``inputs="auto"``: the kernel over one period (``inputs="periodic"``), the model the
        records are: in steady state the response to a periodic input is the circular
        convolution of one period, exact at every excited line, where a truncated kernel
        cuts the slowest modes' memory. ``--solver ls`` or ``tc`` keep the truncated kernel."""
        out = super().command_line_params(records, solver=solver, n_modes=n_modes)
        if (period is not None and solver == "auto" and self.inputs == "auto"
                and not self._modal(records)):
            return {**{k: v for k, v in out.items() if k != "solver"},
                    "inputs": "periodic", "period": int(period)}
        if self.inputs == "periodic":
            if solver != "auto":
                raise InputError(f"Parameter `solver`: not with inputs='periodic' (the kernel "
                                 f"over one period is solved line by line), got {solver!r}")
            return {k: v for k, v in out.items() if k != "solver"}
        if self._modal(records):
            return out
        if solver in ("auto", "ls", "tc"):
            tc = solver == "tc" or (solver == "auto" and len(records) >= 3)
            return {**out, "inputs": "measured", "n_lags": "auto", "solver": "ls",
                    "prior": "tc" if tc else None}
        return {**out, "inputs": "measured", "n_lags": None, "solver": solver}

    def _measured_basis(self, recs) -> tuple[np.ndarray, np.ndarray]:
        """The POMs of all training outputs and their POVs (measured inputs)."""
        return measured_basis(recs, self.n_modes)

    def _fit(self, records, basis) -> None:
        if self.inputs == "periodic":
            self.inputs_ = "periodic"
            self._fit_periodic(records, basis)
        elif self._modal(records):
            if getattr(self, "kernel", "fir") != "fir":
                raise InputError("Parameter `kernel`: applies to measured inputs (the records' "
                                 "inputs are forces at the outputs)")
            self.inputs_ = "modal"
            Ws, Fs = [r.W for r in records], [cast(np.ndarray, r.F) for r in records]
            self._identify(Ws, Fs, records[0].dt, basis)
        else:
            self.inputs_ = "measured"
            self._fit_measured(records, basis)

    def _identify(self, Ws, Fs, dt, basis) -> None:
        solver = make_method_solver(self.solver, self.solver_options)
        system = self._system(Ws, Fs, basis)
        Cbar, info = solve_deconvolution(solver, system[3], system[4], dt,
                                         check_max_growth(self.max_growth), "ML (Eq. 3.48)")
        self._finish(system, Cbar, info, solver, dt)

    def _fit_measured(self, recs, basis) -> None:
        """The kernel from the measured inputs (:mod:`podbench.sysid.methods.inputs`)."""
        U, povs = self._measured_basis(recs) if basis is None else given_basis(recs, basis)
        if self.n_lags is None:
            for name, off in (("prior", None), ("kernel", "fir")):
                if getattr(self, name, off) != off:
                    raise InputError(f"Parameter `{name}`: needs a truncated kernel (n_lags)")
            solver = make_method_solver(self.solver, self.solver_options)
            theta, info = fit_whole(recs, U, lambda Q, B, dt: solve_deconvolution(
                solver, Q, B, dt, what="ML (measured inputs)"), str(self.solver))
            cv: dict = {}
        else:
            theta, info, cv = fit_fir(recs, U, n_lags=self.n_lags, lag_grid=self.lag_grid,
                                      prior=self.prior, feedthrough=self.feedthrough)
            if getattr(self, "kernel", "fir") == "poles":
                self._fit_poles(recs, U, theta, info, cv)
        n_in, k = recs[0].n_inputs, U.shape[1]
        self.theta_ = theta
        self.kernel_ = theta.reshape(-1, n_in, k).transpose(2, 1, 0) / recs[0].dt
        self.first_lag_ = info["first_lag"]
        self.cv_errors_ = cv
        self.modes_, self.povs_, self.n_modes_ = U, povs, k
        self.dt_ = recs[0].dt
        self.info_ = info
        self.reference_ = recs[0]

    def _fit_poles(self, recs, U, theta, info: dict, cv: dict) -> None:
        """``kernel="poles"``: the pole basis from the pilot ``θ`` and its folds' kernels
        (:func:`~podbench.sysid.methods.pole_basis.fit_pole_basis`); sets ``model_`` (the
        state space in the POC coordinates) and ``markov_`` (the pilot's Markov parameters:
        the realization's stabilization check), adds the choice to ``info``/``cv``."""
        if len(recs) < 2:
            raise InputError("Parameter `kernel`: 'poles' chooses its order by "
                             "leave-one-record-out and needs at least 2 training records")
        n_in, first = recs[0].n_inputs, int(info["first_lag"])
        full = pilot_factors(theta, n_in, first)
        folds = [pilot_factors(th, n_in, first) for th in fold_kernels(recs, U, info)]
        self.model_, pinfo, pcv = fit_pole_basis(
            recs, U, folds, full, n_in, first, order=self.pole_order,
            gain=LAG_GAIN, refine=getattr(self, "pole_refine", True))
        L = theta.shape[0] // n_in
        h = np.zeros((L + first, U.shape[1], n_in))
        h[first:] = theta.reshape(L, n_in, -1).transpose(0, 2, 1)
        self.markov_ = h
        info.update(kernel="poles", pilot_cv_error=info.get("cv_error"), **pinfo)
        cv.update(pcv)

    def _period(self) -> tuple[int, int]:
        """``(period, transient_periods)`` of a periodic fit, checked (``period`` required
        and the truncated kernel's ``n_lags`` and ``prior`` refused: the kernel over one
        period has every lag up to the period)."""
        params = self._params()
        if params["period"] is None:
            raise InputError("Parameter `period`: required with inputs='periodic' (the "
                             "samples per period of the excitation)")
        for name in ("n_lags", "prior"):
            if getattr(self, name, None) is not None:
                raise InputError(f"Parameter `{name}`: not with inputs='periodic' (the kernel "
                                 "over one period has every lag up to the period)")
        return params["period"], params["transient_periods"]

    def _fit_periodic(self, recs, basis) -> None:
        """The kernel over one period from the steady-state periods of measured inputs
        (``inputs="periodic"``): the POC and input spectra averaged over the periods of each
        record, the response on the lines pooled by least squares."""
        P, T = self._period()
        check_records(recs, min_samples=(T + 1) * P)
        U, povs = self._measured_basis(recs) if basis is None else given_basis(recs, basis)
        spectra = [period_spectra(r.u, U.T @ r.y, P, T, r.name) for r in recs]
        lines = choose_lines(self.lines, [s.U_mean for s in spectra], P)
        self.modes_, self.povs_, self.n_modes_ = U, povs, U.shape[1]
        self.dt_ = recs[0].dt
        self.reference_ = recs[0]
        self.lines_ = lines
        self.frequencies_ = lines / (P * self.dt_)
        self.first_lag_ = 0  # kernel_[:, :, p] is lag p (the realization reads it)
        self._fit_response(recs, spectra, lines)
        self.info_ = {"n_lines": int(lines.size), "f_min_Hz": float(self.frequencies_[0]),
                      "f_max_Hz": float(self.frequencies_[-1]), "period": P,
                      "steady_periods": int(min(s.n_periods for s in spectra))}

    def _fit_response(self, recs, spectra, lines) -> None:
        """The pooled response on the lines, its noise variance and its kernel over one
        period (a subclass's rule across records may differ)."""
        self.response_ = pooled_response([s.U_mean for s in spectra],
                                         [s.Y_mean for s in spectra], lines)
        self.noise_variance_ = pooled_noise(spectra, lines)
        self.kernel_ = period_kernel(self.response_, lines, int(self.period), self.dt_)

    def _response_for(self, record) -> np.ndarray:
        """The POC frequency response (k, n_in, L) a periodic fit predicts ``record`` with."""
        return self.response_

    def frequency_response(self, record=None) -> np.ndarray:
        """A periodic fit's frequency response in the output channels (n_out, n_in, L) on
        ``lines_``: ``U·response_`` (in (output unit)/(input unit); a subclass's at
        ``record``'s level)."""
        self._check_is_fitted()
        if self.inputs_ != "periodic":
            raise InputError("frequency_response: needs a fit with inputs='periodic'")
        G = self.response_ if record is None else self._response_for(as_record(record))
        return np.einsum("ok,kil->oil", self.modes_, G)

    def predict_periodic(self, record) -> np.ndarray:
        """One steady-state period (n_out × period) of a target's response to a periodic
        excitation: the frequency response times the target's period-averaged input
        spectrum on the lines (the best linear approximation's own prediction)."""
        rec = as_record(record)
        P, T = self._period()
        spec = period_spectra(rec.u, None, P, T, rec.name)
        return periodic_prediction(self.frequency_response(rec), self.lines_, spec.U_mean, P)

    def _measured(self) -> bool:
        return getattr(self, "inputs_", "modal") in ("measured", "periodic")

    def _predict(self, record) -> np.ndarray:
        if not self._measured():
            return super()._predict(record)
        return self.modes_ @ self.predict_coordinates(record)

    def predict_coordinates(self, record) -> np.ndarray:
        """The predicted POC histories ``v̂`` (k × n) of a target's measured inputs."""
        self._check_is_fitted()
        check_compatible(self.reference_, record, min_samples=1)
        if self.inputs_ == "periodic":
            G = self._response_for(record)
            H = self.kernel_ if G is self.response_ else \
                period_kernel(G, self.lines_, int(self.period), self.dt_)
            return period_convolution(H, record.u, self.dt_)
        if self.info_.get("kernel") == "poles":
            A, B, C, D = self.model_
            X = pole_states(A, B, record.u, 1)
            return C @ X + D @ np.asarray(record.u, dtype=float)
        return lag_response(self.theta_, record.u, record.n_inputs, self.first_lag_)

    def frozen_params(self) -> dict:
        """The choices of this fit as hyperparameters (the band's refits,
        :meth:`PODMethod.frozen_params`); on measured inputs ``n_lags`` chosen from
        ``lag_grid`` and the TC prior's ``(τ, γ)`` chosen from the grid."""
        if not self._measured():
            return super().frozen_params()
        self._check_is_fitted()
        params = self.get_params(deep=False)
        out: dict = {}
        if self.inputs_ == "periodic" and isinstance(params.get("lines"), str):
            out["lines"] = tuple(int(k) for k in self.lines_)
        if params.get("n_lags") == "auto":
            out["n_lags"] = int(self.info_["n_lags"])
        if params.get("prior") == "tc" and "tc_tau" in self.info_:
            out["prior"] = (float(self.info_["tc_tau"]), float(self.info_["tc_gamma"]))
        if params.get("kernel") == "poles" and params.get("pole_order") == "auto":
            out["pole_order"] = int(self.info_["pole_order"])
        return out

    @property
    def diagnostics_(self) -> dict:
        """The base diagnostics (modal forces); on measured inputs ``n_modes`` and what the
        fit chose (``info_``)."""
        return self._chosen_diagnostics() if self._measured() else super().diagnostics_

    def _system(self, Ws, Fs, basis) -> tuple:
        """``(U, povs, pocs, Qs, B, cond)``: the basis, the modal forces and the stacked
        scaled POC histories of Eq. 3.48, and the condition number of the load cases
        (checked against ``max_cond``)."""
        n_modes = check_n_modes(self.n_modes)
        max_cond = check_max_cond(self.max_cond)
        U, povs, pocs = per_record_basis(Ws, n_modes, basis, self.basis, (
            "ML: fewer load cases ({n_sets}) than modes ({k}); C̄ has k²n unknowns and each "
            "load case adds only k·n equations (Eq. 3.48), so k = {k} cases are needed"))
        k = U.shape[1]
        Qs = [U.T @ Fj for Fj in Fs]
        L = np.stack([Qj.ravel() for Qj in Qs])  # n_sets × k·n
        s = np.linalg.svd(L, compute_uv=False)
        cond = float(s[0] / s[k - 1]) if s[k - 1] > 0 else np.inf
        if not cond <= max_cond:
            raise IllConditionedError(
                f"ML: the load cases are (nearly) linearly dependent in the POM basis: "
                f"condition number of their modal-force histories is {cond:.3g} > max_cond = "
                f"{max_cond:g}; use linearly independent loads"
            )
        B = np.vstack([(U.T @ Wj).T for Wj in Ws])  # n_sets·n × k
        return U, povs, pocs, Qs, B, cond

    def _finish(self, system: tuple, Cbar, info, solver, dt, residual: bool = True) -> None:
        """Set the fitted state from the solved system (:meth:`_system`); ``residual=False``
        leaves ``fit_residual_`` unset (a fold model of :meth:`fold_predictions`, which
        only predicts: the residual is a convolution of every record, read by nothing)."""
        U, povs, pocs, Qs, B, cond = system
        k, n = U.shape[1], B.shape[0] // len(Qs)
        kernel = np.empty((k, k, n))
        for i in range(k):
            kernel[:, i, :] = Cbar[i * n : (i + 1) * n].T
        self.solver_ = solver
        self.solver_info_ = info
        self._set_basis(U, povs, pocs, dt)
        self.Cbar_ = Cbar
        self.kernel_ = self._truncate(kernel)
        self.condition_number_ = cond
        if residual:
            self.fit_residual_ = _relative_residual(Qs, Cbar, B, dt)

    def fold_predictions(self, records, basis, frozen=None) -> list[np.ndarray] | None:
        """The leave-one-record-out predictions of a prediction band
        (:mod:`~podbench.sysid.methods.bands`): record ``j`` predicted by a copy of this
        model (hyperparameters and ``frozen``) fitted in ``basis`` to the other records —
        the same as refitting each fold, to round-off — with the folds' deconvolutions
        solved together (``solve_many``: one batched forward substitution for
        ``"block"``). None on measured inputs (each fold is refitted)."""
        if self._measured():
            return None
        recs = list(records)
        est = type(self)(**{**self.get_params(deep=False), **(frozen or {})})
        est.set_params(n_modes=np.shape(basis)[1])
        est._validate_params()
        solver = make_method_solver(est.solver, est.solver_options)
        dt = check_dt(recs[0].dt)
        systems = [est._system([r.W for r in recs[:j] + recs[j + 1:]],
                               [cast(np.ndarray, r.F) for r in recs[:j] + recs[j + 1:]], basis)
                   for j in range(len(recs))]
        solved = solve_deconvolutions(solver, [(sy[3], sy[4]) for sy in systems], dt,
                                      check_max_growth(est.max_growth), "ML (Eq. 3.48)")
        out = []
        for j, (sy, (Cbar, info)) in enumerate(zip(systems, solved, strict=True)):
            fold = type(est)(**est.get_params(deep=False))
            fold._finish(sy, Cbar, info, solver, dt, residual=False)
            fold.inputs_ = "modal"
            out.append(np.asarray(fold.predict(records[j]), dtype=float))
        return out

    def _modal_response(self, kernel: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``Ṽ = [Q̃̌_1 … Q̃̌_k] C̄`` (Eq. 3.49) as a fast convolution."""
        return convolve_kernel(kernel, q, self.dt_)
