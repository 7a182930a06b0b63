"""Start-up of ``podbench --help`` and ``podbench list`` against ``python -c "import numpy,
scipy.linalg"``, as ratios timed in one session (target: each within 3×).

    python benchmarks/cli_startup.py            # prints the ratios
    python benchmarks/cli_startup.py --write    # and replaces the cli_startup rows of
                                                # results/benchmarks.csv

Each command runs in a fresh interpreter (this one's), interleaved with the reference, best
of ``--repeats`` (7) each: a shared machine's load moves all three alike.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

from benchmarks import report  # noqa: E402

COMMANDS = {
    "reference": [sys.executable, "-c", "import numpy, scipy.linalg"],
    "podbench --help": [sys.executable, "-m", "podbench", "--help"],
    "podbench list": [sys.executable, "-m", "podbench", "list"],
}


def wall(cmd) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    best = {k: float("inf") for k in COMMANDS}
    for _ in range(args.repeats):
        for k, cmd in COMMANDS.items():
            best[k] = min(best[k], wall(cmd))
    ref = best["reference"]
    rows = []
    for k in ("podbench --help", "podbench list"):
        print(f"{k}: {best[k]:.3f} s; import numpy, scipy.linalg: {ref:.3f} s; ratio "
              f"{best[k] / ref:.2f}x (target <= 3x)")
        rows.append(report.row(group="cli_startup", case=k, status="ok",
                               time_s=f"{best[k]:.4g}", baseline="import numpy, scipy.linalg",
                               baseline_time_s=f"{ref:.4g}", speedup=f"{ref / best[k]:.3g}",
                               note=f"ratio {best[k] / ref:.2f} (python "
                                    "benchmarks/cli_startup.py)"))
    if args.write:
        path = ROOT / "results" / "benchmarks.csv"
        kept = [r for r in report.read_csv(path) if r.get("group") != "cli_startup"]
        report.write_csv(kept + rows, path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
