"""Scenario files: the Chapter 4 studies load; malformed files fail with one clear message."""

from pathlib import Path

import pytest
from conftest import CHAIN_FREE

from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.study.claims import load_claims
from podbench.study.scenarios import find_scenarios, load_scenario

ROOT = Path(__file__).resolve().parents[2]
CH4 = bundled_scenarios() / "chapter4"


def test_the_seven_chapter4_studies_load_as_the_dissertation_defines_them():
    files = find_scenarios([CH4])
    names = [f.stem for f in files]
    assert names == sorted(["beam_free_displacement", "beam_free_velocity", "beam_forced",
                            "beam_mixed", "truss_free_displacement", "truss_free_velocity",
                            "truss_forced"])
    sc = {f.stem: load_scenario(f) for f in files}
    modes = {(n, m.label): m.n_modes for n, s in sc.items() for m in s.reported_methods()}
    assert modes[("beam_free_displacement", "POVR")] == 3
    assert modes[("beam_free_velocity", "POVR")] == 4
    assert modes[("beam_forced", "SL")] == 4
    assert modes[("beam_mixed", "MR")] == 4
    assert modes[("truss_free_displacement", "POVR")] == 5
    assert modes[("truss_free_velocity", "POVR")] == 7
    assert modes[("truss_forced", "SL")] == 5
    # the coupled methods use as many data sets as the diagonal method uses modes
    assert len(sc["beam_free_displacement"].method("MDS").train) == 3
    assert len(sc["truss_free_velocity"].method("MDS").train) == 7
    assert len(sc["truss_forced"].method("ML").train) == 5
    assert sc["beam_forced"].cases["load5"].force[0]["location"] == 23.0
    assert sc["truss_forced"].n_samples == 200 and sc["truss_forced"].dt == 0.05


VARIANTS = bundled_scenarios() / "chapter4_variants"


def _without(d, *keys):
    return {k: v for k, v in d.items() if k not in keys}


def test_chapter4_variants_differ_from_the_main_study_only_in_their_reading():
    """scenarios/chapter4_variants/ (issue 11): each file is its main scenario with one
    reading changed: the fracture model, the impulse, or the pulses' start (f₀ ≠ 0)."""
    main = {f.stem: load_scenario(f) for f in find_scenarios([CH4])}
    var = {f.stem: load_scenario(f) for f in find_scenarios([VARIANTS])}
    assert sorted(var) == sorted([
        "truss_free_displacement__stiffness_only", "truss_free_velocity__stiffness_only",
        "truss_forced__stiffness_only", "beam_free_velocity__impulse_one_step",
        "beam_free_velocity__impulse_ideal_half_ms", "beam_mixed__impulse_one_step",
        "truss_free_velocity__impulse_one_step",
        "beam_forced__f0_nonzero", "beam_mixed__f0_nonzero", "truss_forced__f0_nonzero",
        "beam_mixed__design_19_11_3"])
    for name, v in var.items():
        base, kind = name.split("__")
        m = main[base]
        assert v.name == name and v.targets == m.targets and v.cases.keys() == m.cases.keys()
        assert [x.label for x in v.methods] == [x.label for x in m.methods]
        if kind == "stiffness_only":
            assert v.structures == ("satellite_truss_stiffness_only",)
            assert m.structures == ("satellite_truss",)
        else:
            assert v.structures == m.structures
        for case, c in v.cases.items():
            mc = m.cases[case]
            if kind.startswith("impulse") and c.initial_velocity is not None:
                iv, miv = c.initial_velocity, mc.initial_velocity
                # each section's own pulse (§4.1: 0.5 ms; §4.2.2: 0.4 s), measured; the
                # variant: one step of the scenario's dt, or the same duration, ideal
                pulse = 0.4 if base.startswith("truss") else 5e-4
                assert miv["velocity"] == "measured" and miv["duration"] == pulse
                assert "velocity" not in iv
                assert iv["duration"] == (v.dt if kind == "impulse_one_step" else pulse)
                assert _without(iv, "duration", "dt") == _without(miv, "duration", "dt",
                                                                   "velocity")
            elif kind == "f0_nonzero":
                assert len(c.force) == len(mc.force)
                for f, mf in zip(c.force, mc.force, strict=True):
                    assert f["start"] == 0.0 and "start" not in mf
                    assert _without(f, "start") == mf
            elif kind == "design_19_11_3" and case in "abc":  # the former impulse design
                iv, miv = c.initial_velocity, mc.initial_velocity
                assert iv["impulses"] == [[{"a": 19.0, "b": 11.0, "c": 3.0}[case], 1000.0]]
                assert miv["impulses"] == [[{"a": 3.0, "b": 19.0, "c": 11.0}[case], 1000.0]]
                assert _without(iv, "impulses") == _without(miv, "impulses")
                assert _without(c.__dict__, "initial_velocity") == \
                    _without(mc.__dict__, "initial_velocity")
            else:
                assert c == mc


def test_claims_file_parses_and_names_existing_rows():
    claims, _ = load_claims(CH4 / "claims.toml")
    assert len(claims) >= 20
    sc = {f.stem: load_scenario(f) for f in find_scenarios([CH4])}
    for c in claims:
        assert c.scenario in sc, c.id
        assert set(c.targets) <= set(sc[c.scenario].targets), c.id
        assert set(c.structures) <= set(sc[c.scenario].structures), c.id


@pytest.mark.parametrize("edit, field", [
    (("title =", "titel ="), "scenario.title"),                 # misspelt field
    (('n_samples = 300', 'n_samples = -3'), "scenario.n_samples"),
    (('dt = 0.002', 'dt = "fast"'), "scenario.dt"),
    (('train = ["x1"]', 'train = ["x9"]'), "methods[0].train[0]"),
    (('twin = "MDS"', 'twin = "XYZ"'), "methods[0].twin"),
    (('method = "POVR"', 'method = "PODX"'), "methods[0].method"),
    (('targets = ["x6"]', 'targets = ["nothing"]'), "scenario.targets[0]"),
    (('label = "MDS"', 'label = "POVR"'), "methods[1].label"),
])
def test_malformed_scenarios_name_the_file_and_field(write_scenario, edit, field):
    p = write_scenario(CHAIN_FREE.replace(*edit))
    with pytest.raises(ScenarioFileError) as e:
        load_scenario(p)
    msg = str(e.value)
    assert "chain_free.toml" in msg and f"`{field}`" in msg


def test_syntax_errors_name_mismatch_and_missing_paths(write_scenario, tmp_path):
    p = write_scenario(CHAIN_FREE + "\n[[broken\n")
    with pytest.raises(ScenarioFileError, match="TOML syntax error"):
        load_scenario(p)
    q = write_scenario(CHAIN_FREE, "other")
    q.rename(q.with_name("renamed.toml"))
    with pytest.raises(ScenarioFileError, match="does not match the file name"):
        load_scenario(q.with_name("renamed.toml"))
    with pytest.raises(ScenarioFileError, match="no such file or folder"):
        find_scenarios([tmp_path / "nope"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(ScenarioFileError, match="no scenario files"):
        find_scenarios([tmp_path / "empty"])


def test_unknown_structure_and_bad_excitation_are_scenario_errors(write_scenario):
    from podbench.harness.runner import run_unit

    p = write_scenario(CHAIN_FREE.replace('structures = ["chain_coupled"]',
                                          'structures = ["no_such_beam"]'))
    with pytest.raises(ScenarioFileError, match="no_such_beam"):
        run_unit(p, "no_such_beam")
    p = write_scenario(CHAIN_FREE.replace("loads = [[4, 1.0]], by = \"dof\"",
                                          "loads = [[40, 1.0]], by = \"dof\""))
    with pytest.raises(ScenarioFileError,
                       match=r"field `cases.x1.initial_displacement.loads\[0\]` on chain_coupled"):
        run_unit(p, "chain_coupled")
