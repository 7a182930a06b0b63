"""Scenario inheritance (`scenario.base`) and structure variants (`[variants.<name>]`): the
sensitivity studies of scenarios/sensitivity run Chapter 4's cases on structures whose
unstated parameters (Fig. 4.3's tip-mass law, Fig. 4.2's cubic spring) are varied."""

import textwrap
from pathlib import Path

import numpy as np
import pytest

from podbench import cli, load_structure
from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.harness.runner import run_unit
from podbench.structures.beam import beam_mass
from podbench.study.resolve import resolve_structure
from podbench.study.scenarios import find_scenarios, load_scenario

ROOT = Path(__file__).resolve().parents[2]
CH4 = bundled_scenarios() / "chapter4"


def _write(tmp_path, name, text):
    p = tmp_path / f"{name}.toml"
    p.write_text(textwrap.dedent(text), encoding="utf-8")
    return p


def _derived(tmp_path, extra=""):
    return _write(tmp_path, "derived", f"""
        [scenario]
        name = "derived"
        base = "{CH4 / 'beam_free_displacement.toml'}"
        structures = ["light"]
        [variants.light]
        structure = "ltv_beam"
        set = {{ "tip_mass.mean" = 0.1, "tip_mass.amplitude" = 0.05 }}
        """ + textwrap.dedent(extra))


def test_a_derived_scenario_inherits_cases_methods_and_targets(tmp_path):
    base = load_scenario(CH4 / "beam_free_displacement.toml")
    sc = load_scenario(_derived(tmp_path))
    assert sc.base == base.path and sc.name == "derived"
    assert sc.structures == ("light",)
    assert sc.cases == base.cases and sc.methods == base.methods
    assert (sc.targets, sc.n_samples, sc.dt, sc.title) == (base.targets, base.n_samples,
                                                           base.dt, base.title)
    assert sc.digest != base.digest  # a change of the base file invalidates derived sweeps


def test_a_variant_replaces_the_named_fields_only(tmp_path):
    sc = load_scenario(_derived(tmp_path))
    light = resolve_structure("light", sc)
    heavy = load_structure("ltv_beam")
    assert light.name == "light" and "tip_mass.mean = 0.1" in light.description
    # steel, 24 × 1 × 0.75 in, 500 lbm/ft³ (structures/ltv_beam.toml)
    m_b = beam_mass(length=24.0, width=1.0, depth=0.75, density=500.0 / 1728 / 386.0886)
    assert m_b == pytest.approx(0.013490, rel=1e-4)
    t = np.array([0.0, 0.0125, 0.03])  # the law m(t) = mean·m_b·(1 + 0.5 sin(2πt/0.05))
    expected = 0.1 * m_b * (1 + 0.5 * np.sin(2 * np.pi * t / 0.05))
    np.testing.assert_allclose(light.variable_mass(t), expected, rtol=1e-6)  # g = 386.088…
    np.testing.assert_allclose(heavy.variable_mass(t), 10 * light.variable_mass(t), rtol=1e-12)
    for a, b in ((light.K, heavy.K), (light.M, heavy.M)):  # sparse: compare the entries
        assert (a != b).nnz == 0


@pytest.mark.heavy
def test_the_variant_runs_and_its_rows_carry_its_name(tmp_path):
    res = run_unit(_derived(tmp_path), "light", cache_dir=tmp_path / "cache")
    assert {r["structure"] for r in res.rows} == {"light"}
    assert all(r["status"] == "ok" for r in res.rows)


@pytest.mark.parametrize("extra, field, needle", [
    ("""
     [variants.bad]
     structure = "ltv_beam"
     set = { "tip_mass.meen" = 0.1 }
     """, "variants.bad.set", "does not have"),
    ("""
     [variants.bad]
     structure = "ltv_beam"
     set = { "tip_mass.mean" = "heavy" }
     """, "variants.bad.set", "another type"),
    ("""
     [variants.bad]
     structure = "no_such_beam"
     set = { "tip_mass.mean" = 0.1 }
     """, "variants.bad.structure", "no_such_beam"),
])
def test_a_bad_variant_is_one_line_exit_2_before_any_simulation(tmp_path, capsys, extra, field,
                                                                needle):
    p = _derived(tmp_path, extra)
    p.write_text(p.read_text().replace('structures = ["light"]', 'structures = ["bad"]'))
    code = cli.main(["run", str(p), "--out", str(tmp_path / "out"), "--cache",
                     str(tmp_path / "cache"), "-q", "--no-figures"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"field `{field}`" in err and needle in err
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.npz"))


def test_a_base_cycle_and_a_missing_base_are_errors(tmp_path):
    a = _write(tmp_path, "a", '[scenario]\nname = "a"\nbase = "b.toml"\n')
    _write(tmp_path, "b", '[scenario]\nname = "b"\nbase = "a.toml"\n')
    with pytest.raises(ScenarioFileError, match="field `scenario.base`.*cycle"):
        load_scenario(a)
    c = _write(tmp_path, "c", '[scenario]\nname = "c"\nbase = "nope.toml"\n')
    with pytest.raises(ScenarioFileError, match="field `scenario.base`: no such scenario"):
        load_scenario(c)


def test_the_sensitivity_studies_load_and_span_the_stated_ranges():
    files = find_scenarios([bundled_scenarios() / "sensitivity"])
    assert len(files) >= 4
    means, anchors = set(), set()
    for f in files:
        sc = load_scenario(f)
        assert sc.base is not None and set(sc.structures) <= set(sc.variants)
        for v in sc.variants.values():
            means.update(x for k, x in v.set.items() if k == "tip_mass.mean")
            anchors.update(x for k, x in v.set.items() if k == "tip_spring.k3_match_linear_at")
    assert min(means) == 0.02 and max(means) == 1.0  # × the beam's mass (issue 11 item 4)
    assert min(anchors) == 0.3 and max(anchors) == 1.0  # in


@pytest.mark.heavy
def test_a_sensitivity_study_judges_the_base_claims_on_every_variant(tmp_path, monkeypatch):
    """A folder of derived scenarios whose base folder has a claims.toml gets a FINDINGS.md
    with each claim's verdict at every value of the varied parameter."""
    from conftest import NL_BEAM

    from podbench.study.sensitivity import _ranges

    monkeypatch.chdir(tmp_path)
    base = tmp_path / "base"
    base.mkdir()
    (base / "nl_short.toml").write_text(textwrap.dedent(NL_BEAM.format(name="nl_short")))
    # one claim whose verdict must change with the spring: MDS's error on the NL beam falls
    # as the cubic spring weakens (the anchor displacement grows)
    (base / "claims.toml").write_text(textwrap.dedent('''
        [[claims]]
        id = "mds-under-half"
        source = "test"
        quote = "MDS is accurate"
        scenario = "nl_short"
        structure = "nl_beam"
        target = "w3"
        checks = ["MDS.total_error < 0.5"]
        '''))
    sens = tmp_path / "sens"
    sens.mkdir()
    variants = "".join(f'''
        [variants."k{a}"]
        structure = "nl_beam"
        set = {{ "tip_spring.k3_match_linear_at" = {a} }}
        ''' for a in (0.3, 1.0, 3.0))
    (sens / "nl_k3.toml").write_text(textwrap.dedent('''
        [scenario]
        name = "nl_k3"
        base = "../base/nl_short.toml"
        structures = ["k0.3", "k1.0", "k3.0"]
        ''') + textwrap.dedent(variants))
    out = tmp_path / "out"
    assert cli.main(["run", str(sens), "--out", str(out), "-q", "--no-figures"]) == 0
    import pandas as pd

    df = pd.read_csv(out / "summary.csv")
    mds = df[df.method == "MDS"].set_index("structure")["total_error"]
    expected = ["reproduced" if mds[f"k{a}"] < 0.5 else "not reproduced" for a in (0.3, 1.0, 3.0)]
    assert len(set(expected)) == 2, mds  # the verdict does change over this range
    text = (out / "FINDINGS.md").read_text()
    for a, verdict in zip((0.3, 1.0, 3.0), expected, strict=True):
        assert f"| {a:g} | k{a} | {verdict} |" in text
    points = [{"value": a, "verdict": v} for a, v in zip((0.3, 1.0, 3.0), expected, strict=True)]
    assert f"| `tip_spring.k3_match_linear_at` | {_ranges(points)} |" in text
    assert _ranges([{"value": 1, "verdict": "reproduced"}, {"value": 2, "verdict": "x"},
                    {"value": 3, "verdict": "reproduced"}, {"value": 4, "verdict": "reproduced"}]
                   ) == "1, 3–4"
