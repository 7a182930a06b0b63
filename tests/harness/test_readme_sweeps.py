"""The sweeps page's table of the deconvolution solvers under noise (docs/studies/sweeps.md)
is results/beam_forced_noise/sweep.csv (issue 23: numbers in the docs come from the tables,
never typed): ML on the LTI
beam's load 5, the median total error over the seeds per noise level, the 5 % maximum in
brackets, three significant digits as sweep.md writes them."""

import re
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
LEVELS = (0.0, 0.01, 0.03, 0.05)


def expected_table() -> str:
    d = pd.read_csv(ROOT / "results" / "beam_forced_noise" / "sweep.csv")
    d = d[(d.structure == "lti_beam") & (d.method == "ML") & (d.target == "load5")]
    lines = ["| solver | noise 0 | 1 % | 3 % | 5 % |", "|---|---|---|---|---|"]
    for solver in dict.fromkeys(d.solver):
        s = d[d.solver == solver]
        cells = [f"{s[s.noise == lv].total_error.median():.3g}" for lv in LEVELS]
        cells[-1] += f" ({s[s.noise == LEVELS[-1]].total_error.max():.3g})"
        lines.append(f"| {solver} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def test_the_readme_solver_table_is_the_sweep():
    text = (ROOT / "docs" / "studies" / "sweeps.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- beam_forced_noise:[^>]*-->\n(.*?)\n<!-- /beam_forced_noise -->",
                      text, re.S)
    assert block, "docs/studies/sweeps.md lost its beam_forced_noise table markers"
    assert block.group(1) == expected_table()
