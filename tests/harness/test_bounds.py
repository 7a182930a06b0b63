"""The text's bound on an unstated parameter (issue 11 item 4): the measure of "diagonal
terms that are not close in value" against the consistent-mass theory, the values of the
sensitivity study it admits, and the sensitivity verdicts linked from the base FINDINGS."""

import textwrap

import numpy as np
import pytest

from podbench import cli, load_structure
from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.structures.beam import beam_mass
from podbench.study.bounds import evaluate_bounds, mass_diagonal_spread
from podbench.study.claims import load_claims_file
from podbench.study.scenarios import load_scenario
from podbench.study.sensitivity import bounded_summary

CH4 = bundled_scenarios() / "chapter4"
SENS = bundled_scenarios() / "sensitivity"
M_B = beam_mass(length=24.0, width=1.0, depth=0.75, density=500.0 / 1728 / 386.0886)
TIMES = np.arange(500) * 1.0e-4  # the §4.1 record: 0.05 s at 0.1 ms


def _theory(mean: float) -> np.ndarray:
    """Consistent mass of 24 Euler–Bernoulli elements (m_e = m_b/24): the interior vertical
    DOFs carry 2·156/420·m_e, the tip 156/420·m_e + m(t); the spread is max(r, 1/r)."""
    m_e = M_B / 24
    m = mean * M_B * (1 + 0.5 * np.sin(2 * np.pi * TIMES / 0.05))  # ltv_beam.toml's law
    r = (156 / 420 * m_e + m) / (312 / 420 * m_e)
    return np.maximum(r, 1 / r)


def test_the_lti_beam_tip_term_is_half_the_others():
    s = mass_diagonal_spread(load_structure("lti_beam"), TIMES)
    np.testing.assert_allclose(s, 2.0, rtol=1e-12)  # 312/156


@pytest.mark.parametrize("mean", [0.02, 0.1, 1.0])
def test_the_ltv_spread_follows_the_consistent_mass_and_the_law(mean):
    ltv = load_structure("ltv_beam", overrides={"tip_mass.mean": mean,
                                                "tip_mass.amplitude": mean / 2})
    np.testing.assert_allclose(mass_diagonal_spread(ltv, TIMES), _theory(mean), rtol=1e-10)


def test_the_bound_admits_the_tip_masses_that_spread_the_terms_beyond_the_lti_beams():
    claims = load_claims_file(CH4 / "claims.toml")
    (bound,) = claims.bounds
    assert (bound.structure, bound.reference, bound.statistic) == ("ltv_beam", "lti_beam",
                                                                   "mean")
    assert claims.sensitivity == SENS.resolve()
    seed = "/work/shared/seed/allison2007_pod_system_identification.txt"
    try:
        assert bound.quote in open(seed, encoding="utf-8").read()
    except FileNotFoundError:  # pragma: no cover - the seed is not shipped
        pass
    sc = load_scenario(SENS / "ltv_free_displacement.toml")
    got = evaluate_bounds(bound, sc, sc.structures)
    assert got["reference"]["mean"] == pytest.approx(2.0)
    for name in sc.structures:
        mean = sc.variants[name].set["tip_mass.mean"]
        s = _theory(mean)
        p = got["points"][name]
        assert p["mean"] == pytest.approx(s.mean()) and p["min"] == pytest.approx(s.min())
        assert p["admitted"] == (s.mean() > 2.0)
        assert p["admitted_alternative"] == (s.min() > 2.0)
    # r̄ = 0.5 + 24·mean/(312/420) > 2  <=>  mean > 0.0464: 0.02 is out, 0.05 in; at every
    # instant (r_min with the law's 0.5·mean) 0.05 is out too
    admitted = [sc.variants[n].set["tip_mass.mean"] for n in sc.structures
                if got["points"][n]["admitted"]]
    assert admitted == [0.05, 0.1, 0.2, 0.5, 1]
    assert not got["points"]["ltv_beam_m0.05"]["admitted_alternative"]


def _points(values, verdicts, admitted):
    return [{"value": v, "verdict": "reproduced" if ok else "not reproduced",
             "measure": {"admitted": a, "admitted_alternative": a}}
            for v, ok, a in zip(values, verdicts, admitted, strict=True)]


def test_the_bounded_summary_judges_only_the_admitted_values():
    class B:  # a bound (only its presence matters here)
        pass

    v = {"structure": "ltv_beam", "parameter": "tip_mass.mean", "bound": B(),
         "points": _points([0.02, 0.1, 0.5, 1], [False, True, True, False],
                           [False, True, True, True])}
    kind, text = bounded_summary(v)
    assert kind == "depends on an unstated parameter"
    assert text.startswith("holds at 0.1–0.5, fails at 1 of ltv_beam `tip_mass.mean` 0.1–1")
    v["points"] = _points([0.02, 0.1, 1], [False, True, True], [False, True, True])
    assert bounded_summary(v)[0] == "holds over the text's range"  # 0.02 is not admitted
    v["bound"] = None
    assert bounded_summary(v)[0] == "depends on an unstated parameter"


@pytest.mark.parametrize("extra, field", [
    ('[[bounds]]\nstructure = "b"\nmeasure = "nope"\nreference = "a"\nstatistic = "mean"\n'
     'alternative = "min"\nsource = "s"\nquote = "q"\nreading = "r"\n', "bounds[0].measure"),
    ('[[bounds]]\nstructure = "b"\nmeasure = "mass_diagonal_spread"\nreference = "a"\n'
     'statistic = "median"\nalternative = "min"\nsource = "s"\nquote = "q"\nreading = "r"\n',
     "bounds[0].statistic"),
])
def test_a_bad_bound_names_the_field(tmp_path, extra, field):
    p = tmp_path / "claims.toml"
    p.write_text(extra)
    with pytest.raises(ScenarioFileError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_claims_file(p)


def test_a_missing_sensitivity_folder_is_an_error(tmp_path):
    p = tmp_path / "claims.toml"
    p.write_text('sensitivity = "../nowhere"\n')
    with pytest.raises(ScenarioFileError, match="sensitivity.*not a folder"):
        load_claims_file(p)


@pytest.mark.heavy
def test_the_base_findings_link_the_sensitivity_verdicts(tmp_path, monkeypatch):
    """A base study whose claims file names a sensitivity folder: its FINDINGS.md gives each
    varied claim's verdict over the parameter, the same words as the sensitivity study's own
    FINDINGS.md, and is byte-identical on a second run."""
    from conftest import NL_BEAM

    monkeypatch.chdir(tmp_path)
    base, sens = tmp_path / "base", tmp_path / "sens"
    base.mkdir()
    sens.mkdir()
    (base / "nl_short.toml").write_text(textwrap.dedent(NL_BEAM.format(name="nl_short")))
    (base / "claims.toml").write_text(textwrap.dedent('''
        sensitivity = "../sens"
        [[claims]]
        id = "mds-under-half"
        source = "test"
        quote = "MDS is accurate"
        scenario = "nl_short"
        structure = "nl_beam"
        target = "w3"
        checks = ["MDS.total_error < 0.5"]
        '''))
    (sens / "nl_k3.toml").write_text(textwrap.dedent('''
        [scenario]
        name = "nl_k3"
        base = "../base/nl_short.toml"
        structures = ["k0.3", "k3.0"]
        [variants."k0.3"]
        structure = "nl_beam"
        set = { "tip_spring.k3_match_linear_at" = 0.3 }
        [variants."k3.0"]
        structure = "nl_beam"
        set = { "tip_spring.k3_match_linear_at" = 3.0 }
        '''))
    args = ["-q", "--no-figures", "--cache", str(tmp_path / "cache")]
    assert cli.main(["run", str(sens), "--out", str(tmp_path / "s"), *args]) == 0
    assert cli.main(["run", str(base), "--out", str(tmp_path / "b"), *args]) == 0
    import pandas as pd

    df = pd.read_csv(tmp_path / "s" / "summary.csv")
    mds = df[df.method == "MDS"].set_index("structure")["total_error"]
    held = [mds["k0.3"] < 0.5, mds["k3.0"] < 0.5]
    kind = ("holds over the studied range" if all(held) else "fails over the studied range"
            if not any(held) else "depends on an unstated parameter")
    findings = (tmp_path / "b" / "FINDINGS.md").read_text()
    assert "| claim | source | verdict | over the unstated parameter |" in findings
    row = next(line for line in findings.splitlines() if line.startswith("| [mds-under-half]"))
    assert f"| {kind}: " in row
    text = row.split(f"| {kind}: ")[1].rstrip(" |")
    assert text in (tmp_path / "s" / "FINDINGS.md").read_text()
    assert cli.main(["run", str(base), "--out", str(tmp_path / "b2"), *args]) == 0
    assert (tmp_path / "b2" / "FINDINGS.md").read_bytes() == findings.encode()
