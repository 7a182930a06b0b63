"""The §5.2 nonlinearity checks (Figs. 5.12, 5.13) as part of a study run.

A claims file may declare::

    [nonlinearity]
    name = "nonlinearity"            # the pseudo-scenario its claims name (default)
    structure = "rubber_band_beam"   # a structure with one OneSidedSpring
    zetas = [0.0, 0.005]             # modal damping ratios run
    fractions = [0.0, 0.25, 0.5, 1.0]  # slack and pre-stretch, × the largest tip amplitude A

``podbench run <study>`` (the whole study) then runs
:func:`podbench.harness.nonlinearity.nonlinearity_table` at those values, writes
``nonlinearity.md`` / ``nonlinearity.csv`` (and Figs. 5.12 / 5.13 per row into ``figures/``),
and judges the claims naming ``scenario = "nonlinearity"`` on rows of the same shape as the
summary table: structure the structure's name, target ``undamped`` or ``zeta_<ζ %>pct``,
method ``band`` for the structure's own band (slack 0, the text's words) and
``slack_<f>A`` / ``prestretch_<f>A`` for the sweep. Each such claim is judged on ``band``;
its checks are then evaluated again with ``band`` standing for every swept row, and
FINDINGS.md's "over the unstated parameter" column says over which slack / pre-stretch it
holds (:func:`swept_verdicts`, the wording of :mod:`podbench.study.sensitivity`).

Metrics per row (first reference period T for the scaled response; lags in % of T):

* ``deviation`` — ‖s₀ − s_b‖/‖s_b‖ of the smallest load's scaled tip history s₀ against the
  1.8-lbf baseline's s_b (0 for a linear system: superposition).
* ``scaled_rms_change``, ``scaled_away_change`` — relative change of the scaled tip RMS and of
  the scaled band-side peak from the smallest load to the largest (negative: "decrease as the
  impulse magnitude is increased", Fig. 5.12).
* ``lag_first``, ``lag_last`` — lag of the smallest load's response behind the baseline at
  the first and last time (500 and 2000 ms read literally); positive: the small load has the
  lower frequency, i.e. "the lowest frequency of the system increases with the excitation
  magnitude" (Fig. 5.13). ``lag_growth`` = ``lag_last − lag_first`` ("phase differences ...
  that grow with time").

Units: inch, lbf, second.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

__all__ = ["NonlinearitySpec", "parse_spec", "claim_rows", "zeta_words",
           "zeta_label", "row_label"]

METRICS = ("deviation", "scaled_rms_change", "scaled_away_change", "lag_first", "lag_last",
           "lag_growth")


@dataclass(frozen=True)
class NonlinearitySpec:
    """The ``[nonlinearity]`` table of a claims file."""

    structure: str
    zetas: tuple
    fractions: tuple
    name: str = "nonlinearity"


def parse_spec(t) -> NonlinearitySpec:
    """Read a ``[nonlinearity]`` table (a :class:`podbench.structures.spec.Table`; errors name the
    file and field)."""
    zetas = tuple(float(z) for z in t.raw("zetas"))
    fractions = tuple(float(f) for f in t.raw("fractions"))
    for z in zetas:
        if not 0.0 <= z < 1.0:
            t.fail("zetas", f"expected damping ratios in [0, 1), got {z!r}")
    if not fractions or any(f < 0.0 for f in fractions) or 0.0 not in fractions:
        t.fail("fractions", "expected non-negative fractions of the tip amplitude, "
                            f"including 0 (the structure's own band), got {list(fractions)}")
    if not zetas:
        t.fail("zetas", "expected at least one damping ratio")
    spec = NonlinearitySpec(structure=t.string("structure"), zetas=zetas,
                            fractions=tuple(sorted(set(fractions))),
                            name=t.string("name", "nonlinearity"))
    t.close()
    return spec


def zeta_label(z: float) -> str:
    return "undamped" if z == 0.0 else f"zeta_{100 * z:g}pct"


def zeta_words(target: str) -> str:
    return "undamped" if target == "undamped" else \
        "ζ = " + target.removeprefix("zeta_").replace("pct", " %")


def row_label(r: dict) -> str:
    return "band" if r["kind"] == "none" else f"{r['kind']}_{r['fraction']:g}A"


ROUNDOFF_METRIC = 1e-9
"""Metrics below this in magnitude are round-off of a positively homogeneous (linear) band and
written as 0: their digits (1e-14…1e-11) differ between CPUs."""

METRIC_DIGITS = 4
"""Significant digits of the metrics: a phase lag's sixth digit moved between CPUs
(−0.000196977 against −0.000196976 % of the period)."""


def _digits(v: float) -> float:
    v = float(v)
    if abs(v) < ROUNDOFF_METRIC:
        return 0.0
    return float(f"{v:.{METRIC_DIGITS}g}")


def _metrics(r: dict) -> dict:
    lags = r["lags"][0]
    raw = {
        "deviation": float(r["deviation"][0]),
        "scaled_rms_change": float((r["rms"][-1] - r["rms"][0]) / r["rms"][0]),
        "scaled_away_change": float((r["away"][-1] - r["away"][0]) / r["away"][0]),
        "lag_first": float(lags[0]), "lag_last": float(lags[-1]),
        "lag_growth": float(lags[-1] - lags[0]),
    }
    return {k: _digits(v) for k, v in raw.items()}


def claim_rows(rows, spec: NonlinearitySpec) -> pd.DataFrame:
    """Summary-table-shaped rows (scenario, structure, target, method, metrics, offset)."""
    return pd.DataFrame([{
        "scenario": spec.name, "structure": spec.structure, "target": zeta_label(r["zeta"]),
        "method": row_label(r), "kind": r["kind"], "fraction": r["fraction"],
        "offset_in": r["offset_in"], "amplitude_in": r["amplitude_in"],
        "period_s": r["period_s"], **_metrics(r)} for r in rows])


