"""A run's results as tables: ``summary.csv`` (one row per scenario × structure × method ×
target), ``fits.csv`` (what each fit measured about itself), ``modal.csv`` and
``pom_modes.csv`` (the modes against the finite-element model's), and the one CSV format of
every table podbench writes (fixed digits, fixed row order, so a rerun is byte-identical)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from podbench.harness.digits import DIAGNOSTIC_COLUMNS, ESTIMATE_COLUMNS, diagnostic_digits
from podbench.harness.metrics import roundoff_errors
from podbench.harness.modal import MODAL_COLUMNS, POM_COLUMNS
from podbench.harness.runner import COLUMNS

FLOAT_FORMAT = "%.6g"
"""Six significant digits: far above the run-to-run noise of the errors, and stable."""


#: ``error_estimate`` (a prediction's own estimate of its total error, the band's scale) is
#: written to three significant digits: it is an estimate (scored within a factor of 2), and
#: its sixth digit is round-off that depends on the BLAS build (up to 1.2e-5 relative on
#: Chapter 4), which would make the table depend on the CPU.
ESTIMATE_DIGITS = 3


def _significant(v: float, digits: int) -> float:
    return float(f"{v:.{digits}g}") if np.isfinite(v) else v


def summary_table(results) -> pd.DataFrame:
    """All rows of the unit results, in the runner's deterministic order; round-off errors
    written as 0 (:func:`~podbench.harness.metrics.roundoff_errors`)."""
    rows = [r for u in results for r in u.rows]
    df = roundoff_errors(pd.DataFrame(rows, columns=list(COLUMNS)))
    df["n_modes"] = df["n_modes"].astype(int)
    if "error_estimate" in df and pd.api.types.is_numeric_dtype(df["error_estimate"]):
        df["error_estimate"] = df["error_estimate"].map(
            lambda v: _significant(v, ESTIMATE_DIGITS))
    return df


#: Residual columns of ``fits.csv`` (``fit_residual``, ``solver_residual``: relative
#: ‖AX − B‖/‖B‖ of the fit) below this are round-off and written as 0. An exact solve leaves
#: 1e-16…1e-15 whose digits differ between CPUs (docs/noise.md), which would make the table
#: machine-dependent; the appendix TLS on noise-free Chapter 5 records leaves 1.0e-12…1.4e-12
#: by one exact route to the eigenvectors of XᵀX and 0 by another (the same eigenvalues bit
#: for bit): round-off of a system conditioned about 1e4, so the floor sits two decades above.
#: Every residual of the committed studies' fits.csv is 0 or above 1e-9.
ROUNDOFF_RESIDUAL = 1e-10




def fits_table(results) -> pd.DataFrame:
    """One row per (scenario, structure, reported method): what its fit measured about
    itself (:attr:`podbench.methods.PODMethod.diagnostics_`: mode count, fit residual,
    condition number, the solver's amplification, regularization, iterations, …)."""
    rows = [f for u in results for f in getattr(u, "fits", [])]
    df = pd.DataFrame(rows)
    for c in df.columns:  # round-off residuals: their digits depend on the CPU's round-off
        if c.endswith("residual") and pd.api.types.is_numeric_dtype(df[c]):
            df[c] = df[c].mask(df[c].abs() < ROUNDOFF_RESIDUAL, 0.0)
    for c in ESTIMATE_COLUMNS + DIAGNOSTIC_COLUMNS:
        if c in df and pd.api.types.is_numeric_dtype(df[c]):
            df[c] = df[c].map(lambda v, c=c: diagnostic_digits(c, v))
    first = [c for c in ("scenario", "structure", "method", "n_modes", "solver") if c in df]
    return df[first + sorted(c for c in df.columns if c not in first)]


def table_csv(df: pd.DataFrame) -> str:
    """``df`` as the CSV every table of podbench is written in: six significant digits
    (:data:`FLOAT_FORMAT`), ``\\n`` line ends, no index, and a negative zero written as 0
    (``-0.0 + 0.0 == +0.0``: which zero a computation ends on depends on summation order)."""
    floats = df.select_dtypes(include="float").columns
    if len(floats):
        df = df.copy()
        df[floats] = df[floats] + 0.0
    return df.to_csv(index=False, float_format=FLOAT_FORMAT, lineterminator="\n")


TIMING_FILE = "timing.csv"
"""Wall-clock seconds per method of a run: written beside the tables, never tracked (the
seconds differ from run to run, so the tables stay deterministic without them)."""


def timing_table(results) -> pd.DataFrame:
    """One row per (scenario, structure, reported method): ``fit_seconds`` (its fit and the
    targets' predictions) and ``seconds`` (with its twins, refits and bands), wall clock."""
    rows = [t for u in results for t in getattr(u, "timing", [])]
    return pd.DataFrame(rows, columns=["scenario", "structure", "method", "fit_seconds",
                                       "seconds"])


def slowest_method(path) -> tuple[str, float, float] | None:
    """``(method, its seconds, all methods' seconds)`` of a run's ``timing.csv`` (the
    ``seconds`` column summed per ``method``; an own runner's table has its own rows), or
    None when the file is absent or has no such columns."""
    try:
        df = pd.read_csv(path)
    except (OSError, ValueError):
        return None
    if not {"method", "seconds"} <= set(df.columns) or df.empty:
        return None
    per = pd.to_numeric(df["seconds"], errors="coerce").groupby(df["method"]).sum()
    if per.empty or not np.isfinite(per.max()):
        return None
    return str(per.idxmax()), float(per.max()), float(per.sum())


def modal_tables(results) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """``(modal.csv, pom_modes.csv)`` of a run (:mod:`podbench.harness.modal`), in the
    runner's order; ``(None, None)`` when no fit was compared with finite-element modes (a
    study of measured records)."""
    modal = [r for u in results for r in getattr(u, "modal", [])]
    if not modal:
        return None, None
    poms = [r for u in results for r in getattr(u, "pom_modes", [])]
    return (pd.DataFrame(modal, columns=list(MODAL_COLUMNS)),
            pd.DataFrame(poms, columns=list(POM_COLUMNS)))
