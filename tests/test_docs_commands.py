"""Every command and code block of the README and the docs is run by a test.

What counts: each fenced or indented code block of ``README.md``, ``docs/**/*.md`` (except
the generated CLI reference) and ``benchmarks/README.md``, and each inline code span that is
a command (it starts with ``podbench `` or ``python `` followed by ``-m`` or a script).
Every one of them must be listed below, in :data:`BLOCKS` (code blocks, by document and
first line) or :data:`COMMANDS` (each shell command, its trailing comment dropped), with how
it is tested:

* ``RUN`` / ``SLOW``: run as written, in a scratch folder holding copies of ``scenarios/``,
  ``structures/``, ``benchmarks/`` and ``docs/`` (so the checkout stays clean; ``results/``
  and the simulation cache land in the scratch folder), with this checkout's podbench
  first on ``PYTHONPATH``; it must exit 0. ``SLOW`` is marked ``slow`` (minutes);
* ``SYNOPSIS``: a usage line (placeholders, brackets): its subcommand exists and every
  ``--option`` it names is in the command's ``--help``;
* Python blocks run as a script in the scratch folder, after a stated prelude that defines
  what the block takes as given (``structure``, ``model``, records); TOML blocks parse, and
  the README's scenario runs as ``podbench run my_study/``;
* ``NOT_RUN`` / ``COVERED``: not run here, with the reason (it installs from the network,
  is the test suite itself, or another named test runs it).

A new command or block in the docs fails :func:`test_every_documented_command_is_listed`
until it is listed here.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]
GENERATED = {ROOT / "docs" / "reference" / "cli.md"}
"""Pages generated from the code (the CLI reference is the parser's ``--help``, checked by
tests/test_docs_site.py): not written by hand, so not listed here."""
DOCS = [ROOT / "README.md",
        *sorted(p for p in (ROOT / "docs").rglob("*.md") if p not in GENERATED),
        ROOT / "benchmarks" / "README.md"]

RUN, SLOW, SYNOPSIS = "run", "slow", "synopsis"


def NOT_RUN(reason: str) -> tuple[str, str]:  # noqa: N802 - reads as a table entry
    return ("not run", reason)


def COVERED(test: str) -> tuple[str, str]:  # noqa: N802
    assert (ROOT / test.split("::")[0]).is_file(), test
    return ("covered", test)


_SUITE = NOT_RUN("the test suite itself (running it from inside the suite would recurse); "
                 "CI runs it")
_INSTALL = NOT_RUN("installs into the current environment (from the network for the "
                   "extras); tests/test_install.py builds and installs the wheel and "
                   "test_the_extras_named_in_the_docs_exist checks the extra's name")

COMMANDS: dict[str, object] = {
    "podbench --help": COVERED("tests/harness/test_first_week.py::"
                               "test_the_command_line_imports_no_heavy_module_until_a_command_"
                               "needs_it"),
    "podbench regress chapter4": COVERED("tests/harness/test_first_week.py::"
                                         "test_regress_of_one_study_judges_only_its_rows"),
    "python benchmarks/era_order.py [--case beam|chain6|painter_street]": NOT_RUN(
        "a timing benchmark (ERA's order selection over its single fit, a ratio in one "
        "process); its measured ratios are in benchmarks/README.md"),
    'pip install -e ".[mdof]"': _INSTALL,
    "python benchmarks/cli_startup.py": NOT_RUN(
        "a timing benchmark (ratios against the numpy+scipy import in the same process); "
        "its rows are in results/benchmarks.csv"),
    # set-up and the test suite
    'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/podbench run':
        NOT_RUN("creates a virtual environment and installs from the network (minutes); "
                "its parts are tested: the install by tests/test_install.py, `podbench run` "
                "here (slow)"),
    ".venv/bin/python -m pytest": _SUITE,
    "python -m pytest": _SUITE,
    "python -m pytest -m slow -n 0": _SUITE,
    "python -m pytest -n 0": _SUITE,
    'python -m pytest -m "not slow and not heavy"': _SUITE,
    "pip install .": _INSTALL,
    "pip install 'podbench[peers]'": _INSTALL,
    "pip install 'podbench[mdof]'": _INSTALL,
    "pip install 'podbench[measured]'": _INSTALL,
    '.venv/bin/pip install -e ".[mdof]"': _INSTALL,
    "mkdocs serve": NOT_RUN("serves the site until stopped; the same site is built by "
                            "tests/test_docs_site.py"),
    "mkdocs build --strict": COVERED("tests/test_docs_site.py"),
    # usage lines
    "podbench run [PATH ...] [--jobs N] [--out DIR] [--cache DIR | --no-cache] [--engine "
    "exudyn] [--no-figures] [--quiet]": SYNOPSIS,
    "podbench regress [PATH ...] [--baseline CSV] [--rtol 0.01] [--atol 1e-6] [--update] "
    "[--table CSV]": SYNOPSIS,
    "podbench sweep [PATH ...] [--jobs N | --scheduler ADDRESS] [--noise ...] [--n-modes ...] "
    "[--seeds ...]": SYNOPSIS,
    "podbench sweep [PATH ...] [--jobs N | --scheduler tcp://host:8786] [--noise 0,0.01,0.05] "
    "[--n-modes 3,4,5] [--seeds 0-4] [--solvers ls,tls-dt] [--out DIR]": SYNOPSIS,
    "podbench experiment PATH [--check]": SYNOPSIS,
    "podbench <command>": SYNOPSIS,
    "podbench run <study>": SYNOPSIS,
    "podbench run FOLDER": SYNOPSIS,
    "podbench regress PATH": SYNOPSIS,
    "podbench sweep --scheduler": SYNOPSIS,
    "podbench predict": SYNOPSIS,
    "podbench methods NAME": SYNOPSIS,
    "python -m podbench.report.nonlinearity [--zeta 0] [--zeta 0.005] [--figures DIR]":
        SYNOPSIS,
    "python benchmarks/run.py --only deconv pod newmark --out PATH --readme PATH | --no-readme "
    "--dense-budget SECONDS (900) --dense-max-gb GIB (2) --newmark-max-gb GIB (2) --no-merge":
        SYNOPSIS,
    "python benchmarks/study_time.py --study chapter4 --jobs 1 [--tree OTHER_CHECKOUT] "
    "[--no-write]": SYNOPSIS,
    # quick commands
    "podbench list": RUN,
    "podbench methods": RUN,
    "podbench methods <name>": SYNOPSIS,
    "podbench predict --method": SYNOPSIS,
    "podbench fit --method M --train A.npz B.npz ... --out DIR [--solver S] [--n-modes K]":
        SYNOPSIS,
    "podbench predict --model DIR/model.npz --target X.npz --out OUT": SYNOPSIS,
    "podbench methods [NAME ...]": SYNOPSIS,
    "podbench predict --method ML --train FILE ... --target FILE ... --out DIR": COVERED(
        "tests/measured_io/test_predict_and_painter_street.py"),
    "podbench run chapter4/beam_forced": SLOW,  # 7 methods on three beams: ~35 s; the same
    # runner is run whole in the default suite by tests/harness/test_cli.py on a small scenario
    "podbench run scenarios/examples/measured/measured_chain.toml": RUN,
    "podbench experiment chapter5 --check": RUN,
    "python -m podbench.sysid.paramdocs docs/methods.md": RUN,
    "podbench run my_study/": COVERED("tests/test_docs_commands.py::"
                                      "test_the_readme_scenario_runs"),
    "podbench run path/to/my_study/": COVERED("tests/test_docs_commands.py::"
                                              "test_the_readme_scenario_runs"),
    # the studies and the long maintenance commands (minutes each)
    "podbench run": SLOW,
    "podbench run chapter4": SLOW,
    "podbench run calibration": SLOW,
    "podbench run chapter4_variants": SLOW,
    "podbench run painter_street": SLOW,
    "podbench run peers": SLOW,
    "podbench run sensitivity": SLOW,
    "podbench run substructuring": SLOW,
    "podbench run mr_designs": SLOW,
    "podbench run chapter5": SLOW,
    "podbench run chapter5 --no-figures --jobs 2": SLOW,
    "podbench experiment chapter5": SLOW,
    "podbench regress": SLOW,
    "podbench regress --update": SLOW,
    "podbench sweep": SLOW,
    "podbench sweep sweeps/beam_forced_noise": SLOW,
    "podbench sweep sweeps/peers_noise": SLOW,
    "podbench run base_excited": SLOW,
    "podbench run f16_gvt": SLOW,
    "podbench predict --method ML": SYNOPSIS,
    "podbench predict --method ML --solver tc": SYNOPSIS,
    ("podbench predict --method ML --train scenarios/f16_gvt/data/f16_fullmsine_level1_12N.npz "
     "scenarios/f16_gvt/data/f16_fullmsine_level3_37N.npz scenarios/f16_gvt/data/"
     "f16_fullmsine_level5_74N.npz --target scenarios/f16_gvt/data/"
     "f16_fullmsine_level2_25N_validation.npz scenarios/f16_gvt/data/"
     "f16_fullmsine_level4_61N_validation.npz --coverage 0.9 --out f16_ml"): SLOW,
    "python benchmarks/study_time.py --study f16_gvt --jobs 2 --no-write": NOT_RUN(
        "times a cold `podbench run f16_gvt` between two reference workloads (minutes on the "
        "shared machine); the study command itself is run (slow)"),
    "python benchmarks/f16_tc_oracle.py": SLOW,
    "python benchmarks/f16_tc_oracle.py --rules": SLOW,
    "python benchmarks/f16_tc_oracle.py --no-oracle --measured": SLOW,
    "python benchmarks/f16_time.py": SLOW,
    "python benchmarks/f16_time.py --srim-horizons 0.25,0.5,0.75": SLOW,
    "python benchmarks/study_time.py --jobs 1,2": NOT_RUN(
        "times two cold runs of the whole Chapter 5 study (tens of minutes on the shared "
        "machine); the study command itself is run (slow)"),
    "python benchmarks/study_time.py --baseline-tree PREVIOUS_CHECKOUT": NOT_RUN(
        "times two checkouts of a whole study against the reference workload (tens of "
        "minutes); the study commands themselves are run (slow)"),
    "python benchmarks/defaults.py": NOT_RUN(
        "the default-solver benchmark on a 150-DOF frame (minutes, dense `ls` included); its "
        "solvers are tested in tests/sysid/test_default_solver.py"),
    "python benchmarks/defaults.py --n 2000 --k 4 --no-ls --dt 1e-4": NOT_RUN(
        "as above, at n = 2000"),
    "python benchmarks/auto_test.py": NOT_RUN(
        "the noise test's whole confusion table (tens of minutes: the robust solver runs on "
        "every noisy point); its reduced form below is run"),
    "python benchmarks/auto_test.py --cases truss,frame40 --loads rect5 --on W": SLOW,
    "python -m podbench.report.nonlinearity": SLOW,
    "python -m tests.sysid.noise_study": SLOW,
    "python benchmarks/run.py --quick": SLOW,
    "python benchmarks/run.py --only methods": SLOW,
    "python benchmarks/run.py": NOT_RUN(
        "the full benchmark (large sizes, dense solves up to a 900-s budget) rewrites "
        "results/benchmarks.csv and benchmarks/README.md by design; its `--quick` and "
        "`--only methods` forms are run (slow)"),
    "python benchmarks/robust.py": NOT_RUN(
        "n = 8000, k = 16 with the dense comparison takes tens of minutes; the 1000×6 form "
        "below is run (slow)"),
    "python benchmarks/robust.py --sizes 1000x6 --solvers subspace,auto,kernel,realization,"
    "cgls --seeds 0,1,2,3,4": SLOW,
    "python benchmarks/bands.py": NOT_RUN(
        "times a band against the plain fit for nine method cases at two noise levels "
        "(minutes; speed is measured, never asserted); the bands themselves are tested in "
        "tests/sysid/test_bands.py"),
    "python benchmarks/bands.py --cpu --repeat 10": NOT_RUN(
        "the same timings on the process's CPU clock (minutes); speed is measured, never "
        "asserted"),
    "podbench predict --coverage 0.9": SYNOPSIS,
    "podbench predict --method ML|MDS --train … --target … --coverage 0.9": SYNOPSIS,
    "python benchmarks/bands_cli.py": NOT_RUN(
        "times the band through podbench predict on held-out-like files, eight designs at "
        "one or more noise levels (about 40 minutes); speed is measured, never asserted"),
    "python benchmarks/bands_cli.py --noise 0.01": NOT_RUN(
        "the same at 1 % noise (about 40 minutes at load 5)"),
    "python benchmarks/bands_heldout.py": NOT_RUN(
        "simulates and fits 46 models at three noise levels (half an hour on 2 cores); a "
        "design of it is run in tests/test_benchmarks.py"),
    "python benchmarks/bands_levels.py --data DIR": NOT_RUN(
        "reads the F-16 ground-vibration test's measured records, which are not in the "
        "checkout (the F-16 study's data); fits ML on 16384 samples with a 1600-sample FIR "
        "(minutes); the level term it measures is tested in "
        "tests/measured_io/test_io_bands.py"),
    "python benchmarks/bands_heldout.py --set dev": NOT_RUN(
        "simulates and fits 48 models at three noise levels (half an hour on 2 cores); a "
        "design of it is run in tests/test_benchmarks.py"),
    "python benchmarks/bands_heldout.py --set dev --features --rows dev.csv": NOT_RUN(
        "the dev set's half hour on 2 cores, each row also carrying the target's terms and "
        "its model's folds; a design of it is run in tests/test_benchmarks.py"),
    "python benchmarks/bands_studies.py record <study> --rows R": NOT_RUN(
        "runs a committed study (minutes to an hour on 2 cores) storing its bands; the "
        "scoring applies the band code's own rule functions, tested in tests/sysid"),
    "python benchmarks/bands_studies.py score R results/<study>/calibration.csv": NOT_RUN(
        "reads the rows a 'record' run stores (a study's run)"),
    "python benchmarks/bands_studies.py score R results/f16_gvt/summary.csv --realized "
    "rel_whole": NOT_RUN("reads the rows a 'record' run of the F-16 study stores"),
    "python benchmarks/bands_rules.py dev.csv": NOT_RUN(
        "reads the rows of a bands_heldout.py --features run (half an hour on 2 cores); its "
        "offline band is checked against the live one in tests/test_benchmarks.py"),
    "python benchmarks/bands_amplitude.py ROWS --set SET": NOT_RUN(
        "reads the rows of a bands_heldout.py --features run (half an hour on 2 cores); its "
        "load levels are checked by hand in tests/test_benchmarks.py"),
    "python benchmarks/bands_amplitude.py ROWS --set SET --note": NOT_RUN(
        "rebuilds the held-out designs' records (minutes) and reads the rows of a "
        "bands_heldout.py --features run; the note it scores is tested in "
        "tests/sysid/test_band_note.py"),
    "python benchmarks/bands_rules.py dev.csv --rules gains J hypot geomean gain": NOT_RUN(
        "reads the rows of a bands_heldout.py --features run (20 min on 2 cores); its offline "
        "band is checked against the live one in tests/test_benchmarks.py"),
    "python benchmarks/bands_rules.py dev.csv --rules J hypot geomean gain --jack-full":
        NOT_RUN("reads the rows of a bands_heldout.py --features run (20 min on 2 cores)"),
    "python benchmarks/bands_rules.py dev.csv --jack-diagnostics": NOT_RUN(
        "reads the rows of a bands_heldout.py --features run (20 min on 2 cores)"),
    "python benchmarks/bands_heldout.py --set dev --jack-cost": NOT_RUN(
        "times eight designs' fits, bands and fold refits (minutes; speed is measured, never "
        "asserted)"),
    "python benchmarks/bands_heldout.py --set test --rows test.csv": NOT_RUN(
        "simulates and fits 46 models at three noise levels (half an hour on 2 cores); a "
        "design of it is run in tests/test_benchmarks.py"),
    "python benchmarks/dense_tls.py": SLOW,
    "python benchmarks/tls_route.py": SLOW,
    "python benchmarks/tls_route.py --tridiagonal --chapter5": SLOW,
    "python benchmarks/tls_krylov.py": SLOW,
    "python benchmarks/study_time.py --study chapter5 --jobs 2": NOT_RUN(
        "times a cold `podbench run chapter5` between two reference workloads (6 min on 2 "
        "idle cores); the study command itself is run (slow)"),
    "python benchmarks/chapter5_accounting.py --out DIR": NOT_RUN(
        "runs the whole Chapter 5 study cold in one process, timing every task and row (10-20 "
        "min on the shared machine); the study command itself is run (slow)"),
    "python benchmarks/modal.py": NOT_RUN(
        "fits ML and ERA on two structures at two noise levels (minutes; accuracy is measured, "
        "never asserted) and rewrites its rows of results/benchmarks.csv; its one-structure "
        "clean form below is run (slow), the realizations and modes are tested in "
        "tests/sysid/test_modal.py"),
    "python benchmarks/modal.py --structures chain_coupled --levels 0 --no-write": SLOW,
    "python benchmarks/long_memory.py --structure S --oracle": NOT_RUN(
        "fits ML-poles (its pilot ML-TC with lags up to 2400 columns) and ERA on 40-s records "
        "(minutes per structure; the errors are measured, never asserted); the lengthening "
        "rule and the pole basis are tested in tests/measured_io/test_io_methods.py"),
    "python benchmarks/modal_matching.py": NOT_RUN(
        "runs chapter4 with the frequency tie-break of the modal matching (minutes); the "
        "rule is tested in tests/sysid/test_modal.py"),
    "python benchmarks/modal_matching.py --rule mac-frequency --copies each": NOT_RUN(
        "runs chapter4 reading every copy of a pole as a mode (minutes); the merge and the "
        "variant are tested in tests/sysid/test_modal.py"),
    "podbench fit": SYNOPSIS,
    "python benchmarks/model_file.py --repeat 3": NOT_RUN(
        "times fit + save + load + predict against fit + predict (a minute; the ratio is "
        "measured, never asserted); saved = fresh is tested in tests/sysid/test_models.py"),
    "python benchmarks/study_time.py": NOT_RUN(
        "times a cold `podbench run chapter5` (35 min on the shared 2-core machine) and "
        "appends to results/benchmarks.csv; `podbench run chapter5` itself is run (slow)"),
}
"""Every documented shell command → how it is tested."""

NOT_CODE = "not code"
BLOCKS: dict[tuple[str, str], object] = {
    # shell blocks: their lines are COMMANDS
    ("README.md", "python3 -m venv .venv && .venv/bin/pip install -e \".[test]\" && "
     ".venv/bin/podbench run"): "shell",
    ("docs/running.md", "podbench run [PATH ...] [--jobs N] [--out DIR] [--cache DIR | "
     "--no-cache] [--engine exudyn]"): "shell",
    ("docs/studies/sweeps.md", "podbench sweep [PATH ...] [--jobs N | --scheduler "
     "tcp://host:8786] [--noise 0,0.01,0.05]"): "shell",
    ("docs/index.md", "python3 -m venv .venv && .venv/bin/pip install -e \".[test]\" && "
     ".venv/bin/podbench run"): "shell",
    ("docs/getting-started.md", "python3 -m venv .venv && .venv/bin/pip install -e \".[test]\" "
     "&& .venv/bin/podbench run"): "shell",
    ("docs/studies/chapter4.md", "podbench run chapter4                 # = podbench run; "
     "writes results/chapter4/ (16 s)"): "shell",
    ("docs/bands.md", "python benchmarks/bands_heldout.py --set dev --features --rows "
     "dev.csv     # 20 min"): "shell",
    ("docs/studies/calibration.md", "podbench run calibration              # writes "
     "results/calibration/ (41 s)"): "shell",
    ("docs/studies/base_excited.md", "podbench run base_excited             # writes "
     "results/base_excited/ (SI units; 12 s)"): "shell",
    ("docs/studies/substructuring.md", "podbench run substructuring           # writes "
     "results/substructuring/ (104 s)"): "shell",
    ("docs/studies/painter_street.md", ".venv/bin/pip install -e \".[mdof]\"    # the "
     "committed tables include the mdof peer's rows"): "shell",
    ("docs/studies/regression.md", "podbench regress                      # Chapter 4 and 5 "
     "against results/baseline.csv"): "shell",
    ("docs/reference/records.md", "podbench predict --method ML --train FILE ... --target FILE "
     "... --out DIR"): "shell",
    ("docs/chapter5.md", "podbench experiment chapter5          # scenarios/chapter5/"
     "experiment.toml -> data/ (atomic)"): "shell",
    ("docs/peers.md", "pip install 'podbench[peers]'      # pydmd, opinf, and python-control "
     "(tests of ERA)"): "shell",
    ("benchmarks/README.md", "python benchmarks/run.py             # full run: writes "
     "results/benchmarks.csv and the table below"): "shell",
    ("benchmarks/README.md", "python benchmarks/robust.py                                "
     "# n=1000,k=6 and n=8000,k=16 at 1 %, subspace and auto"): "shell",
    ("benchmarks/README.md", "python benchmarks/study_time.py                     # podbench "
     "run chapter5, --jobs auto, no figures"): "shell",
    ("benchmarks/README.md", "python benchmarks/defaults.py                        # n = 1000, "
     "k = 4, dt = 1e-3 s"): "shell",
    ("docs/studies/f16_gvt.md", "podbench predict --method ML --train scenarios/f16_gvt/data/"
     "f16_fullmsine_level1_12N.npz scenarios/f16_gvt/data/f16_fullmsine_level3_37N.npz "
     "scenarios/f16_gvt/data/f16_fullmsine_level5_74N.npz --target scenarios/f16_gvt/data/"
     "f16_fullmsine_level2_25N_validation.npz scenarios/f16_gvt/data/"
     "f16_fullmsine_level4_61N_validation.npz --coverage 0.9 --out f16_ml"): "shell",
    ("benchmarks/README.md", "python benchmarks/modal.py                 # chain_coupled and "
     "aluminium_beam, clean and 1 % noise"): "shell",
    ("benchmarks/README.md", "python benchmarks/model_file.py --repeat 3"): "shell",
    ("docs/models.md", "python benchmarks/long_memory.py --structure S --oracle"): "shell",
    ("docs/models.md", "python benchmarks/modal_matching.py"): "shell",
    # Python blocks
    ("docs/studies/calibration.md", "p = model.predict(target, coverage=0.9)     # "
     "model.predict(target) still returns the array"): "python",
    ("docs/extending.md", "# my_method.py, beside the scenario file           # scenario: "
     "method = \"my_method.py:Shrunk\""): COVERED("tests/harness/test_readme_examples.py"),
    ("docs/extending.md", "# my_solver.py"): COVERED("tests/harness/test_readme_examples.py"),
    ("README.md", "import podbench as pb"): COVERED("tests/harness/test_readme_api.py"),
    ("docs/python-api.md", "import numpy as np"): COVERED("tests/harness/test_readme_api.py"),
    ("docs/dynamics.md", "from podbench.dynamics import simulate"): "python",
    ("docs/methods.md", "from podbench import Record"): "python",
    ("docs/models.md", "import numpy as np"): "python",
    ("docs/models.md", "# podbench fit and podbench predict --model, from Python"): "python",
    ("docs/structures.md", "from podbench.fem import load_structure, list_structures"): "python",
    ("docs/structures.md", "from podbench.fem.files import register_kind"): "python",
    # TOML blocks
    ("docs/reference/scenarios.md", "[scenario]"): COVERED(
        "tests/test_docs_commands.py::test_the_readme_scenario_runs"),
    ("docs/reference/scenarios.md", "# a variant of the NL beam (scenarios/sensitivity/"
     "nl_mixed.toml)"): COVERED("tests/test_docs_formats.py"),
    ("docs/reference/scenarios.md", "# scenarios/chapter5/linear_beam_noise_5pct.toml: the 0 % "
     "scenario with other record files"): COVERED("tests/test_docs_formats.py"),
    ("docs/reference/claims.md", "# one claim of scenarios/chapter4/claims.toml (quote "
     "shortened)"): COVERED("tests/test_docs_formats.py"),
    ("docs/structures.md", "# Units: inch, lbf, second (...)        <- first line, required by "
     "the tests for shipped files"): "toml",
    ("docs/structures.md", "[matrices]"): NOT_RUN(
        "a field reference with placeholders (`[...]`), not a file: tests/structures/"
        "test_structure_files.py loads matrices files with every field"),
    ("docs/structures.md", "builder = \"my_builder:build\"   # module:function"): "toml",
    # not code: diagrams, formulas and example output
    ("docs/ARCHITECTURE.md", "cli          podbench/cli.py            argument parsing, "
     "printing, exit codes; nothing else"): NOT_CODE,
    ("docs/ARCHITECTURE.md", "structures/*.toml ──► podbench.structures (load_structure) ──► "
     "Structure: M, C, K(t)"): NOT_CODE,
    ("docs/ARCHITECTURE.md", "record files (.npz, .mat; CSV, UFF 58 via podbench.core.iofiles)"):
        NOT_CODE,
    ("docs/ARCHITECTURE.md", "# podbench/sysid/methods/scaled.py: the one class"): COVERED(
        "tests/test_architecture.py::"
        "test_the_worked_example_adds_a_method_with_one_class_and_one_registry_line"),
    ("docs/ARCHITECTURE.md", "[study]"): NOT_RUN(
        "a template (`...` stands for the runner's own table): the complete files are "
        "scenarios/substructuring/substructuring.toml and scenarios/painter_street/"
        "painter_street.toml, run by `podbench run substructuring` / `painter_street` (slow)"),
    ("docs/structures.md", "T_top    = [[0, 0, -y_t], [1, 0, 0], [0, 0, 0]]     d_top    = "
     "T_top    (Δ_top, Δ_bot, Θ)"): NOT_CODE,
    ("docs/structures.md", "K_e = Σ_members (EA/L) gᵀ g,   g = eᵀ (B_j − B_i)"): NOT_CODE,
    ("docs/structures.md", "structures/foo.toml: field `beam.n_elements`: expected a positive "
     "integer, got -3"): NOT_CODE,
    ("docs/reference/scenarios.md", "my_study/my_study.toml: field `methods[1].train[2]`: "
     "unknown case \"load9\"; the file defines: load1, load2, ..."): NOT_CODE,
    ("docs/dynamics.md", "M(t) q'' + C q' + K(t) q + g(q, q') = Sᵀ f(t)"): NOT_CODE,
    ("docs/dynamics.md", "q_{j+1} = q_j + dt v_j + dt²/4 (a_j + a_{j+1})"): NOT_CODE,
    ("docs/methods.md", "Y[s] = Δt Σ_{p≤s} G[s−p] X[p],   s = 0 … n−1."): NOT_CODE,
    ("docs/methods.md", "[(Q̌_c − r_cd Q̌_a) − R (Q̌_b − r_bd Q̌_a)] c = (v̂_c − r_cd v̂_a) − R "
     "(v̂_b − r_bd v̂_a)"): NOT_CODE,
    ("docs/methods.md", "r_bd = u_iᵀw0_b / u_iᵀw0_a,  r_cd = u_iᵀw0_c / u_iᵀw0_a,"): NOT_CODE,
    ("docs/methods.md", "v̂_a =      D +      V + Q̌_a c"): NOT_CODE,
    ("docs/methods.md", "Σ_j ‖Y_j − Δt (G_j + ΔG_j(e)) ∗ X‖² / σ_Y,j² + ‖e‖² + λ²‖X‖²,   "
     "ΔG_j[s] = σ_δ,j e_j[s] D_jᵀ,"): NOT_CODE,
}
"""Every code block, by (document, first line) → its kind ("shell", "python", "toml"), how it
is covered, or :data:`NOT_CODE` (a diagram, a formula or example output)."""

_FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)
_INLINE = re.compile(r"`([^`\n]+)`")
_COMMAND = re.compile(r"^(podbench(?: |$)|python3? (?:-m |benchmarks/|tests/)|\.venv/|pip |"
                      r"mkdocs )")


def _rel(doc: Path) -> str:
    return doc.relative_to(ROOT).as_posix()


def _strip_comment(line: str) -> str:
    return re.sub(r"\s+#\s.*$", "", line).strip()


def _indented_blocks(text: str):
    """Indented code blocks: 4-space-indented lines after a blank line, outside lists (an
    indented paragraph inside a list item continues the item)."""
    lines = text.split("\n")
    in_list, i = False, 0
    while i < len(lines):
        ln = lines[i]
        if re.match(r"^\s*([-*+]|\d+[.)]) ", ln):
            in_list = True
        elif ln.strip() and not ln.startswith((" ", "\t")):
            in_list = False
        if (ln.startswith(("    ", "\t")) and ln.strip() and i > 0 and not lines[i - 1].strip()
                and not in_list):
            j = i
            while j < len(lines) and (lines[j].startswith(("    ", "\t")) or not lines[j].strip()):
                j += 1
            yield textwrap.dedent("\n".join(lines[i:j])).strip("\n")
            i = j
            continue
        i += 1


def documented_blocks() -> list[tuple[str, str, str, str]]:
    """(document, first line, language, body) of every fenced or indented code block."""
    out = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        for m in _FENCE.finditer(text):
            body = m.group(2)
            out.append((_rel(doc), body.strip("\n").split("\n")[0].strip(), m.group(1), body))
        for body in _indented_blocks(_FENCE.sub("", text)):
            out.append((_rel(doc), body.split("\n")[0].strip(), "", body))
    return out


def documented_commands() -> dict[str, set[str]]:
    """Every shell command (comment dropped) → the documents that give it."""
    cmds: dict[str, set[str]] = {}
    for doc, first, _lang, body in documented_blocks():
        if BLOCKS.get((doc, first)) == "shell":
            for line in body.split("\n"):
                line = line.strip()
                if line and not line.startswith(("#", "[", "--")):  # a usage line continues
                    cmds.setdefault(_strip_comment(line), set()).add(doc)
    for doc in DOCS:
        text = _FENCE.sub("", doc.read_text(encoding="utf-8"))
        for m in _INLINE.finditer(text):
            span = m.group(1).strip()
            if _COMMAND.match(span):
                cmds.setdefault(_strip_comment(span), set()).add(_rel(doc))
    return cmds


def _usage_lines() -> dict[str, str]:
    """A usage block's lines joined with their continuation lines (``    [--quiet]``)."""
    joined = {}
    for doc, first, _lang, body in documented_blocks():
        if BLOCKS.get((doc, first)) != "shell":
            continue
        current = None
        for line in body.split("\n"):
            if line.startswith(" ") and current is not None and line.strip().startswith(
                    ("[", "--")):
                joined[current] += " " + line.strip()
            elif line.strip():
                current = _strip_comment(line.strip())
                joined.setdefault(current, current)
    return joined


# ------------------------------------------------------------------------------ the listing
def test_every_documented_command_is_listed():
    found = documented_commands()
    usage = _usage_lines()
    keys = {usage.get(c, c) for c in found}
    missing = sorted(keys - set(COMMANDS))
    assert not missing, ("documented commands not listed in tests/test_docs_commands.py "
                         f"COMMANDS (say how each is tested): {missing}")
    stale = sorted(set(COMMANDS) - keys)
    assert not stale, f"COMMANDS lists commands no document gives any more: {stale}"


def test_every_code_block_is_listed():
    blocks = {(d, f) for d, f, _, _ in documented_blocks()}
    missing = sorted(blocks - set(BLOCKS))
    assert not missing, f"code blocks not listed in BLOCKS (say how each is tested): {missing}"
    stale = sorted(set(BLOCKS) - blocks)
    assert not stale, f"BLOCKS lists blocks no document holds any more: {stale}"


def test_the_extras_named_in_the_docs_exist():
    with open(ROOT / "pyproject.toml", "rb") as fh:
        extras = set(tomllib.load(fh)["project"]["optional-dependencies"])
    named = set()
    for cmd in COMMANDS:
        named |= set(re.findall(r"podbench\[(\w+)\]", cmd)) | set(
            re.findall(r'"\.\[(\w+)\]"', cmd))
    assert named and named <= extras, named - extras


# ------------------------------------------------------------------------------ running them
@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A folder with copies of the checkout's inputs (nothing written there reaches it)."""
    d = tmp_path_factory.mktemp("docs_commands")
    for name in ("scenarios", "structures", "benchmarks", "docs"):
        shutil.copytree(ROOT / name, d / name)
    (d / "results").mkdir()
    shutil.copy(ROOT / "results" / "baseline.csv", d / "results" / "baseline.csv")
    (d / "tests").mkdir()
    shutil.copytree(ROOT / "tests" / "sysid", d / "tests" / "sysid")
    return d


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(
        os.pathsep)
    env.setdefault("MPLBACKEND", "Agg")
    return env


def run_documented(command: str, cwd: Path, timeout: float) -> subprocess.CompletedProcess:
    """``command`` as a user types it, with ``podbench`` and ``python`` this interpreter."""
    argv = shlex.split(command)
    if argv[0] == "podbench":
        argv = [sys.executable, "-m", "podbench", *argv[1:]]
    elif argv[0] in ("python", "python3"):
        argv = [sys.executable, *argv[1:]]
    return subprocess.run(argv, cwd=cwd, env=_env(), capture_output=True, text=True,
                          timeout=timeout)


EXPECT = {
    "python -m podbench.sysid.paramdocs docs/methods.md": "docs/methods.md: unchanged",
    "podbench experiment chapter5 --check": "every record file equals a fresh generation",
    "podbench list": "scenarios in ",
}
"""What a command's output must say besides exiting 0 (the docs' tables are current, the
committed records regenerate)."""


def _listed(kind: str) -> list[str]:
    return sorted(c for c, how in COMMANDS.items() if how == kind)


@pytest.mark.heavy
@pytest.mark.parametrize("command", _listed(RUN))
def test_a_documented_command_runs(command, scratch):
    r = run_documented(command, scratch, timeout=900)
    assert r.returncode == 0, f"{command}: exit {r.returncode}\n{r.stderr[-2000:]}"
    if command.startswith("podbench run"):
        assert r.stdout.strip().splitlines()[-1].startswith("report: "), r.stdout[-500:]
    assert EXPECT.get(command, "") in r.stdout + r.stderr, (r.stdout + r.stderr)[-1000:]


@pytest.mark.slow
@pytest.mark.parametrize("command", _listed(SLOW))
def test_a_documented_long_command_runs(command, scratch):
    r = run_documented(command, scratch, timeout=4 * 3600)
    assert r.returncode == 0, f"{command}: exit {r.returncode}\n{r.stderr[-2000:]}"


def _usages():
    for usage in _listed(SYNOPSIS):  # podbench's own in-process; scripts in a subprocess
        marks = () if usage.startswith("podbench") else (pytest.mark.heavy,)
        yield pytest.param(usage, marks=marks, id=usage[:60])


@pytest.mark.parametrize("usage", list(_usages()))
def test_a_usage_line_names_real_options(usage, capsys):
    argv = usage.split()
    if argv[0] == "podbench":
        from podbench import cli

        sub = argv[1] if len(argv) > 1 and not argv[1].startswith("<") else None
        with pytest.raises(SystemExit) as exc:
            cli.main([*([sub] if sub else []), "--help"])
        assert exc.value.code == 0
        text = capsys.readouterr().out
    else:
        help_argv = [sys.executable, *argv[1:3 if argv[1] == "-m" else 2], "--help"]
        r = subprocess.run(help_argv, cwd=ROOT, env=_env(), capture_output=True, text=True,
                           timeout=300)
        assert r.returncode == 0, r.stderr[-1000:]
        text = r.stdout
    options = set(re.findall(r"--[a-z][a-z-]*", usage))
    missing = sorted(o for o in options if o not in text)
    assert not missing, f"{usage}: options not in `--help`: {missing}"


# ------------------------------------------------------------------------------ code blocks
PRELUDES = {
    ("docs/studies/calibration.md", "p = model.predict"): """
        from podbench import load_structure, simulate
        from podbench.sysid.methods import MultipleLoad
        from podbench.excitations import Pulse
        beam = load_structure("lti_beam")
        def record(x):
            return simulate(beam, n_samples=300, dt=1e-4,
                            force=Pulse(location=x, amplitude=500.0, duration=5e-4))
        # four loads for four modes: each fold refits in the modes its three records excite
        # (tests/sysid/test_bands.py::test_a_band_with_as_many_records_as_modes_given_explicitly)
        train = [record(x) for x in (2.0, 5.0, 7.0, 11.0)]
        model = MultipleLoad(n_modes=4).fit(train)
        target = record(23.0)
    """,
    ("docs/dynamics.md", "from podbench.dynamics"): """
        from podbench import load_structure
        structure = load_structure("lti_beam")
    """,
    ("docs/methods.md", "from podbench import Record"): """
        import numpy as np
        from podbench import load_structure, simulate
        from podbench.excitations import Pulse, static_displacement
        beam = load_structure("lti_beam")
        dt = 1e-4
        def free(loads):
            r = simulate(beam, n_samples=200, dt=dt, initial_displacement=static_displacement(
                beam, loads=loads))
            return r.W, r.w0
        W, w0 = free([[24.0, 100.0]])
        W_any, w0_new = free([[14.0, 80.0]])
        def forced(x):
            r = simulate(beam, n_samples=200, dt=dt,
                         force=Pulse(location=x, amplitude=500.0, duration=5e-4))
            return r.W, r.F
        cases = [forced(x) for x in (7.0, 11.0, 16.0, 23.0)]
        from podbench import Record
        from podbench.excitations import impulse_velocity
        def mixed(x, loads, kicks):
            r = simulate(beam, n_samples=200, dt=dt,
                         initial_displacement=static_displacement(beam, loads=loads),
                         initial_velocity=impulse_velocity(beam, kicks, 5e-4),
                         force=Pulse(location=x, amplitude=300.0, duration=1e-3))
            return Record(W=r.W, F=r.F, w0=r.w0, v0=r.v0, dt=dt)
        rec_a, rec_b, rec_c = (mixed(x, [[y, 100.0]], [[z, 1000.0], [24.0, 500.0]])
                               for x, y, z in ((7.0, 24.0, 3.0), (11.0, 18.0, 19.0),
                                               (16.0, 12.0, 11.0)))
        rec_new = mixed(23.0, [[20.0, 120.0]], [[15.0, 1000.0]])
    """,
    ("docs/structures.md", "from podbench.fem import load_structure"): """
        import pathlib, shutil
        pathlib.Path("path/to").mkdir(parents=True, exist_ok=True)
        text = pathlib.Path("structures/lti_beam.toml").read_text(encoding="utf-8")
        pathlib.Path("path/to/my_model.toml").write_text(
            text.replace('name = "lti_beam"', 'name = "my_model"'), encoding="utf-8")
    """,
    ("docs/structures.md", "from podbench.fem.files import register_kind"): """
        def my_builder(n, name):
            import numpy as np
            from podbench.fem import from_matrices
            K = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
            return from_matrices(M=np.eye(n), K=K, name=name)
    """,
}
"""What each Python block takes as given (the names it uses without defining them)."""

EPILOGUES = {
    ("docs/structures.md", "from podbench.fem.files import register_kind"): """
        import pathlib
        pathlib.Path("mine.toml").write_text(
            '# Units: inch, lbf, second\\nname = "mine"\\nkind = "my_kind"\\n'
            'units = "inch, lbf, second"\\ndescription = "test"\\n[my_table]\\nn = 3\\n',
            encoding="utf-8")
        from podbench.fem import load_structure
        s = load_structure("mine.toml")
        assert s.M.shape == (3, 3), s.M.shape
    """,
}
"""Checks after a block that only defines something (the kind it registers is used)."""


def _python_blocks():
    for doc, first, _lang, body in documented_blocks():
        if BLOCKS.get((doc, first)) == "python":
            yield pytest.param(doc, first, body, id=f"{doc}:{first[:30]}")


def _lookup(table: dict, doc: str, first: str) -> str:
    return next((textwrap.dedent(v) for (d, f), v in table.items()
                 if d == doc and first.startswith(f)), "")


@pytest.mark.heavy
@pytest.mark.parametrize("doc, first, body", list(_python_blocks()))
def test_a_documented_python_block_runs(doc, first, body, scratch, tmp_path):
    work = tmp_path / "work"
    shutil.copytree(scratch / "structures", work / "structures")
    script = "\n".join([_lookup(PRELUDES, doc, first), body, _lookup(EPILOGUES, doc, first)])
    (work / "block.py").write_text(script, encoding="utf-8")
    r = subprocess.run([sys.executable, "block.py"], cwd=work, env=_env(), capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, f"{doc} ({first}):\n{r.stderr[-3000:]}"


@pytest.mark.parametrize("doc, first, body", [
    pytest.param(d, f, b, id=f"{d}:{f[:30]}") for d, f, _, b in documented_blocks()
    if BLOCKS.get((d, f)) == "toml"])
def test_a_documented_toml_block_parses(doc, first, body):
    data = tomllib.loads(body)
    assert data


@pytest.mark.heavy
def test_the_readme_scenario_runs(scratch, tmp_path):
    """The scenario reference's complete example (docs/reference/scenarios.md), saved as
    ``my_study/my_study.toml`` with the structure it names (``my_structure.toml``: the LTI
    beam under another name), runs as ``podbench run my_study/`` and as ``podbench run
    path/to/my_study/``: the structure file in ``my_study/structures/`` as the block's
    comment says."""
    page = "docs/reference/scenarios.md"
    text = (ROOT / page).read_text(encoding="utf-8")
    (body,) = [b for d, f, _, b in documented_blocks() if (d, f) == (page, "[scenario]")]
    assert "podbench run path/to/my_study/" in text
    for folder in (tmp_path / "my_study", tmp_path / "path" / "to" / "my_study"):
        folder.mkdir(parents=True)
        (folder / "my_study.toml").write_text(body, encoding="utf-8")
        beam = (ROOT / "structures" / "lti_beam.toml").read_text(encoding="utf-8")
        (folder / "structures").mkdir()
        (folder / "structures" / "my_structure.toml").write_text(
            beam.replace('name = "lti_beam"', 'name = "my_structure"'), encoding="utf-8")
    for command in ("podbench run my_study/", "podbench run path/to/my_study/"):
        r = run_documented(command + " --no-figures", tmp_path, timeout=600)
        assert r.returncode == 0, f"{command}: {r.stderr[-2000:]}"
    summary = (tmp_path / "results" / "my_study" / "summary.csv").read_text(encoding="utf-8")
    assert summary.count("\n") == 3  # header + SL on the two structures, target load5
    assert ",SL,load5," in summary


# ------------------------------------------------------------------------------ wall times
WALL_TIMES = "## The studies and how long each takes"
STUDIES_PAGE = ROOT / "docs" / "studies" / "index.md"


def _manifest() -> dict:
    """``command -> entry`` of results/MANIFEST.toml, the one source of the wall times."""
    with (ROOT / "results" / "MANIFEST.toml").open("rb") as fh:
        return {e["command"]: e for e in tomllib.load(fh).values()}


def _time_rows(text: str):
    """``(line, command, minutes)`` of every table row ``| `podbench ...` | ... | 16 s |``."""
    for ln in text.splitlines():
        if not ln.startswith("| `podbench "):
            continue
        cells = [c.strip() for c in ln.strip("|").split("|")]
        m = re.search(r"(\d+(?:\.\d+)?) (s|min)\b", cells[-1])
        if m:
            minutes = float(m.group(1)) / (60.0 if m.group(2) == "s" else 1.0)
            yield ln, re.match(r"`([^`]+)`", cells[0]).group(1), minutes


def test_every_documented_wall_time_is_the_manifests():
    """A wall time in a table of any page (a row naming a command of results/MANIFEST.toml)
    is the manifest's, so the docs never give two times for one command."""
    manifest = _manifest()
    n = 0
    for doc in DOCS:
        for ln, command, minutes in _time_rows(doc.read_text(encoding="utf-8")):
            if command in manifest:
                assert minutes == pytest.approx(manifest[command]["minutes"], abs=0.051), \
                    (_rel(doc), ln)
                n += 1
    assert n >= 15  # the studies' table (13) and getting started's (2)


def test_the_readme_states_every_studys_wall_time():
    """The studies' page's table names every bundled study (the folders of ``scenarios/``
    that ``podbench run <name>`` finds; the sweeps by ``podbench sweep``) with a measured
    wall time, and says on which machine it was measured."""
    from podbench.core.resources import bundled_studies

    text = STUDIES_PAGE.read_text(encoding="utf-8")
    assert WALL_TIMES in text, f"{_rel(STUDIES_PAGE)} has no section {WALL_TIMES!r}"
    section = text[text.index(WALL_TIMES):]
    section = section[:section.index("\n## ")]
    rows = [ln for ln in section.splitlines() if ln.startswith("| `podbench ")]
    named = {m.group(1) for ln in rows if (m := re.match(r"\| `podbench run (\w+)`", ln))}
    studies = set(bundled_studies()) - {"sweeps"}
    assert studies <= {d.name for d in (ROOT / "scenarios").iterdir()}
    assert named == studies, (sorted(studies - named), sorted(named - studies))
    assert any(ln.startswith("| `podbench sweep") for ln in rows)
    # every row's time is the one results/MANIFEST.toml holds for the same command
    manifest = _manifest()
    for ln in rows:
        cells = [c.strip() for c in ln.strip("|").split("|")]
        m = re.search(r"(\d+(?:\.\d+)?) (s|min)\b", cells[-1])
        assert m, ln
        minutes = float(m.group(1)) / (60.0 if m.group(2) == "s" else 1.0)
        command = re.match(r"`([^`]+)`", cells[0]).group(1)
        if command in manifest:
            assert minutes == pytest.approx(manifest[command]["minutes"], abs=0.051), ln
            # "N rows" is the committed table's row count (summary.csv, or a sweep's sweep.csv)
            rows_said = re.search(r"(\d+) rows", cells[1])
            if rows_said:
                folder = ROOT / manifest[command]["paths"][0]
                table = folder / ("sweep.csv" if command.startswith("podbench sweep")
                                  else "summary.csv")
                n = len(table.read_text(encoding="utf-8").splitlines()) - 1
                assert int(rows_said.group(1)) == n, (ln, n)
    for words in ("measured", "2-core", "load"):
        assert words in section, words
