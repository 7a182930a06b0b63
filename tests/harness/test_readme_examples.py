"""The user method and user solver examples of docs/extending.md run as written, in a
scenario."""

import re
from pathlib import Path

import numpy as np
import pandas as pd
from conftest import CHAIN_FORCED

from podbench.harness.runner import run_study

PAGE = Path(__file__).resolve().parents[2] / "docs" / "extending.md"


def _example(first_line: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    found = [b for b in blocks if b.startswith(first_line)]
    assert len(found) == 1, first_line
    return found[0]


def test_readme_user_method_and_solver_run_in_a_scenario(write_scenario, tmp_path):
    p = write_scenario(CHAIN_FORCED + """
[[methods]]
label = "Shrunk"
method = "my_method.py:Shrunk"
n_modes = 5
train = ["f1"]
options = {{ factor = 0.5 }}
twin = "ML"

[[methods]]
label = "ML ridge"
method = "ML"
train = ["f1", "f2", "f3", "f4", "f5"]
options = {{ solver = "my_solver.py:Ridge", solver_options = {{ alpha = 1e-6 }} }}
""", "chain_forced")
    (p.parent / "my_method.py").write_text(_example("# my_method.py"))
    (p.parent / "my_solver.py").write_text(_example("# my_solver.py"))
    units = run_study([p])
    df = pd.DataFrame([r for u in units for r in u.rows]).set_index("method")
    assert (df.status == "ok").all()
    # Shrunk = SL × 0.5: its distance to the twin ML is |0.5·Ŵ_SL − Ŵ_ML|; ML is exact here
    # (k = m on the coupled chain), so Shrunk's total error is ‖0.5·Ŵ_SL − W‖ / ‖W‖ > 0.4
    assert df.loc["Shrunk", "total_error"] > 0.4
    assert df.loc["Shrunk", "diagonalization_error"] > 0.4
    # the ridge with a small α reproduces exact ML to within its α² regularization bias
    assert df.loc["ML ridge", "total_error"] < 1e-6  # measured 9.7e-9 at α = 1e-6
    assert np.isfinite(df.loc["ML ridge", "residual_error"])
    fits = {f["method"]: f for u in units for f in u.fits}
    assert fits["ML ridge"]["solver"] == "ridge"
