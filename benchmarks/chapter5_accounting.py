"""CPU seconds of a cold Chapter 5 run, task by task and row by row, split by who reads them.

    nice -n 10 python benchmarks/chapter5_accounting.py --out /tmp/ch5acc     # ~10 min of CPU
    python benchmarks/chapter5_accounting.py --report /tmp/ch5acc            # table again

Runs ``podbench run chapter5 --jobs 1 --no-figures`` in this process with an empty truth
cache (one BLAS thread), timing every task of the pool (the units, the noise seeds' refits,
the nonlinearity checks) in CPU seconds (``time.process_time``), and every reported method of
a unit (``timing.csv``'s ``seconds``: its fit, twins, refits and bands; the runner's clock
replaced by the CPU clock in this process only). A method's row counts as *read* when a check
of ``scenarios/chapter5/claims.toml`` (claims and named variants) reads it
(:func:`podbench.study.claims.checked_rows`: the seeds refit exactly these), as *mentioned*
when its label appears in the committed FINDINGS.md (outside its calibration summary, which
lists every label) or in docs/chapter5.md before its Speed section (a reading may cite it),
else as *unread*. Writes ``tasks.csv``, ``methods.csv`` and the study's
tables to ``--out``; prints the shares.

Speed is measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
import types
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CALIBRATION_LINE = "Every prediction's 90 % band"
SPEED_SECTION = "\n## Speed"


def _run(out: Path) -> None:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import pandas as pd

    from podbench import cli
    from podbench.harness import runner

    rows = []
    orig = runner._dispatch

    def timed(item):
        func, task = item
        t0 = time.process_time()
        r = orig(item)
        secs = time.process_time() - t0
        name = getattr(func, "__name__", str(func))
        if name == "_unit_worker":
            label = f"{Path(task[0]).stem} × {task[1]}"
        elif name == "seed_unit":
            label = f"{Path(task[0]).stem} × {task[1]} seed {task[2]}"
        else:
            label = f"{task[0]} zeta {task[1]} fraction {task[2]}"
        rows.append({"kind": name, "task": label, "cpu_s": secs})
        return r

    runner._dispatch = timed
    runner.time = types.SimpleNamespace(perf_counter=time.process_time)  # timing.csv in CPU s
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as cache:
        code = cli.main(["run", "chapter5", "--jobs", "1", "--no-figures", "--quiet",
                         "--cache", cache, "--out", str(out / "tables")])
    total = time.process_time() - t0
    if code != 0:
        sys.exit(f"podbench run chapter5 exited {code}")
    rows.append({"kind": "total", "task": "whole run in this process", "cpu_s": total})
    pd.DataFrame(rows).to_csv(out / "tasks.csv", index=False)


def _classify(out: Path):
    import pandas as pd

    from podbench.study.claims import checked_rows, load_claims_file

    claims_file = load_claims_file(ROOT / "scenarios" / "chapter5" / "claims.toml")
    read = checked_rows(claims_file.claims)
    timing = pd.read_csv(out / "tables" / "timing.csv")
    findings = (ROOT / "results" / "chapter5" / "FINDINGS.md").read_text(encoding="utf-8")
    docs = (ROOT / "docs" / "chapter5.md").read_text(encoding="utf-8")
    # not readings: the calibration summary lists every label; the docs' Speed section
    # names rows by their cost
    text = "".join(line for line in findings.splitlines(keepends=True)
                   if not line.startswith(CALIBRATION_LINE)) + docs.split(SPEED_SECTION)[0]

    def who(r) -> str:
        methods = read.get((r["scenario"], r["structure"]), ((), (), ()))[0]
        if r["method"] in methods:
            return "read"
        if re.search(rf"(?<![\w-]){re.escape(r['method'])}(?![\w-])", text):
            return "mentioned"
        return "unread"

    timing["reader"] = timing.apply(who, axis=1)
    return timing


def _report(out: Path) -> None:
    import pandas as pd

    tasks = pd.read_csv(out / "tasks.csv")
    total = float(tasks.loc[tasks.kind == "total", "cpu_s"].iloc[0])
    print(f"whole run: {total:.0f} s of CPU (one process, cold, no figures)")
    by_kind = tasks[tasks.kind != "total"].groupby("kind")["cpu_s"].agg(["sum", "count"])
    for kind, r in by_kind.iterrows():
        print(f"  {kind:14s} {r['sum']:7.1f} s  {100 * r['sum'] / total:5.1f} %  "
              f"({int(r['count'])} tasks)")
    m = _classify(out)
    m.to_csv(out / "methods.csv", index=False)
    units = float(by_kind.loc["_unit_worker", "sum"])
    print(f"units' methods (timing.csv, fit + twins + refits + bands): "
          f"{m['seconds'].sum():.1f} s of the units' {units:.1f} s")
    m["solver"] = m["method"].str.split("-", n=1).str[1].fillna(m["method"])
    for reader, g in m.groupby("reader"):
        print(f"  {reader:9s} {g['seconds'].sum():7.1f} s  "
              f"{100 * g['seconds'].sum() / total:5.1f} % of the run  ({len(g)} rows)")
        sol = g.groupby("solver")["seconds"].sum().sort_values(ascending=False)
        print("            " + ", ".join(f"{k} {v:.1f}" for k, v in sol.items()))
    noisy = m[m["scenario"].str.contains("noise|scatter|unit") & ~m["scenario"].str.contains(
        "noise_0pct")]
    un = noisy[noisy.reader != "read"]
    print(f"noisy scenarios' rows no check reads: {un['seconds'].sum():.1f} s "
          f"({100 * un['seconds'].sum() / total:.1f} % of the run, {len(un)} rows)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="folder for tasks.csv, methods.csv, tables")
    ap.add_argument("--report", type=Path, help="only print the shares of a finished run")
    a = ap.parse_args()
    if a.report is not None:
        _report(a.report)
        return
    if a.out is None:
        ap.error("--out or --report is needed")
    a.out.mkdir(parents=True, exist_ok=True)
    _run(a.out)
    _report(a.out)


if __name__ == "__main__":
    main()
