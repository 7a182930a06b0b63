"""Accuracy regression: compare a study's summary table with a committed baseline.

A row is identified by ``(scenario, structure, method, target)``. For every error column of
:data:`COMPARED` the check fails ("worse") when

    new > base · (1 + rtol) + atol      (or new is NaN where base was a number)

with defaults ``rtol = 0.01`` and ``atol = 1e-6``: an error that grows by more than 1 %
of itself (plus a floor for errors near zero) is a regression; floating-point differences
between machines are far below that. A baseline row missing from the new table, or a
method whose status changes from ``ok`` to a failure, is also a regression. Improvements and
new rows are reported but do not fail.

Calibration (the prediction bands) is regressed too, through two derived columns of
:data:`CALIBRATION` (compared by the same rule, with an absolute floor of
:data:`CALIBRATION_ATOL`):
``coverage_gap = |coverage − 0.9|`` (the 90 % band's distance from its nominal coverage) and
``estimate_log_ratio = |ln(error_estimate / total_error)|`` (how far the error estimate is
from the realized error, in log terms). A baseline written before the band columns existed
has neither, and they are skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pandas as pd

from podbench.errors import InputError
from podbench.harness.metrics import ERROR_COLUMNS

__all__ = ["compare", "Comparison", "COMPARED", "KEY", "read_table", "CALIBRATION"]

KEY = ("scenario", "structure", "method", "target")
COMPARED = (*ERROR_COLUMNS, "norm_pe_median", "norm_pe_p90")
CALIBRATION = ("coverage_gap", "estimate_log_ratio")
"""Derived calibration columns (:func:`calibration_columns`), regressed like the errors."""
CALIBRATION_ATOL = 0.01
"""Absolute floor of a calibration regression: a coverage that moves by less than one
percentage point, or an estimate by less than 1 % of itself, is not one."""


def calibration_columns(row: dict) -> dict:
    """``coverage_gap`` and ``estimate_log_ratio`` of one table row (NaN when the row has no
    band columns or no finite error)."""
    nan = float("nan")
    cov = float(row.get("coverage", nan))
    est, tot = float(row.get("error_estimate", nan)), float(row.get("total_error", nan))
    ratio = abs(math.log(est / tot)) if est > 0 and tot > 0 and math.isfinite(est / tot) \
        else nan
    return {"coverage_gap": abs(cov - 0.9), "estimate_log_ratio": ratio}


@dataclass
class Comparison:
    worse: list = field(default_factory=list)      # (key, column, base, new)
    better: list = field(default_factory=list)
    missing: list = field(default_factory=list)    # keys in the baseline only
    added: list = field(default_factory=list)      # keys in the new table only
    status: list = field(default_factory=list)     # (key, base status, new status)
    n_rows: int = 0

    @property
    def failed(self) -> bool:
        return bool(self.worse or self.missing or self.status)

    def report(self, rtol: float, atol: float) -> str:
        lines = [f"compared {self.n_rows} rows × {len(COMPARED)} error columns and "
                 f"{len(CALIBRATION)} calibration columns "
                 f"(worse when new > base·(1 + {rtol:g}) + {atol:g})"]
        def k(key):
            return " / ".join(str(x) for x in key)
        if self.worse:
            lines.append(f"WORSE ({len(self.worse)}):")
            for key, col, b, n in self.worse:
                meaningful = math.isfinite(b) and math.isfinite(n) and abs(b) > 1e3 * atol
                rel = f"  ({(n - b) / abs(b):+.2%})" if meaningful else ""
                lines.append(f"  {k(key)}: {col} {b:.6g} -> {n:.6g}{rel}")
        for key, b, n in self.status:
            lines.append(f"  {k(key)}: status {b!r} -> {n!r}")
        for key in self.missing:
            lines.append(f"  {k(key)}: in the baseline but not produced by this run")
        if self.better:
            lines.append(f"better ({len(self.better)}; `podbench regress --update` records "
                         "them):")
            for key, col, b, n in self.better[:20]:
                lines.append(f"  {k(key)}: {col} {b:.6g} -> {n:.6g}")
            if len(self.better) > 20:
                lines.append(f"  ... and {len(self.better) - 20} more")
        for key in self.added:
            lines.append(f"  new row (not in the baseline): {k(key)}")
        lines.append("RESULT: " + ("regression" if self.failed else "no error got worse"))
        return "\n".join(lines)


def read_table(path) -> pd.DataFrame:
    """Read a summary/baseline CSV, checking its columns."""
    try:
        df = pd.read_csv(path, keep_default_na=True)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a readable CSV table ({exc})") from None
    missing = [c for c in (*KEY, "total_error", "status") if c not in df.columns]
    if missing:
        raise InputError(f"{path}: missing columns {', '.join(missing)}")
    if df.duplicated(list(KEY)).any():
        raise InputError(f"{path}: duplicate rows for the same scenario/structure/method/target")
    for c in (c for c in COMPARED if c in df.columns):
        try:
            df[c] = pd.to_numeric(df[c])
        except (ValueError, TypeError):
            raise InputError(f"{path}: column {c} is not numeric") from None
    return df


def compare(new: pd.DataFrame, base: pd.DataFrame, *, rtol: float = 0.01,
            atol: float = 1e-6) -> Comparison:
    """Compare a new table with the baseline (see the module docstring)."""
    out = Comparison()
    nk = {tuple(r[c] for c in KEY): r for r in new.to_dict("records")}
    bk = {tuple(r[c] for c in KEY): r for r in base.to_dict("records")}
    for key, b in bk.items():
        n = nk.get(key)
        if n is None:
            out.missing.append(key)
            continue
        out.n_rows += 1
        if b["status"] == "ok" and n["status"] != "ok":
            out.status.append((key, b["status"], n["status"]))
        for col in COMPARED:
            if col in b and col in n:  # not a column added after the baseline was written
                _judge(out, key, col, float(b[col]), float(n[col]), rtol, atol)
        if "coverage" not in b or "coverage" not in n:
            continue
        bc, nc = calibration_columns(b), calibration_columns(n)
        for col in CALIBRATION:
            _judge(out, key, col, bc[col], nc[col], rtol, CALIBRATION_ATOL)
    out.added = [k for k in nk if k not in bk]
    return out


def _judge(out: Comparison, key, col: str, bv: float, nv: float, rtol: float,
           atol: float) -> None:
    """File one error of a row as worse (above ``bv·(1 + rtol) + atol``, or NaN where the
    baseline has a number) or better (below ``bv·(1 − rtol) − atol``); a NaN baseline is
    not compared."""
    if math.isnan(bv):
        return
    if math.isnan(nv) or nv > bv * (1 + rtol) + atol:
        out.worse.append((key, col, bv, nv))
    elif nv < bv * (1 - rtol) - atol:
        out.better.append((key, col, bv, nv))
