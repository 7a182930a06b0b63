"""The digits podbench's tables write, so that a table regenerates byte-identically on any CPU.

A number is written at the digits its computation determines: a fit diagnostic whose last
digits move between CPUs at two significant digits (:func:`diagnostic_digits`); the
rows of a fit at what its estimator declares (:func:`estimator_writer`): a method's round-off
floor (``floor_digits``, ERA/OKID's), or its deconvolution solver's stopping tolerance
(``SolverResult.determined``: :mod:`podbench.sysid.deconvolution.determined`). The
measurements behind the rules are in docs/noise.md."""

from __future__ import annotations

import numpy as np

from podbench.errors import PodbenchError
from podbench.sysid.deconvolution import get_solver
from podbench.sysid.deconvolution.determined import (
    ITERATIVE_MARGIN,
    Determined,
    StoppingRule,
    iterative_digits,
)
from podbench.sysid.noise import noise_generator

__all__ = ["ESTIMATE_COLUMNS", "DIAGNOSTIC_COLUMNS", "ROUNDOFF_COLUMNS", "ROUNDOFF_FLOOR",
           "COVERAGE_DECIMALS", "CONDITION_COLUMNS", "SINGULAR_CONDITION", "diagnostic_digits",
           "coverage_digits", "ROUNDOFF_PROBE", "PROBED_DIGITS", "probe_perturbation",
           "determined_digits", "determined", "determined_row", "FLOOR_DIGITS",
           "floor_digits", "floor_row", "ITERATIVE_MARGIN", "StoppingRule",
           "iterative_digits", "solver_digits", "ITERATION_COLUMNS", "NOT_SOLVED",
           "iterative_row", "iterative_note", "RESIDUAL_COLUMNS", "residual_digits",
           "decade_bound", "residual_written", "estimator_writer", "estimator_determined"]

#: Estimates in ``fits.csv`` written to two significant digits: the noise floor that ``auto``
#: compares with its threshold (1e-3) is an evidence estimate whose fourth digit moves
#: between CPUs on clean single-precision records (docs/noise.md).
ESTIMATE_COLUMNS = ("solver_noise_floor",)

#: Conditioning diagnostics and iteration counts in ``fits.csv`` and ``sweep.csv`` written to
#: two significant digits: a condition number of an ill-conditioned system, the amplification
#: and growth of a triangular solve, and the iteration at which a stopping rule is met all
#: move between CPUs; what they tell — the order of magnitude, roughly how many
#: iterations — is in the first two digits.
DIAGNOSTIC_COLUMNS = ("condition_number", "solver_condition", "solver_amplification",
                      "solver_growth", "solver_iterations", "solver_solves")

#: Estimates that are round-off on clean data, written as 0 below :data:`ROUNDOFF_FLOOR`
#: (and to two significant digits above): ``auto``'s noise floor from its kernel test is a
#: ratio of Hankel singular values, round-off (1e-15…8e-11) on exact double-precision
#: records, at least 3e-8 on records rounded to single precision (benchmarks/auto_test.py).
ROUNDOFF_COLUMNS = ("solver_noise_floor",)
ROUNDOFF_FLOOR = 1e-9

#: Condition numbers ``σ_max/σ_min`` written as ``inf`` at or above :data:`SINGULAR_CONDITION`
#: (``σ_min ≤ 1e-14·σ_max``): such a ``σ_min`` is the SVD's round-off of a numerically
#: singular matrix (about ``n·ε·σ_max``, ε = 2.2e-16), not a property of the data; every
#: well-posed system of the committed studies reads below 1e13 (docs/noise.md).
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
#: two decimals: the band's edges move in their sixth digit between CPUs, so a
#: sample of the truth lying on an edge falls in or out. The coverage is judged against
#: 0.85–0.95.
COVERAGE_DECIMALS = 2


def coverage_digits(value: float) -> float:
    """``value`` to :data:`COVERAGE_DECIMALS` decimals (NaN unchanged)."""
    return round(float(value), COVERAGE_DECIMALS) if np.isfinite(value) else float(value)


#: Relative size of the probe perturbation of :func:`determined`'s rule: every training
#: record's ``W`` is multiplied sample by sample by ``1 + ROUNDOFF_PROBE·z`` (``z`` standard
#: normal from a fixed stream, :func:`probe_perturbation`) and the fit is repeated. At 1e-10
#: the probe's effect is set by the data and the seed, a hundred times the round-off floor
#: of the fits it is used on (docs/noise.md), so the digits it leaves in place are the same
#: on every CPU and move between kernels only when a value lies within the floor of a
#: rounding boundary.
ROUNDOFF_PROBE = 1e-10

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


#: The significant digits of a method whose estimates sit on a round-off floor, when it
#: declares none of its own (``floor_digits``; ERA/OKID's observer recursion amplifies the
#: records' round-off past the tables' sixth digit: docs/noise.md).
FLOOR_DIGITS = 3


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
def _rule(name: str) -> StoppingRule | None:
    """The stopping rule the built-in solver ``name`` declares (None: direct, or unknown)."""
    try:
        cls = get_solver(name)
    except PodbenchError:
        return None
    return cls.stopping


def _named(solver: str, tol: float | None):
    """The :class:`Determined` of each iterative part of a solver label (``a+b``: a
    superposition's parts), from the built-in solvers' declarations at their default
    tolerance or ``tol``."""
    out = []
    for name in str(solver).split("+"):
        try:
            det = get_solver(name)().determined() if tol is None \
                else get_solver(name)(**{get_solver(name).stopping_tol: tol}).determined()
        except (PodbenchError, TypeError):
            det = None
        out.append(det)
    return [d for d in out if d is not None]


def solver_digits(solver: str, tol: float | None = None) -> int | None:
    """Significant digits of the numbers of a fit with built-in solver ``solver`` (``a+b``:
    the fewest of its parts) at its default tolerance or ``tol``, as the solver declares
    them (:meth:`~podbench.deconvolution.Solver.determined`); None for a direct solver."""
    det = Determined.fewest(_named(solver, tol))
    return None if det is None else det.digits


def residual_digits(solver: str, tol: float | None = None) -> int | None:
    """Significant digits of the relative residual of a fit with built-in solver ``solver``
    (0: known only to its decade, :func:`decade_bound`); None for a direct solver."""
    det = Determined.fewest(_named(solver, tol))
    return None if det is None else det.residual_digits


#: Iteration counts: where a stopping test is first met, which round-off moves by one or
#: more iterations; no rounding makes that stable, so they are not written for an iterative
#: solve (they stay in the estimator's ``diagnostics_``).
ITERATION_COLUMNS = ("solver_iterations", "solver_solves")

#: Entries not derived from the solve: labels, structural integers, the projection error
#: (the POD basis only), wall times.
NOT_SOLVED = ("scenario", "structure", "method", "target", "solver", "status", "n_modes",
              "projection_error", "noise", "modes", "seed", "band_seconds", "plain_seconds",
              "solver_shift", "solver_force_channels", "solver_rank", "solver_rank_max",
              "solver_order", "solver_horizon", "solver_n_pilot", "solver_n_rule",
              "solver_blocks", "solver_holdout_best_order", "converged")

#: Columns of ``fits.csv`` that are the fit's relative residual ``‖AX − B‖/‖B‖``.
RESIDUAL_COLUMNS = ("fit_residual", "solver_residual")


def iterative_row(row: dict, digits: int, residual: int | None = None) -> dict:
    """``row`` with every number derived from an iterative solve written at ``digits``
    significant digits (:func:`floor_row`), its iteration counts (:data:`ITERATION_COLUMNS`)
    as NaN, and its relative residuals (:data:`RESIDUAL_COLUMNS`) at ``residual`` digits
    (:func:`residual_written`; at ``digits`` when ``residual`` is None); entries of
    :data:`NOT_SOLVED`, text, flags and integers unchanged."""
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
            "stopping tolerance determines, three digits above the CPU's round-off "
            f"(significant digits {digits}), its iteration counts left empty (docs/noise.md, "
            "*Digits of an iterative solve*).")


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


# ------------------------------------------------------------- what an estimator declares
def _infos(est) -> list:
    """Every solver-info dict a fitted estimator holds (a superposition's parts' too)."""
    info = getattr(est, "solver_info_", None)
    out = list(info) if isinstance(info, list) else ([info] if isinstance(info, dict) else [])
    for part in getattr(est, "parts_", None) or ():
        out += _infos(part)
    return out


def estimator_determined(est) -> Determined | None:
    """The least determined of the deconvolutions a fitted estimator ran (their
    ``SolverResult.info["determined"]``), None when every one was direct."""
    return Determined.fewest(Determined.from_info(i.get("determined")) for i in _infos(est))


def _floor(est) -> int | None:
    """The fewest ``floor_digits`` the estimator or one of its parts declares."""
    own = getattr(est, "floor_digits", None)
    parts = [_floor(p) for p in getattr(est, "parts_", None) or ()]
    found = [d for d in (own, *parts) if isinstance(d, int)]
    return min(found) if found else None


def estimator_writer(est, *, keep=NOT_SOLVED):
    """How the rows, ``fits.csv`` row and band scores of one fitted estimator are written,
    as it declares (None: as computed):

    * a method with a round-off floor (``floor_digits``, e.g. ERA/OKID, or a superposition
      with such a part): every estimate at that many significant digits (:func:`floor_row`;
      entries named in ``keep`` unchanged);
    * an iterative deconvolution (:func:`estimator_determined`): :func:`iterative_row` at the
      digits its stopping tolerance determines, its residuals at those it determines of
      them.

    A direct solve keeps the tables' digits; a numerically singular one too: its round-off
    between kernels was measured below one unit of the sixth digit (docs/noise.md), which
    :func:`podbench.harness.rewrite.unmoved` absorbs."""
    floor = _floor(est)
    if floor is not None:
        return lambda row: floor_row(row, keep=keep, digits=floor)
    det = estimator_determined(est)
    if det is not None:
        return lambda row: iterative_row(row, det.digits, det.residual_digits)
    return None
