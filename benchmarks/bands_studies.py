"""Score the error-estimate rules of :data:`podbench.sysid.methods.bands.ESTIMATE_RULE` (and
the input level's reference, :data:`~podbench.sysid.methods.bands.LEVEL_REFERENCE`) on a
committed study's cross-validated bands, offline: ``record`` runs the study (its MANIFEST
command, into a scratch folder) and stores each band's folds and target terms as JSON lines;
``score`` applies every rule to them through the band code itself and scores the estimates
against the study table's realized errors (rows matched in order by the stored estimate).

    python benchmarks/bands_studies.py record chapter5 --rows ch5.jsonl
    python benchmarks/bands_studies.py score ch5.jsonl results/chapter5/calibration.csv
    python benchmarks/bands_studies.py score peers.jsonl results/peers/summary.csv \
        --leverage-exponents 1 0.75 0.5
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

VARIANTS = (("gains", None, False), ("folds", None, False), ("folds-leverage", None, False),
            ("folds-gains", None, False), ("folds-gains", None, True))
LEVEL_VARIANTS = (("gains", "range", False), ("gains", "effective", False))


def record(study: str, rows: str, level_reference: str | None = None) -> int:
    """Run ``study`` (``--jobs 1``, no figures, into a scratch folder), appending one JSON
    line per cross-validated band to ``rows``."""
    from podbench.cli import main
    from podbench.sysid.methods import bands

    if level_reference:
        bands.LEVEL_REFERENCE = level_reference
    orig = bands._cross_validated

    def recorded(model, target, Wh, cal, c):
        out = orig(model, target, Wh, cal, c)
        err, _, _, terms, a = out
        ft = cal.fold_terms or []
        row = dict(method=type(model).__name__, err=err, lev2=terms.leverage2,
                   blind2=terms.blind2, rho=terms.rho, a=a, level_rule=cal.level_rule,
                   level_power=cal.level_power, fold_errors=[float(x) for x in cal.fold_errors],
                   fold_factors=[float(x) for x in cal.fold_factors],
                   fold_lev2=[t.leverage2 for t in ft], fold_blind2=[t.blind2 for t in ft],
                   fold_rho=[t.rho for t in ft], amplitude_range=list(cal.amplitude_range),
                   input_levels=list(cal.input_levels),
                   input_energies=list(cal.input_energies),
                   target_level=bands.input_level(target))
        with open(rows, "a") as f:
            f.write(json.dumps(row) + "\n")
        return out

    bands._cross_validated = recorded
    with tempfile.TemporaryDirectory() as out:
        return main(["run", study, "--jobs", "1", "-q", "--no-figures", "-o", out])


def load(rows_path: str, table: str, est_col: str = "error_estimate"):
    """The stored bands matched to the table's cross-validated rows, in order."""
    import pandas as pd

    rows = [json.loads(line) for line in open(rows_path)]
    t = pd.read_csv(table)
    t = t[t["source"] == "cross-validation"] if "source" in t.columns else \
        t[np.isfinite(pd.to_numeric(t[est_col], errors="coerce"))]
    t = t.reset_index(drop=True)
    out, keep, j = [], [], 0
    for i in range(len(t)):
        te = float(t.loc[i, est_col])
        k = j
        while k < len(rows) and not abs(rows[k]["err"] - te) <= 0.006 * abs(te) + 1e-12:
            k += 1
        if k < len(rows):
            out.append(rows[k])
            keep.append(i)
            j = k + 1
    return out, t.iloc[keep].reset_index(drop=True)


def rule_estimate(r: dict, rule: str, level_reference: str | None, growth: bool) -> float:
    """A stored band's estimate under ``rule`` (the band code's own constants)."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    old = (bands.ESTIMATE_RULE, bands.LEVEL_REFERENCE, bands.FOLDS_GAINS_GROWTH)
    bands.ESTIMATE_RULE, bands.FOLDS_GAINS_GROWTH = rule, growth
    bands.LEVEL_REFERENCE = level_reference or bands.LEVEL_REFERENCE
    try:
        terms = [TargetTerms(a, b, c) for a, b, c in
                 zip(r["fold_lev2"], r["fold_blind2"], r["fold_rho"], strict=True)]
        errors = np.array(r["fold_errors"])
        cal = bands.BandCalibration("cross-validation", np.zeros(0), 0.0,
                                    np.ones(bands.N_TIME_BINS), None, len(errors), 0,
                                    amplitude_range=tuple(r["amplitude_range"]),
                                    level_rule=r["level_rule"])
        if r["level_rule"] == "input":
            lv, en = r["input_levels"], r["input_energies"]
            exc = [bands.input_excursion(lv[j], lv[:j] + lv[j + 1:], en[:j] + en[j + 1:])
                   for j in range(len(lv))]
            cal.input_levels, cal.input_energies = tuple(lv), tuple(en)
            a = bands.input_excursion(r["target_level"], lv, en) if r["target_level"] else 1.0
        else:
            beta = r["level_power"]
            exc = np.array(r["fold_factors"]) ** (1.0 / beta) if beta > 0 else \
                np.ones(errors.size)
            a = r["a"]
        bands._rule_constants(cal, errors, terms, np.asarray(exc, dtype=float))
        return bands.rule_estimate(cal, TargetTerms(r["lev2"], r["blind2"], r["rho"]), a)
    finally:
        bands.ESTIMATE_RULE, bands.LEVEL_REFERENCE, bands.FOLDS_GAINS_GROWTH = old


def score(rows_path: str, table: str, realized: str = "total_error",
          exponents: tuple | None = None) -> str:
    """A markdown table: within ×2 (ML rows and the others), Spearman and the median
    estimate/realized of every rule on the matched rows; ``exponents``: one row more, the
    ``"gains"`` rule with the leverage exponent γ chosen per band's folds among them
    (:data:`~podbench.sysid.methods.bands.GAINS_LEVERAGE_EXPONENTS`)."""
    from scipy.stats import spearmanr

    from podbench.sysid.methods import bands

    rows, t = load(rows_path, table)
    tot = t[realized].to_numpy(float)
    ml = t["method"].astype(str).str.startswith("ML").to_numpy()
    variants = LEVEL_VARIANTS if any(r["level_rule"] == "input" for r in rows) else VARIANTS
    lines = [f"{len(rows)} of the table's cross-validated rows matched", "",
             "| rule | within ×2 | ML rows | other rows | Spearman | median estimate/realized |",
             "|---|---|---|---|---|---|"]
    extra = [("gains", None, False, exponents)] if exponents else []
    for rule, ref, growth, gammas in [v + (None,) for v in variants] + extra:
        old = bands.GAINS_LEVERAGE_EXPONENTS
        bands.GAINS_LEVERAGE_EXPONENTS = gammas or old
        try:
            est = np.array([rule_estimate(r, rule, ref, growth) for r in rows])
        finally:
            bands.GAINS_LEVERAGE_EXPONENTS = old
        ratio = est / tot
        ok = (ratio >= 0.5) & (ratio <= 2.0)
        part = [f"{np.mean(ok[m]):.3f}" if m.any() else "—" for m in (ml, ~ml)]
        name = rule + (" (growth)" if growth else "") + (f", level {ref}" if ref else "") + \
            (f", γ from {{{', '.join(f'{g:g}' for g in gammas)}}}" if gammas else "")
        lines.append(f"| {name} | {np.mean(ok):.3f} | {part[0]} | {part[1]} | "
                     f"{spearmanr(est, tot).correlation:.3f} | {np.median(ratio):.2f} |")
    return "\n".join(lines) if rows else "no rows matched"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    rec = sub.add_parser("record", help="run a study, storing its bands")
    rec.add_argument("study")
    rec.add_argument("--rows", required=True)
    rec.add_argument("--level-reference", choices=("range", "effective"), default=None)
    sc = sub.add_parser("score", help="score the rules on stored bands")
    sc.add_argument("rows")
    sc.add_argument("table", help="the study's table with error_estimate and the realized")
    sc.add_argument("--realized", default="total_error",
                    help="the realized error's column (f16_gvt: rel_whole)")
    sc.add_argument("--leverage-exponents", nargs="*", type=float, default=None,
                    help="one row more: the gains with γ chosen among these per band")
    args = ap.parse_args(argv)
    if args.cmd == "record":
        return record(args.study, args.rows, args.level_reference)
    print(score(args.rows, args.table, args.realized,
                tuple(args.leverage_exponents) if args.leverage_exponents else None))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
