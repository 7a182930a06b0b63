"""Small scenarios for the harness tests (written into tmp_path)."""
# ruff: noqa: E501  (TOML scenario text: one excitation per line reads best)

import textwrap

import pytest

from podbench.harness import executor

CHAIN_FREE = """
[scenario]
name = "{name}"
title = "Coupled chain, free response (k = m = 5)"
source = "podbench test"
structures = ["chain_coupled"]
n_samples = 300
dt = 0.002
targets = ["x6"]

[cases.x1]
initial_displacement = {{ kind = "static_displacement", loads = [[4, 1.0]], by = "dof" }}
[cases.x2]
initial_displacement = {{ kind = "static_displacement", loads = [[1, -2.0]], by = "dof" }}
[cases.x3]
initial_displacement = {{ kind = "static_displacement", loads = [[2, 1.5], [4, -0.5]], by = "dof" }}
[cases.x4]
initial_displacement = {{ kind = "static_displacement", loads = [[3, 1.0]], by = "dof" }}
[cases.x5]
initial_displacement = {{ kind = "static_displacement", loads = [[0, 2.0], [3, 1.0]], by = "dof" }}
[cases.x6]
initial_displacement = {{ kind = "static_displacement", loads = [[1, 1.0], [2, 1.0], [4, 1.0]], by = "dof" }}

[[methods]]
label = "POVR"
method = "POVR"
n_modes = 5
train = ["x1"]
twin = "MDS"

[[methods]]
label = "MDS"
method = "MDS"
train = ["x1", "x2", "x3", "x4", "x5"]
"""

CHAIN_FORCED = """
[scenario]
name = "{name}"
title = "Coupled chain, forced response (k = m = 5)"
structures = ["chain_coupled"]
n_samples = 120
dt = 0.004
targets = ["f6"]

[cases.f1]
force = {{ kind = "pulse", location = 4, amplitude = 1.0, duration = 0.02, by = "dof" }}
[cases.f2]
force = {{ kind = "pulse", location = 3, amplitude = 1.0, duration = 0.02, by = "dof" }}
[cases.f3]
force = {{ kind = "pulse", location = 2, amplitude = 1.0, duration = 0.02, by = "dof" }}
[cases.f4]
force = {{ kind = "pulse", location = 1, amplitude = 1.0, duration = 0.02, by = "dof" }}
[cases.f5]
force = {{ kind = "pulse", location = 0, amplitude = 1.0, duration = 0.02, by = "dof" }}
[cases.f6]
force = {{ kind = "pulse", location = 2, amplitude = 2.0, duration = 0.06, by = "dof", shape = "half_sine" }}

[[methods]]
label = "SL"
method = "SL"
n_modes = 5
train = ["f1"]
twin = "ML"

[[methods]]
label = "ML"
method = "ML"
train = ["f1", "f2", "f3", "f4", "f5"]
"""

NL_BEAM = """
[scenario]
name = "{name}"
title = "NL and LTI beams, short free response"
structures = ["lti_beam", "nl_beam"]
n_samples = 150
dt = 1.0e-4
targets = ["w3"]

[cases.w0]
initial_displacement = {{ kind = "static_displacement", loads = [[17.0, 300.0], [18.0, 200.0], [24.0, -260.0]], reference = "lti_beam" }}
[cases.w1]
initial_displacement = {{ kind = "static_displacement", loads = [[24.0, 100.0]], reference = "lti_beam" }}
[cases.w2]
initial_displacement = {{ kind = "static_displacement", loads = [[8.0, -300.0]], reference = "lti_beam" }}
[cases.w3]
initial_displacement = {{ kind = "static_displacement", loads = [[14.0, 2000.0], [18.0, -1300.0]], reference = "lti_beam" }}

[[methods]]
label = "POVR"
method = "POVR"
n_modes = 3
train = ["w0"]
twin = "MDS"

[[methods]]
label = "MDS"
method = "MDS"
train = ["w0", "w1", "w2"]
"""


@pytest.fixture
def write_scenario(tmp_path):
    """write_scenario(template, name) -> path of a scenario file in tmp_path/scenarios."""

    def _write(template: str, name: str = "chain_free", folder: str = "scenarios"):
        d = tmp_path / folder
        d.mkdir(exist_ok=True)
        p = d / f"{name}.toml"
        p.write_text(textwrap.dedent(template.format(name=name)), encoding="utf-8")
        return p

    return _write


@pytest.fixture
def pool_at_once(monkeypatch):
    """Worker processes started at once with jobs > 1 (by default they start only after
    POOL_AFTER seconds of work in the calling process, which a test's tiny study never
    reaches): the test then really computes in two processes."""
    monkeypatch.setattr(executor, "POOL_AFTER", 0.0)
