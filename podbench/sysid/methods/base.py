"""The base class of the identification methods: one contract, explicit ``fit`` and ``predict``.

Every method — POVR, MDS, SL, ML, MR, FIR-LS, the peers, a :class:`Superposition`, a user's
class — is an estimator in scikit-learn's manner over records
(:class:`~podbench.core.records.Record`):

* ``__init__`` takes keyword-only hyperparameters and stores them unchanged;
* ``fit(records, *, basis=None)`` validates the hyperparameters and the records, keeps the
  training records and returns ``self``; learned state ends in an underscore (``modes_``,
  ``kernel_`` …);
* ``predict(record, *, coverage=None)`` returns the predicted outputs, or with a coverage
  the :class:`~podbench.sysid.methods.bands.Prediction` (band and error estimate) after the
  named calibration step :meth:`PODMethod.calibrate_band`; ``NotFittedError`` before ``fit``.

A subclass implements ``_fit(records, basis)`` and ``_predict(record)`` and declares what it
needs (its traits and :meth:`PODMethod.required_fields`); the base does the rest. The
dissertation's array forms of ``fit`` and ``predict`` are read into records by one adapter,
:mod:`podbench.sysid.methods.arrays`.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from podbench.core.records import Record, as_record, check_records
from podbench.errors import DimensionError, IllConditionedError, InputError, NotFittedError
from podbench.sysid.deconvolution import ConvolutionSystem, Solver, deconvolve, make_solver
from podbench.sysid.deconvolution._api import SOLVER_OPTIONS
from podbench.sysid.methods.arrays import (
    FIELD_WORDS,
    ArrayForm,
    is_record_input,
    target_record,
    training_records,
)
from podbench.sysid.methods.bands import calibrate, check_coverage, predict_band
from podbench.sysid.methods.checks import (  # re-exported: the methods' modules read them here
    check_datasets,
    check_dt,
    check_force,
    check_forces,
    check_new_force,
    check_profile,
    check_profiles,
    check_snapshots,
)
from podbench.sysid.params import InstanceOf, Interval, Options, ParamsMixin, check_param
from podbench.sysid.pod import check_orthonormal, n_modes_for_energy, numerical_rank, snapshot_svd

__all__ = ["PODMethod", "ArrayForm", "is_record_input", "check_datasets", "check_dt",
           "check_force", "check_forces", "check_new_force", "check_profile",
           "check_profiles", "check_snapshots"]


class PODMethod(ParamsMixin):
    """Base class of the identification methods (module docstring: the contract).

    Hyperparameters: ``_parameter_constraints`` declares what each admits
    (:mod:`podbench.sysid.params`); :meth:`_validate_params` checks them without data (``fit``
    calls it; the scenario loader calls it when a file is read, so a bad option fails
    before any simulation) and raises :class:`~podbench.errors.InvalidParameterError` naming
    ``.param``; :meth:`get_params` / :meth:`set_params` read the constructor's signature, so
    :func:`sklearn.base.clone` works.

    Traits, what a method needs and is: :attr:`excitation_kind` (``"free"``, ``"forced"``,
    ``"mixed"`` or ``"io"``), :attr:`coupled` (identifies full modal matrices: it is its
    own coupled twin), :attr:`n_records` (how many training records it takes),
    :attr:`records_per_mode` (``k`` is bounded by the number of records), :attr:`composite`
    (a sum of other methods, each fitted on its own records), :attr:`array_form` (the
    dissertation's array form of ``fit``/``predict``, or None), :meth:`required_fields`
    (what it reads from a record), :meth:`coupled_twin` (the unfitted coupled method whose
    error, in the same basis, isolates the diagonal assumption) and :meth:`refusal` (the
    reason it cannot identify from given records).
    """

    #: Short name used in tables (e.g. "POVR").
    abbreviation = ""
    #: "free" (initial conditions), "forced" (loads from rest), "mixed" (both) or "io"
    #: (measured inputs to measured outputs).
    excitation_kind = ""
    #: True when the method identifies full (coupled) modal matrices (MDS, ML).
    coupled = False
    #: (minimum, maximum or None) number of training records.
    n_records: tuple[int, int | None] = (1, None)
    #: True when ``k`` may not exceed the number of training records (MDS, ML).
    records_per_mode = False
    #: True for a sum of other methods (:class:`Superposition`): ``fit`` takes one training
    #: set per part.
    composite = False
    #: The dissertation's array form of ``fit``/``predict`` (None: records only).
    array_form: ArrayForm | None = None
    #: False for a method that identifies in its own coordinates and takes no ``basis=``
    #: (then it has no prediction band: the band refits a method in its fitted basis).
    takes_basis = True
    #: True for a method whose answer amplifies the records' round-off past a table's
    #: digits (a study writes its errors at the digits a perturbation of the records
    #: leaves in place, :func:`podbench.harness.digits.determined`).
    amplifies_round_off = False

    # fitted state (set by ``fit``; declared for type checkers, absent before)
    modes_: np.ndarray
    n_modes_: int
    dt_: float

    # ------------------------------------------------------------------ the contract
    def fit(self, records, *arrays, basis=None, **fields) -> PODMethod:
        """Identify the model from training records.

        Parameters
        ----------
        records : Record or sequence of Record
            The training records (:meth:`required_fields` says what each must hold). The
            dissertation's array forms — ``fit(W, x0)``, ``fit([W…], [F…], dt=…)`` — are
            read into records by :mod:`podbench.sysid.methods.arrays` (``*arrays``,
            ``**fields``: the method's :attr:`array_form`).
        basis : (m, k) array_like, optional
            Orthonormal basis replacing the POMs the method would compute.

        Returns
        -------
        self
        """
        self._validate_params()
        if basis is not None and not self.takes_basis:
            raise InputError(f"Parameter `basis`: {type(self).__name__} takes no basis (it "
                             "identifies in its own coordinates), so it has no prediction "
                             "band (the band refits a method in its fitted basis)")
        for name in [k for k in vars(self) if k.endswith("_") and not k.startswith("_")]:
            delattr(self, name)  # a refit starts from nothing
        recs = self._training_records(training_records(self, records, arrays, fields))
        self._fit(recs, basis)
        self.training_records_ = recs
        return self

    def predict(self, record=None, *, coverage=None, **fields):
        """Predict the outputs of a target record.

        Parameters
        ----------
        record : Record
            The target: its excitation (inputs, or the initial condition of a free
            response). The array forms ``predict(x0_new)``, ``predict(F_new)`` and MR's
            ``predict(w0=…, v0=…, F=…)`` are read into a record
            (:mod:`podbench.sysid.methods.arrays`).
        coverage : float in (0, 1), optional
            Also give the prediction band of that coverage and an error estimate, calibrated
            on the training records (:meth:`calibrate_band`, run on first use).

        Returns
        -------
        ndarray or Prediction
            The predicted outputs (n_out × n, the training outputs' unit); with
            ``coverage`` a :class:`~podbench.sysid.methods.bands.Prediction` (``mean``,
            ``lower``, ``upper``, ``error_estimate``).
        """
        self._check_is_fitted()
        target = target_record(self, record, fields)
        mean = self._predict(target)
        if coverage is None:
            return mean
        c = check_coverage(coverage)
        cal = self.__dict__.get("band_calibration_")
        if cal is None:
            cal = self.calibrate_band()
        return predict_band(self, target, c, cal, mean)

    def calibrate_band(self, *, noise_std=None, n_draws: int | None = None, seed: int = 0,
                       cross_validate: bool = True, reuse_choices: bool = True):
        """Calibrate the prediction band on the training records
        (:func:`podbench.sysid.methods.bands.calibrate`); ``predict(..., coverage=c)`` runs
        it with the defaults when the fit has no calibration yet. Call it to set the noise
        level ``noise_std`` (per channel, in the units of the outputs), the number of noise
        refits ``n_draws``, ``cross_validate=False`` for the noise part alone, or
        ``reuse_choices=False`` to let every refit choose its regularization again. Returns
        the :class:`~podbench.sysid.methods.bands.BandCalibration` (kept as
        ``band_calibration_``)."""
        self._check_is_fitted()
        if self.composite:
            raise InputError(f"{type(self).__name__}: no prediction band for a sum of methods "
                             "fitted on one record list per part; ask each part")
        self.band_calibration_ = calibrate(self, self.training_records_, noise_std=noise_std,
                                           n_draws=n_draws, seed=seed,
                                           cross_validate=cross_validate,
                                           reuse_choices=reuse_choices)
        return self.band_calibration_

    def _fit(self, records, basis) -> None:
        """Identify the model from the checked training records (a subclass's own step)."""
        raise NotImplementedError

    def _predict(self, record: Record) -> np.ndarray:
        """The prediction for a target record (a subclass's own step)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ choices
    def frozen_params(self) -> dict:
        """Hyperparameters that fix this fit's data-driven choices, for the refits of the
        prediction band (:mod:`podbench.sysid.methods.bands`): a fold refitted with
        ``get_params() | frozen_params()`` re-identifies the dynamics on its records at the
        full fit's regularization instead of choosing it again. The rules:

        * a hyperparameter of :data:`DATA_CHOSEN` left to the data (``None``, ``"auto"`` or
          ``"gcv"``) whose fitted value the model keeps as ``<name>_`` (ERA's ``order_``,
          OpInf's ``regularizer_``, ``n_lags_``) takes that value;
        * a deconvolution solved once (ML; not SL/MR, one solve per mode) freezes the
          solver's own choice (:func:`frozen_solver`): the GCV ``reg`` of ``"cgls"``,
          ``"fft"``, ``"stls"``, the hold-out ``order`` of ``"realization"`` /
          ``"subspace"``, the evidence hyperparameters of ``"kernel"``, and what ``"auto"``
          chose.

        Needs a fitted model; ``{}`` when nothing was chosen from the data."""
        self._check_is_fitted()
        params = self.get_params(deep=False)
        out: dict = {}
        for name, value in params.items():
            if name not in DATA_CHOSEN or not (
                    value is None or (isinstance(value, str) and value in ("auto", "gcv"))):
                continue
            fitted = getattr(self, name + "_", None)
            if isinstance(fitted, (int, float, np.integer, np.floating)) and \
                    not isinstance(fitted, bool):
                out[name] = fitted.item() if isinstance(fitted, np.generic) else fitted
        info = getattr(self, "solver_info_", None)
        if isinstance(params.get("solver"), str) and isinstance(info, dict):
            frozen = frozen_solver(params["solver"], params.get("solver_options"), info)
            if frozen is not None:
                out["solver"], out["solver_options"] = frozen
        return out

    def _validate_params(self) -> None:
        """Check the declared hyperparameters (:mod:`podbench.sysid.params`) and, for a
        method that declares ``solver``, build its solver (an unknown name or option, a bad
        option value)."""
        params = self._params()
        if "solver" in type(self)._parameter_constraints:
            make_method_solver(params["solver"], params.get("solver_options"))

    # ------------------------------------------------------------------ declarations
    def required_fields(self) -> tuple[str, ...]:
        """The record fields ``fit`` reads from every training record (``predict`` reads
        the same fields but ``W`` and ``dt``)."""
        return ("W",)

    @property
    def initial_field(self) -> str:
        """The record field of a free response's initial condition (``"w0"`` or ``"v0"``,
        by ``excitation``): what the array form's ``x0`` is."""
        return {"displacement": "w0", "velocity": "v0"}.get(
            str(getattr(self, "excitation", "")), "w0")

    def refusal(self, records) -> str | None:
        """Why the method cannot identify from ``records`` at all (e.g. SL from inputs that
        are not forces at the outputs), or None; ``fit`` raises it before anything else."""
        return None

    def command_line_params(self, records, *, solver: str = "auto", n_modes=None,
                            period: int | None = None) -> dict:
        """The parameters ``podbench predict --solver S --n-modes K`` mean for this method
        and these training records: ``n_modes`` and ``solver`` where the method has them.
        An option the method does not have is refused (not silently dropped): ``--n-modes``
        always, ``--solver`` unless it is the default ``auto``. ``period`` is the samples per
        period the training files carry (``period_samples``), None if they carry none; a
        method with a form for a periodic excitation may take it (ML does), the others
        ignore it."""
        names = self._get_param_names()
        name = self.abbreviation or type(self).__name__
        out: dict = {}
        if n_modes is not None:
            if "n_modes" not in names:
                raise InputError(f"Parameter `n_modes`: {name} has none")
            out["n_modes"] = n_modes
        if "solver" in names:
            out["solver"] = solver
        elif solver != "auto":
            raise InputError(f"Parameter `solver`: {name} takes no deconvolution solver")
        return out

    def _modal(self, records) -> bool:
        """Whether a forced method reads the records in the dissertation's form — modal
        forces ``Uᵀ F`` of forces at the output sensors — rather than their inputs as
        measured: its ``inputs`` hyperparameter (``"modal"``, ``"measured"``, or ``"auto"``:
        modal when every record's inputs are forces at its output channels); modal for a
        method without one."""
        inputs = getattr(self, "inputs", "modal")
        if inputs == "auto":
            return all(r.collocated for r in records)
        return inputs == "modal"

    def _inputs_refusal(self, records) -> str | None:
        """The refusal of a method with an ``inputs`` hyperparameter: a free response (no
        inputs), or modal forces asked of inputs that are not forces at the outputs."""
        name = self.abbreviation or type(self).__name__
        for r in records:
            if r.u is None:
                return (f"{name}: {r.name}: a free response (no inputs); {name} identifies "
                        "from loads or measured inputs")
            if getattr(self, "inputs", "modal") == "modal" and not r.collocated:
                return (f"{name}: {r.name}: inputs='modal' needs forces at the output "
                        "channels (the modal forces Uᵀ F, Eq. 3.47); these inputs are "
                        f"{r.input_quantity} at {', '.join(r.input_channels or ())}: use "
                        "inputs='measured'")
        return None

    def coupled_twin(self) -> PODMethod | None:
        """An unfitted estimator of the coupled twin (None if the method has none).

        A coupled method is its own twin (a fresh copy is returned)."""
        if self.coupled:
            return type(self)(**self.get_params(deep=False))
        return None

    # ------------------------------------------------------------------ fitted state
    def _set_basis(self, U, povs, pocs, dt: float | None = None) -> None:
        """Set the fitted basis (``modes_``, ``povs_``, ``pocs_``, ``n_modes_``) and, for a
        method that has one, the training sampling interval ``dt_``."""
        self.modes_ = U
        self.povs_ = povs
        self.pocs_ = pocs
        self.n_modes_ = U.shape[1]
        if dt is not None:
            self.dt_ = dt

    def _check_is_fitted(self) -> None:
        if not hasattr(self, "modes_"):
            raise NotFittedError(
                f"This {type(self).__name__} instance is not fitted yet; call `fit` before "
                "`predict`"
            )

    @property
    def diagnostics_(self) -> dict:
        """What the fit measured about itself, as a flat dict of scalars (shown in the
        harness's ``fits.csv``): ``n_modes``, ``fit_residual`` and ``condition_number``
        where the method has them, and the deconvolution solver's diagnostics
        (``solver``, ``solver_amplification``, ``solver_reg``, ``solver_iterations``,
        ``solver_rank``, …; ``solver_choice``: what ``solver="auto"`` returned, e.g.
        ``"block"`` or ``"realization"``, and ``solver_order`` the realization's order).
        A method that deconvolves once per mode (SL, MR) reports the largest value over the
        modes (the sum for ``solver_iterations``)."""
        self._check_is_fitted()
        out: dict = {"n_modes": int(self.n_modes_)}
        for name in ("fit_residual_", "condition_number_"):
            if hasattr(self, name):
                out[name[:-1]] = float(getattr(self, name))
        info = getattr(self, "solver_info_", None)
        infos = info if isinstance(info, list) else ([info] if info else [])
        if infos:
            out["solver"] = str(infos[0].get("solver", ""))
            keys = sorted({k for i in infos for k in i if k != "solver"})
            for key in keys:
                vals = [i[key] for i in infos if isinstance(i.get(key), (int, float))
                        and not isinstance(i.get(key), bool)]
                if vals:
                    out[f"solver_{key}"] = sum(vals) if key == "iterations" else max(vals)
            # what solver="auto" chose (distinct values over the modes, in order)
            choices = list(dict.fromkeys(str(i["choice"]) for i in infos
                                         if isinstance(i.get("choice"), str)))
            if choices:
                out["solver_choice"] = ",".join(choices)
        return out

    def _chosen_diagnostics(self) -> dict:
        """``n_modes`` and what the fit chose (``info_``: lags, prior, order …) as the
        diagnostics of a fit on measured inputs."""
        self._check_is_fitted()
        out: dict = {"n_modes": int(self.n_modes_)}
        out.update({k: v for k, v in self.info_.items() if isinstance(v, (int, float, str))})
        return out

    @property
    def n_sensors_(self) -> int:
        """Number of sensors ``m`` seen in ``fit``."""
        self._check_is_fitted()
        return self.modes_.shape[0]

    # ------------------------------------------------------------------ records
    def _training_records(self, records, name: str = "records") -> list[Record]:
        """The training records as a list, checked against the class declarations: what
        the method refuses (:meth:`refusal`), their number (:attr:`n_records`), their
        shapes (:meth:`_check_shapes`), the fields the method needs, one ``dt``."""
        if is_record_input(records):
            recs = ([as_record(r, f"{name}[{j}]") for j, r in enumerate(records)]
                    if isinstance(records, (list, tuple)) else [as_record(records, name)])
        else:
            raise InputError(
                f"Parameter `{name}`: expected a record or a sequence of records (objects with "
                f"W, F, w0, v0, dt such as podbench.Record), got {type(records).__name__}"
            )
        reason = self.refusal(recs)
        if reason is not None:
            raise InputError(reason)
        lo, hi = self.n_records
        if len(recs) < lo or (hi is not None and len(recs) > hi):
            want = f"exactly {lo}" if lo == hi else (f"at least {lo}" if hi is None
                                                      else f"{lo} to {hi}")
            raise InputError(
                f"Parameter `{name}`: {type(self).__name__} takes {want} training record"
                f"{'' if want.endswith(' 1') else 's'}, got {len(recs)}"
            )
        self._check_shapes(recs, name)
        for field_name in self.required_fields():
            for j, r in enumerate(recs):
                if getattr(r, field_name) is None:
                    raise InputError(
                        f"Parameter `{name}[{j}].{field_name}`: {type(self).__name__} needs "
                        f"{FIELD_WORDS[field_name]} of every training record"
                    )
        if "dt" in self.required_fields():
            dt0 = recs[0].dt
            for j, r in enumerate(recs[1:], start=1):
                if not np.isclose(cast(float, r.dt), cast(float, dt0), rtol=1e-12, atol=0.0):
                    raise DimensionError(
                        f"Parameter `{name}[{j}].dt`: {r.dt:g} s differs from `{name}[0].dt` = "
                        f"{dt0:g} s; all training records need one sampling interval"
                    )
        return recs

    def _check_shapes(self, recs: list[Record], name: str) -> None:
        """Every record of one shape (the dissertation's methods stack their records);
        records read with their inputs as measured (:meth:`_modal`) may differ in length
        and are checked against each other (channels, units, ``dt``)."""
        if not self._modal(recs):
            check_records(recs)
            return
        shape = recs[0].W.shape if recs[0].W is not None else None
        for j, r in enumerate(recs[1:], start=1):
            if r.W is not None and r.W.shape != shape:
                raise DimensionError(
                    f"Parameter `{name}[{j}].W`: shape {r.W.shape} differs from "
                    f"`{name}[0].W` {shape}; all records need the same sensors and sample count"
                )

    def _target_record(self, record, name: str = "record", *, fields: bool = True) -> Record:
        """A record to predict from: the fields the method needs (unless ``fields`` is
        False), its ``dt`` equal to the training one (when the method has one)."""
        rec = as_record(record, name)
        for field_name in self.required_fields() if fields else ():
            if field_name in ("W", "dt", "y"):
                continue
            if getattr(rec, field_name) is None:
                raise InputError(
                    f"Parameter `{name}.{field_name}`: {type(self).__name__} predicts from "
                    f"{FIELD_WORDS[field_name]}; the record has none"
                )
        dt_fit = getattr(self, "dt_", None)
        if dt_fit is not None and rec.dt is not None and \
                not np.isclose(rec.dt, dt_fit, rtol=1e-12, atol=0.0):
            raise DimensionError(
                f"Parameter `{name}.dt`: {rec.dt:g} s differs from the training records' "
                f"{dt_fit:g} s (the identified kernel is sampled at the training interval)"
            )
        return rec


# ---------------------------------------------------------------------- declarations
# What the methods' common hyperparameters admit (their `_parameter_constraints` use these).
N_MODES: list = [None, Interval("integer", 1)]
ENERGY: list = [Interval("number", 0, 1, closed="right")]
TOL: list = [Interval("number", 0, 1, closed="neither")]
MAX_COND: list = [Interval("number", 1)]
MAX_GROWTH: list = [Interval("number", 1)]
BASES: list = [Options("first", "all")]
SOLVER: list = [InstanceOf((str, Solver, type), "a solver name, a Solver subclass or instance")]
SOLVER_PARAMS: dict = {"solver": SOLVER, "solver_options": SOLVER_OPTIONS}


def check_n_modes(n_modes) -> int | None:
    return check_param(n_modes, "n_modes", N_MODES)


def check_energy(energy) -> float:
    return check_param(energy, "energy", ENERGY)


def check_tol(tol, name: str = "tol") -> float:
    return check_param(tol, name, TOL)


def check_max_cond(max_cond) -> float:
    return check_param(max_cond, "max_cond", MAX_COND)


def make_method_solver(solver, solver_options):
    """The solver object of a method's ``solver`` / ``solver_options`` hyperparameters.

    ``solver`` is a built-in name (:func:`podbench.deconvolution.available_solvers`), a
    ``"module:Class"`` name, or a solver instance (then ``solver_options`` must be empty).
    Raises InputError naming ``solver`` or ``solver_options``.
    """
    return make_solver(solver, solver_options)


def amplification(Q_list, X, B, dt: float) -> float:
    """``‖A‖‖X‖/‖B‖`` of a deconvolution ``A X ≈ B`` (Eq. 3.43/3.48), with the bound
    ``‖A‖ ≤ Δt Σ_s ‖G_s‖_F`` of the block-Toeplitz operator (``G_s``: every load case's
    modal forces at sample ``s``); the measure the ``"block"`` solver's ``max_growth``
    uses. Near 1 for a well-posed system; huge when the solution amplifies noise or model
    error (e.g. one record with random forces: its convolution matrix is ill-conditioned)."""
    G2 = sum(np.sum(np.asarray(q, dtype=float) ** 2, axis=0) for q in Q_list)
    norm_a = dt * float(np.sum(np.sqrt(G2)))
    norm_b = float(np.linalg.norm(B))
    norm_x = float(np.linalg.norm(X))
    if norm_b == 0:
        return 0.0 if norm_x == 0 else float("inf")
    return norm_a * norm_x / norm_b


def check_max_growth(max_growth) -> float:
    return check_param(max_growth, "max_growth", MAX_GROWTH)


DATA_CHOSEN = ("order", "regularizer", "n_lags")
"""Hyperparameters that a fit chooses from the data when left at None/"auto" and keeps as
``<name>_`` (:meth:`PODMethod.frozen_params`): a realization's order (ERA), OpInf's
regularizer, a kernel's lag count."""

FROZEN_CHOICES = {"gcv": ("reg",), "holdout": ("order",), "evidence": ("lam", "rho", "gamma")}
"""Solver diagnostics that record a choice from the data (``reg_rule``/``order_rule``) →
the options that fix it (:func:`frozen_solver`)."""


def frozen_solver(solver: str, options, info: dict):
    """``(solver, options)`` that repeat the choice a solver made from the data (its
    diagnostics ``info``): the GCV ``reg`` (``"cgls"``, ``"fft"``, ``"stls"``), the hold-out
    ``order`` (``"realization"``, ``"subspace"``), the evidence ``lam``, ``rho``, ``gamma``
    (``"kernel"``); for ``"auto"`` the solver it returned (``info["choice"]``) with that
    solver's choice fixed. None when nothing was chosen from the data. The options stay
    scale-free where the solver's are (``reg`` is relative to the system's largest
    singular value)."""
    opts = dict(options or {})
    name = solver
    if solver == "auto":
        choice = info.get("choice")
        if not isinstance(choice, str):
            return None
        name, opts = choice, {}
        if choice == "kernel":  # auto's kernel keeps auto's prior and grid
            opts = {key: opts_value for key, opts_value in (options or {}).items()
                    if key in ("kernel", "n_hyper")}
    chosen = {}
    for rule_key in ("reg_rule", "order_rule"):
        for key in FROZEN_CHOICES.get(str(info.get(rule_key)), ()):
            if isinstance(info.get(key), (int, float)) and not isinstance(info[key], bool):
                chosen[key] = info[key]
    if not chosen and name == solver:
        return None
    return name, {**opts, **chosen}


def solve_deconvolution(solver, Q_list, B, dt: float, max_growth: float = np.inf,
                        what: str = ""):
    """Solve Eq. 3.43/3.48 with a solver object of :func:`make_method_solver`; returns
    ``(X, info)`` with the solver's diagnostics (a dict of JSON-able scalars) and
    ``info["amplification"]`` (:func:`amplification`).

    Raises
    ------
    IllConditionedError
        The amplification exceeds ``max_growth``: the solution is dominated by amplified
        noise or model error, not by the data (``what`` names the system in the message).
    """
    res = deconvolve(Q_list, B, dt, solver, return_info=True)
    X, info = res.X, dict(res.info)
    growth = amplification(Q_list, X, B, dt)
    info["amplification"] = growth
    if not growth <= max_growth:
        name = info.get("solver", "")
        raise IllConditionedError(
            f"{what or 'deconvolution'}: solver {name!r} amplified the data by {growth:.3g} "
            f"(‖A‖‖X‖/‖B‖ > max_growth = {max_growth:g}); the convolution system is "
            "ill-conditioned for these forces (e.g. random or noisy forces, or a record "
            "that does not start at rest) and the kernel would be noise. Use a regularized "
            "solver ('cgls' or 'fft', Tikhonov) or raise max_growth"
        )
    return X, info


def solve_deconvolutions(solver, systems, dt: float, max_growth: float = np.inf,
                         what: str = "") -> list:
    """:func:`solve_deconvolution` on several ``(Q_list, B)`` at once (the solver may solve
    them together, ``solve_many``: the leave-one-record-out folds of a prediction band);
    a list of ``(X, info)``, each as :func:`solve_deconvolution` returns it."""
    results = solver.solve_many([ConvolutionSystem(Q, B, dt) for Q, B in systems])
    out = []
    for (Q_list, B), res in zip(systems, results, strict=True):
        X, info = res.X, dict(res.info)
        growth = amplification(Q_list, X, B, dt)
        if not growth <= max_growth:  # the one-by-one solve raises its own message
            return [solve_deconvolution(solver, Q, Bj, dt, max_growth, what)
                    for Q, Bj in systems]
        info["amplification"] = growth
        out.append((X, info))
    return out


def select_basis(W: np.ndarray, n_modes, basis, *, energy: float | None = None):
    """The ``(m, k)`` basis a method works in, with the POVs and POCs of ``W`` in it.

    Parameters
    ----------
    W : (m, n) ndarray
        First (or only) data set.
    n_modes : int or None
        Requested ``k``. ``None``: ``basis.shape[1]`` if a basis is given, else the
        smallest ``k`` capturing ``energy`` (Eq. 2.3, σ-based); if ``energy`` is also None
        the caller must pass ``n_modes``.
    basis : (m, k) array_like or None
        Orthonormal basis replacing the POMs of ``W``.

    Returns
    -------
    U : (m, k) ndarray
    povs : (k,) ndarray
        POVs of ``W`` (with a basis: the norms ``‖u_iᵀ W‖``).
    pocs : (n, k) ndarray
        POC histories of ``W`` (with a basis: ``Wᵀu_i / ‖u_iᵀ W‖``, not orthogonal in
        general; a zero history stays zero).
    """
    m = W.shape[0]
    if basis is not None:
        U = check_orthonormal(basis, "basis", n_rows=m)
        if n_modes is not None and n_modes != U.shape[1]:
            raise InputError(
                f"Parameter `n_modes`: {n_modes} differs from the {U.shape[1]} columns of "
                "`basis` (give one or make them agree)"
            )
        Vh = U.T @ W
        povs = np.linalg.norm(Vh, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            pocs = np.where(povs[:, None] > 0, Vh / povs[:, None], 0.0).T
        return U, povs, pocs
    full = snapshot_svd(W)
    rank = numerical_rank(full.povs, W.shape)
    if n_modes is None:
        if energy is None:
            raise InputError("Parameter `n_modes`: required")
        n_modes = n_modes_for_energy(full.povs, energy, kind="sigma")
    if n_modes > rank:
        raise InputError(
            f"Parameter `n_modes`: {n_modes} modes requested but the data set has numerical "
            f"rank {rank} (shape {W.shape}); use at most {rank} modes"
        )
    return full.modes[:, :n_modes], full.povs[:n_modes], full.pocs[:, :n_modes]


def per_record_basis(Ws, n_modes, basis, rule: str, too_few: str):
    """The basis of a method whose ``k`` may not exceed the number ``N`` of training records
    (MDS, ML: :attr:`PODMethod.records_per_mode`), with the POVs and POCs of the first record
    in it (:func:`select_basis`).

    ``basis`` when given (``k`` its columns); else the ``k`` leading POMs (``k = n_modes``,
    default ``N``) of the first record (``rule="first"``, the dissertation's) or of all
    records side by side, ``[¹W ²W …]`` (``rule="all"``). Raises InputError with the
    message ``too_few.format(k=k, n_sets=N)`` when ``k > N``, before any POD.
    """
    n_sets = len(Ws)
    if basis is not None:
        U, povs, pocs = select_basis(Ws[0], n_modes, basis)
        k = U.shape[1]
    else:
        k = n_sets if n_modes is None else n_modes
    if k > n_sets:
        raise InputError(too_few.format(k=k, n_sets=n_sets))
    if basis is not None:
        return U, povs, pocs
    if rule == "first":
        return select_basis(Ws[0], k, None)
    U_all, _, _ = select_basis(np.hstack(Ws), k, None)
    return select_basis(Ws[0], None, U_all)


def modal_share_too_small(a: np.ndarray, scale: float, tol: float) -> np.ndarray:
    """Boolean mask of ``|a_i| <= tol·scale`` (a divisor too small to use)."""
    return np.abs(a) <= tol * scale


def as_int_list(idx) -> str:
    """'1, 3' from a boolean mask or indices (1-based, for messages)."""
    idx = np.flatnonzero(idx) if np.asarray(idx).dtype == bool else np.asarray(idx)
    return ", ".join(str(int(i) + 1) for i in idx)
