"""The digits podbench's tables write for fit diagnostics: those whose last digits move between
BLAS kernels are rounded where they are recorded, so that a table regenerates byte-identically
on any CPU.

:func:`row_writer` says how the rows of one fit are written: ERA's at :data:`FLOOR_DIGITS`;
an iterative solver's at the digits its stopping tolerance determines
(:func:`solver_digits`), its relative residuals at those it determines of them
(:func:`residual_digits`, a decade bound when not one digit) (docs/noise.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.sysid.noise import noise_generator

__all__ = ["ESTIMATE_COLUMNS", "DIAGNOSTIC_COLUMNS", "ROUNDOFF_COLUMNS", "ROUNDOFF_FLOOR",
           "COVERAGE_DECIMALS", "CONDITION_COLUMNS", "SINGULAR_CONDITION", "diagnostic_digits",
           "coverage_digits", "ROUNDOFF_PROBE", "PROBED_DIGITS", "probe_perturbation",
           "determined_digits", "determined", "determined_row", "FLOOR_DIGITS",
           "FLOOR_METHODS", "floor_digits", "floor_row", "ITERATIVE_MARGIN",
           "StoppingRule", "STOPPING_RULES", "ITERATIVE_PILOTS", "iterative_digits",
           "solver_digits", "ITERATION_COLUMNS", "NOT_SOLVED", "iterative_row", "iterative_note",
           "RESIDUAL_COLUMNS", "RESIDUAL_RULES", "residual_digits", "decade_bound",
           "residual_written", "row_writer"]

#: Estimates in ``fits.csv`` written to two significant digits: the noise floor that ``auto``
#: compares with its threshold (1e-3) is an evidence estimate, and on clean single-precision
#: records (1e-7…1e-6, the rounding of the file) its fourth digit differs between OpenBLAS
#: kernels (measured: 1.87089e-06 against 1.87098e-06 for the same fit).
ESTIMATE_COLUMNS = ("solver_noise_floor",)

#: Conditioning diagnostics and iteration counts in ``fits.csv`` and ``sweep.csv`` written to
#: two significant digits: a condition number of an ill-conditioned system, the amplification
#: and growth of a triangular solve, and the iteration at which a stopping rule is met all
#: move between OpenBLAS kernels (measured: the ``ls`` condition number in its third digit,
#: cgls stopping at iteration 188 against 189, stls at 279 against 281); what they tell — the
#: order of magnitude, roughly how many iterations — is in the first two digits.
DIAGNOSTIC_COLUMNS = ("condition_number", "solver_condition", "solver_amplification",
                      "solver_growth", "solver_iterations", "solver_solves")


#: Estimates that are round-off on clean data, written as 0 below :data:`ROUNDOFF_FLOOR`
#: (and to two significant digits above): ``auto``'s noise floor from its kernel test is a
#: ratio of Hankel singular values, 1e-15…8e-11 on exact double-precision records (digits
#: that are round-off and differ between BLAS kernels), 3e-8…8e-5 on records rounded to
#: single precision, at least 2.5e-3 with 0.3 % noise (benchmarks/auto_test.py).
ROUNDOFF_COLUMNS = ("solver_noise_floor",)
ROUNDOFF_FLOOR = 1e-9

#: Condition numbers ``σ_max/σ_min`` written as ``inf`` at or above :data:`SINGULAR_CONDITION`
#: (``σ_min ≤ 1e-14·σ_max``): such a ``σ_min`` is the SVD's round-off of a numerically
#: singular matrix (about ``n·ε·σ_max``, ε = 2.2e-16), not a property of the data. Measured
#: on Chapter 5's 2048-sample force matrices: 1.6e16…4.6e16 on the SkylakeX OpenBLAS kernel,
#: 4.2e16 against 4.6e16 for the same fit on the Haswell kernel; every well-posed system of
#: the committed studies reads below 1e13.
CONDITION_COLUMNS = ("condition_number", "solver_condition")
SINGULAR_CONDITION = 1e14


def diagnostic_digits(name: str, value):
    """``value`` of diagnostic ``name`` at the digits the tables write (:data:`ESTIMATE_COLUMNS`,
    :data:`DIAGNOSTIC_COLUMNS`: two significant digits; :data:`ROUNDOFF_COLUMNS`: 0 below
    :data:`ROUNDOFF_FLOOR`, else two significant digits; :data:`CONDITION_COLUMNS`: ``inf``
    at or above :data:`SINGULAR_CONDITION`); other values unchanged."""
    if name in ESTIMATE_COLUMNS + DIAGNOSTIC_COLUMNS + ROUNDOFF_COLUMNS \
            and isinstance(value, (int, float)) and not isinstance(value, bool) \
            and np.isfinite(value) and value != 0:
        if name in ROUNDOFF_COLUMNS and abs(value) < ROUNDOFF_FLOOR:
            return 0.0
        if name in CONDITION_COLUMNS and abs(value) >= SINGULAR_CONDITION:
            return float("inf")
        return float(f"{value:.2g}")
    return value


#: A band's realized coverage (the fraction of the truth's samples inside it) is written to
#: two decimals: the band's edges move in their sixth digit between OpenBLAS kernels, so a
#: sample of the truth lying on an edge falls in or out (measured on the MR designs: 0.63792
#: against 0.638, one sample of 12,500). The coverage is judged against 0.85–0.95.
COVERAGE_DECIMALS = 2


def coverage_digits(value: float) -> float:
    """``value`` to :data:`COVERAGE_DECIMALS` decimals (NaN unchanged)."""
    return round(float(value), COVERAGE_DECIMALS) if np.isfinite(value) else float(value)


#: Relative size of the probe perturbation of :func:`determined`'s rule: every training
#: record's ``W`` is multiplied sample by sample by ``1 + ROUNDOFF_PROBE·z`` (``z`` standard
#: normal from a fixed stream, :func:`probe_perturbation`) and the fit is repeated. Measured
#: on ERA/OKID (peers study, LTV beam, order 12): any perturbation from 1e-16 to 1e-13
#: moves its Markov parameters by the same 3e-6 (relative) and its error by 3e-7…2e-6 —
#: the floor of the computation's own round-off, which is all that two OpenBLAS kernels
#: change; above 1e-11 the change grows in proportion (2e-5 at 1e-11, 2e-4…4e-4 at 1e-10,
#: 2e-3…4e-3 at 1e-9). At 1e-10 the probe's effect is set by the data and the seed (the same
#: on every CPU to 1 %) and a hundred times the round-off floor, so the digits it leaves in
#: place are the same on every CPU and move between kernels only when a value lies within
#: the floor of a rounding boundary.
ROUNDOFF_PROBE = 1e-10
# Used by the base-excited study's ERA rows (byte-identical on both kernels with it). Applied
# to every ERA/cgls/stls/kernel/realization row of the runner's studies (branch h-kernel, not
# merged: it doubles those fits' cost and was not verified on every study), the peers study's
# ERA errors and decomposition came out identical on both kernels (0.845, 0.833, …), but their
# band columns (error_estimate, coverage, interval scores, relative half-width) still differ
# in the digit the probe leaves (0.496 / 0.5, 0.45 / 0.448): the band's leave-one-out refits of
# ERA on two records have a round-off floor near 1e-2, of the size of this probe's effect, so
# the agreement is a coin toss there. A probe for them must sit a hundred times above their
# floor (not done; see issue 23).

#: The most significant digits a probed value is written with: those of ``summary.csv``
#: (:data:`podbench.harness.tables.FLOAT_FORMAT`).
PROBED_DIGITS = 6


def probe_perturbation(X, *key: str) -> np.ndarray:
    """``X·(1 + ROUNDOFF_PROBE·z)``, ``z`` standard normal from the stream
    :func:`podbench.sysid.noise.noise_generator` ``(0, "roundoff-probe", *key)``: the same
    bits on every machine; zeros stay zero (a record at rest stays at rest)."""
    X = np.asarray(X, dtype=float)
    z = noise_generator(0, "roundoff-probe", *key).standard_normal(X.shape)
    return X * (1.0 + ROUNDOFF_PROBE * z)


def determined_digits(a: float, b: float, most: int = PROBED_DIGITS) -> int:
    """Significant digits of ``a`` that the probe leaves in place: the largest ``d ≤ most``
    with ``|a − b| ≤ ½·10^(e − d + 1)`` (``e`` the decimal exponent of ``a``), 0 if not
    even the first digit is (``most`` when ``a == b``; 0 when one of them is not finite)."""
    if a == b or (np.isnan(a) and np.isnan(b)):
        return most
    if not (np.isfinite(a) and np.isfinite(b)):
        return 0
    e = int(np.floor(np.log10(abs(a)))) if a != 0 else int(np.floor(np.log10(abs(b))))
    gap = abs(a - b)
    for d in range(most, 0, -1):
        if gap <= 0.5 * 10.0 ** (e - d + 1):
            return d
    return 0


def determined(a, b, most: int = PROBED_DIGITS):
    """``a`` written at the digits the data determine, judged by its probed twin ``b`` (the
    same value from the fit on the records perturbed by :data:`ROUNDOFF_PROBE`): rounded to
    :func:`determined_digits` significant digits, NaN where not even the first digit is
    determined. Integers (model orders, iterations) and flags are kept where equal and NaN
    where the probe changes them; anything else (text) is ``a``."""
    if isinstance(a, bool) or not isinstance(a, (int, float, np.integer, np.floating)):
        return a
    if not isinstance(b, (int, float, np.integer, np.floating)) or isinstance(b, bool):
        return float("nan")
    if isinstance(a, (int, np.integer)):
        return a if a == b else float("nan")
    a, b = float(a), float(b)
    d = determined_digits(a, b, most)
    if d == 0:
        return float("nan")
    return float(f"{a:.{d}g}") if np.isfinite(a) else a


def determined_row(row: dict, probe: dict, keep=(), most: int = PROBED_DIGITS) -> dict:
    """``row`` with every numeric entry written by :func:`determined` (at most ``most``
    digits) against ``probe``'s (entries named in ``keep``, and those ``probe`` lacks,
    unchanged)."""
    return {k: (v if k in keep or k not in probe else determined(v, probe[k], most))
            for k, v in row.items()}


#: Significant digits of every estimate in the rows of a method of :data:`FLOOR_METHODS`
#: (errors, norms, fit diagnostics; integers and labels as they are). ERA/OKID: its observer
#: recursion (Eq. 2 of :mod:`podbench.sysid.methods.peers.era`) amplifies the records'
#: round-off past the tables' sixth digit. Measured on the peers study between the OpenBLAS
#: Haswell and SkylakeX kernels (LTV and NL beams, order 12): errors 0.725049 / 0.725047
#: (3e-6 relative), the Eq. 4.2 maximum 526.002 / 526.014 (2.3e-5), the Hankel
#: singular-value ratio 0.551121 / 0.551123; the same under a 1-ulp perturbation of the
#: records. Three digits (the tables' rule for estimates) put the written digit at least 40×
#: above that floor. A per-value probe (:func:`determined`) was tried on the peers study and
#: its digit count itself flipped between kernels (a relative half-width 0.218 / 0.22).
FLOOR_DIGITS = 3
FLOOR_METHODS = ("ERA",)


def floor_digits(value, digits: int = FLOOR_DIGITS):
    """A float at ``digits`` significant digits (:data:`FLOOR_DIGITS`); integers, flags,
    text and non-finite values unchanged."""
    if isinstance(value, (bool, int, np.integer)) or not isinstance(value, (float, np.floating)):
        return value
    return float(f"{value:.{digits}g}") if np.isfinite(value) and value != 0 else value


def floor_row(row: dict, keep=(), digits: int = FLOOR_DIGITS) -> dict:
    """``row`` with every float entry at ``digits`` significant digits (:func:`floor_digits`;
    entries named in ``keep`` unchanged)."""
    return {k: (v if k in keep else floor_digits(v, digits)) for k, v in row.items()}
# ---------------------------------------------------------------- iterative solvers' digits
#: Margin, in decimal digits, kept between the last digit a number of an iterative solve is
#: written with and the round-off that moves it between BLAS kernels: a written value then
#: changes only where the unrounded one lies within 1e-3…1e-2 of a last-digit unit of a
#: rounding boundary (values spread over six decades, moved by ±3.3e-6 and written at three
#: digits: 0.12 % change; at six digits 81 %).
ITERATIVE_MARGIN = 3


@dataclass(frozen=True)
class StoppingRule:
    """How far the numbers of one iterative solver's answer are determined (issue 23).

    An iterative solve stops at the first iteration whose stopping test passes; the iterate
    there is the answer only to the tolerance, and round-off (another BLAS kernel) can move
    the stopping iteration. ``tol`` is the solver's default stopping tolerance; a move of
    the stopping point by a decade of tolerance moves every written number by at most
    ``gain·tol**power`` relative (``power`` 1 for a test on a residual norm, ½ for a test on
    the decrease of an objective near its minimum, where the objective is quadratic in the
    iterate's error); ``roundoff`` is the largest relative move of a written number between
    the OpenBLAS Haswell and SkylakeX kernels with the same stopping test. Both are
    measurements (:data:`STOPPING_RULES`)."""

    tol: float
    gain: float
    power: float
    roundoff: float

    def tolerance_move(self, tol: float | None = None) -> float:
        """The relative move of a written number that a decade of tolerance can make."""
        return self.gain * float(self.tol if tol is None else tol) ** self.power


#: The iterative solvers of :mod:`podbench.deconvolution` and what was measured of them
#: (Chapter 5's linear and rubber-band beams at 1 % and 5 % noise, SL and ML, every column
#: of summary.csv and fits.csv; the decade of tolerance both ways):
#:
#: * ``cgls`` — stop at ``‖Aᵀ(B − AX) − λ²X‖ ≤ tol·‖AᵀB‖``, ``tol = 1e-10`` (7–11
#:   iterations a decade): the errors move by ≤ 1.9e-9, the norm percent errors' maximum
#:   (a ratio at the smallest norms of the record) by ≤ 1.7e-6 = 1.7e4·tol; between kernels
#:   ≤ 1e-10 in the errors, ≤ 3.3e-6 in the norm percent errors' maximum (the iteration
#:   count 110 against 109, 87 against 85).
#: * ``stls`` — stop when a Gauss–Newton step lowers the objective by less than ``tol =
#:   1e-6`` (relative): 3–4 steps a decade; the errors move by ≤ 3.3e-4, the norm percent
#:   errors by ≤ 5.3e-3 = 5.3·√tol (3.3e-4 and 5.3e-3 for 1e-5, 1.1e-4 and 2.0e-3 for 1e-7);
#:   between kernels ≤ 2.2e-7 in the errors, ≤ 1.3e-6 in the norm percent errors (the same
#:   number of steps in every fit measured; LSQR's inner iterations differ).
#: * ``kernel`` — its conjugate gradients stop at a residual of ``tol = 1e-6`` (relative);
#:   not measured (15–100 s a fit, in no committed study): the cgls gain and round-off are
#:   taken for it (the same CG core, the same kind of test).
#: * ``realization`` realizes a cgls pilot kernel: cgls's (``subspace`` takes its poles from
#:   the records by direct linear algebra, no iteration).
STOPPING_RULES = {
    "cgls": StoppingRule(tol=1e-10, gain=1.7e4, power=1.0, roundoff=3.3e-6),
    "stls": StoppingRule(tol=1e-6, gain=5.3, power=0.5, roundoff=1.3e-6),
    "kernel": StoppingRule(tol=1e-6, gain=1.7e4, power=1.0, roundoff=3.3e-6),
}


def iterative_digits(tolerance_move: float, roundoff: float, margin: int = ITERATIVE_MARGIN,
                     most: int = PROBED_DIGITS, least: int = 1) -> int:
    """Significant digits of a number derived from an iterative solve: those its stopping
    tolerance determines, kept ``margin`` digits above the round-off of the kernel.

    A value ``v`` written at ``d`` significant digits has a last-digit unit of at least
    ``10^(1−d)·|v|/10`` and at most ``10^(1−d)·|v|``. The tolerance determines digit ``d``
    when a decade of tolerance moves ``v`` by less than that unit:
    ``d ≤ ⌊−log10(tolerance_move)⌋ + 1``; the margin asks the kernel's round-off to stay
    ``margin`` digits below it: ``d ≤ ⌊−log10(roundoff)⌋ + 1 − margin``. The result is the
    smaller, at most ``most`` and at least ``least`` (1; :func:`residual_digits` asks 0: not
    even the first digit, only the decade)."""
    by_tol = int(np.floor(-np.log10(tolerance_move))) + 1 if tolerance_move > 0 else most
    by_roundoff = int(np.floor(-np.log10(roundoff))) + 1 - margin if roundoff > 0 else most
    return max(least, min(most, by_tol, by_roundoff))


def solver_digits(solver: str, tol: float | None = None) -> int | None:
    """Significant digits of the numbers of a fit with deconvolution solver ``solver`` (a
    label of :func:`podbench.scenarios.method_solver`; ``a+b`` for a superposition: the
    fewest of its parts), ``None`` for a direct solver (its numbers keep the tables'
    digits). ``tol`` is the solver's stopping tolerance if not its default."""
    digits = []
    for name in solver.split("+"):
        rule = STOPPING_RULES.get(ITERATIVE_PILOTS.get(name, name))
        if rule is not None:
            digits.append(iterative_digits(rule.tolerance_move(
                tol if name in STOPPING_RULES else None), rule.roundoff))
    return min(digits) if digits else None


#: Solvers whose answer is built on an iterative solver's: the realization of a cgls
#: pilot kernel (``realization``).
ITERATIVE_PILOTS = {"realization": "cgls"}

#: Iteration counts: where a stopping test is first met, which round-off moves by one or
#: more iterations (cgls 110 against 109 and 87 against 85, stls's LSQR total 170 against
#: 180 at two digits on two kernels); no rounding makes that stable (a count ~100 jittering
#: by 2 crosses a one-digit boundary in ~2 % of fits), so they are not written for an
#: iterative solve (they stay in the estimator's ``diagnostics_``).
ITERATION_COLUMNS = ("solver_iterations", "solver_solves")

#: Entries not derived from the solve: labels, structural integers, the projection error
#: (the POD basis only), wall times.
NOT_SOLVED = ("scenario", "structure", "method", "target", "solver", "status", "n_modes",
              "projection_error", "noise", "modes", "seed", "band_seconds", "plain_seconds",
              "solver_shift", "solver_force_channels", "solver_rank", "solver_rank_max",
              "solver_order", "solver_horizon", "solver_n_pilot", "solver_n_rule",
              "solver_blocks", "solver_holdout_best_order", "converged")


def iterative_row(row: dict, digits: int, residual: int | None = None) -> dict:
    """``row`` with every number derived from an iterative solve written at ``digits``
    significant digits (:func:`floor_row`, :func:`solver_digits`), its iteration counts
    (:data:`ITERATION_COLUMNS`) as NaN, and its relative residuals
    (:data:`RESIDUAL_COLUMNS`) at ``residual`` digits (:func:`residual_written`; at ``digits``
    when ``residual`` is None); entries of :data:`NOT_SOLVED`, text, flags and integers
    unchanged."""
    out = floor_row(row, keep=NOT_SOLVED, digits=digits)
    for k in ITERATION_COLUMNS:
        if k in out and not isinstance(out[k], (bool, np.bool_)) and \
                isinstance(out[k], (int, float, np.integer, np.floating)):
            out[k] = float("nan")
    if residual is not None:
        for k in RESIDUAL_COLUMNS:
            if k in row:
                out[k] = residual_written(row[k], residual)
    return out


def iterative_note(solvers) -> str:
    """The sentence a table's header gives when some of its rows come from iterative solvers
    (``solvers``: the solver labels of its fits; "" when none is iterative)."""
    names = sorted({n for s in solvers if s for n in str(s).split("+")
                    if solver_digits(n) is not None})
    if not names:
        return ""
    digits = ", ".join(f"`{n}`: {solver_digits(n)}" for n in names)
    return ("Rows of a fit with an iterative solver are written at the significant digits its "
            "stopping tolerance determines, three digits above the BLAS kernel's round-off "
            f"(significant digits {digits}), its iteration counts left empty (docs/noise.md, "
            "*Digits of an iterative solve*).")


# ------------------------------------------------------- a residual at its solver's floor
#: Columns of ``fits.csv`` that are the fit's relative residual ``‖AX − B‖/‖B‖``.
RESIDUAL_COLUMNS = ("fit_residual", "solver_residual")

#: How far an iterative solve determines its relative residual (:data:`RESIDUAL_COLUMNS`),
#: which is not what it determines of its errors: the same :class:`StoppingRule` fields
#: (the relative move of the residual by a decade of tolerance, ``gain·tol**power``, and
#: between the OpenBLAS Haswell and SkylakeX kernels, ``roundoff``), measured on Chapter 5's
#: clean and 1 % linear beam and clean rubber-band beam, SL and ML, tolerance a decade
#: either way of the default and beyond (docs/noise.md, *A residual at its solver's
#: floor*):
#:
#: * ``stls`` — its test is on the decrease of the objective
#:   ``φ = ‖R‖² + ‖e‖² + λ²‖X‖²``; near the minimum a step that changes ``φ`` by ``δφ``
#:   trades residual against the penalties to first order, ``|δ‖R‖| ≲ √(2·δφ)``, so a
#:   residual that is a share ``f = ‖R‖²/φ`` of the objective is determined only to a
#:   relative ``√(2·tol/f)``. On the clean ML fit ``f ≈ 8e-4`` (λ²‖X‖² and ‖e‖² hold the
#:   rest): 5 %. Measured: 3.396e-6 → 3.469e-6 → 3.472e-6 → 3.474e-6 for tol 1e-5, 1e-6,
#:   1e-7, 1e-8 (2.1 % for the decade 1e-5 → 1e-6: ``gain`` 21 with ``power`` ½); on the
#:   SkylakeX kernel 3.361e-6 at 1e-6 (3.2 %), and still 2.4 % apart at 1e-8: no tolerance
#:   closes it (the same fits' errors differ by 1e-9…1e-8). ``roundoff`` 3.2e-2.
#: * ``cgls`` — its test is on the normal-equation residual; the clean ML fit's relative
#:   residual 5.5894e-8 → 5.5854e-8 for tol 1e-9 → 1e-10 (7.2e-4 = 7.2e6·tol), 3.4e-5
#:   between the kernels (calibration's clean ML4 fit: 4.44e-7 / 4.45e-7).
#: * ``kernel`` — cgls's (its CG core); ``realization`` — its cgls pilot's.
RESIDUAL_RULES = {
    "cgls": StoppingRule(tol=1e-10, gain=7.2e6, power=1.0, roundoff=3.4e-5),
    "stls": StoppingRule(tol=1e-6, gain=21.0, power=0.5, roundoff=3.2e-2),
    "kernel": StoppingRule(tol=1e-6, gain=7.2e6, power=1.0, roundoff=3.4e-5),
}


def residual_digits(solver: str, tol: float | None = None) -> int | None:
    """Significant digits of the relative residual of a fit with solver ``solver``
    (:data:`RESIDUAL_RULES`, :func:`iterative_digits` with ``least=0``; the fewest over the
    parts of ``a+b``): 0 when not even the first digit is three digits above the kernel's
    round-off (the residual is then known only to its decade, :func:`decade_bound`);
    ``None`` for a direct solver."""
    digits = []
    for name in solver.split("+"):
        rule = RESIDUAL_RULES.get(ITERATIVE_PILOTS.get(name, name))
        if rule is not None:
            move = rule.tolerance_move(tol if name in RESIDUAL_RULES else None)
            digits.append(iterative_digits(move, rule.roundoff, least=0))
    return min(digits) if digits else None


def decade_bound(value):
    """The decade above ``|value|``, ``10^⌈log10 |value|⌉`` with its sign: an upper bound on a
    number known only to its order of magnitude (a power of ten is its own bound); 0,
    non-finite values, integers, flags and text unchanged."""
    if isinstance(value, (bool, int, np.integer)) or not isinstance(value, (float, np.floating)):
        return value
    if not np.isfinite(value) or value == 0:
        return value
    bound = 10.0 ** int(np.ceil(np.log10(abs(float(value)))))
    return float(np.copysign(float(f"{bound:.1g}"), value))


def residual_written(value, digits: int):
    """A relative residual as the tables write it: at ``digits`` significant digits
    (:func:`floor_digits`), or as its :func:`decade_bound` when ``digits`` is 0."""
    return decade_bound(value) if digits == 0 else floor_digits(value, digits)


def row_writer(solver: str | None, tol: float | None = None, *, floored: bool = False,
               keep=NOT_SOLVED):
    """How the rows, ``fits.csv`` row and band scores of one fit are written (issue 23: the
    same bytes on every BLAS kernel), or ``None``: as computed.

    * ``floored`` (a method of :data:`FLOOR_METHODS`): every estimate at
      :data:`FLOOR_DIGITS` (:func:`floor_row`; entries named in ``keep`` unchanged);
    * an iterative ``solver`` (:func:`solver_digits`): :func:`iterative_row` at the digits
      its stopping tolerance ``tol`` (None: the default) determines, its residuals at
      :func:`residual_digits`.

    A direct solve on a numerically singular system (condition written ``inf``) keeps the
    tables' digits: its round-off between kernels was measured below one unit of the sixth
    digit (docs/noise.md, *A numerically singular solve*), which
    :func:`podbench.harness.rewrite.unmoved` absorbs."""
    if floored:
        return lambda row: floor_row(row, keep=keep)
    digits = solver_digits(solver, tol) if solver else None
    if digits is not None:
        residual = residual_digits(str(solver), tol)
        return lambda row: iterative_row(row, digits, residual)
    return None
