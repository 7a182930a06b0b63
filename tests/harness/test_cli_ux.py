"""A new user's first hour: bundled data found by name, a part of a study never replaces the
study, progress on stderr (a bar or plain lines, nothing with --quiet), and the small items
of issue 14 (python -m podbench, list, sweep.md wording, one-line warnings, plurals, help)."""

import io
import subprocess
import sys
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import CHAIN_FORCED, CHAIN_FREE

from podbench import api, cli
from podbench.core.resources import (
    bundled_root,
    bundled_scenarios,
    bundled_structures,
    bundled_studies,
    display_path,
    resolve_bundled,
)
from podbench.harness.progress import Progress
from podbench.harness.runner import _failure
from podbench.harness.sweep import SWEEP_COLUMNS, sweep_table
from podbench.report.sweep import sweep_markdown

ROOT = Path(__file__).resolve().parents[2]

CLAIMS = '''
[[claims]]
id = "free-mds-exact"
source = "test"
quote = "MDS is exact"
scenario = "chain_free"
structure = "chain_coupled"
target = "x6"
checks = ["MDS.total_error < 1e-3"]

[[claims]]
id = "forced-ml-exact"
source = "test"
quote = "ML is exact"
scenario = "chain_forced"
structure = "chain_coupled"
target = "f6"
checks = ["ML.total_error < 1e-3"]
'''


@pytest.fixture
def study(write_scenario, tmp_path, monkeypatch):
    """tmp_path/my_study/{chain_free,chain_forced,claims}.toml, the current folder tmp_path."""
    monkeypatch.chdir(tmp_path)
    write_scenario(CHAIN_FREE, "chain_free", folder="my_study")
    write_scenario(CHAIN_FORCED, "chain_forced", folder="my_study")
    (tmp_path / "my_study" / "claims.toml").write_text(CLAIMS, encoding="utf-8")
    return tmp_path / "my_study"


def _tree(folder: Path) -> dict:
    """The study's files and contents; report.html (the date) and timing.csv (wall clock,
    not tracked) are left out."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name not in ("report.html", "timing.csv")}


# ------------------------------------------------------------------------- bundled data
def test_bundled_data_are_the_checkouts_top_level_folders():
    # in a checkout the bundled data are the project's top-level structures/ and scenarios/
    # (an installed wheel carries them as podbench/_bundled/: tests/test_install.py)
    root = bundled_root()
    assert root == ROOT and not resources.files("podbench").joinpath("_bundled").is_dir()
    assert root.joinpath("structures", "lti_beam.toml").is_file()
    assert root.joinpath("structures", "examples", "user_matrices.npz").is_file()
    assert root.joinpath("scenarios", "chapter4", "claims.toml").is_file()
    assert root.joinpath("scenarios", "sweeps", "beam_forced_noise.toml").is_file()
    assert bundled_structures() == bundled_root() / "structures"
    assert list(bundled_studies()) == ["base_excited", "calibration", "chapter4",
                                      "chapter4_variants", "chapter5", "f16_gvt",
                                      "mr_designs", "painter_street", "peers", "sensitivity",
                                      "substructuring", "sweeps"]
    assert len(list((bundled_scenarios() / "chapter4").glob("*.toml"))) == 8


def test_bundled_names_resolve_and_display_the_same_everywhere():
    ch4 = bundled_scenarios() / "chapter4"
    assert resolve_bundled("chapter4") == ch4
    assert resolve_bundled("chapter4/beam_forced") == ch4 / "beam_forced.toml"
    assert resolve_bundled("chapter4/beam_forced.toml") == ch4 / "beam_forced.toml"
    assert resolve_bundled("chapter4/claims") is None
    assert resolve_bundled("chapter9") is None and resolve_bundled("a/b/c") is None
    assert resolve_bundled("chapter5/experiment") is None
    assert display_path(ch4 / "claims.toml") == "scenarios/chapter4/claims.toml"


def test_an_unknown_name_is_one_line_naming_the_bundled_studies(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "chapter9", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "chapter9: no such file or folder, nor a bundled study or scenario" in err
    assert ("base_excited, calibration, chapter4, chapter4_variants, chapter5, f16_gvt, "
            "mr_designs, painter_street, peers, "
            "sensitivity, substructuring, sweeps") in err
    assert not (tmp_path / "results").exists()


def test_list_shows_bundled_and_local_with_where_each_comes_from(study, tmp_path, capsys):
    (tmp_path / "structures").mkdir()
    src = bundled_structures() / "chain_ideal.toml"
    (tmp_path / "structures" / "chain_ideal.toml").write_bytes(src.read_bytes())
    (tmp_path / "scenarios").mkdir()
    (study / "chain_free.toml").rename(tmp_path / "scenarios" / "chain_free.toml")
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "structures in ./structures:\n  chain_ideal\n" in out
    assert "structures bundled with podbench (structures):" in out
    assert "  chain_ideal  (a local file of this name comes first)" in out
    assert "scenarios in ./scenarios (podbench run scenarios):\n  chain_free:" in out
    assert "scenarios bundled with podbench: chapter4 (scenarios/chapter4" in out
    assert "  beam_forced: Beams, forced response to pulses" in out
    assert "scenarios bundled with podbench: sweeps (scenarios/sweeps" in out
    assert "  beam_forced_noise:" in out and "[sweep]" in out


# --------------------------------------------------------------------------- partial runs
@pytest.mark.heavy
def test_a_part_of_a_study_never_replaces_the_study(study, tmp_path, capsys):
    assert cli.main(["run", "my_study", "-q", "--no-figures"]) == 0
    whole = tmp_path / "results" / "my_study"
    assert "claims: 2 of 2 reproduced" in capsys.readouterr().out
    before = _tree(whole)

    # one file: its own folder, its own claims only, the study untouched, stdout says so
    assert cli.main(["run", "my_study/chain_forced.toml", "-q", "--no-figures"]) == 0
    out = capsys.readouterr().out
    part = tmp_path / "results" / "chain_forced"
    assert f"-> {Path('results') / 'chain_forced'}/summary.csv" in out
    assert "claims: 1 of 1 reproduced" in out
    assert (f"part of the study in my_study: written to {Path('results') / 'chain_forced'}/, "
            f"{Path('results') / 'my_study'}/ left as it was") in out
    assert _tree(whole) == before
    assert set(pd.read_csv(part / "summary.csv").scenario) == {"chain_forced"}
    findings = (part / "FINDINGS.md").read_text(encoding="utf-8")
    assert "forced-ml-exact" in findings and "free-mds-exact" not in findings

    # forcing the study's folder as --out is refused before any work
    assert cli.main(["run", "my_study/chain_forced.toml", "-q", "--out", str(whole)]) == 2
    err = capsys.readouterr().err
    assert "holds the results of 1 scenario this run does not produce (chain_free)" in err
    assert _tree(whole) == before

    # two files: names joined; the whole study again replaces its own folder
    assert cli.main(["run", "my_study/chain_forced.toml", "my_study/chain_free.toml", "-q",
                     "--no-figures"]) == 0
    assert (tmp_path / "results" / "chain_forced+chain_free" / "summary.csv").is_file()
    assert cli.main(["run", "my_study", "-q", "--no-figures"]) == 0
    assert _tree(whole) == before


# ------------------------------------------------------------------------------- progress
@pytest.mark.heavy
def test_progress_plain_lines_off_a_terminal_and_nothing_when_quiet(study, capsys):
    assert cli.main(["run", "my_study", "--no-cache"]) == 0
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert [ln.split("  ")[0] for ln in lines if ln.startswith("simulating")] == [
        "simulating and fitting: 0/2 units", "simulating and fitting: 1/2",
        "simulating and fitting: 2/2"]
    assert "drawing figures: 2/2" in cap.err and "\r" not in cap.err
    assert "elapsed" not in cap.out  # progress never goes to stdout
    # the first line says what runs, the last where the report is
    assert lines[0] == ("podbench: running 2 scenarios (2 units of structure × scenario); "
                        "then figures and report.html")
    assert cap.out.splitlines()[-1] == f"report: {Path('results') / 'my_study' / 'report.html'}"
    assert cli.main(["run", "my_study", "--no-cache", "--quiet"]) == 0
    quiet = capsys.readouterr()
    assert quiet.err == ""
    strip = [ln for ln in cap.out.splitlines() if " s (" not in ln]
    assert strip == [ln for ln in quiet.out.splitlines() if " s (" not in ln]


def test_progress_bar_on_a_terminal_counts_items():
    stream = io.StringIO()
    with Progress(bar=True, stream=stream).stage("drawing figures", 3, "figure") as st:
        for _ in range(3):
            st.advance("x")
    text = stream.getvalue()
    assert "drawing figures" in text and "3/3" in text and "\r" in text
    stream = io.StringIO()
    with Progress(quiet=True, bar=True, stream=stream).stage("units", 3, "unit") as st:
        st.advance()
    assert stream.getvalue() == ""


# ---------------------------------------------------------------------------- small items
def test_python_dash_m_podbench_runs_the_command_line():
    r = subprocess.run([sys.executable, "-m", "podbench", "--version"], capture_output=True,
                       text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and r.stdout.startswith("podbench ")


def test_regress_help_does_not_promise_findings(capsys):
    with pytest.raises(SystemExit):
        cli.main(["regress", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "FINDINGS" not in text and "nothing is written" in text
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "judged into FINDINGS.md" in text and "results/<file name>" in text


@pytest.mark.heavy
def test_responses_reused_within_a_run_are_not_cache_hits(study, tmp_path, capsys):
    # the same chain cases in two scenarios: a cold run simulates each distinct response once
    text = (study / "chain_free.toml").read_text(encoding="utf-8")
    (study / "chain_free_again.toml").write_text(
        text.replace('name = "chain_free"', 'name = "chain_free_again"'), encoding="utf-8")
    cache = tmp_path / "cache"
    assert cli.main(["run", "my_study", "-q", "--no-figures", "--cache", str(cache)]) == 0
    out = capsys.readouterr().out
    assert "(12 responses simulated, 0 from the cache)" in out
    assert cli.main(["run", "my_study", "-q", "--no-figures", "--cache", str(cache)]) == 0
    assert "(0 responses simulated, 12 from the cache)" in capsys.readouterr().out


def test_singular_and_plural(study, capsys):
    (study / "chain_forced.toml").unlink()
    assert cli.main(["run", "my_study/chain_free.toml", "-q", "--no-figures"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("2 rows from 1 scenario in ")
    assert cli._plural(1, "response") == "1 response" and cli._plural(2, "row") == "2 rows"
    assert cli._plural(1, "row has", "rows have") == "1 row has"


@pytest.mark.heavy
def test_a_corrupt_cache_entry_is_one_warning_line(study, tmp_path, capsys):
    cache = tmp_path / "cache"
    args = ["run", "my_study/chain_free.toml", "-q", "--no-figures", "--cache", str(cache)]
    assert cli.main(args) == 0
    entry = sorted(cache.rglob("*.npz"))[0]
    entry.write_bytes(b"not an npz file")
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        assert cli.main(args) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln]
    assert len(lines) == 1, err
    assert lines[0].startswith("podbench run: warning: truth cache: entry ")
    assert "unusable" in lines[0] and "re-simulating" in lines[0]
    assert ".py:" not in err and "warnings.warn" not in err


def test_structure_integer_field_message_uses_an(tmp_path):
    from podbench.errors import StructureFileError
    from podbench.structures import load_structure

    text = (bundled_structures() / "chain_ideal.toml").read_text(encoding="utf-8")
    assert "\nn = 5\n" in text
    p = tmp_path / "chain_ideal.toml"
    p.write_text(text.replace("\nn = 5\n", '\nn = "five"\n'), encoding="utf-8")
    with pytest.raises(StructureFileError, match=r"expected (an integer|a positive integer), "
                                                 r"got .five."):
        load_structure(p)


def test_failure_status_is_shortened_at_a_word():
    status = _failure(ValueError("word " * 100))
    assert len(status) <= 300 and status.endswith(" …")
    assert status[:-2].endswith("word")
    assert _failure(ValueError("short")) == "failed: ValueError: short"


def test_sweep_md_says_the_noise_free_column_is_one_run():
    rows = []
    for seed in (0, 1):
        for noise, err, status in ((0.0, 0.1, "failed: X: y"), (0.01, 0.2 + seed, "ok")):
            rows.append({"scenario": "s", "structure": "b", "method": "ML", "target": "t",
                         "n_modes": 4, "total_error": np.nan if status != "ok" else err,
                         "status": status, "noise": noise, "modes": -1, "seed": seed,
                         "solver": "ls"})
    df = sweep_table(rows)
    assert list(df.columns) == list(SWEEP_COLUMNS)

    class Sc:
        name, title, source, sweep = "s", "A sweep", "", None

    md = sweep_markdown(df, Sc)
    assert "median (max) over seeds 0, 1; noise 0: one noise-free run, no seed" in md
    assert "| b | ML | t | 4 | ls | failed | 0.7 (1.2) |" in md
    assert "- b / ML [ls] / t, 1 of 3 points: failed: X: y" in md  # not 2 of 4
    clean = sweep_table([r for r in rows if r["noise"] == 0 and r["seed"] == 0])
    assert "one noise-free run per point (no seed)" in sweep_markdown(clean, Sc)


def test_default_run_in_the_checkout_writes_results_chapter4(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    paths, files = api.resolve_study([])
    assert paths == [bundled_scenarios() / "chapter4"] and len(files) == 7
    assert api.default_out(paths) == Path("results") / "chapter4"
    assert api.default_out([files[0]]) == Path("results") / files[0].stem


def test_help_examples_keep_their_line_continuations():
    """An example continued with a backslash must show it: in a plain Python string "\\" +
    newline joins the lines, and `podbench predict --help` once printed its examples as one
    line with a run of spaces in the middle of the command."""
    import argparse
    import re

    parser = cli._parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in subs.choices.items():
        for line in (sub.epilog or "").splitlines():
            if line.lstrip().startswith("podbench "):
                command = line.split("#")[0].rstrip()
                assert not re.search(r"\S {3,}--", command), (name, line)


def test_the_runs_claims_line_counts_the_texts_claims_apart_from_variants():
    """`podbench run`'s last line on the claims counts as FINDINGS.md's headline: a claim
    with its part_of entries once, an uncheckable claim apart, variants only as a number
    (Chapter 5 once printed "20 of 45 reproduced", mixing both)."""
    from podbench.study.claims import NOT_CHECKABLE, TIE, Claim, ClaimResult, Verdict

    def entry(cid, verdict, **kw):
        c = Claim(id=cid, source="§5", quote="q", scenario="s", structures=("b",),
                  targets=("t",), checks=("A.x < 1",), criterion="c", note="", **kw)
        return ClaimResult(c, Verdict(verdict))

    claims = [entry("a", "reproduced"), entry("a2", "not reproduced", part_of="a"),
              entry("b", "reproduced"), entry("c", TIE), entry("d", "reproduced",
                                                              checkable=False),
              entry("a-stls", "reproduced", variant="solver: stls"),
              entry("b-ls", "not reproduced", variant="solver: ls")]
    assert cli._claims_line(claims) == (
        f"claims: 1 of the text's 4 reproduced, 1 not reproduced, 1 {TIE}, 1 {NOT_CHECKABLE}; "
        "2 variants also judged")
    assert cli._claims_line(claims[2:3]) == "claims: 1 of 1 reproduced"
