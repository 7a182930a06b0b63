"""Prediction bands and error estimates: every prediction states its own error.

``model.predict(target, coverage=0.9)`` returns a :class:`Prediction` (``mean``, ``lower``,
``upper``, ``error_estimate``, ``note``, ``to_pandas()``); ``model.predict(target)`` still
returns the array. Everything is built from the training records, never from the truth
(docs/bands.md has the derivations and the measurements):

* **Cross-validation** (a method whose records allow leaving one out): each training record
  is predicted by the method refitted on the others in the fitted basis (at the full fit's
  regularization, :meth:`~podbench.sysid.methods.base.PODMethod.frozen_params`). The error
  estimate of a prediction is ``sqrt(d²(κ_Λ²(Λ² + 1) + κ_Δ²Δ²) + ρ²)``: the target's
  leverage ``Λ``, blind spot ``Δ`` and projection share ``ρ``
  (:mod:`~podbench.sysid.methods.band_target`), the level factor ``d`` (:func:`levels`,
  :func:`extrapolation`: a measured input's RMS outside the training inputs' range, above
  or below, else the prediction's RMS above the training responses'), and two gains
  fitted to the folds' realized errors (:func:`fit_gains`); :data:`ESTIMATE_RULE` names
  the variants ``"folds"``, ``"folds-leverage"`` (:func:`folds_estimate`) and ``"choose"``
  (:func:`rule_losses`). The band is normalized conformal:
  each fold's residual in units of
  its own estimate spread over its prediction's envelope, the conformal quantile of the
  pooled scores scaling the target's difficulty (:func:`_difficulty`).
* **One design only** (POVR, SL: one record; MR: exactly three): the in-sample residual,
  the noise propagated by refits on noisy copies, and for SL and POVR the diagonal
  assumption's split (:func:`diagonal_split`); MR has no model-form term and gives no
  estimate (NaN, with ``Prediction.note`` saying why).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

from podbench.core.hints import percent_hint
from podbench.core.records import as_record
from podbench.errors import InputError
from podbench.sysid.methods import band_target
from podbench.sysid.methods.band_target import TargetTerms

__all__ = ["Prediction", "BandCalibration", "calibrate", "predict_band", "check_coverage",
           "interval_score", "band_coverage"]

N_TIME_BINS = 10
"""Bins of the learned time profile g(t) of the model-form difficulty."""
ENVELOPE_FRACTION = 0.05
"""Window of the moving-RMS envelope, as a fraction of the record length."""
FLOOR = 0.05
"""Floor of the envelope, as a fraction of the prediction's overall RMS at that sensor (a
sensor at rest at time t still gets a band)."""


DIAGONAL_TERM = True
"""Whether the single-record diagonal methods' band carries the diagonal assumption's term."""
DIAGONAL_RULE = "split"
"""That term's rule: ``"split"`` (:func:`diagonal_split`: the prediction's response to the
excitation outside the training pattern, and a bound on the structure's) or ``"tangent"``
(:func:`diagonal_inconsistency`: the spread of the modal scales, the tangent of the angle
between the target's and the training excitation; unbounded)."""

PROJECTION_SHARE = True
"""Whether a method that can measure a target's share outside its basis
(``projection_share(record)``: the free-response methods on an initial displacement, whose
response starts at ``w0``) takes the error estimate as the identification's error inside
the basis (its residuals' part ``U Uᵀ R_j``) plus that share, ``sqrt(e_in² + ρ²)``, instead
of the training records' projection error."""

EXTRAPOLATE_BELOW = False
"""Whether a prediction below the training RMS range also counts as extrapolated."""
TRAINING_FLOOR = True
"""Whether the envelope's floor also scales with the training records' per-sensor RMS."""
AMPLITUDE_POWER = 1.0
"""β of the amplitude-extrapolation factor ``d^β`` of the model-form difficulty
(:func:`extrapolation`); 0 switches it off. For the input level (:data:`LEVEL_RULE`) the
folds may raise it (:func:`fit_level_power`)."""
LEVEL_RULE = "input"
"""How a prediction's level is compared with the training records' range (:func:`levels`):
``"input"``: where every record carries a measured input (input/output records: the force or
ground motion a test applies, e.g. a ground-vibration test run at several force levels) the
RMS of that input, outside the range *above or below* it (a structure whose best linear
model changes with the level, through friction, clearance or a stiffening spring, is as far
from a low level as from a high one); every other record: the prediction's RMS against the
training responses', above the range only (:data:`EXTRAPOLATE_BELOW`). ``"response"``: the
latter for every record (the former rule)."""
LEVEL_REFERENCE = "effective"
"""What a measured input's level is compared with (:func:`input_excursion`):
``"effective"`` the pooled fit's effective level, the training levels' mean weighted by each
record's input energy ``Σ u²`` (:func:`effective_level`), the excursion
``max(x/x_eff, x_eff/x)``; ``"range"`` (the former rule) the training levels' range,
``max(x/x_max, x_min/x, 1)``. A least-squares fit pooled over records of several levels
weighs each record's equations by its input power, so for a structure whose linear model
``G(x)`` changes with the level it returns, to first order in the change, ``G`` at that
weighted mean level (``Σ a_l³/Σ a_l²`` for records of one length and RMS ``a_l``), not a
model valid over the whole range: a target inside the range but far from that level is an
extrapolation of the model, and one near it is not."""
LEVEL_POWERS = (1.0, 1.5, 2.0, 3.0)
"""The exponents β of the input level's excursion the folds choose from (:func:`fit_level_power`);
the smallest is :data:`AMPLITUDE_POWER`'s default."""
LEVEL_SPREAD = 1.1
"""A fold counts as outside the others' input-level range when its excursion exceeds this:
below it, the spread of the folds' errors from every other cause swamps a level effect."""


def _rms(X) -> float:
    return float(np.sqrt(np.mean(np.asarray(X, dtype=float) ** 2)))


def extrapolation(amplitude: float, lo: float, hi: float, below: bool | None = None) -> float:
    """How far a prediction of RMS ``amplitude`` lies beyond the RMS range ``[lo, hi]`` of
    the records the model was fitted on: ``max(amplitude/hi, 1)``, and ``lo/amplitude``
    below the range when ``below`` (default :data:`EXTRAPOLATE_BELOW`)."""
    if not amplitude > 0 or not hi > 0:
        return 1.0
    below = EXTRAPOLATE_BELOW if below is None else below
    under = lo / amplitude if below and lo > 0 else 1.0
    return float(max(amplitude / hi, under, 1.0))


def input_level(record) -> float | None:
    """The RMS of a record's measured input over all input channels (input unit), or None
    for a record without one (simulated records: ``F``, ``w0`` are loads, not measured
    inputs) or when :data:`LEVEL_RULE` is ``"response"``."""
    if LEVEL_RULE != "input" or record.u is None or record.collocated:
        return None
    return _rms(record.u)


def effective_level(levels, energies) -> float:
    """The effective level ``Σ E_l a_l / Σ E_l`` of a pooled fit on records of levels
    ``a_l`` (input RMS) and input energies ``E_l = Σ u_l²`` (:data:`LEVEL_REFERENCE`)."""
    a = np.asarray(levels, dtype=float)
    e = np.asarray(energies, dtype=float)
    return float(np.sum(e * a) / np.sum(e)) if np.sum(e) > 0 else float(np.mean(a))


def input_energy(record) -> float:
    """``Σ u²`` over a record's input channels and samples (input unit² · samples)."""
    return float(np.sum(np.asarray(record.u, dtype=float) ** 2))


def input_excursion(level: float, levels, energies, reference: str | None = None) -> float:
    """How far a measured input's RMS ``level`` lies from the training records' levels
    (``levels``, their input ``energies``), both ways: against ``reference`` (default
    :data:`LEVEL_REFERENCE`; ``"nearest"`` for a model kept per level,
    :func:`level_reference`)."""
    reference = reference or LEVEL_REFERENCE
    if reference == "range":
        return extrapolation(level, min(levels), max(levels), below=True)
    if reference == "nearest":
        lv = np.asarray(levels, dtype=float)
        lv = lv[lv > 0]
        if not level > 0 or lv.size == 0:
            return 1.0
        return float(np.min(np.maximum(level / lv, lv / level)))
    ref = effective_level(levels, energies)
    if not level > 0 or not ref > 0:
        return 1.0
    return float(max(level / ref, ref / level))


def level_reference(model) -> str:
    """What a fitted model's input levels are compared with: ``"nearest"`` for a model that
    keeps one identification per training level and interpolates between them at the
    target's level (it has ``levels_``: ML-interp), whose model at a level between two
    training levels is built from those two, so its distance from what was identified is
    the distance to the nearest training level, ``min_l max(x/x_l, x_l/x)``; else
    :data:`LEVEL_REFERENCE` (a pooled fit sits at its effective level)."""
    return "nearest" if getattr(model, "levels_", None) is not None else LEVEL_REFERENCE


def levels(records) -> tuple[str, list[float]]:
    """``(rule, levels)`` of the training records: ``"input"`` and their input RMS where
    every record has a measured input (:func:`input_level`), else ``"response"`` and the
    RMS of their responses ``W``."""
    lv = [input_level(r) for r in records]
    if all(v is not None and v > 0 for v in lv):
        return "input", [float(v) for v in lv]
    return "response", [_rms(r.W) for r in records]


def load_levels(record) -> dict | None:
    """The size of a record's load by two measures, where the load is not a measured input
    whose level the estimate charges itself (:func:`input_level`): a force ``F`` at the
    sensors, its peak ``max|F|`` (force unit) and impulse ``Σ_i Σ_t |F_i(t)| dt`` (force
    unit · s; ``dt`` 1 for a record without one); an initial displacement ``w0``, its peak
    ``max|w0|`` and norm ``‖w0‖`` (length unit). None for any other record."""
    if record.u is not None:
        if not record.collocated or input_level(record) is not None:
            return None
        F = np.abs(np.asarray(record.u, dtype=float))
        return {"peak": float(F.max()), "impulse": float(F.sum()) * float(record.dt or 1.0)}
    if record.w0 is not None:
        w0 = np.asarray(record.w0, dtype=float)
        return {"peak": float(np.abs(w0).max()), "norm": float(np.linalg.norm(w0))}
    return None


def load_note(record, cal) -> str:
    """Why a cross-validated estimate may be low for this target (empty when there is no
    reason): its load (:func:`load_levels`) lies beyond the largest training record's by
    more than any fold's lay beyond the other folds' (and by more than
    :data:`LEVEL_SPREAD`). The folds then never showed how the error grows with the load's
    size, and the estimate does not grow with it; on a linear structure it need not (the
    relative error of a linear model does not change with the load's size), on a nonlinear
    one the error does. The estimate is kept; the note tells the user."""
    lv = load_levels(record) if cal.load_levels else None
    if lv is None:
        return ""
    out = []
    for name, x in lv.items():
        train = np.array([t[name] for t in cal.load_levels], dtype=float)
        if train.size < 2 or not (x > 0 and train.max() > 0):
            continue
        folds = max(train[j] / max(np.delete(train, j).max(), 1e-300)
                    for j in range(train.size))
        reach = max(LEVEL_SPREAD, float(folds))
        if x / train.max() > reach:
            out.append(f"{name} {x / train.max():.3g}× the largest training record's, "
                       f"a fold's at most {folds:.3g}× the other folds'")
    if not out:
        return ""
    return ("the target's load lies beyond every training load by more than the folds "
            "measured (" + "; ".join(out) + "): the estimate does not grow with the "
            "load's size, and on a nonlinear structure it may be low")


def diagonal_split(pattern, excitation, respond) -> tuple[np.ndarray, np.ndarray]:
    """The diagonal assumption's error of a single-record method (SL, POVR), split into
    what the record determines and what it cannot (module docstring, *One design only*).

    ``pattern`` (k,): the training record's modal excitation direction ``a`` (SL: the
    dominant left singular vector of its modal forces ``UᵀF``; POVR: ``Uᵀx0``);
    ``excitation`` (k,) or (k, n): the target's ``q'`` (``UᵀF'``; ``Uᵀx0'``); ``respond``
    maps a modal excitation of that shape to the method's predicted response (m, n), and
    is linear in it (Eqs. 3.44–3.45 with the diagonal kernel ``c_ii``; Eq. 3.24 with
    ``σ̃_i = σ_i q'_i/u_i``). With ``â = a/‖a‖`` the target splits into its part with the
    training pattern, ``q'_∥ = â âᵀq'``, and the rest ``q'_⊥ = q'− q'_∥``. The scaling
    ``s_i = q'_i/u_i`` is exact on ``q'_∥`` (every mode sees the same scale: the method
    returns the training response to that scale, the linear structure's own), so the
    prediction's error is ``Ŵ_⊥ − W_⊥``: the method's response to ``q'_⊥`` (returned,
    known) minus the structure's (unknown: the record never saw that excitation).
    ``W_⊥`` is bounded by what the record does determine, the response to each mode's
    unexplained excitation ``q'_⊥,i`` (row ``i``) applied in the training pattern:
    ``T² = Σ_i respond(â q'_⊥,i)²`` (pointwise; depends on ``q'_⊥`` only through
    ``q'_⊥ᵀq'_⊥``). Returns ``(Ŵ_⊥, T²)``, both (m, n). The error ``Ŵ_⊥ − W_⊥`` is bounded
    by the prediction's own unexplained part and the pattern's response, never by
    ``1/u_i``: a mode the training load barely excites (``u_i → 0``) inflates ``Ŵ_⊥``
    exactly as much as it inflates the prediction, and no more."""
    a = np.asarray(pattern, dtype=float).ravel()
    q = np.asarray(excitation, dtype=float)
    shape = q.shape
    q = q.reshape(a.size, -1)
    scale = float(np.linalg.norm(a))
    if scale == 0:
        raise ValueError("diagonal_split: zero training pattern")
    a = a / scale
    q_perp = q - np.outer(a, a @ q)
    W_perp = np.asarray(respond(q_perp.reshape(shape)), dtype=float)
    T2 = np.zeros_like(W_perp)
    for row in q_perp:
        if np.any(row):
            T2 += np.asarray(respond(np.outer(a, row).reshape(shape)), dtype=float) ** 2
    return W_perp, T2


def diagonal_inconsistency(pattern, excitation) -> float:
    """How far a target's modal excitation is from the one a diagonal single-record method
    (SL, POVR) was identified from: the model-form term of their band (module docstring,
    *One design only*). ``pattern`` (k,): the training record's modal excitation
    direction (SL: the dominant left singular vector of its modal forces ``UᵀF``; POVR:
    ``Uᵀx0``); ``excitation`` (k,) or (k, n): the target's (``UᵀF'``, ``Uᵀx0'``). The
    method treats mode ``i`` as the training excitation scaled by ``s_i = q'_i / u_i``; it
    is exact when every mode sees the same scale (the target's excitation has the training
    pattern). The returned ``D`` is the spread of the ``s_i`` about their least-squares
    mean ``s̄ = uᵀq'/‖u‖²`` (weights ``u_i²/‖u‖²``), over the RMS of ``s̄``:
    ``D = sqrt(Σ_i w_i ‖s_i − s̄‖²) / ‖s̄‖``; 0 for a target with the training pattern, inf
    when the target excites only what the training pattern does not."""
    u = np.asarray(pattern, dtype=float).ravel()
    q = np.asarray(excitation, dtype=float)
    q = q.reshape(u.size, -1)
    scale = float(np.linalg.norm(u))
    if scale == 0 or not np.any(q):
        return 0.0
    u_safe = np.where(np.abs(u) > 1e-12 * scale, u, np.copysign(1e-12 * scale, u))
    S = q / u_safe[:, None]
    w = u ** 2 / scale ** 2
    sbar = w @ S
    num = float(np.sqrt(np.sum(w[:, None] * (S - sbar) ** 2)))
    den = float(np.sqrt(np.sum(sbar ** 2)))
    return num / den if den > 0 else math.inf


def check_coverage(coverage) -> float:
    """A coverage in (0, 1); InputError naming ``coverage`` otherwise."""
    try:
        c = float(coverage)
    except (TypeError, ValueError):
        raise InputError(f"Parameter `coverage`: expected a number in (0, 1), got "
                         f"{coverage!r}") from None
    if not 0.0 < c < 1.0 or not math.isfinite(c):
        raise InputError(f"Parameter `coverage`: must be in (0, 1), got {coverage!r}"
                         f"{percent_hint(c)}")
    return c


@dataclass(frozen=True, eq=False)
class Prediction:
    """A prediction with its band and error estimate.

    Attributes
    ----------
    mean : (m, n) ndarray
        The prediction (what ``predict(target)`` returns).
    lower, upper : (m, n) ndarray
        The band meant to hold the true response at each sensor and time with probability
        ``coverage``.
    coverage : float
        The nominal coverage.
    error_estimate : float
        The predicted total error ‖Ŵ − W‖_F/‖W‖_F (the harness's ``total_error``).
    source : str
        What the model-form part rests on: ``"cross-validation"`` (leave one record out,
        ``n_folds`` folds), ``"in-sample"`` (one design only: no split) or ``"noise"``
        (the noise part alone was asked for).
    details : dict
        Scalars of the calibration (conformal quantile, folds, noise level, the target's
        leverage, blind spot and projection share, …).
    note : str
        Why no error estimate can be made (``error_estimate`` is then NaN), or why the
        estimate given may be low (:func:`load_note`: a load beyond the training loads'
        size that the folds could not measure); empty otherwise.
    """

    mean: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    coverage: float
    error_estimate: float
    dt: float | None = None
    source: str = ""
    details: dict = field(default_factory=dict)
    note: str = ""

    @property
    def half_width(self) -> np.ndarray:
        return 0.5 * (self.upper - self.lower)

    def to_arrays(self) -> dict:
        """``{"W_hat": mean, "lower": lower, "upper": upper}`` (what an ``.npz`` holds)."""
        return {"W_hat": self.mean, "lower": self.lower, "upper": self.upper}

    def to_pandas(self):
        """A long table: one row per sensor and sample (``sensor``, ``sample``, ``time``,
        ``mean``, ``lower``, ``upper``)."""
        import pandas as pd

        m, n = self.mean.shape
        sensor, sample = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
        time = sample * self.dt if self.dt is not None else np.full((m, n), np.nan)
        return pd.DataFrame({
            "sensor": sensor.ravel(), "sample": sample.ravel(), "time": time.ravel(),
            "mean": self.mean.ravel(), "lower": self.lower.ravel(),
            "upper": self.upper.ravel(),
        })

    def covers(self, W) -> float:
        """Fraction of the samples of ``W`` (the truth) inside the band."""
        return band_coverage(W, self.lower, self.upper)

    def interval_score(self, W) -> float:
        """Mean interval score (Gneiting & Raftery 2007) of the band against ``W``."""
        return interval_score(W, self.lower, self.upper, self.coverage)

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self.mean, dtype=dtype)


def band_coverage(W, lower, upper) -> float:
    W = np.asarray(W, dtype=float)
    n = min(W.shape[1], lower.shape[1])
    inside = (W[:, :n] >= lower[:, :n]) & (W[:, :n] <= upper[:, :n])
    return float(np.mean(inside))


def interval_score(W, lower, upper, coverage: float) -> float:
    """Mean over samples of ``(u − l) + (2/α)(l − y)₊ + (2/α)(y − u)₊``, α = 1 − coverage
    (Gneiting & Raftery 2007, Eq. 43): lower is better; it rewards narrow bands and
    penalizes misses by their distance."""
    y = np.asarray(W, dtype=float)
    n = min(y.shape[1], lower.shape[1])
    y, lo, up = y[:, :n], lower[:, :n], upper[:, :n]
    a = 1.0 - coverage
    s = (up - lo) + (2 / a) * np.maximum(lo - y, 0) + (2 / a) * np.maximum(y - up, 0)
    return float(np.mean(s))


# ---------------------------------------------------------------------- difficulty
def _moving_rms(X: np.ndarray, width: int) -> np.ndarray:
    """Centered moving RMS along the last axis (window ``width`` samples, edges shrink)."""
    width = max(1, int(width))
    X2 = np.asarray(X, dtype=float) ** 2
    n = X2.shape[-1]
    a = width // 2
    # the cumulative sum c[0 … n] (c[0] = 0) extended by its edge values, a zeros before and
    # c[n] after: window s sums c[hi] − c[lo] = ext[s + width] − ext[s], two slices
    ext = np.zeros(X2.shape[:-1] + (n + width,))
    np.cumsum(X2, axis=-1, out=ext[..., a + 1 : a + 1 + n])
    ext[..., a + 1 + n :] = ext[..., a + n : a + n + 1]
    lo = np.clip(np.arange(n) - a, 0, n)
    hi = np.clip(np.arange(n) + width - a, 0, n)
    return np.sqrt(np.maximum((ext[..., width:] - ext[..., :n]) / (hi - lo), 0.0))


def _sensor_rms(records) -> np.ndarray:
    """Per-sensor RMS over the records' W (m,)."""
    return np.sqrt(np.mean([np.mean(np.asarray(r.W, float) ** 2, axis=1) for r in records],
                           axis=0))


def _local_rms(W_hat: np.ndarray) -> np.ndarray:
    """The envelope's moving RMS before its floor (window ENVELOPE_FRACTION of the record)."""
    return _moving_rms(W_hat, max(3, round(ENVELOPE_FRACTION * W_hat.shape[-1])))


def _envelope(W_hat: np.ndarray, reference=None, local=None) -> np.ndarray:
    """Local RMS envelope of a prediction at each sensor, with a floor (FLOOR × the larger
    of the sensor's overall RMS in the prediction and, given, in the training records
    ``reference`` (m,): a prediction of almost nothing still gets a band on the scale of
    what the model was fitted on; and 1e-12 × the whole prediction's RMS). ``local``: the
    prediction's :func:`_local_rms` when it is already computed (the floors differ between
    the folds' scores and their difficulty, the moving RMS does not)."""
    env = _local_rms(W_hat) if local is None else local
    rms_i = np.sqrt(np.mean(W_hat ** 2, axis=-1, keepdims=True))
    if reference is not None and TRAINING_FLOOR:
        rms_i = np.maximum(rms_i, np.asarray(reference, dtype=float)[..., None])
    tiny: float | np.ndarray
    if W_hat.ndim == 2:
        tiny = 1e-12 * (float(np.sqrt(np.mean(W_hat ** 2))) or 1.0)
    else:  # a stack of predictions (..., m, n): each its own
        overall = np.sqrt(np.mean(W_hat ** 2, axis=(-2, -1), keepdims=True))
        tiny = 1e-12 * np.where(overall > 0, overall, 1.0)
    return np.sqrt(env ** 2 + (FLOOR * rms_i) ** 2 + tiny ** 2)


def _bins(n: int) -> np.ndarray:
    return np.minimum((np.arange(n) * N_TIME_BINS) // max(n, 1), N_TIME_BINS - 1)


# ---------------------------------------------------------------------- calibration
@dataclass
class BandCalibration:
    """What the training records say about a fitted method's error (reused by every
    prediction of that fit)."""

    source: str                      # "cross-validation" | "in-sample"
    scores: np.ndarray               # pooled normalized residuals |R|/s (unordered)
    mean_square_score: float         # E[score²]: the error estimate's scale
    time_profile: np.ndarray         # g per time bin (N_TIME_BINS,)
    noise_std: np.ndarray | None     # per channel, (m,) (None: no noise part)
    n_folds: int
    n_draws: int
    cv_modes: int | None = None      # k of the cross-validation refits
    noise_models: list = field(default_factory=list)  # refits on noisy copies
    amplitude_range: tuple = (0.0, 0.0)  # level range of the training records (levels())
    input_levels: tuple = ()         # "input" level rule: each record's input RMS
    input_energies: tuple = ()       # "input" level rule: each record's Σ u² (the weights)
    reference_rms: np.ndarray | None = None  # per-sensor RMS of the training records' W
    inside_score: float | None = None  # mean_square_score of the residuals inside the basis
    gains: tuple | None = None       # (κ_Λ², κ_Δ²) of the target-aware estimate (folds)
    excitations: object = None       # band_target.Excitations of the training records in U
    fold_errors: np.ndarray | None = None     # realized relative error of each fold
    fold_estimates: np.ndarray | None = None  # the estimate's value for each fold
    fold_terms: list | None = None   # each fold's TargetTerms (what the gains were fitted on)
    fold_factors: np.ndarray | None = None  # each fold's level factor d = a^β
    fold_excursions: np.ndarray | None = None  # each fold's level excursion a
    fold_scale: float | None = None  # "folds" rule: median error inside the basis over d
    fold_blind: float | None = None  # "folds" rule: the folds' median blind spot Δ_j²
    fold_sizes: tuple = ()           # samples of each fold's scores (their order in scores)
    fold_leverage: float | None = None  # "folds-leverage", "folds-gains": max_j Λ_j² + 1
    gains_level_power: float = AMPLITUDE_POWER  # "folds-gains": the gains' β (beyond the folds)
    rule: str = ""                   # the estimate rule this calibration applied
    note: str = ""                   # why no estimate can be made (empty: it can)
    level_rule: str = "response"     # what the level is: "input" RMS or "response" RMS
    level_power: float = AMPLITUDE_POWER  # β of the level's excursion d = a^β
    leverage_exponent: float = 1.0   # γ of the gains' leverage term (Λ² + 1)^γ
    level_reference: str = ""        # input_excursion's reference ("": LEVEL_REFERENCE)
    load_levels: tuple = ()          # each training record's load_levels() (folds only)

    def quantile(self, coverage: float) -> float:
        """The conformal quantile: the ⌈(1 − α)(N + 1)⌉-th smallest score (N scores);
        inf when there are too few."""
        n = self.scores.size
        if n == 0:
            return 0.0
        rank = math.ceil(coverage * (n + 1))
        # the rank-th smallest by selection (np.partition), not a full sort
        return float(np.partition(self.scores, rank - 1)[rank - 1]) if rank <= n \
            else math.inf


def _frozen(model) -> dict:
    """The fitted model's data-driven choices as hyperparameters
    (:meth:`~podbench.sysid.methods.base.PODMethod.frozen_params`; ``{}`` for a method
    without the hook)."""
    hook = getattr(model, "frozen_params", None)
    return dict(hook()) if callable(hook) else {}


def _refit(model, records, *, n_modes=None, basis=None, frozen=None):
    est = type(model)(**{**model.get_params(deep=False), **(frozen or {})})
    if basis is not None and "basis" not in inspect.signature(est.fit).parameters:
        raise InputError(f"{type(model).__name__}: no prediction band: the band refits the "
                         "method in its fitted basis (leave one record out), and its fit "
                         "takes no basis")
    params = est.get_params(deep=False)
    if n_modes is None and basis is not None and params.get("n_modes") is not None:
        n_modes = np.shape(basis)[1]  # a fold in fewer modes (k > N − 1): the basis's count
    if n_modes is not None and "n_modes" in params:
        est.set_params(n_modes=n_modes)
    return est.fit(records, basis=basis)


def _with_W(rec, W):
    return as_record(rec).replace(y=W)


def estimate_noise_std(model, records) -> np.ndarray:
    """Per-channel noise std from the training records: the part outside the fitted basis,
    ``(I − UUᵀ)W``, scaled by ``m/(m − k)`` (white per-channel noise leaves that share
    outside a k-dimensional subspace); includes the projection error (errs high). Zeros
    when ``k = m`` (nothing is outside: give ``noise_std``)."""
    U = np.asarray(model.modes_, dtype=float)
    m, k = U.shape
    if k >= m:
        return np.zeros(m)
    R = [np.asarray(r.W, float) - U @ (U.T @ np.asarray(r.W, float)) for r in records]
    ms = np.mean([np.mean(Rj ** 2, axis=1) for Rj in R], axis=0)
    return np.sqrt(ms * m / (m - k))


def _noise_is_negligible(noise_std, records) -> bool:
    scale = np.sqrt(np.mean([np.mean(np.asarray(r.W, float) ** 2, axis=1) for r in records],
                            axis=0))
    return bool(np.all(noise_std <= 1e-4 * np.maximum(scale, 1e-300)))


def _noise_std(model, recs, noise_std, m: int):
    """The per-channel noise std (m,) of the training records: given, or estimated (None
    where it is negligible)."""
    if noise_std is None:
        sig = estimate_noise_std(model, recs)
        return None if _noise_is_negligible(sig, recs) else sig
    sig = np.broadcast_to(np.asarray(noise_std, dtype=float), (m,)).copy()
    if np.any(sig < 0) or not np.all(np.isfinite(sig)):
        raise InputError("Parameter `noise_std`: expected finite values >= 0")
    return sig


def _noise_refits(model, recs, sig, n_draws: int, seed: int, U, frozen=None) -> list:
    """``n_draws`` refits of ``model`` in the basis ``U`` on noisy copies of the records (at
    the full fit's regularization, ``frozen``)."""
    noise_models: list = []
    if sig is None or n_draws <= 0:
        return noise_models
    rng = np.random.default_rng(seed)
    for _ in range(n_draws):
        noisy = [_with_W(r, np.asarray(r.W, float)
                         + sig[:, None] * rng.standard_normal(np.shape(r.W)))
                 for r in recs]
        noise_models.append(_refit(model, noisy, basis=U, frozen=frozen))
    return noise_models


MAX_FOLDS: int | None = None
"""At most this many folds (a variant; ``None``, the default: one fold per training
record, leave-one-record-out). With ``N`` records and ``F = MAX_FOLDS < N`` the records
are dealt into ``F`` folds in turn (record ``j`` into fold ``j mod F``), every record is
predicted once, by the refit of its fold, and every fold is fitted on ``N − ⌈N/F⌉`` records
(the other folds' records, the last of them left out too where the fold predicts fewer
than ``⌈N/F⌉``: every fold's model then has as many records, hence modes, as the others).
That costs ``F`` refits on ``N − ⌈N/F⌉`` records instead of ``N`` on ``N − 1``; each
record's terms, level excursion and envelope floor are then taken against the records its
fold was fitted on. Where the method cannot be fitted on ``N − ⌈N/F⌉`` records (its
``n_records`` bounds) the folds stay leave-one-record-out."""


def fold_groups(n: int, lo: int = 1) -> list[list[int]]:
    """The records each fold leaves out (:data:`MAX_FOLDS`): ``[[0], [1], …]`` by default,
    or record ``j`` in fold ``j mod F``; leave-one-record-out where the larger folds would
    leave fewer than ``lo`` records to fit on."""
    F = MAX_FOLDS
    if F is None or n <= F or n - math.ceil(n / F) < max(lo, 1):
        return [[j] for j in range(n)]
    return [list(range(g, n, F)) for g in range(F)]


def fold_of(groups) -> list[list[int]]:
    """For each record (by index), the records its fold was fitted on: the other folds'
    first ``N − max |g|`` (:data:`MAX_FOLDS`)."""
    n = sum(len(g) for g in groups)
    size = n - max(len(g) for g in groups)
    out: list[list[int]] = [[] for _ in range(n)]
    for g in groups:
        rest = [i for i in range(n) if i not in g][:size]
        for j in g:
            out[j] = rest
    return out


def _fold_predictions(model, recs, U_cv, cv_modes, frozen, groups=None) -> list[np.ndarray]:
    """Each training record predicted by the model refitted in ``U_cv`` to the others:
    the method's own ``fold_predictions`` where it has one (the same predictions without
    the refits: MDS's folds are linear in the other records' projections, ML's
    deconvolutions are solved together), else one refit per fold; ``groups``
    (:func:`fold_groups`) of several records: one refit per group, on the other groups'
    records."""
    if groups is not None and any(len(g) > 1 for g in groups):
        out: list = [None] * len(recs)
        fitted = fold_of(groups)
        for g in groups:
            fit = _refit(model, [recs[i] for i in fitted[g[0]]],
                         n_modes=cv_modes, basis=U_cv, frozen=frozen)
            for j in g:
                out[j] = np.asarray(fit.predict(recs[j]), dtype=float)
        return out
    hook = getattr(model, "fold_predictions", None)
    if callable(hook):
        out = hook(recs, U_cv, frozen)
        if out is not None:
            return out
    return [np.asarray(_refit(model, recs[:j] + recs[j + 1:], n_modes=cv_modes, basis=U_cv,
                              frozen=frozen).predict(recs[j]), dtype=float)
            for j in range(len(recs))]


def _fold_envelopes(Whs, recs, reference: str | None = None, groups=None
                    ) -> tuple[list[np.ndarray], list[float], list[np.ndarray]]:
    """``(envelopes, excursions, local)``: each fold's envelope of its prediction, floored by the
    per-sensor RMS of the records it was fitted on (computed for all folds at once where
    the predictions share a shape), and how far its level lies outside the others'
    (:func:`extrapolation` of :func:`levels`: the left-out record's input RMS against the
    others', both ways, or its prediction's RMS against the others' responses), and each
    prediction's moving RMS before the floor (:func:`_local_rms`, reused by the scores);
    ``groups`` (:func:`fold_groups`): "the others" are the records the fold was fitted on."""
    N = len(recs)
    fitted = fold_of(groups if groups is not None else [[j] for j in range(N)])
    ms = [np.mean(np.asarray(r.W, float) ** 2, axis=1) for r in recs]
    rule, amps = levels(recs)
    energy = [input_energy(r) for r in recs] if rule == "input" else [1.0] * N
    refs, excursions = [], []
    for j, Wh in enumerate(Whs):
        rest = [ms[l] for l in fitted[j]]
        rest_lv = [amps[l] for l in fitted[j]]
        refs.append(np.sqrt(np.mean(rest, axis=0)))
        if rule == "input":
            excursions.append(input_excursion(
                amps[j], rest_lv, [energy[l] for l in fitted[j]], reference))
        else:
            excursions.append(extrapolation(_rms(Wh), min(rest_lv), max(rest_lv)))
    if len({Wh.shape for Wh in Whs}) == 1:
        stack = np.stack(Whs)
        local = _local_rms(stack)
        return list(_envelope(stack, np.stack(refs), local)), excursions, list(local)
    local = [_local_rms(Wh) for Wh in Whs]
    return ([_envelope(Wh, ref, lr) for Wh, ref, lr in zip(Whs, refs, local, strict=True)],
            excursions, local)


def folds_per_mode(model) -> bool:
    """Whether a fold (``N − 1`` records) is refitted in the first ``N − 1`` modes when the
    model has more: MDS and ML (:attr:`~podbench.sysid.methods.base.PODMethod.records_per_mode`,
    Eqs. 3.29 and 3.48: ``k`` is bounded by the records) and every other method driven by
    the modal forces ``UᵀF`` (the peers on forced records: ERA/OKID, DMDc, OpInf), whose
    ``N − 1`` records excite ``N − 1`` directions of the k-dimensional input, so that a
    fold cannot identify the input direction the left-out record carries and would charge
    the full model for a mode it does identify."""
    if getattr(model, "records_per_mode", False):
        return True
    return band_target.kind_of(model) == "forced" and getattr(model, "inputs_", "") == "modal"


def _residuals(model, recs, U, can_split: bool, frozen=None):
    """``(source, residuals, envelopes, cv_modes, predictions, excursions, local)``:
    leave-one-record-out residuals where the records allow a split, else the in-sample
    residuals; ``local`` the folds' :func:`_local_rms` (empty in-sample)."""
    residuals, envs, excursions, local = [], [], [], []
    source = "in-sample"
    cv_modes = None
    Whs: list = []
    if can_split:
        source = "cross-validation"
        k = int(U.shape[1])
        groups = fold_groups(len(recs), getattr(model, "n_records", (1, None))[0])
        fitted = len(recs) - max(len(g) for g in groups)  # the fewest records a fold fits
        if folds_per_mode(model) and k > fitted:
            cv_modes = fitted
        U_cv = U if cv_modes is None else U[:, :cv_modes]
        Whs = _fold_predictions(model, recs, U_cv, cv_modes, frozen, groups)
        envs, excursions, local = _fold_envelopes(Whs, recs, level_reference(model), groups)
        for j, Wh in enumerate(Whs):
            W = np.asarray(recs[j].W, dtype=float)[:, :Wh.shape[1]]
            if cv_modes is None:
                residuals.append(W - Wh)
            else:
                # the fold's error inside its k − 1 modes (the identification error) plus the
                # whole basis's projection error: the k-mode model's error without charging
                # it the mode the fold cannot identify
                inside = U_cv @ (U_cv.T @ W) - Wh
                residuals.append(inside + (W - U @ (U.T @ W)))
    else:
        for r in recs:
            Wh = np.asarray(model.predict(r), dtype=float)
            W = np.asarray(r.W, dtype=float)[:, :Wh.shape[1]]
            residuals.append(W - Wh)
            envs.append(_envelope(Wh))
            Whs.append(Wh)
            excursions.append(1.0)
    return source, residuals, envs, cv_modes, Whs, excursions, local


def _time_profile(residuals, envs) -> np.ndarray:
    """The time profile g: RMS of residual/envelope per time bin over folds and sensors,
    normalized to a mean square of one. Records of different lengths (measured
    input/output records) are binned each over its own length (g is a profile over the
    fraction of the record)."""
    if len({R.shape[1] for R in residuals}) == 1:
        bins = _bins(residuals[0].shape[1])
        ratio2 = (np.stack(residuals) / np.stack(envs)) ** 2
        # the bins are contiguous runs of samples: slices, not boolean copies
        edges = np.searchsorted(bins, np.arange(N_TIME_BINS + 1))
        g = np.array([np.sqrt(np.mean(ratio2[:, :, lo:hi])) if hi > lo else 1.0
                      for lo, hi in zip(edges[:-1], edges[1:], strict=True)])
    else:
        sums = np.zeros(N_TIME_BINS)
        counts = np.zeros(N_TIME_BINS)
        for R, E in zip(residuals, envs, strict=True):
            r2 = (R / E) ** 2
            b = np.broadcast_to(_bins(R.shape[1]), r2.shape).ravel()
            sums += np.bincount(b, weights=r2.ravel(), minlength=N_TIME_BINS)
            counts += np.bincount(b, minlength=N_TIME_BINS)
        g = np.where(counts > 0, np.sqrt(sums / np.maximum(counts, 1)), 1.0)
    if not np.all(np.isfinite(g)) or np.max(g) == 0:
        return np.ones(N_TIME_BINS)
    g = np.maximum(g, 1e-3 * np.max(g))
    return g / np.sqrt(np.mean(g ** 2))


def calibrate(model, records, *, noise_std=None, n_draws: int | None = None, seed: int = 0,
              cross_validate: bool = True, reuse_choices: bool = True) -> BandCalibration:
    """Calibrate the band of a fitted ``model`` on its training ``records`` (docs/bands.md).
    ``noise_std``: per-channel noise std of the training records (scalar or (m,)), default
    estimated; ``n_draws`` noise refits (default: 2 where the records allow no split, 0
    where they are cross-validated — each fold is then fitted on noisy records and scored
    against a noisy one, so the noise reaches the band through the folds, at the cost of
    no extra refit); ``cross_validate=False`` gives the noise part alone (the known-answer
    case); ``reuse_choices=False`` lets every refit choose its regularization again."""
    recs = list(records)
    if recs[0].u is not None and not recs[0].collocated and cross_validate and len(recs) < 2:
        raise InputError(f"{type(model).__name__}: a prediction band on input/output records "
                         "is calibrated by leave-one-record-out: it needs at least 2 training "
                         f"records (got {len(recs)})")
    lo, hi = getattr(model, "n_records", (1, None))
    can_split = cross_validate and len(recs) >= 2 and len(recs) - 1 >= lo and \
        (hi is None or len(recs) - 1 <= hi)
    if n_draws is None:
        n_draws = 0 if can_split else 2
    U = np.asarray(model.modes_, dtype=float)
    sig = _noise_std(model, recs, noise_std, U.shape[0])
    frozen = _frozen(model) if reuse_choices else {}
    noise_models = _noise_refits(model, recs, sig, n_draws, seed, U, frozen)
    if not cross_validate:
        return BandCalibration("noise", np.zeros(0), 0.0, np.ones(N_TIME_BINS), sig, 0,
                               len(noise_models), None, noise_models)
    source, residuals, envs, cv_modes, Whs, excursions, local = _residuals(
        model, recs, U, can_split, frozen)
    g = _time_profile(residuals, envs)
    rule, amps = levels(recs)
    cal = BandCalibration(source, np.zeros(0), 0.0, g, sig,
                          len(fold_groups(len(recs), lo)) if source == "cross-validation"
                          else 0,
                          len(noise_models), cv_modes, noise_models,
                          (min(amps), max(amps)), _sensor_rms(recs), level_rule=rule)
    if rule == "input":
        cal.level_reference = level_reference(model)
        cal.input_levels = tuple(amps)
        cal.input_energies = tuple(input_energy(r) for r in recs)
    if source == "cross-validation":
        lv = [load_levels(r) for r in recs] if rule == "response" else []
        cal.load_levels = tuple(lv) if lv and all(x is not None for x in lv) else ()
        _fold_estimate(cal, model, recs, U, residuals, Whs, excursions, local)
    else:
        _in_sample_scale(cal, residuals, envs)
    return cal


def _fold_estimate(cal: BandCalibration, model, recs, U, residuals, Whs, excursions,
                   local) -> None:
    """The target-aware estimate's constants, each fold's estimate and the band's
    normalized scores (docs/bands.md, *The estimate*): each fold's realized error and its
    :func:`~podbench.sysid.methods.band_target.fold_terms`, the :data:`ESTIMATE_RULE`'s
    constants from them (:func:`fold_rule` or :func:`fit_gains`), and every residual
    sample over the fold's difficulty — its
    estimate spread over the prediction's envelope."""
    U_cv = U if cal.cv_modes is None else U[:, :cal.cv_modes]
    cal.excitations = band_target.excitations(model, recs, U)
    # the folds' excitations are the model's own when the folds keep every mode
    terms = band_target.fold_terms(model, recs, U_cv, U,
                                   cal.excitations if cal.cv_modes is None else None,
                                   fold_of(fold_groups(len(recs), getattr(
                                       model, "n_records", (1, None))[0])))
    if terms is None:  # no excitation to compare: one number per model
        terms = [TargetTerms(0.0, 0.0, None)] * len(recs)
    errors = np.array([float(np.linalg.norm(R)) / max(float(np.linalg.norm(
        np.asarray(r.W, float)[:, :R.shape[1]])), 1e-300)
        for R, r in zip(residuals, recs, strict=True)])
    a = np.asarray(excursions, dtype=float)
    if cal.level_rule == "input":
        cal.level_power = fit_level_power(errors, terms, a)
    cal.fold_terms, cal.fold_errors = list(terms), errors
    _rule_constants(cal, errors, terms, a)
    scores = [(np.abs(R) / S).ravel() for R, S in
              zip(residuals, _fold_difficulties(Whs, cal, cal.fold_estimates, local),
                  strict=True)]
    cal.scores = np.concatenate(scores)
    cal.fold_sizes = tuple(int(x.size) for x in scores)
    cal.mean_square_score = float(np.mean(cal.scores ** 2))


def _in_sample_scale(cal: BandCalibration, residuals, envs) -> None:
    """One design only: the in-sample residuals in units of the envelope (the scale of the
    band's in-sample part and of its estimate)."""
    difficulty = [E * cal.time_profile[_bins(R.shape[1])][None, :]
                  for R, E in zip(residuals, envs, strict=True)]
    cal.scores = np.concatenate([(np.abs(R) / S).ravel()
                                 for R, S in zip(residuals, difficulty, strict=True)])
    cal.mean_square_score = _geometric_mean(np.array([
        np.sum(R ** 2) / np.sum(S ** 2) for R, S in zip(residuals, difficulty, strict=True)]))


def estimate(gains, terms: TargetTerms, factor: float = 1.0) -> float:
    """The predicted relative error ``sqrt(d²(κ_Λ²(Λ² + 1) + κ_Δ²Δ²) + ρ²)`` of a target
    (or a fold) with :class:`~podbench.sysid.methods.band_target.TargetTerms` ``terms``
    and amplitude factor ``d`` (docs/bands.md, *The estimate*)."""
    a, b = gains
    rho2 = (terms.rho or 0.0) ** 2
    return math.sqrt(factor ** 2 * (a * (terms.leverage2 + 1.0) + b * terms.blind2) + rho2)


FLOOR_SHARE = 0.01
"""A fold's error left after its projection share ρ is at least this share of its error²
(the gains are fitted on logarithms)."""
ESTIMATE_RULE = "gains"
"""How the folds' realized errors become a target's estimate (docs/bands.md, *The
estimate*): ``"gains"`` the two gains κ_Λ², κ_Δ² of :func:`fit_gains` fitted to the folds
of each model, the target's leverage and blind spot scaled by them; ``"folds"`` (a
variant) the median of the folds' errors inside the basis (each over its level factor),
times the target's blind spot against the folds' median blind spot to the power
:data:`BLIND_POWER`, times the target's level factor. The variant is better on the held-out
benchmark's random designs and much worse where a target's leverage exceeds every fold's
(Chapter 5's ML: it drops the leverage); ``"folds-leverage"`` (a variant) that rule times
the target's leverage beyond every fold's (:data:`LEVERAGE_POWER`); ``"choose"`` (a
variant) ``"gains"`` or ``"folds"`` per fitted model, whichever estimates its folds better
left out (:func:`rule_losses`); ``"folds-gains"`` (a variant) the ``"folds"`` rule for a
target whose leverage lies inside the folds' range (``Λ² + 1`` at most the folds' largest)
and the ``"gains"`` rule beyond it (:func:`rule_estimate`), or with
:data:`FOLDS_GAINS_GROWTH` the ``"folds"`` rule times the gains' growth beyond the range.
docs/bands.md has them all measured."""
FOLDS_GAINS_GROWTH = False
"""``"folds-gains"`` beyond the folds' leverage range: ``False`` the gains' estimate itself;
``True`` the folds' estimate times ``sqrt(G(Λ²)/G(L_max − 1))``, ``G`` the gains' part
``κ_Λ²(Λ² + 1) + κ_Δ²Δ²`` at the target's blind spot (continuous at the range's edge)."""
BLIND_POWER = 0.4
"""γ of the ``"folds"`` rule's blind-spot factor ``(Δ²/median_j Δ_j²)^γ``: chosen on the
held-out benchmark's dev set over 0–0.5 (docs/bands.md gives the verdicts over that range
on the dev and test sets)."""
RESPONSE_LEVEL_POWER = 0.0
"""β of the ``"folds"`` rule's level factor where the level is the prediction's RMS (records
without a measured input): off. A linear model's relative error does not depend on the
load's size, and a prediction's RMS above the training responses' says as much about the
load's position as about its size; on the held-out benchmark's dev set the factor a^β
with β = 0, 0.5, 1 gives 0.66, 0.61, 0.55 within a factor of 2 (0.63, 0.48, 0.33 on the
83 targets above the range; docs/bands.md). A measured input's level keeps its factor
(:func:`fit_level_power`)."""
GAINS_RESPONSE_LEVEL_POWER = 0.0
"""β of the ``"gains"`` rule's level factor where the level is the prediction's RMS (records
without a measured input; :data:`RESPONSE_LEVEL_POWER` is the other rules'): off. On the
held-out benchmark's dev set β = 0, 0.5, 1 give 0.60, 0.53, 0.47 within a factor of 2 (test:
0.77, 0.64, 0.60); a prediction larger than every training response is mostly a load
position, and dividing the folds' errors by their own factor lowers the gains for every
target (docs/bands.md). A measured input's level keeps its factor (:func:`fit_level_power`)."""
LEVERAGE_POWER = 0.25
"""p of the ``"folds-leverage"`` rule's factor ``max((Λ² + 1)/max_j(Λ_j² + 1), 1)^p``: a
target whose leverage exceeds every fold's is charged for it (an error of each training
record reaches the prediction multiplied by Λ, and no fold has shown that much). Chosen on
the held-out benchmark's dev set over 0.25–1 (docs/bands.md gives the verdicts)."""
BLIND_TINY = 1e-12
"""Added to both blind spots² of that ratio (a basis that holds every load: Δ² = 0)."""
GAINS_LEVERAGE_EXPONENTS = (1.0,)
"""The exponents γ of the ``"gains"`` rule's leverage term ``κ_Λ²(Λ² + 1)^γ`` the folds of
each model choose from, by the fit's logarithmic loss on its folds (:func:`_choose_exponent`;
ties keep the earlier). ``(1.0,)`` (the default): the term as an error of each training
record proportional to its response reaches the prediction (``Λ``, module
:mod:`~podbench.sysid.methods.band_target`). A variant ``(1.0, 0.75, 0.5)`` lets the folds
choose a slower growth (measured in docs/bands.md, not adopted)."""


def fold_rule(errors, terms, factors, leverage: bool = False):
    """``(scale, blind_ref, fold_estimates)`` of the ``"folds"`` rule: the median over the
    folds of ``y_j = sqrt(max(e_j² − ρ_j², FLOOR_SHARE e_j²))/d_j`` and of their blind
    spots Δ_j², and each fold's own estimate from the other folds alone (its score is then
    a prediction's score: the fold's error was not used to estimate it); ``leverage``: with
    the ``"folds-leverage"`` factor against the other folds' largest ``Λ² + 1``."""
    e = np.asarray(errors, dtype=float)
    rho2 = np.array([(t.rho or 0.0) ** 2 for t in terms])
    d = np.asarray(factors, dtype=float)
    y = np.sqrt(np.maximum(e ** 2 - rho2, FLOOR_SHARE * e ** 2)) / d
    b = np.array([t.blind2 for t in terms], dtype=float)
    ok = np.isfinite(y) & np.isfinite(b)
    if not np.any(ok):
        return math.nan, math.nan, np.full(e.size, math.nan)
    own = []
    for j in range(e.size):
        rest = ok & (np.arange(e.size) != j)
        if not np.any(rest):
            own.append(math.nan)
            continue
        ref = max(terms[i].leverage2 + 1.0 for i in np.flatnonzero(rest)) if leverage \
            else None
        own.append(folds_estimate(float(np.median(y[rest])), float(np.median(b[rest])),
                                  terms[j], d[j], ref))
    return float(np.median(y[ok])), float(np.median(b[ok])), np.array(own)


def folds_estimate(scale: float, blind_ref: float, terms: TargetTerms,
                   factor: float = 1.0, leverage_ref: float | None = None) -> float:
    """The ``"folds"`` rule's estimate ``sqrt((d·s·((Δ² + τ)/(Δ_ref² + τ))^γ·l)² + ρ²)``
    (τ = :data:`BLIND_TINY`, γ = :data:`BLIND_POWER`); ``l = max((Λ² + 1)/L_ref, 1)^p``
    (p = :data:`LEVERAGE_POWER`) given the folds' largest ``L_ref = Λ_j² + 1`` (the
    ``"folds-leverage"`` rule), else 1."""
    ratio = (terms.blind2 + BLIND_TINY) / (blind_ref + BLIND_TINY)
    inside = factor * scale * ratio ** BLIND_POWER
    if leverage_ref is not None and leverage_ref > 0:
        inside *= max((terms.leverage2 + 1.0) / leverage_ref, 1.0) ** LEVERAGE_POWER
    return math.sqrt(inside ** 2 + (terms.rho or 0.0) ** 2)


def _rule_constants(cal: BandCalibration, errors, terms, excursions) -> None:
    """The :data:`ESTIMATE_RULE`'s constants on ``cal`` from the folds' realized errors,
    terms and level excursions, and each fold's own estimate (``"gains"``: the two gains
    fitted to every fold; the ``"folds"`` rules: from the other folds only; ``"choose"``:
    of ``"gains"`` and ``"folds"`` the one whose leave-one-fold-out estimates explain the
    folds' errors with the smaller log loss, :func:`rule_losses`)."""
    rule = ESTIMATE_RULE
    a = np.asarray(excursions, dtype=float)
    cal.level_power = fit_level_power(errors, terms, a) if cal.level_rule == "input" \
        else GAINS_RESPONSE_LEVEL_POWER
    if rule == "choose":
        losses = rule_losses(errors, terms, a ** cal.level_power)
        rule = "gains" if losses["gains"] <= losses["folds"] else "folds"
    if rule != "gains" and cal.level_rule != "input":
        cal.level_power = RESPONSE_LEVEL_POWER
    d = a ** cal.level_power
    cal.fold_factors, cal.fold_excursions, cal.rule = d, a, rule
    if rule == "gains":
        if GAINS_LEVERAGE_EXPONENTS != (1.0,):
            terms, d = _choose_exponent(cal, errors, terms, a)
        cal.gains = fit_gains(errors, terms, d)
        cal.fold_estimates = np.array([estimate(cal.gains, t, f)
                                       for t, f in zip(terms, d, strict=True)])
        return
    lev = rule == "folds-leverage"
    cal.fold_scale, cal.fold_blind, cal.fold_estimates = fold_rule(errors, terms, d, lev)
    if lev or rule == "folds-gains":
        cal.fold_leverage = float(max(t.leverage2 for t in terms) + 1.0)
    if rule == "folds-gains":
        _beyond_folds(cal, errors, terms, a)


def with_exponent(terms: TargetTerms, gamma: float) -> TargetTerms:
    """``terms`` with the leverage's ``Λ² + 1`` raised to ``gamma`` (the ``"gains"`` rule's
    :data:`GAINS_LEVERAGE_EXPONENTS`); the terms themselves at ``gamma = 1``."""
    if gamma == 1.0:
        return terms
    return TargetTerms((terms.leverage2 + 1.0) ** gamma - 1.0, terms.blind2, terms.rho)


def _choose_exponent(cal: BandCalibration, errors, terms, excursions):
    """``(terms, factors)`` of the folds at the :data:`GAINS_LEVERAGE_EXPONENTS` value whose
    gains (:func:`_fit`, at the level power :func:`fit_level_power` gives them) explain the
    folds' errors with the least logarithmic loss; sets ``cal.leverage_exponent`` and
    ``cal.level_power``."""
    a = np.asarray(excursions, dtype=float)
    best = None
    for gamma in GAINS_LEVERAGE_EXPONENTS:
        t = [with_exponent(x, gamma) for x in terms]
        beta = fit_level_power(errors, t, a) if cal.level_rule == "input" else \
            cal.level_power
        loss = _fit(errors, t, a ** beta)[0]
        if best is None or loss < best[0] - 1e-12 * max(1.0, best[0]):
            best = (loss, gamma, beta, t)
    _, cal.leverage_exponent, cal.level_power, t = best
    d = a ** cal.level_power
    cal.fold_factors = d
    return t, d


def _beyond_folds(cal: BandCalibration, errors, terms, excursions) -> None:
    """The ``"folds-gains"`` rule's gains (fitted on every fold at the ``"gains"`` rule's
    level power), and each fold's own estimate: the ``"folds"`` rule's from the other folds
    where its leverage lies inside theirs, the gains' beyond (:func:`rule_estimate`)."""
    a = np.asarray(excursions, dtype=float)
    cal.gains_level_power = cal.level_power if cal.level_rule == "input" else \
        GAINS_RESPONSE_LEVEL_POWER
    d = a ** cal.gains_level_power
    cal.gains = fit_gains(errors, terms, d)
    L = np.array([t.leverage2 + 1.0 for t in terms])
    own = np.array(cal.fold_estimates, dtype=float)
    for j, t in enumerate(terms):
        rest = np.delete(L, j)
        if rest.size and L[j] > rest.max():
            own[j] = _gains_beyond(cal, t, a[j], float(rest.max()), own[j])
    cal.fold_estimates = own


def _gains_beyond(cal: BandCalibration, terms: TargetTerms, excursion: float,
                  leverage_ref: float, inside: float) -> float:
    """A ``"folds-gains"`` estimate beyond the folds' leverage range ``leverage_ref``: the
    gains' estimate, or (:data:`FOLDS_GAINS_GROWTH`) the folds' estimate ``inside`` times
    the gains' growth from the range's edge to the target's leverage."""
    d = excursion ** cal.gains_level_power
    if not FOLDS_GAINS_GROWTH:
        return estimate(cal.gains, terms, d)
    a, b = cal.gains
    grow = a * (terms.leverage2 + 1.0) + b * terms.blind2
    edge = a * leverage_ref + b * terms.blind2
    return inside * math.sqrt(grow / edge) if edge > 0 and grow > 0 else inside


def rule_estimate(cal: BandCalibration, terms: TargetTerms, excursion: float) -> float:
    """A target's estimate under the calibration's rule (:data:`ESTIMATE_RULE`) from its
    terms and its level excursion ``a`` (:func:`target_excursion`)."""
    d = excursion ** cal.level_power
    if cal.rule == "gains":
        return estimate(cal.gains, with_exponent(terms, cal.leverage_exponent), d)
    if cal.rule != "folds-gains":
        return folds_estimate(cal.fold_scale, cal.fold_blind, terms, d,
                              cal.fold_leverage if cal.rule == "folds-leverage" else None)
    inside = folds_estimate(cal.fold_scale, cal.fold_blind, terms, d)
    if cal.fold_leverage is not None and terms.leverage2 + 1.0 > cal.fold_leverage:
        return _gains_beyond(cal, terms, excursion, cal.fold_leverage, inside)
    return inside


def rule_losses(errors, terms, factors) -> dict:
    """``{"gains": loss, "folds": loss}``: the mean of ``(ln e_j − ln ê_j)²`` over the
    folds, each fold's estimate ``ê_j`` made without it (the gains refitted on the other
    folds; the ``"folds"`` rule's own estimates, :func:`fold_rule`). No truth: the folds'
    errors are known from the training records alone. ``"folds"`` uses no response level
    factor (:data:`RESPONSE_LEVEL_POWER`), so ``factors`` reach only the gains."""
    e = np.asarray(errors, dtype=float)
    d = np.asarray(factors, dtype=float)
    gains = []
    for j in range(e.size):
        rest = [i for i in range(e.size) if i != j]
        g = fit_gains(e[rest], [terms[i] for i in rest], d[rest]) if rest else (0.0, 0.0)
        gains.append(estimate(g, terms[j], d[j]))
    folds = fold_rule(e, terms, np.ones(e.size))[2]

    def loss(est) -> float:
        est = np.asarray(est, dtype=float)
        ok = np.isfinite(est) & (est > 0) & (e > 0)
        return float(np.mean((np.log(e[ok]) - np.log(est[ok])) ** 2)) if np.any(ok) \
            else math.inf

    return {"gains": loss(gains), "folds": loss(folds)}
GAIN_GRID = 41
"""Candidates of the blind-spot gain κ_Δ² (log-spaced over five decades, and 0)."""


def fit_level_power(errors, terms, excursions) -> float:
    """β of the input level's excursion ``d = a^β`` (:data:`LEVEL_RULE`): the
    :data:`LEVEL_POWERS` value whose :func:`fit_gains` explains the folds' errors with the
    least logarithmic loss, when at least two folds lie outside the others' level range
    (excursion above :data:`LEVEL_SPREAD`: a left-out lowest and highest level); else the
    smallest, :data:`AMPLITUDE_POWER`. Never below it: two or three folds cannot tell a
    structure whose error does not grow with the level from one whose error does, and a
    level outside the training range is an extrapolation of a model that the records show
    only inside it."""
    a = np.asarray(excursions, dtype=float)
    if np.count_nonzero(a > LEVEL_SPREAD) < 2:
        return AMPLITUDE_POWER
    best = None
    for beta in sorted({AMPLITUDE_POWER, *LEVEL_POWERS}):
        if beta < AMPLITUDE_POWER:
            continue
        loss = _fit(errors, terms, a ** beta)[0]
        if best is None or loss < best[0] - 1e-12 * max(1.0, best[0]):
            best = (loss, beta)
    return float(best[1])


def fit_gains(errors, terms, factors) -> tuple[float, float]:
    """``(κ_Λ², κ_Δ²)`` fitted to the folds' realized errors ``e_j`` in log space:
    ``Σ_j (ln y_j − ln(κ_Λ²(Λ_j² + 1) + κ_Δ²Δ_j²))²`` least, with
    ``y_j = (e_j² − ρ_j²)/d_j²`` (the share outside the basis is known, the amplitude
    factor stated). For each κ_Δ² on a grid (0, and five decades about the value that
    explains the folds by the blind spot alone) κ_Λ² is the geometric mean that the
    logarithmic fit gives; the pair of least loss is kept (deterministic: a grid, no
    optimizer). Where every fold's blind spot is 0 (the basis spans the loads' space, its
    computed value round-off:
    :func:`~podbench.sysid.methods.band_target.roundoff_floor`) the grid is {0}: κ_Δ² = 0
    and the estimate rests on the leverage alone, κ_Λ² the geometric mean of
    ``y_j/(Λ_j² + 1)`` over the folds."""
    return _fit(errors, terms, factors)[1:]


def fit_data(errors, terms, factors):
    """``(y, L, D, candidates)`` of the gains' fit, or None when no fold is usable: each
    fold's squared error less its projection share over its level factor ``y``, its
    ``Λ² + 1`` and ``Δ²``, and the grid of ``κ_Δ²`` (0 and :data:`GAIN_GRID` values over
    five decades about the value that explains the folds by the blind spot alone)."""
    e2 = np.asarray(errors, dtype=float) ** 2
    rho2 = np.array([(t.rho or 0.0) ** 2 for t in terms])
    y = np.maximum(e2 - rho2, FLOOR_SHARE * e2) / np.asarray(factors, float) ** 2
    L = np.array([t.leverage2 + 1.0 for t in terms])
    D = np.array([t.blind2 for t in terms])
    ok = np.isfinite(y) & (y > 0) & np.isfinite(L) & np.isfinite(D)
    if not np.any(ok):
        return None
    y, L, D = y[ok], L[ok], D[ok]
    cands = [0.0]
    if np.any(D > 0):
        base = float(np.median(y[D > 0] / D[D > 0]))
        cands += list(base * np.logspace(-4, 1, GAIN_GRID))
    return y, L, D, cands


def _fit(errors, terms, factors) -> tuple[float, float, float]:
    """``(loss, κ_Λ², κ_Δ²)`` of :func:`fit_gains`."""
    data = fit_data(errors, terms, factors)
    if data is None:
        return math.inf, 0.0, 0.0
    y, L, D, cands = data
    b = np.array(cands)[:, None]
    # every candidate at once, one row each (the rows reduce as the single vectors would)
    ratio = np.maximum(y - b * D, 1e-12 * y) / L
    a = np.exp(np.mean(np.log(ratio), axis=1)) if np.all(ratio > 0) else \
        np.array([_geometric_mean(r) for r in ratio])
    losses = np.sum((np.log(y) - np.log(a[:, None] * L + b * D)) ** 2, axis=1)
    best = None
    for loss, ai, bi in zip(losses.tolist(), a.tolist(), cands, strict=True):
        if best is None or loss < best[0] - 1e-12 * max(1.0, best[0]):
            best = (loss, ai, bi)
    return best


def _difficulty(Wh: np.ndarray, cal: BandCalibration, err: float, local=None) -> np.ndarray:
    """The band's difficulty of a prediction ``Ŵ`` whose relative error is estimated as
    ``err``: its envelope (floored by the training records' per-sensor RMS) times the time
    profile ``g``, scaled so that its Frobenius norm is the absolute error that ``err``
    means, ``‖Ŵ‖ err/sqrt(1 + err²)`` (the truth's norm is ``‖Ŵ‖/sqrt(1 + err²)`` for an
    error uncorrelated with it). ``local``: ``Ŵ``'s :func:`_local_rms` if computed."""
    E = _envelope(Wh, cal.reference_rms, local) * cal.time_profile[_bins(Wh.shape[1])][None, :]
    norm_e = float(np.linalg.norm(E))
    if not (math.isfinite(err) and norm_e > 0):
        return E
    scale = float(np.linalg.norm(Wh)) * err / math.sqrt(1.0 + err ** 2)
    tiny = 1e-12 * (float(np.sqrt(np.mean(Wh ** 2))) or 1.0)
    return np.maximum(E * (scale / norm_e), tiny)


def _fold_difficulties(Whs, cal: BandCalibration, errs, local) -> list[np.ndarray]:
    """:func:`_difficulty` of every fold's prediction, the elementwise work done once on
    their stack where they share a shape (each fold's norms and floors its own, so the same
    numbers as one by one)."""
    if len({Wh.shape for Wh in Whs}) != 1 or not local:
        local = local or [None] * len(Whs)
        return [_difficulty(Wh, cal, e, lr) for Wh, e, lr in zip(Whs, errs, local,
                                                                  strict=True)]
    W = np.stack(Whs)
    rms_i = np.sqrt(np.mean(W ** 2, axis=-1, keepdims=True))
    if cal.reference_rms is not None and TRAINING_FLOOR:
        rms_i = np.maximum(rms_i, np.asarray(cal.reference_rms, dtype=float)[..., None])
    tiny = np.array([1e-12 * (float(np.sqrt(np.mean(Wh ** 2))) or 1.0) for Wh in Whs])
    env = np.sqrt(np.stack(local) ** 2 + (FLOOR * rms_i) ** 2 + tiny[:, None, None] ** 2)
    E = env * cal.time_profile[_bins(W.shape[-1])][None, None, :]
    out = []
    for j, err in enumerate(errs):
        norm_e = float(np.linalg.norm(E[j]))
        if not (math.isfinite(err) and norm_e > 0):
            out.append(E[j])
            continue
        scale = float(np.linalg.norm(Whs[j])) * err / math.sqrt(1.0 + err ** 2)
        out.append(np.maximum(E[j] * (scale / norm_e), tiny[j]))
    return out


def _geometric_mean(ms: np.ndarray) -> float:
    return float(np.exp(np.mean(np.log(ms[ms > 0])))) if np.any(ms > 0) else 0.0


def _diagonal_part(model, record, Wh: np.ndarray, cal: BandCalibration):
    """``(s_diag, details, norm)``: the diagonal assumption's part of the band of a
    single-record method and the norm its error estimate is relative to; zeros, ``{}`` and
    ``‖Ŵ‖`` for every other method.

    :data:`DIAGONAL_RULE` ``"split"`` (:func:`diagonal_split`, through the method's
    ``diagonal_parts(record)``): ``s_diag² = env(Ŵ_⊥)² + env(T)²`` (local mean squares
    over the envelope's window) — the method's unexplained response and the bound on the
    structure's — and the truth's norm estimated by ``‖Ŵ − Ŵ_⊥‖² + ‖T‖²``.
    ``"tangent"`` (:func:`diagonal_inconsistency`): ``D`` spread over the prediction's
    envelope, ``‖s_diag‖_F = D·‖Ŵ‖_F``."""
    norm = float(np.linalg.norm(Wh))
    if cal.source != "in-sample" or not DIAGONAL_TERM:
        return np.zeros_like(Wh), {}, norm
    if DIAGONAL_RULE == "split":
        hook = getattr(model, "diagonal_parts", None)
        if not callable(hook):
            return np.zeros_like(Wh), {}, norm
        W_perp, T2 = hook(record)
        width = max(3, round(ENVELOPE_FRACTION * Wh.shape[1]))
        s2 = _moving_rms(W_perp, width) ** 2 + _moving_rms(np.sqrt(T2), width) ** 2
        ref = math.sqrt(float(np.sum((Wh - W_perp) ** 2)) + _unexplained_norm2(W_perp, T2))
        details = {"diagonal_unexplained": float(np.linalg.norm(W_perp)) / norm
                   if norm > 0 else math.inf,
                   "diagonal_bound": math.sqrt(float(np.sum(T2))) / norm if norm > 0
                   else math.inf}
        return np.sqrt(s2), details, ref if ref > 0 else norm
    hook = getattr(model, "diagonal_inconsistency", None)
    if not callable(hook):
        return np.zeros_like(Wh), {}, norm
    D = float(hook(record))
    env = _envelope(Wh)
    ratio = norm / float(np.linalg.norm(env))
    return D * env * ratio, {"diagonal_inconsistency": D}, norm


DIAGONAL_NORM = "bracket"
"""How a single-record diagonal method's error estimate reads the norm of the structure's
unknown response ``W_⊥`` to the target's unexplained excitation (docs/bands.md, *One design
only*): ``"bracket"`` the geometric mean of its two readings, the method's own ``‖Ŵ_⊥‖``
(exact when the POMs are uncoupled modes, the diagonal assumption) and the training
pattern's gain ``‖T‖`` (exact when the structure's gain is the same in every direction);
``"pattern"`` ``‖T‖`` alone (the former rule: far too small when the training load excites
only stiff directions, e.g. a load near a clamp, and then the relative estimate explodes)."""


def _unexplained_norm2(W_perp: np.ndarray, T2: np.ndarray) -> float:
    """``‖W_⊥‖²`` as :data:`DIAGONAL_NORM` reads it."""
    t2 = float(np.sum(T2))
    if DIAGONAL_NORM == "pattern":
        return t2
    return math.sqrt(float(np.sum(W_perp ** 2)) * t2)


def predict_band(model, record, coverage: float, cal: BandCalibration,
                 mean: np.ndarray) -> Prediction:
    """The band of ``model``'s prediction ``mean`` for ``record`` at ``coverage``."""
    c = check_coverage(coverage)
    Wh = np.asarray(mean, dtype=float)
    n = Wh.shape[1]
    var_noise = np.zeros_like(Wh)
    if cal.noise_models:
        devs = np.stack([np.asarray(e.predict(record), dtype=float) - Wh
                         for e in cal.noise_models])
        # moving RMS over time smooths the few draws' spread
        var_noise = _moving_rms(np.sqrt(np.mean(devs ** 2, axis=0)),
                                max(3, round(ENVELOPE_FRACTION * n))) ** 2
    z = NormalDist().inv_cdf(0.5 + c / 2)
    details = {"n_folds": cal.n_folds, "n_draws": cal.n_draws,
               "n_scores": int(cal.scores.size),
               "noise_std_max": float(np.max(cal.noise_std)) if cal.noise_std is not None
               else 0.0}
    if cal.cv_modes is not None:
        details["cv_modes"] = cal.cv_modes
    if cal.source == "cross-validation":
        err, s_model, q, terms, a = _cross_validated(model, record, Wh, cal, c)
        details.update(conformal_quantile=q, leverage=math.sqrt(terms.leverage2),
                       blind_spot=math.sqrt(terms.blind2), level_excursion=a,
                       level_power=cal.level_power, level_rule=cal.level_rule,
                       estimate_rule=cal.rule)
        if terms.rho is not None:
            details["projection_share"] = terms.rho
        half = np.sqrt((q * s_model) ** 2 + z ** 2 * var_noise)
        note = load_note(record, cal)
    else:
        err, half, note, more = _one_design(model, record, Wh, cal, c, z, var_noise)
        details.update(more)
    return Prediction(mean=Wh, lower=Wh - half, upper=Wh + half, coverage=c,
                      error_estimate=err, dt=getattr(model, "dt_", None) or
                      getattr(record, "dt", None), source=cal.source, details=details,
                      note=note)


def _cross_validated(model, record, Wh, cal: BandCalibration, c: float):
    """``(estimate, difficulty, conformal quantile, terms, level excursion)`` of a
    cross-validated band."""
    U = np.asarray(model.modes_, dtype=float)
    terms = band_target.target_terms(model, cal.excitations, record, U)
    if terms is None:
        terms = TargetTerms(0.0, 0.0, None)
    a = target_excursion(record, Wh, cal)
    err = rule_estimate(cal, terms, a)
    return err, _difficulty(Wh, cal, err), cal.quantile(c), terms, a


def target_excursion(record, Wh, cal: BandCalibration) -> float:
    """How far a target lies from the training records' levels (:func:`levels`): its
    measured input's RMS against their effective level, both ways
    (:func:`input_excursion`), or its prediction's RMS above their range."""
    if cal.level_rule == "input":
        level = input_level(record)
        if level is not None:
            return input_excursion(level, cal.input_levels or cal.amplitude_range,
                                   cal.input_energies or (1.0, 1.0), cal.level_reference)
    return extrapolation(_rms(Wh), *cal.amplitude_range)


def _one_design(model, record, Wh, cal: BandCalibration, c: float, z: float, var_noise):
    """``(estimate, half-width, note, details)`` of a band fitted on one design only (no
    split): the in-sample residual's part, the noise part and, for SL and POVR, the
    diagonal assumption's split; no estimate (NaN and a note) for a method that has no
    model-form term (MR)."""
    s_model = np.zeros_like(Wh)
    q = 0.0
    if cal.source == "in-sample":
        s_model = _envelope(Wh) * cal.time_profile[_bins(Wh.shape[1])][None, :]
        q = cal.quantile(c)
    s_diag, details, norm = _diagonal_part(model, record, Wh, cal)
    half = np.sqrt((z ** 2) * (var_noise + s_diag ** 2) + (q * s_model) ** 2)
    details["conformal_quantile"] = q
    if cal.source == "in-sample" and "diagonal_unexplained" not in details and \
            "diagonal_inconsistency" not in details:
        note = (f"no error estimate: {type(model).__name__} was fitted on one design "
                f"({len(getattr(model, 'training_records_', None) or ())} records, none of "
                "which can be left out) and its in-sample residual does not show the "
                "model-form error; the band holds the noise and the in-sample residual only")
        return math.nan, half, note, details
    pred_sq = float(np.sum(cal.mean_square_score * s_model ** 2 + var_noise + s_diag ** 2))
    err = math.sqrt(pred_sq) / norm if norm > 0 else math.inf
    return err, half, "", details
