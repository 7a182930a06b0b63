"""§5.2 in the study: cross-scenario operands naming a structure and target, the
[nonlinearity] table, the claim rows of the nonlinearity checks and their swept verdicts."""

import numpy as np
import pandas as pd
import pytest

from podbench.errors import ScenarioFileError
from podbench.harness.nonlinearity import run_checks
from podbench.study.claims import evaluate_claims, load_claims, load_claims_file
from podbench.study.nonlinearity import NonlinearitySpec, claim_rows
from podbench.study.sensitivity import swept_verdicts

TABLE = pd.DataFrame([
    {"scenario": "rb", "structure": "rubber", "method": "ML", "target": "load4",
     "linearization_error": 0.0157},
    {"scenario": "ch4", "structure": "nl_beam", "method": "ML", "target": "load5",
     "linearization_error": 0.156},
    {"scenario": "ch4", "structure": "nl_beam", "method": "ML", "target": "other",
     "linearization_error": 0.001},
])


def _claims(tmp_path, checks, scenario="rb", structure="rubber", target="load4", extra=""):
    p = tmp_path / "claims.toml"
    p.write_text(f'''{extra}
[[claims]]
id = "x"
source = "s"
quote = "q"
scenario = "{scenario}"
structure = {structure!r}
target = {target!r}
checks = {checks!r}
'''.replace("'", '"'))
    return p


def test_cross_scenario_operand_names_structure_and_target(tmp_path):
    p = _claims(tmp_path, ["ML.linearization_error < ch4/nl_beam/load5:ML.linearization_error"])
    e = evaluate_claims(load_claims(p)[0], TABLE)[0]
    assert e.verdict == "reproduced"  # 0.0157 < 0.156
    assert "ch4/nl_beam/load5:ML.linearization_error = 0.156" in e.details[0].shown
    # another target of the same scenario: 0.0157 > 0.001
    p = _claims(tmp_path, ["ML.linearization_error < ch4/nl_beam/other:ML.linearization_error"])
    assert evaluate_claims(load_claims(p)[0], TABLE)[0].verdict == "not reproduced"
    # half a location is not measurable (and says why)
    p = _claims(tmp_path, ["ML.linearization_error < ch4/nl_beam:ML.linearization_error"])
    e = evaluate_claims(load_claims(p)[0], TABLE)[0]
    assert e.verdict == "not measured" and "SCENARIO/STRUCTURE/TARGET" in e.details[0].shown


@pytest.mark.parametrize("table, field", [
    ('structure = "rubber_band_beam"\nzetas = [0.0]\nfractions = [0.5]', "fractions"),
    ('structure = "rubber_band_beam"\nzetas = [1.5]\nfractions = [0.0]', "zetas"),
    ('structure = "rubber_band_beam"\nzetas = [0.0]\nfractions = [0.0]\nbogus = 1', "bogus"),
])
def test_bad_nonlinearity_table_gives_one_line(tmp_path, table, field):
    p = _claims(tmp_path, ["ML.x < 1"], extra=f"[nonlinearity]\n{table}\n")
    with pytest.raises(ScenarioFileError) as ei:
        load_claims_file(p)
    msg = str(ei.value)
    assert "\n" not in msg and "claims.toml" in msg and field in msg, msg


def _row(kind, frac, dev, rms_change, lag_last, zeta=0.0):
    rms = np.array([1.0, 1.0 + rms_change])
    return {"zeta": zeta, "kind": kind, "fraction": frac, "offset_in": 0.01 * frac,
            "amplitude_in": 0.01, "period_s": 0.1, "deviation": np.array([dev, 0.0]),
            "rms": rms, "away": rms, "lags": np.array([[lag_last / 4, lag_last], [0, 0]])}


def test_swept_verdicts_say_over_which_slack_a_claim_holds(tmp_path):
    spec = NonlinearitySpec("rubber", (0.0,), (0.0, 0.25, 0.5, 1.0))
    rows = [_row("none", 0.0, 1e-13, 0.0, 0.0),
            _row("slack", 0.25, 0.09, -0.013, 44.8), _row("slack", 0.5, 0.03, -0.006, 14.9),
            _row("slack", 1.0, 1e-13, 0.0, 0.0),
            _row("prestretch", 0.25, 0.06, 0.01, -40.2),
            _row("prestretch", 0.5, 0.015, 0.003, -11.9),
            _row("prestretch", 1.0, 1e-13, 0.0, -0.02)]
    table = claim_rows(rows, spec)
    assert list(table.method) == ["band", "slack_0.25A", "slack_0.5A", "slack_1A",
                                  "prestretch_0.25A", "prestretch_0.5A", "prestretch_1A"]
    assert table.scaled_rms_change.iloc[1] == pytest.approx(-0.013)
    assert table.lag_growth.iloc[2] == pytest.approx(14.9 * 0.75, rel=1e-3)  # 4 digits
    assert table.deviation.iloc[0] == 0.0  # 1e-13: round-off of the linear band, written 0
    p = _claims(tmp_path, ["band.lag_last > 0.01"], scenario="nonlinearity",
                structure="rubber", target="undamped")
    claims = load_claims(p)[0]
    e = evaluate_claims(claims, table)[0]
    assert e.verdict == "not reproduced"  # the literal band: lag 0
    sw = swept_verdicts(claims, table, spec)["x"]
    (k1, t1, w1), (k2, t2, w2) = sw
    assert w1 == "nonlinearity, undamped, slack" and w2 == "nonlinearity, undamped, prestretch"
    assert k1 == "depends on an unstated parameter"
    assert t1.startswith("holds at 0.25–0.5, fails at 0, 1 of rubber (undamped) "
                         "`tip_band.slack / A` 0–1")
    assert k2 == "fails over the studied range"


@pytest.mark.slow
def test_nonlinearity_claim_rows_against_the_raw_responses():
    """Undamped, literal band and a slack of 0.5 A (15 simulations of 2.2 s, ~30-60 s): the
    claim metrics recomputed from the tip histories; the literal band is homogeneous."""
    spec = NonlinearitySpec("rubber_band_beam", (0.0,), (0.0, 0.5))
    rows = run_checks(spec)
    assert [(r["kind"], r["fraction"]) for r in rows] == [
        ("none", 0.0), ("slack", 0.5), ("prestretch", 0.5)]
    table = claim_rows(rows, spec)
    for r, m in zip(rows, table.to_dict("records"), strict=True):
        d = r["data"]
        win = d.t <= r["period_s"] + 1e-12
        sc = d.tip[:, win] / d.impulses[:, None]
        # four significant digits, round-off (< 1e-9) written as 0
        assert m["deviation"] == pytest.approx(
            np.linalg.norm(sc[0] - sc[-1]) / np.linalg.norm(sc[-1]), rel=1e-3, abs=1e-9)
        rms = np.sqrt(np.mean(sc**2, axis=1))
        assert m["scaled_rms_change"] == pytest.approx((rms[-1] - rms[0]) / rms[0],
                                                       rel=1e-3, abs=1e-9)
    band, slack, pre = table.to_dict("records")
    assert band["deviation"] < 1e-9 and abs(band["lag_last"]) < 1e-6
    # slack: stiffening, small loads lag (frequency rises with load); pre-stretch: the reverse
    assert slack["deviation"] > 0.01 and slack["scaled_rms_change"] < 0 < slack["lag_last"]
    assert pre["lag_last"] < 0


def test_impulse_responses_read_back_exactly_from_the_cache(tmp_path):
    """A cached response equals the simulated one bit for bit (the study's tables must not
    depend on whether the cache was warm); a changed band misses the cache."""
    from podbench.harness.cache import TruthCache
    from podbench.harness.nonlinearity import band_variant, impulse_responses
    from podbench.structures.files import load_structure

    s = load_structure("rubber_band_beam")
    cache = TruthCache(tmp_path)
    a = impulse_responses(s, (0.36, 1.8), t_end=0.02)
    b = impulse_responses(s, (0.36, 1.8), t_end=0.02, cache=cache)
    c = impulse_responses(s, (0.36, 1.8), t_end=0.02, cache=cache)
    assert (cache.misses, cache.hits) == (2, 2)
    for x in (b, c):
        assert np.array_equal(x.tip, a.tip) and np.array_equal(x.impulses, a.impulses)
    # impulse of a 1-ms half-sine of peak P sampled at 0.1 ms: P * dt * sum(sin(pi k / 10))
    k = np.arange(1, 10)
    assert a.impulses[1] == pytest.approx(1.8 * 1e-4 * np.sin(np.pi * k / 10).sum(), rel=1e-9)
    impulse_responses(band_variant(s, slack=0.001), (1.8,), t_end=0.02, cache=cache)
    assert cache.misses == 3


@pytest.mark.slow
def test_podbench_run_writes_and_judges_the_nonlinearity_checks(tmp_path):
    """A whole-study `podbench run` with a [nonlinearity] table (undamped, slack 0 and
    0.5 A: 15 simulations of 2.2 s, ~40-80 s) writes nonlinearity.md/.csv, judges the claim
    on the band and sweeps it in FINDINGS; a rerun from the cache is byte-identical; a run of
    one file of the study skips the checks."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from podbench.core.resources import bundled_scenarios

    root = Path(__file__).resolve().parents[2]
    study = tmp_path / "s"
    study.mkdir()
    shutil.copy(bundled_scenarios() / "chapter4" / "beam_forced.toml", study)
    sc = (study / "beam_forced.toml").read_text().replace(
        'structures = ["lti_beam", "ltv_beam", "nl_beam"]', 'structures = ["lti_beam"]')
    (study / "beam_forced.toml").write_text(sc)
    (study / "other.toml").write_text(sc.replace('name = "beam_forced"', 'name = "other"'))
    (study / "claims.toml").write_text('''
[nonlinearity]
structure = "rubber_band_beam"
zetas = [0.0]
fractions = [0.0, 0.5]

[[claims]]
id = "freq"
source = "s"
quote = "q"
scenario = "nonlinearity"
structure = "rubber_band_beam"
target = "undamped"
checks = ["band.lag_last > 0.01"]
''')
    env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"}

    def run(out, *paths):
        r = subprocess.run([sys.executable, "-m", "podbench", "run", "-q", "--no-figures",
                            "--cache", str(tmp_path / "cache"), "-o", str(out), *paths],
                           capture_output=True, text=True, cwd=tmp_path, env=env)
        assert r.returncode == 0, r.stderr
        return out

    a = run(tmp_path / "a", str(study))
    nl = pd.read_csv(a / "nonlinearity.csv")
    assert list(nl.method) == ["band", "slack_0.5A", "prestretch_0.5A"]
    assert abs(nl.lag_last[0]) < 1e-6 and nl.lag_last[1] > 0.01 > nl.lag_last[2]
    findings = (a / "FINDINGS.md").read_text()
    assert "| [freq](#freq) | s | not reproduced | depends on an unstated parameter: " \
           "holds at 0.5, fails at 0 of rubber_band_beam (undamped) `tip_band.slack / A`" \
        in findings
    assert "fails at every value of rubber_band_beam (undamped) `tip_band.prestretch / A`" \
        in findings
    b = run(tmp_path / "b", str(study))
    for f in ("nonlinearity.csv", "nonlinearity.md", "FINDINGS.md", "summary.csv"):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    c = run(tmp_path / "c", str(study / "beam_forced.toml"))
    assert not (c / "nonlinearity.md").exists()
