"""Prediction bands and error estimates: every prediction states its own error (issue 21).

``model.predict(target, coverage=0.9)`` returns a :class:`Prediction` (``mean``, ``lower``,
``upper``, ``error_estimate``, ``to_pandas()``); ``model.predict(target)`` still returns the
array. The band is built from the training records only (no truth), from two sources:

1. **Identification uncertainty** (measurement noise through the deconvolution). The noise
   of each sensor channel is estimated from the training records — the part of every
   record outside the fitted basis, ``(I − UUᵀ)W``, holds ``(m − k)/m`` of white per-channel
   noise (and the projection error, so the estimate errs high) — or given (``noise_std``).
   It is propagated by refitting the method on the training records with fresh noise of that
   level (``n_draws`` Monte-Carlo refits in the fitted basis; by default only where the
   records allow no split — with cross-validation the noise reaches the band through the
   folds, which are fitted on noisy records and scored against a noisy one); the spread of
   the target's prediction over the draws is ``s_noise(i, t)`` (a moving RMS over time
   smooths the few draws). Under Gaussian noise and a linear fit this part alone is exact:
   ``half-width = z_{(1+c)/2} · s_noise``.
2. **Model-form error** (projection, diagonalization, linearization, time variance) by
   cross-validation over the training records: each training record is predicted by a
   model fitted to the others in the fitted basis ``U`` (leave one record out; the basis
   stays that of the whole fit, so the folds differ from the model only in the dynamics
   they identify; a method whose ``k`` is bounded by the number of records refits in the
   first ``N − 1`` columns of ``U``: see below). Each
   residual ``R_j(i, t)`` is normalized by a difficulty ``s(i, t)`` computed from the
   *prediction only* — its local RMS envelope at that sensor times a time profile ``g(t)``
   (10 bins, learned from the folds' residuals: phase errors grow with time) — and the
   conformal quantile ``q`` of the pooled normalized residuals at the level ``c`` (with the
   ``(n + 1)`` correction of split-conformal regression, as crepes' normalized
   ``ConformalRegressor`` computes it) scales the target's band:
   ``half-width = q · s(i, t)``.

The two half-widths add in quadrature. **Exchangeability.** Samples of one time history are
not exchangeable (neighbouring samples share their error), so no per-sample guarantee is
claimed. The unit that is argued exchangeable is the *record*: training load cases and the
target are draws of one test design (load position, shape, initial profile); the coverage
podbench scores is the fraction of a target's samples inside the band, and the pooled
quantile estimates the quantile of that fraction's distribution over records. With N
records the guarantee is at the record level only, and weak (N = 3…6); it is measured, not
assumed (the calibration study). Where a method takes one design only (POVR, SL: one
record; MR: exactly three) there is no split: the model-form part then rests on the
training record's in-sample residual (its projection error) alone, which cannot see the
diagonal assumption's error (SL and POVR add its split, *One design only* below) —
such bands are reported with their calibration and ``Prediction.source`` says
``"in-sample"``.

The error estimate (the predicted ``total_error`` ‖Ŵ − W‖_F/‖W‖_F) is the RMS of the band's
predicted residual, ``sqrt(Σ (μ·s² + s_noise²)) / ‖Ŵ‖_F`` (SL, POVR: plus the
diagonal part, over the truth's norm its split supports: below; MDS and POVR on an initial
displacement: the part inside the basis plus the target's own share outside it, *The
target's own projection share* below), with ``μ`` the geometric mean over
the folds of ``‖R_j‖²_F / ‖s_j‖²_F`` (each fold's Frobenius error in units of its
difficulty, so the estimate measures what ``total_error`` measures): relative errors differ
by orders of magnitude between records (a load near the clamp barely moves the beam and its
relative projection error is ten times the others'), and an estimate scored within a factor
of 2 is a log-scale estimate, for which the geometric mean is the central value. The band
keeps the pooled quantile (its coverage is a fraction of samples over all folds).

**Cost** (``python benchmarks/bands.py``, issue 21: at most 5× the plain fit and
predict). A method may give its folds without refits, ``fold_predictions(records, basis,
frozen)`` (the same predictions as the refits, to round-off; tested): MDS's fold
prediction is linear in the other records' projections (``U Σ_l c_l Uᵀ ˡW``, ``c`` from
the fold's ``V̂0``), ML's folds are deconvolved together (``Solver.solve_many``; ``"block"``:
one batched forward substitution). The band's arithmetic runs on the stacked folds (one
envelope pass, the moving RMS by slices of a cumulative sum, the conformal quantile by
selection). Measured (a machine at load 13–17 on 2 cores; sub-millisecond ratios vary up
to 2× between runs): MDS5 12–49× → 4.9–6.0×, ML4-block 5–7× → 2.5–4.7×, POVR 6–7.3× →
5.4–7.6× (its 0.4-ms fit against two noise refits and the diagonal split: over target);
clean / 1 % noise: ML6-cgls 2.6 / 3.5×, ML6-fft 4.1 / 3.8×, ML4-cgls 1.5 / 1.6×, SL
2.6 / 2.9×, FIR-LS 3.6 / 3.9×, ML-TC 2.2 / 2.2×.

**The target's own projection share** (:data:`PROJECTION_SHARE`). A free-response
method on an initial displacement (MDS, POVR) knows the target's ``w̃0`` and predicts in
the span of ``U``: its relative error at ``t = 0`` is exactly ``ρ = ‖(I − UUᵀ)w̃0‖/‖w̃0‖``
(``projection_share``), measurable before the truth is known, and on the free beams the
whole history's error follows it (MDS5 on the LTI beam: realized 0.042 / 0.0007 / 0.0035
/ 0.0022 / 0.0060 / 0.0007 against ρ = 0.043 / 0.0007 / 0.0033 / 0.0019 / 0.0061 /
0.0008). The estimate of such a target is ``sqrt(e_in² + ρ²)``: the identification's
error inside the basis (the same scale rule on the residuals' part ``U Uᵀ R_j``) plus the
target's own share outside it, instead of the training records' projection error; the
band is unchanged. Measured on results/calibration (before → after; no constant; found on
the LTI beam, checked on the others): within ×2 0.328 → 0.361, Spearman 0.861 → 0.871;
cross-validated within ×2 0.352 → 0.402, Spearman 0.778 → 0.809 (median
estimate/realized 2.11 → 1.91); free beams within ×2 0.438 → 0.519 (LTV MDS5 0.22 → 0.50,
Spearman 0.47 → 0.75; NL unchanged); coverage identical. On the 5-DOF chain (k = 3 of 5)
MDS's estimate 0.837 → 0.326 against a realized 0.310.

**What limits the estimate's accuracy** (measured on results/calibration's 402
predictions, log₂ of estimate/realized). The estimate is the expected error (the RMS of
the band's predicted residual), not a quantile. Its misses are mostly *within* a fitted
model: the study fits 60 models (method × structure class × noise level), each predicting
4–8 targets, and an oracle constant per fitted model, chosen on the truth, puts 0.79 of
the estimates within ×2 (0.774 before the projection share; one constant for all 0.44,
per method 0.60). Any correction that is one number per fitted model — a rescaling, a
leave-one-out fold-size correction derived from the folds, a mean of the folds instead of
their geometric mean — is at most that oracle, so none reaches "within ×2 for 80 %":

* cross-validated estimates are nearly one number per model: across a model's targets
  log₂(estimate) has a standard deviation of 0.43 (median over models) against 1.54 for
  the realized error, within-model Spearman 0.53 (0.25 before the projection share;
  oracle per model 0.74): the difficulty ``s`` follows the prediction's own envelope, so
  ``‖s‖/‖Ŵ‖`` hardly depends on the target; for forced targets nothing like ``ρ`` is
  known (the response starts at rest), and the folds cannot tell how far a target lies
  from the training design;
* the one-design split (SL, POVR) ranks a model's targets (within-model Spearman 0.98,
  oracle per model 0.89) but its level is off (SL ×7.8 high on the beams, where the
  realized ``‖W_⊥‖`` is 5–16× the training pattern's gain ``‖T‖``).

A per-(method, class) shift tuned at 0 % noise and checked at 1 and 5 % reaches 0.64 of
the former estimates within ×2 (unshifted 0.33) — a constant fitted on the truth, so not
adopted.

**Regularization of the refits.** Every refit (fold or noise draw) runs at the full fit's
data-driven choices (:meth:`~podbench.sysid.methods.base.PODMethod.frozen_params`: the GCV
``reg`` of ``"cgls"``/``"fft"``/``"stls"``, a realization's hold-out order, ERA's order,
OpInf's regularizer, the FIR lags and TC prior of the IO methods) instead of choosing them
again from its own records. The folds then measure the model-form error *at the full fit's
regularization*, which is the regularization of the model whose prediction the band is
for; re-choosing would add the variability of the choice (a different λ per fold) to the
band, and its search is most of the cost (ML6 with ``"cgls"``: the band cost 6.4× the plain
fit and predict with a GCV search per fold, 2.5× without; ``benchmarks/bands.py``). Bias:
the full fit's λ was chosen with the held-out record among the data (a mild leak, which
makes a fold's error optimistic), while a fold has fewer records at the same λ than the
choice was made for (its system is less determined: pessimistic). Measured on the
calibration study (before the amplitude factor below): class coverage moves by at most a
few points on the beams, both ways (ML NL 0.82 → 0.82, ML4 LTI 0.95 → 0.93); on the truss a
fold whose own GCV λ collapsed (2e-4 instead of 0.135: error 176× its response) now
predicts at the full λ (error 0.99), i.e. almost nothing, and its residual in units of its
own envelope dominated the pooled quantile (ML7: coverage 0.89 → 0.99, interval score 19×
the constant band's) until the envelope's floor below was tied to the training
amplitudes. ``reuse_choices=False`` (:func:`calibrate`) re-chooses in every refit.

**Amplitude extrapolation.** A fold (or target) whose prediction is larger than every
record its model was fitted on is not exchangeable with the others: the linearization error
of a nonlinear structure grows with amplitude. Its difficulty is multiplied by ``d^β``
(:func:`extrapolation`, ``d = max(a/a_max, 1)``, ``a`` the RMS of the prediction — what the
method sees — and ``a_max`` the largest RMS of its training records; β =
:data:`AMPLITUDE_POWER` = 1, stated, not fitted: with N = 4…7 folds and one of them beyond
the range a fitted β is one point's slope), in the folds' scores and in the target's band.
The envelope's floor is also taken relative to the training records' per-sensor RMS
(:data:`TRAINING_FLOOR`), so that a fold predicting almost nothing gets a band on the scale
of what its model was fitted on. Measured on the calibration study (reuse on; class means
of ML): LTI 0.95 → 0.94, LTV 0.91 → 0.95, NL 0.82 → 0.82, truss 0.99 → 0.99 with its
interval score 19 → 1.8× the constant band's; Spearman over the cross-validated
predictions 0.751 → 0.778. Counting a prediction *below* the range as extrapolated too
(:data:`EXTRAPOLATE_BELOW`) was measured and is off: the fold of the load nearest the clamp
(a response 10× smaller, ten times the others' relative projection error — a position
effect) is then charged to amplitude, its scores are divided by ``d`` ≈ 7–9 and the pooled
quantile drops (ML NL 0.79). The NL misses are targets beyond the training amplitudes
(ML6's 2-ms pulse: 2.2× the largest training tip amplitude, realized error 1.27 against an
estimate of 0.05) whose error grows much faster than ``d`` (a cubic spring): the factor
does not reach them, and nothing the records show tells how fast it grows. Measured
(ML4 and ML6 on the NL beam, results/calibration): the training records are one load
(500 lbf, 0.5 ms) at several positions, so their amplitudes differ by position only, and
the one fold beyond the others' range (22 in, ``d`` = 1.3) has 3–9× the error of the
folds inside — on the *linear* beam too (0.0041 against 0.0011–0.0013: a position
effect, the load nearest the free end), so a slope fitted to the folds (β ≈ 4 on the LTI
beam) measures position, not nonlinearity. Of the misses two lie *inside* the training
RMS range (the 200-lbf pulse at 13 in: ``a/a_max`` = 0.19, realized 0.10, coverage
0.57–0.76; the 1.5-ms half-sine: 0.51, 0.09, 0.71–0.84): the nonlinearity shows in the
load's amplitude and shape at one position, which the design never varies, and no factor
of the prediction's RMS can see it. ML's NL coverage over the targets of the training
load's amplitude and shape is 0.92 / 0.89 / 0.96 (0 / 1 / 5 % noise), over the other
three 0.61 / 0.52 / 0.82; β stays 1.

**One design only (SL, POVR): the diagonal assumption.** One record cannot cross-validate,
and its in-sample residual cannot see the diagonal assumption's error (SL: estimate 0.047
against a realized 2.1). SL and POVR scale each mode's training response by
``s_i = q'_i/u_i`` (Chapter 3: SL's ``ṽ_i = c_ii * q̃_i`` with ``c_ii`` deconvolved from the
training mode's response to ``u_i``, Eqs. 3.43–3.44; POVR's ``σ̃_i = σ_i q'_i/u_i``,
Eq. 3.24; ``u`` the training record's modal excitation, ``q'`` the target's). Their
prediction is linear in ``q'``, and the scaling is *exact* on the part of the target with
the training pattern, ``q'_∥ = â âᵀq'`` (``â = u/‖u‖``): there every mode sees the same
scale and the method returns the training response itself, scaled — the linear
structure's own (``c_ii u_i = Σ_l c_il u_l`` is what the deconvolution identifies). Hence,
for a linear structure and a training load of one spatial pattern, the prediction's error
is exactly ``Ŵ − W = Ŵ_⊥ − W_⊥`` (:func:`diagonal_split`; tested to round-off on the
coupled chain): the method's response to the rest ``q'_⊥ = q' − q'_∥`` (known) minus the
structure's (unknown: the record never saw that excitation). ``W_⊥`` is bounded by what
the record determines, the response to each mode's unexplained excitation applied in the
training pattern, ``T² = Σ_i respond(â q'_⊥,i)²`` (the structure's gain along the one
direction the record shows). The band's model-form part is then ``s_diag² = env(Ŵ_⊥)² +
env(T)²`` (``env``: the local mean square over the envelope's window; half-width
``z·s_diag``, the two unknown-signed parts added in quadrature, Gaussian reading), and
the error estimate is relative to the truth's norm the split supports,
``‖W‖² ≈ ‖Ŵ − Ŵ_⊥‖² + ‖T‖²``, instead of ``‖Ŵ‖`` (a prediction that is mostly artefact
is measured against what the record says the truth is). Nothing in it divides by ``u_i``:
a mode the training load barely excites inflates ``Ŵ_⊥`` exactly as much as it inflates
the prediction, so the band is bounded by the prediction's own unexplained part.

The former rule (:data:`DIAGONAL_RULE` ``"tangent"``, :func:`diagonal_inconsistency`:
the spread ``D`` of the ``s_i``, the tangent of the angle between ``q'`` and ``u``, spread
over the prediction as ``‖s_diag‖_F = D‖Ŵ‖_F``) divides by ``cos`` of that angle: on the
truss's face-10 double hit ``D`` = 5910 / 161 / 6.5 at 0 / 1 / 5 % training noise against
a realized 49, and the study's interval score was 50× the constant band's. Measured on
the calibration study (results/calibration, ``"tangent"`` → ``"split"``): interval score
over all 402 predictions 50 → 0.31 × the best constant band's (beams alone 0.77 → 0.54;
SL 56 → 0.20, POVR 0.84 → 0.91); the double hit's estimate 5910 / 161 / 6.5 → 31 / 31 /
28 (realized 49 / 49 / 47), coverage 1.0 → 0.99; Spearman(error_estimate, total_error)
0.857 → 0.861; within a factor of 2 0.38 → 0.33: ``T`` is the gain along the training
pattern only, and on the beams the target's unexplained excitation falls on modes of
larger gain (``‖W_⊥‖`` is 5–16× ``‖T‖``), so SL's estimates there err high (median
estimate/realized 1.7 → 7.8) while the truss's come within ×2 (0.25 → 1.0). Coverage: SL
LTI 1.0 → 1.0, LTV 0.83 → 0.78, NL 1.0 → 0.97, truss 0.99 → 0.99; POVR LTI 0.99 → 1.0,
LTV 0.79 → 0.94, NL 0.57 → 0.70. :data:`DIAGONAL_TERM` switches the term off.

With as many records as modes (MDS, ML on Chapter 4's designs) a fold refits in the first
``N − 1`` columns of ``U``; its residual is taken as the fold's error inside those modes plus
the whole basis's projection error ``(I − UUᵀ)W_j`` (not the error of the missing mode,
which the fitted model does identify).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

from podbench.core.records import as_record
from podbench.errors import InputError

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
(:func:`extrapolation`); 0 switches it off."""


def _rms(X) -> float:
    return float(np.sqrt(np.mean(np.asarray(X, dtype=float) ** 2)))


def extrapolation(amplitude: float, lo: float, hi: float) -> float:
    """How far a prediction of RMS ``amplitude`` lies beyond the RMS range ``[lo, hi]`` of
    the records the model was fitted on: ``max(amplitude/hi, 1)`` (and ``lo/amplitude``
    below the range when :data:`EXTRAPOLATE_BELOW`)."""
    if not amplitude > 0 or not hi > 0:
        return 1.0
    below = lo / amplitude if EXTRAPOLATE_BELOW else 1.0
    return float(max(amplitude / hi, below, 1.0))


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
        raise InputError(f"Parameter `coverage`: must be in (0, 1), got {coverage!r}")
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
        Scalars of the calibration (conformal quantile, folds, noise level, …).
    """

    mean: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    coverage: float
    error_estimate: float
    dt: float | None = None
    source: str = ""
    details: dict = field(default_factory=dict)

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


def _envelope(W_hat: np.ndarray, reference=None) -> np.ndarray:
    """Local RMS envelope of a prediction at each sensor, with a floor (FLOOR × the larger
    of the sensor's overall RMS in the prediction and, given, in the training records
    ``reference`` (m,): a prediction of almost nothing still gets a band on the scale of
    what the model was fitted on; and 1e-12 × the whole prediction's RMS)."""
    n = W_hat.shape[-1]
    env = _moving_rms(W_hat, max(3, round(ENVELOPE_FRACTION * n)))
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
    amplitude_range: tuple = (0.0, 0.0)  # RMS range of the training records' W
    reference_rms: np.ndarray | None = None  # per-sensor RMS of the training records' W
    inside_score: float | None = None  # mean_square_score of the residuals inside the basis

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


def _fold_predictions(model, recs, U_cv, cv_modes, frozen) -> list[np.ndarray]:
    """Each training record predicted by the model refitted in ``U_cv`` to the others:
    the method's own ``fold_predictions`` where it has one (the same predictions without
    the refits: MDS's folds are linear in the other records' projections, ML's
    deconvolutions are solved together), else one refit per fold."""
    hook = getattr(model, "fold_predictions", None)
    if callable(hook):
        out = hook(recs, U_cv, frozen)
        if out is not None:
            return out
    return [np.asarray(_refit(model, recs[:j] + recs[j + 1:], n_modes=cv_modes, basis=U_cv,
                              frozen=frozen).predict(recs[j]), dtype=float)
            for j in range(len(recs))]


def _fold_envelopes(Whs, recs) -> list[np.ndarray]:
    """Each fold's difficulty: the envelope of its prediction, floored by the per-sensor
    RMS of the records it was fitted on, times its amplitude-extrapolation factor
    (computed for all folds at once where the predictions share a shape)."""
    N = len(recs)
    ms = [np.mean(np.asarray(r.W, float) ** 2, axis=1) for r in recs]
    amps = [_rms(r.W) for r in recs]
    refs, factors = [], []
    for j, Wh in enumerate(Whs):
        rest = [ms[l] for l in range(N) if l != j]
        rest_rms = [amps[l] for l in range(N) if l != j]
        refs.append(np.sqrt(np.mean(rest, axis=0)))
        factors.append(extrapolation(_rms(Wh), min(rest_rms), max(rest_rms))
                       ** AMPLITUDE_POWER)
    if len({Wh.shape for Wh in Whs}) == 1:
        return list(_envelope(np.stack(Whs), np.stack(refs))
                    * np.asarray(factors)[:, None, None])
    return [_envelope(Wh, ref) * f for Wh, ref, f in zip(Whs, refs, factors, strict=True)]


def _residuals(model, recs, U, can_split: bool, frozen=None):
    """``(source, residuals, envelopes, cv_modes)``: leave-one-record-out residuals where the
    records allow a split, else the in-sample residuals."""
    residuals, envs = [], []
    source = "in-sample"
    cv_modes = None
    if can_split:
        source = "cross-validation"
        k = int(U.shape[1])
        if getattr(model, "records_per_mode", False) and k > len(recs) - 1:
            cv_modes = len(recs) - 1
        U_cv = U if cv_modes is None else U[:, :cv_modes]
        Whs = _fold_predictions(model, recs, U_cv, cv_modes, frozen)
        envs = _fold_envelopes(Whs, recs)
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
    return source, residuals, envs, cv_modes


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
    """Calibrate the band of a fitted ``model`` on its training ``records`` (see the module
    docstring). ``noise_std``: per-channel noise std of the training records (scalar or
    (m,)), default estimated; ``n_draws`` noise refits (default: 2 where the records allow
    no split, 0 where they are cross-validated — each fold is then fitted on noisy records
    and scored against a noisy one, so the noise reaches the band through the folds, at
    the cost of no extra refit); ``cross_validate=False`` gives the noise part alone (the
    known-answer case); ``reuse_choices=False`` lets every refit choose its regularization
    again (see the module docstring, *Regularization of the refits*)."""
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
    m = np.asarray(model.modes_).shape[0]
    U = np.asarray(model.modes_, dtype=float)
    sig = _noise_std(model, recs, noise_std, m)
    frozen = _frozen(model) if reuse_choices else {}
    noise_models = _noise_refits(model, recs, sig, n_draws, seed, U, frozen)
    if not cross_validate:
        return BandCalibration("noise", np.zeros(0), 0.0, np.ones(N_TIME_BINS), sig, 0,
                               len(noise_models), None, noise_models)
    source, residuals, envs, cv_modes = _residuals(model, recs, U, can_split, frozen)
    g = _time_profile(residuals, envs)
    difficulty = [E * g[_bins(R.shape[1])][None, :] for R, E in zip(residuals, envs,
                                                                   strict=True)]
    scores = np.concatenate([(np.abs(R) / S).ravel()
                             for R, S in zip(residuals, difficulty, strict=True)])
    # the error estimate's scale: per fold, κ_j² = ‖R_j‖²/‖s_j‖² (the fold's Frobenius
    # error in units of its difficulty, so that the estimate is the same quantity as
    # total_error); the geometric mean over folds (relative errors differ by orders of
    # magnitude between records — a load near the clamp — and the estimate is scored on a
    # log scale: within a factor of 2)
    ms = np.array([np.sum(R ** 2) / np.sum(S ** 2)
                   for R, S in zip(residuals, difficulty, strict=True)])
    ms_gm = _geometric_mean(ms)
    inside = None
    if PROJECTION_SHARE and callable(getattr(model, "projection_share", None)):
        # the same scale from the residuals' part inside the basis (U Uᵀ R_j): the error the
        # identification adds; the target's own share outside the basis is added per target
        inside = _geometric_mean(np.array([np.sum((U @ (U.T @ R)) ** 2) / np.sum(S ** 2)
                                           for R, S in zip(residuals, difficulty,
                                                           strict=True)]))
    amps = [_rms(r.W) for r in recs]
    return BandCalibration(source, scores, ms_gm, g, sig,
                           len(residuals) if source == "cross-validation" else 0,
                           len(noise_models), cv_modes, noise_models,
                           (min(amps), max(amps)), _sensor_rms(recs), inside)


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
        ref = math.sqrt(float(np.sum((Wh - W_perp) ** 2)) + float(np.sum(T2)))
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


def predict_band(model, record, coverage: float, cal: BandCalibration,
                 mean: np.ndarray) -> Prediction:
    """The band of ``model``'s prediction ``mean`` for ``record`` at ``coverage``."""
    c = check_coverage(coverage)
    Wh = np.asarray(mean, dtype=float)
    m, n = Wh.shape
    var_noise = np.zeros_like(Wh)
    if cal.noise_models:
        devs = np.stack([np.asarray(e.predict(record), dtype=float) - Wh
                         for e in cal.noise_models])
        # moving RMS over time smooths the few draws' spread
        var_noise = _moving_rms(np.sqrt(np.mean(devs ** 2, axis=0)),
                                max(3, round(ENVELOPE_FRACTION * n))) ** 2
    z = NormalDist().inv_cdf(0.5 + c / 2)
    if cal.source == "noise":
        s_model = np.zeros_like(Wh)
        q = 0.0
    else:
        bins = _bins(n)
        d = extrapolation(_rms(Wh), *cal.amplitude_range) if cal.source == \
            "cross-validation" else 1.0
        ref = cal.reference_rms if cal.source == "cross-validation" else None
        s_model = _envelope(Wh, ref) * cal.time_profile[bins][None, :] * d ** AMPLITUDE_POWER
        q = cal.quantile(c)
    s_diag, diag_details, norm = _diagonal_part(model, record, Wh, cal)
    half = np.sqrt((z ** 2) * (var_noise + s_diag ** 2) + (q * s_model) ** 2)
    share = getattr(model, "projection_share", None)
    rho = share(record) if cal.inside_score is not None and callable(share) else None
    if rho is None:
        pred_sq = float(np.sum(cal.mean_square_score * s_model ** 2 + var_noise
                               + s_diag ** 2))
        err = math.sqrt(pred_sq) / norm if norm > 0 else math.inf
    else:  # the identification's error inside the basis, and the target's own outside it
        pred_sq = float(np.sum(cal.inside_score * s_model ** 2 + var_noise + s_diag ** 2))
        err = math.sqrt(pred_sq / norm ** 2 + rho ** 2) if norm > 0 else math.inf
    details = {"conformal_quantile": q, "n_folds": cal.n_folds, "n_draws": cal.n_draws,
               "n_scores": int(cal.scores.size),
               "noise_std_max": float(np.max(cal.noise_std)) if cal.noise_std is not None
               else 0.0}
    if cal.cv_modes is not None:
        details["cv_modes"] = cal.cv_modes
    details.update(diag_details)
    return Prediction(mean=Wh, lower=Wh - half, upper=Wh + half, coverage=c,
                      error_estimate=err, dt=getattr(model, "dt_", None) or
                      getattr(record, "dt", None), source=cal.source, details=details)
