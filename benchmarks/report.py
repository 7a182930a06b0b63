"""Benchmark outputs: the CSV file and the Markdown tables of ``benchmarks/README.md``,
both written atomically (:mod:`podbench.core.atomic`)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from podbench.core.atomic import atomic_write_text

__all__ = ["FIELDS", "GROUPS", "row", "write_csv", "read_csv", "table", "write_readme",
           "previous_header"]

FIELDS = (
    "group", "case", "n", "k", "m", "solver", "status", "time_s", "peak_mb", "baseline",
    "baseline_time_s", "speedup", "max_rel_diff", "reference", "error_vs_truth", "note",
)
"""Columns of ``results/benchmarks.csv``."""
GROUPS = ("deconv", "pod", "newmark", "methods")


def row(**kw) -> dict:
    """A CSV row: the given fields, every other column empty."""
    out = {f: "" for f in FIELDS}
    out.update({k: v for k, v in kw.items() if v is not None})
    return out


def write_csv(rows, path: Path) -> None:
    """Write ``rows`` with :data:`FIELDS` to ``path`` (atomically)."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=FIELDS)
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def _diff_cell(r) -> str:
    diff = r["max_rel_diff"]
    if diff and r["reference"] and diff != "0 (reference)":
        diff = f"{diff} (vs {r['reference']})"
    return diff


def table(rows) -> str:
    """Markdown tables, one per benchmark group."""
    out = []
    deconv = [r for r in rows if r["group"] == "deconv"]
    if deconv:
        out += ["**Deconvolution** (LTI beam, 25 sensors, k pulse load cases; ML solves one "
                "n·k × n·k block system, SL k systems n × n; time = the method's `fit`)", "",
                "| method | n | k | solver | time (s) | peak memory (MB) | speed-up vs dense "
                "pinv | prediction vs reference (rel.) | prediction error vs truth | note |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in deconv:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['case']} | {r['n']} | {r['k']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {r['speedup']} | {_diff_cell(r)} | "
                       f"{r['error_vs_truth']} | {r['note']} |")
        out.append("")
    pod = [r for r in rows if r["group"] == "pod"]
    if pod:
        out += ["**POD of a tall snapshot matrix** (m sensors × n samples, k leading modes)", "",
                "| m | n | k | method | time (s) | peak memory (MB) | speed-up vs SVD | "
                "modes vs SVD (max ‖u − u_svd‖₂) | note |", "|---|---|---|---|---|---|---|---|---|"]
        for r in pod:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['m']} | {r['n']} | {r['k']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {r['speedup']} | {_diff_cell(r)} | {r['note']} |")
        out.append("")
    nm = [r for r in rows if r["group"] == "newmark"]
    if nm:
        prev = {(r["case"], str(r["m"]), str(r["n"])): r for r in nm
                if r["solver"] == "previous" and r["status"] == "ok"}

        def mem_ratio(r):
            b = prev.get((r["case"], str(r["m"]), str(r["n"])))
            if b is None or r["solver"] == "previous" or r["status"] != "ok":
                return ""
            return f"{float(b['peak_mb']) / float(r['peak_mb']):.3g}"

        out += ["**Newmark on a sparse chain** (`podbench.fem.chain`: tridiagonal M = I, K, "
                "Rayleigh C, 10 sensors; storage `previous` = the DOF load array and q, v, a "
                "at every DOF and sample as before, `full` = `simulate(dof_histories=True)`, "
                "`sensors` = `simulate(dof_histories=False)`, only W = S q recorded)", "",
                "| case | DOFs | samples | storage | time (s) | peak memory (MB) | memory: "
                "previous / this | time: previous / this | W vs previous (rel.) | note |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in nm:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['case']} | {r['m']} | {r['n']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {mem_ratio(r)} | {r['speedup']} | "
                       f"{r['max_rel_diff']} | {r['note']} |")
        out.append("")
    meth = [r for r in rows if r["group"] == "methods"]
    if meth:
        out += ["**Identification methods on the same data** (the peers study's LTI-beam "
                "records: 4 pulse loads, 25 sensors; target the pulse at 23 in; time = `fit` "
                "+ `predict`, all in one process; ML time / this: above 1 faster than ML)", "",
                "| method | n | k | time (s) | peak memory (MB) | ML time / this | "
                "prediction error vs truth (rel.) | note |", "|---|---|---|---|---|---|---|---|"]
        for r in meth:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['case']} | {r['n']} | {r['k']} | {t} | {r['peak_mb']} | "
                       f"{r['speedup']} | {r['error_vs_truth']} | {r['note']} |")
        out.append("")
    return "\n".join(out).rstrip()


def read_csv(path: Path) -> list[dict]:
    """Rows of an earlier results file (missing columns read as "")."""
    with open(path, newline="") as fh:
        return [{f: r.get(f) or "" for f in FIELDS} for r in csv.DictReader(fh)]


def previous_header(path: Path) -> str:
    """The first line of the results block of an earlier README ("Measured ... on: ...")."""
    start = "<!-- results:start -->"
    if not path.exists() or start not in (text := path.read_text()):
        return ""
    lines = text.split(start, 1)[1].strip().splitlines()
    return lines[0] if lines and lines[0].startswith("Measured") else ""


def write_readme(rows, path: Path, header: str) -> None:
    """Replace the block between the results markers of ``path`` by ``header`` and
    :func:`table` (atomically)."""
    start, end = "<!-- results:start -->", "<!-- results:end -->"
    text = path.read_text() if path.exists() else f"# Benchmarks\n\n{start}\n{end}\n"
    if start not in text or end not in text:
        text = text.rstrip() + f"\n\n{start}\n{end}\n"
    before, rest = text.split(start, 1)
    after = rest.split(end, 1)[1]
    block = f"{start}\n{header}\n\n{table(rows)}\n{end}"
    atomic_write_text(path, before + block + after)
