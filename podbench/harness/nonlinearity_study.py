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
holds (:func:`swept_verdicts`, the wording of :mod:`podbench.harness.sensitivity`).

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
from pathlib import Path

import pandas as pd

from ..fem.files import load_structure
from .claims import check
from .executor import execute
from .nonlinearity import figure_phase_lag, figure_scaled_tip, markdown_table, nonlinearity_table

__all__ = ["NonlinearitySpec", "parse_spec", "run_checks", "claim_rows", "swept_verdicts",
           "write_outputs", "zeta_label", "row_label"]

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
    """Read a ``[nonlinearity]`` table (a :class:`podbench.fem._spec.Table`; errors name the
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


def _zeta_words(target: str) -> str:
    return "undamped" if target == "undamped" else \
        "ζ = " + target.removeprefix("zeta_").replace("pct", " %")


def row_label(r: dict) -> str:
    return "band" if r["kind"] == "none" else f"{r['kind']}_{r['fraction']:g}A"


def _task(args):
    from .cache import TruthCache

    structure, zeta, frac, cache_dir = args
    return nonlinearity_table(load_structure(structure), fractions=(frac,), zetas=(zeta,),
                              cache=TruthCache(cache_dir) if cache_dir is not None else None)


_ORDER = {"none": 0, "slack": 1, "prestretch": 2}


def run_checks(spec: NonlinearitySpec, *, jobs: int = 1, progress=None,
               cache_dir=None) -> list[dict]:
    """The rows of :func:`~podbench.harness.nonlinearity.nonlinearity_table` for ``spec``, one
    task per (ζ, fraction) (``jobs`` processes; ``progress`` as
    :func:`podbench.harness.progress.as_stage`; ``cache_dir``: the truth cache's folder, the
    2.2-s responses are read back exactly on a rerun), in a fixed order: ζ, then the band's own
    row, the slacks and the pre-stretches by fraction."""
    from .progress import as_stage

    tasks = [(spec.structure, z, f, None if cache_dir is None else str(cache_dir))
             for z in spec.zetas for f in spec.fractions]
    with as_stage(progress, "nonlinearity checks", len(tasks), "task") as stage:
        parts = execute(_task, tasks, jobs=jobs, progress=lambda *_: stage.advance())
    rows = [r for part in parts for r in part]
    return sorted(rows, key=lambda r: (r["zeta"], _ORDER[r["kind"]], r["fraction"]))


def _metrics(r: dict) -> dict:
    lags = r["lags"][0]
    return {
        "deviation": float(r["deviation"][0]),
        "scaled_rms_change": float((r["rms"][-1] - r["rms"][0]) / r["rms"][0]),
        "scaled_away_change": float((r["away"][-1] - r["away"][0]) / r["away"][0]),
        "lag_first": float(lags[0]), "lag_last": float(lags[-1]),
        "lag_growth": float(lags[-1] - lags[0]),
    }


def claim_rows(rows, spec: NonlinearitySpec) -> pd.DataFrame:
    """Summary-table-shaped rows (scenario, structure, target, method, metrics, offset)."""
    return pd.DataFrame([{
        "scenario": spec.name, "structure": spec.structure, "target": zeta_label(r["zeta"]),
        "method": row_label(r), "kind": r["kind"], "fraction": r["fraction"],
        "offset_in": r["offset_in"], "amplitude_in": r["amplitude_in"],
        "period_s": r["period_s"], **_metrics(r)} for r in rows])


def swept_verdicts(claims, table: pd.DataFrame, spec: NonlinearitySpec) -> dict:
    """``claim id -> [(kind, text, where)]`` for the claims judged on ``spec.name``: each
    claim's checks with ``band`` standing for every swept row, summarized per ζ and per
    kind of offset (slack, pre-stretch; the band's own row is fraction 0 of both) in the
    words of :func:`podbench.harness.sensitivity.bounded_summary`."""
    from .sensitivity import bounded_summary

    out: dict = {}
    for c in claims:
        if spec.name not in c.all_scenarios():
            continue
        for target in c.targets:
            sub = table[(table.scenario == spec.name) & (table.target == target)]
            if sub.empty:
                continue
            rows = {r["method"]: r for r in sub.to_dict("records")}
            for kind in ("slack", "prestretch"):
                pts = []
                for r in sub.to_dict("records"):
                    if r["kind"] not in ("none", kind):
                        continue
                    oks = [check(expr, {**rows, "band": r})[0] for expr in c.checks]
                    verdict = ("not reproduced" if any(v is False for v in oks) else
                               "not measured" if any(v is None for v in oks) else "reproduced")
                    pts.append({"value": r["fraction"], "verdict": verdict})
                v = {"points": pts, "structure": f"{spec.structure} ({_zeta_words(target)})",
                     "parameter": f"tip_band.{kind} / A"}
                k, text = bounded_summary(v)
                out.setdefault(c.id, []).append((k, text, f"{spec.name}, {target}, {kind}"))
    return out


def write_outputs(rows, table: pd.DataFrame, folder: Path, *, figures: bool,
                  figure_format: str = "png") -> None:
    """``nonlinearity.md``, ``nonlinearity.csv`` and (``figures``) Figs. 5.12 / 5.13 per row."""
    from .report import table_csv

    folder = Path(folder)
    (folder / "nonlinearity.csv").write_text(table_csv(table), encoding="utf-8", newline="\n")
    r0 = rows[0]
    text = [
        "# The §5.2 nonlinearity checks (Figs. 5.12, 5.13)\n\n",
        "Generated by `podbench run` from the claims file's `[nonlinearity]` table "
        "(`podbench.harness.nonlinearity_study`); do not edit. Five half-sine impulses at "
        "4 in (peaks 0.36 … 1.8 lbf), 2.2-s records at 0.1 ms, tip sensor; offsets are "
        "fractions of A, the largest tip amplitude of the literal band (no slack) under the "
        "1.8-lbf load. Readings: docs/chapter5_nonlinearity.md.\n\n",
        f"A = {r0['amplitude_in']:.5g} in; T = {r0['period_s']:.5g} s (bare beam)\n\n",
        markdown_table(rows), "\n\n",
        "Claim metrics (`nonlinearity.csv`): deviation = ‖s₀ − s_b‖/‖s_b‖ of the 0.36-lbf "
        "scaled tip history; scaled_*_change = relative change of the scaled RMS / band-side "
        "peak from 0.36 to 1.8 lbf; lag_* = lag of the 0.36-lbf response behind the baseline "
        "(% of T) at the first / last time.\n\n",
        "| ζ | row | deviation | scaled RMS change | scaled peak change | lag first (% T) "
        "| lag last (% T) |\n|---|---|---|---|---|---|---|\n"]
    for r in table.to_dict("records"):
        text.append(f"| {r['target']} | {r['method']} | {r['deviation']:.3g} "
                    f"| {r['scaled_rms_change']:+.3g} | {r['scaled_away_change']:+.3g} "
                    f"| {r['lag_first']:+.3g} | {r['lag_last']:+.3g} |\n")
    (folder / "nonlinearity.md").write_text("".join(text), encoding="utf-8", newline="\n")
    if figures:
        fdir = folder / "figures"
        fdir.mkdir(exist_ok=True)
        for r in rows:
            tag = f"{zeta_label(r['zeta'])}__{row_label(r)}"
            figure_scaled_tip(r["data"], fdir / f"fig5_12__{tag}.{figure_format}",
                              window=r["period_s"], title=f"Scaled tip displacements, {tag}")
            figure_phase_lag(r["data"], r["lags"], r["times"],
                             fdir / f"fig5_13__{tag}.{figure_format}",
                             title=f"Phase lag behind the 1.8-lbf response, {tag}")
    return None

