"""Base class and shared input checks of the POD-based identification methods.

The methods follow the scikit-learn estimator contract over records (see
:class:`PODMethod` for the whole contract):

* ``__init__`` takes keyword-only hyperparameters and stores them unchanged;
* ``fit(records, *, basis=None)`` validates hyperparameters and data and returns ``self``;
* learned state ends in an underscore (``modes_``, ``povs_``, ``pocs_``, ``kernel_`` …);
* ``predict(record)`` returns the predicted ``(m, n)`` displacement matrix and raises
  :class:`~podbench.errors.NotFittedError` before ``fit``.

Methods see only records (:class:`~podbench.records.Record`: snapshot matrices ``m × n``,
force matrices at the same sensors and times, initial profiles, Δt); they know nothing of
how the data were produced.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import cast

import numpy as np

from podbench.core.records import Record, as_record, is_record
from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, IllConditionedError, InputError, NotFittedError
from podbench.sysid.deconvolution import ConvolutionSystem, Solver, deconvolve, make_solver
from podbench.sysid.deconvolution._api import SOLVER_OPTIONS
from podbench.sysid.methods.bands import calibrate, check_coverage, predict_band
from podbench.sysid.params import InstanceOf, Interval, Options, ParamsMixin, check_param
from podbench.sysid.pod import check_orthonormal, n_modes_for_energy, numerical_rank, snapshot_svd

__all__ = ["PODMethod", "is_record_input"]


class PODMethod(ParamsMixin):
    """Base class of the identification methods (POVR, MDS, SL, ML, MR, superpositions, peers).

    The contract (scikit-learn's, over records instead of feature matrices):

    * ``__init__`` takes keyword-only hyperparameters and stores them unchanged; nothing is
      validated there, so :func:`sklearn.base.clone` works;
    * :meth:`get_params` / :meth:`set_params` read the constructor's signature (nested
      ``solver__reg`` names reach a solver object given as a hyperparameter);
    * ``_parameter_constraints`` declares what each hyperparameter admits
      (:mod:`podbench.sysid.params`); :meth:`_validate_params` checks them without data
      (``fit`` calls it; the scenario loader calls it when a file is read, so a bad option
      fails before any simulation) and raises
      :class:`~podbench.errors.InvalidParameterError` naming ``.param``;
    * ``fit(records, *, basis=None)`` takes a record or a sequence of records (objects with
      ``W, F, w0, v0, dt``: :class:`~podbench.data.Record`, :class:`~podbench.data.Response`)
      and returns ``self``; learned state ends in ``_``; ``modes_`` is the ``m × k``
      orthonormal basis the method predicts in;
    * ``predict(record)`` returns the ``(m, n)`` displacement prediction for the excitation
      in ``record`` (the fields the method uses: :meth:`required_fields`), and raises
      :class:`~podbench.errors.NotFittedError` before ``fit``.

    Each class declares what it needs: :attr:`excitation_kind` (``"free"``, ``"forced"`` or
    ``"mixed"``), :attr:`coupled` (identifies full modal matrices: it is its own coupled
    twin), :attr:`n_records` (how many training records it takes), :attr:`records_per_mode`
    (``k`` is bounded by the number of records) and :meth:`coupled_twin` (the unfitted
    coupled method whose error, in the same basis, isolates the diagonal assumption).
    The array-level signatures of the dissertation (``POVR().fit(W, x0)``,
    ``MultipleLoad().fit([W…], [F…], dt=…)``) remain as thin wrappers.
    """

    #: Short name used in tables (e.g. "POVR").
    abbreviation = ""
    #: "free" (initial conditions), "forced" (loads from rest) or "mixed" (both).
    excitation_kind = ""
    #: True when the method identifies full (coupled) modal matrices (MDS, ML).
    coupled = False
    #: (minimum, maximum or None) number of training records.
    n_records: tuple[int, int | None] = (1, None)
    #: True when ``k`` may not exceed the number of training records (MDS, ML).
    records_per_mode = False

    # fitted state (set by ``fit``; declared for type checkers, absent before)
    modes_: np.ndarray
    n_modes_: int
    dt_: float

    def __init_subclass__(cls, **kwargs):
        # every method's fit remembers its training records and every predict takes
        # ``coverage=`` (a band and an error estimate: podbench.sysid.methods.bands)
        super().__init_subclass__(**kwargs)
        if "fit" in cls.__dict__:
            cls.fit = _remembering_fit(cls.__dict__["fit"])
        if "predict" in cls.__dict__:
            cls.predict = _banded_predict(cls.__dict__["predict"])

    def calibrate_band(self, *, noise_std=None, n_draws: int | None = None, seed: int = 0,
                       cross_validate: bool = True, reuse_choices: bool = True):
        """Calibrate the prediction band on the training records (done on first use of
        ``predict(..., coverage=c)`` with the defaults; call it to set the noise level
        ``noise_std`` (per channel, in the units of ``W``), the number of noise refits
        ``n_draws``, ``cross_validate=False`` for the noise part alone, or
        ``reuse_choices=False`` to let every refit choose its regularization again). Returns the
        :class:`~podbench.sysid.methods.bands.BandCalibration`."""
        self._check_is_fitted()
        recs = getattr(self, "training_records_", None)
        if not recs:
            raise InputError(
                f"{type(self).__name__}: a prediction band needs the record form of fit "
                "(fit(records) with a record or a sequence of records); this model was "
                "fitted from arrays or from one record list per part (a superposition)"
            )
        self.band_calibration_ = calibrate(self, recs, noise_std=noise_std, n_draws=n_draws,
                                           seed=seed, cross_validate=cross_validate,
                                           reuse_choices=reuse_choices)
        return self.band_calibration_

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

    @property
    def n_sensors_(self) -> int:
        """Number of sensors ``m`` seen in ``fit``."""
        self._check_is_fitted()
        return self.modes_.shape[0]

    # ------------------------------------------------------------------ records
    def _training_records(self, records, name: str = "records") -> list[Record]:
        """The training records as a list, checked against the class declarations: their
        number (:attr:`n_records`), one shape, the fields the method needs, one ``dt``."""
        if is_record(records):
            recs = [as_record(records, name)]
        elif isinstance(records, (Sequence, np.ndarray)) and not isinstance(records, str) \
                and len(records) and all(is_record(r) for r in records):
            recs = [as_record(r, f"{name}[{j}]") for j, r in enumerate(records)]
        else:
            raise InputError(
                f"Parameter `{name}`: expected a record or a sequence of records (objects with "
                f"W, F, w0, v0, dt such as podbench.Record), got {type(records).__name__}"
            )
        lo, hi = self.n_records
        if len(recs) < lo or (hi is not None and len(recs) > hi):
            want = f"exactly {lo}" if lo == hi else (f"at least {lo}" if hi is None
                                                      else f"{lo} to {hi}")
            raise InputError(
                f"Parameter `{name}`: {type(self).__name__} takes {want} training record"
                f"{'' if want.endswith(' 1') else 's'}, got {len(recs)}"
            )
        shape = recs[0].W.shape
        for j, r in enumerate(recs[1:], start=1):
            if r.W.shape != shape:
                raise DimensionError(
                    f"Parameter `{name}[{j}].W`: shape {r.W.shape} differs from "
                    f"`{name}[0].W` {shape}; all records need the same sensors and sample count"
                )
        for field_name in self.required_fields():
            for j, r in enumerate(recs):
                if getattr(r, field_name) is None:
                    raise InputError(
                        f"Parameter `{name}[{j}].{field_name}`: {type(self).__name__} needs "
                        f"{_FIELD_WORDS[field_name]} of every training record"
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

    def _fit_records(self, records, **beside) -> list[Record] | None:
        """``fit``'s first step: the hyperparameters checked (:meth:`_validate_params`),
        then the training records (:meth:`_training_records`) when ``fit`` got the record
        form (a record or a sequence of records; then none of the array-form arguments
        ``beside`` may be given too), else None (the array form)."""
        self._validate_params()
        if not is_record_input(records):
            return None
        for name, value in beside.items():
            if value is not None:
                raise InputError(
                    f"Parameter `{name}`: give it in the records (their "
                    f"{_BESIDE.get(name, name)}), not beside them")
        return self._training_records(records)

    def _target_record(self, record, name: str = "record", *, fields: bool = True) -> Record:
        """A record to predict from: the fields the method needs (unless ``fields`` is
        False), its ``dt`` equal to the training one (when the method has one)."""
        rec = as_record(record, name)
        for field_name in self.required_fields() if fields else ():
            if field_name in ("W", "dt"):
                continue
            if getattr(rec, field_name) is None:
                raise InputError(
                    f"Parameter `{name}.{field_name}`: {type(self).__name__} predicts from "
                    f"{_FIELD_WORDS[field_name]}; the record has none"
                )
        dt_fit = getattr(self, "dt_", None)
        if dt_fit is not None and rec.dt is not None and \
                not np.isclose(rec.dt, dt_fit, rtol=1e-12, atol=0.0):
            raise DimensionError(
                f"Parameter `{name}.dt`: {rec.dt:g} s differs from the training records' "
                f"{dt_fit:g} s (the identified kernel is sampled at the training interval)"
            )
        return rec


def _remembering_fit(fit):
    @functools.wraps(fit)
    def wrapper(self, records, *args, **kwargs):
        out = fit(self, records, *args, **kwargs)
        if is_record_input(records) and not args and kwargs.keys() <= {"basis"}:
            recs = [records] if is_record(records) else list(records)
            self.training_records_ = recs
        else:
            self.training_records_ = None
        self.__dict__.pop("band_calibration_", None)
        return out

    return wrapper


def _banded_predict(predict):
    @functools.wraps(predict)
    def wrapper(self, *args, coverage=None, **kwargs):
        mean = predict(self, *args, **kwargs)
        if coverage is None:
            return mean
        c = check_coverage(coverage)
        record = args[0] if args else kwargs.get("record")
        if not is_record(record):
            raise InputError(f"{type(self).__name__}.predict: a band (`coverage`) needs the "
                             "target as a record (an object with W, F, w0, v0, dt)")
        cal = getattr(self, "band_calibration_", None)
        if cal is None:
            cal = self.calibrate_band()
        return predict_band(self, record, c, cal, mean)

    return wrapper


_BESIDE = {"x0": "w0 or v0"}  # the record field of an array-form argument, for messages
_FIELD_WORDS = {
    "W": "the displacements W (in)",
    "F": "the force matrix F (lbf)",
    "w0": "the initial displacement w0 (in)",
    "v0": "the initial velocity v0 (in/s)",
    "dt": "the sampling interval dt (s)",
}


def is_record_input(data) -> bool:
    """True if ``data`` is a record or a non-empty sequence of records (the record form of
    ``fit``), False for arrays (the dissertation's array form)."""
    if is_record(data):
        return True
    if isinstance(data, (list, tuple)) and data and all(is_record(r) for r in data):
        return True
    return False


# ---------------------------------------------------------------------- checks
def check_snapshots(W, name: str = "W") -> np.ndarray:
    """A finite 2-D snapshot matrix with at least one sensor and one sample."""
    W = as_finite_array(W, name, ndim=2)
    if W.shape[0] == 0 or W.shape[1] == 0:
        raise DimensionError(f"Parameter `{name}`: empty snapshot matrix, shape {W.shape}")
    return W


def check_datasets(Ws, name: str = "W") -> list[np.ndarray]:
    """A non-empty sequence of snapshot matrices of one shape (a 3-D array also works)."""
    if isinstance(Ws, np.ndarray) and Ws.ndim == 2:
        raise DimensionError(
            f"Parameter `{name}`: expected a sequence of (m, n) snapshot matrices (one per "
            f"data set), got a single 2-D array of shape {Ws.shape}; wrap it in a list"
        )
    if not isinstance(Ws, (Sequence, np.ndarray)) or isinstance(Ws, str):
        raise InputError(
            f"Parameter `{name}`: expected a sequence of snapshot matrices, got {type(Ws)}"
        )
    if len(Ws) == 0:
        raise InputError(f"Parameter `{name}`: no data set given")
    out = [check_snapshots(W, f"{name}[{j}]") for j, W in enumerate(Ws)]
    for j, W in enumerate(out[1:], start=1):
        if W.shape != out[0].shape:
            raise DimensionError(
                f"Parameter `{name}[{j}]`: shape {W.shape} differs from `{name}[0]` "
                f"{out[0].shape}; all data sets need the same sensors and sample count"
            )
    return out


def check_profile(x, m: int, name: str) -> np.ndarray:
    """A finite initial profile with one entry per sensor, shape (m,)."""
    x = as_finite_array(x, name)
    if x.ndim == 2 and 1 in x.shape:
        x = x.ravel()
    if x.shape != (m,):
        raise DimensionError(
            f"Parameter `{name}`: expected shape ({m},) (one value per sensor), got {x.shape}"
        )
    return x


def check_profiles(xs, n_sets: int, m: int, name: str) -> list[np.ndarray]:
    """One initial profile per data set (a sequence, or a 2-D array with one profile per row)."""
    if isinstance(xs, np.ndarray) and xs.ndim == 1:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_sets} profiles (one per data set), got a single "
            f"1-D array of shape {xs.shape}"
        )
    _check_count(xs, n_sets, name, "profiles")
    return [check_profile(x, m, f"{name}[{j}]") for j, x in enumerate(xs)]


def check_forces(Fs, Ws, name: str = "F") -> list[np.ndarray]:
    """One force matrix per data set, each of the shape of its snapshot matrix."""
    if isinstance(Fs, np.ndarray) and Fs.ndim == 2:
        raise DimensionError(
            f"Parameter `{name}`: expected a sequence of (m, n) force matrices, got a single "
            f"2-D array of shape {Fs.shape}; wrap it in a list"
        )
    _check_count(Fs, len(Ws), name, "force matrices")
    pairs = enumerate(zip(Fs, Ws, strict=True))
    return [check_force(F, W, f"{name}[{j}]") for j, (F, W) in pairs]


def _check_count(xs, n_sets: int, name: str, what: str) -> None:
    """``xs`` is a sequence of ``n_sets`` items, one per data set."""
    try:
        count = len(xs)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected a sequence of {what}") from None
    if count != n_sets:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_sets} {what} (one per data set), got {count}"
        )


def check_force(F, W: np.ndarray, name: str = "F") -> np.ndarray:
    """A finite force matrix of the shape of its snapshot matrix ``W``."""
    F = as_finite_array(F, name, ndim=2)
    if F.shape != W.shape:
        raise DimensionError(
            f"Parameter `{name}`: force matrix shape {F.shape} differs from the snapshot "
            f"matrix shape {W.shape} (forces are sampled at the same sensors and times)"
        )
    return F


def check_new_force(F, m: int, n: int, name: str = "F") -> np.ndarray:
    """A new force matrix with ``m`` rows and at most ``n`` samples."""
    F = as_finite_array(F, name, ndim=2)
    if F.shape[0] != m or not 1 <= F.shape[1] <= n:
        raise DimensionError(
            f"Parameter `{name}`: expected shape ({m}, n') with 1 <= n' <= {n} (the kernel was "
            f"identified from {n} samples), got {F.shape}"
        )
    return F


def check_dt(dt) -> float:
    """Δt > 0 (s)."""
    if dt is None:
        raise InputError("Parameter `dt`: the sampling interval (s) is required")
    return check_positive(dt, "dt")


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
