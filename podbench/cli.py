"""Command line: ``podbench run | regress | sweep | list | experiment | predict | methods``.

Exit codes: 0 success; 1 ``regress`` found an error that got worse; 2 unusable input (a
missing path, a malformed scenario/structure/claims file, an unknown name, a bad option, an
unwritable output), reported on one line; 3 an internal error (a bug: one line, ``--debug``
shows the traceback); 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import re
import sys
import textwrap
import traceback
from pathlib import Path

from podbench.core.hints import did_you_mean, noise_level_hint
from podbench.core.resources import (
    DEFAULT_BASELINE,
    DEFAULT_CACHE,
    SWEEPS_STUDY,
    bundled_scenarios,
    bundled_structures,
    bundled_studies,
    display_path,
)
from podbench.core.tomlfile import load_toml
from podbench.core.version import __version__
from podbench.core.warnfmt import one_line_warnings
from podbench.errors import InputError, PodbenchError, UnknownNameError


class _OnFirstUse:
    """A module imported on first attribute access: ``podbench --help`` and ``podbench
    list`` do not pay for the NumPy/SciPy/pandas/Matplotlib stack of the commands."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr: str):
        return getattr(importlib.import_module(self._name), attr)


api = _OnFirstUse("podbench.api")
registry = _OnFirstUse("podbench.sysid.registry")
_claims = _OnFirstUse("podbench.study.claims")
_scenarios = _OnFirstUse("podbench.study.scenarios")
_deconvolution = _OnFirstUse("podbench.sysid.deconvolution")
_paramdocs = _OnFirstUse("podbench.sysid.paramdocs")


def Progress(**kw):  # noqa: N802 - the class it builds
    """:class:`podbench.harness.progress.Progress` (imported on first use)."""
    return importlib.import_module("podbench.harness.progress").Progress(**kw)


def available_solvers() -> tuple:
    return _deconvolution.available_solvers()


def entries() -> dict:
    return _paramdocs.entries()


def load_scenario(path):
    return _scenarios.load_scenario(path)


_EPILOG = """\
Units are inch, lbf and second (the dissertation's) unless a structure file says SI (units =
"m, N, second") or a record file states its units. Errors are relative (fractions of ‖W‖_F of the
target) and the norm percent errors follow Eq. 4.2 of Allison (2007);
docs/error-decomposition.md defines every column. Exit codes: 0 ok, 1 regression found
(regress), 2 unusable input (one line naming the file and field, or the option), 3 internal
error (a bug; --debug shows the traceback), 130 interrupted.
"""


class _ArgError(Exception):
    """A command-line error found by argparse (reported on one line by :func:`main`)."""

    def __init__(self, prog: str, message: str):
        super().__init__(message)
        self.prog = prog


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage block) and exit code 2."""

    def error(self, message):
        raise _ArgError(self.prog, message)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def _jobs(text: str) -> int | str:
    """``--jobs``: a positive integer or ``auto`` (the cores available)."""
    if text == "auto":
        return text
    try:
        return _positive_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected a positive integer or 'auto', got "
                                         f"{text!r}") from None


def _tolerance(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="podbench",
        description="Benchmark suite for structural system identification with the proper "
                    "orthogonal decomposition (POD), after Allison (2007).",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )

    p.add_argument("--version", action="version", version=f"podbench {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for add in (_add_run, _add_regress, _add_sweep, _add_fit, _add_predict, _add_experiment,
                _add_list, _add_methods):
        add(sub)
    return p


def _add_debug(sp) -> None:
    sp.add_argument("--debug", action="store_true",
                    help="show the Python traceback of an internal error (exit code 3)")


def _add_jobs(sp, help_text: str, default: int | str | None = "auto") -> None:
    """``-j/--jobs N`` (a positive integer or ``auto``); ``default`` None: not given (the
    sweep's ``auto`` unless ``--scheduler``)."""
    sp.add_argument("-j", "--jobs", type=_jobs, default=default, metavar="N", help=help_text)


def _add_cache_options(sp, *, cache_help: str, engine_help: str) -> None:
    """``--cache``, ``--no-cache``, ``--engine`` and ``--quiet`` (run, regress and sweep)."""
    sp.add_argument("--cache", default=str(DEFAULT_CACHE), metavar="DIR",
                    help=f"truth-data cache folder (default {DEFAULT_CACHE}); {cache_help}")
    sp.add_argument("--no-cache", action="store_true", help="simulate everything afresh")
    sp.add_argument("--engine", choices=("newmark", "exudyn"), default=None, help=engine_help)
    sp.add_argument("-q", "--quiet", action="store_true",
                    help="no progress on stderr (neither the bar nor the plain lines)")


def _add_study_options(sp, paths_help: str) -> None:
    """The paths and the options ``run`` and ``regress`` share."""
    sp.add_argument("paths", nargs="*", metavar="PATH", help=paths_help)
    _add_jobs(sp, "processes for the (scenario, structure) units and the figures, or auto "
                  "(default auto: the cores available, at most 8; processes beyond this one "
                  "start only after 2 s of work; results do not depend on N)")
    _add_cache_options(sp, cache_help="entries are keyed by the content of structure and "
                                      "scenario",
                       engine_help="override the scenarios' integration engine (default: each "
                                   "scenario's own, normally newmark)")
    _add_debug(sp)


def _command(sub, name: str, help_text: str, description: str, epilog: str):
    """The sub-parser of one command: its one-line help, its description (wrapped to 88
    columns) and its epilog (shown as written)."""
    return sub.add_parser(name, help=help_text, description=textwrap.fill(description, width=88),
                          epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter)


def _add_run(sub) -> None:
    """``podbench run``."""
    r = _command(
        sub, "run", "run scenarios and write tables, figures and findings",
        "Simulate the truth data (cached), fit every method of every scenario, "
        "predict every target and write OUT/summary.csv, OUT/summary.md, "
        "OUT/fits.csv, OUT/figures/*.png and (with a claims.toml beside the "
        "scenarios) OUT/FINDINGS.md, and OUT/seeds.csv when the claims file "
        "judges its comparisons over noise_seeds. OUT is replaced as a whole only when "
        "everything is written. A part of a study (a scenario file given alone) "
        "is written to its own folder, results/<file name>, never over the "
        "study's results/<study>; an existing OUT that holds scenarios this run "
        "does not produce is refused.",
        _EPILOG + """
Examples:
  podbench run                           # the bundled Chapter 4 study -> results/chapter4
  podbench run chapter4/beam_forced      # one bundled scenario -> results/beam_forced
  podbench run my_study/                 # your folder of scenarios -> results/my_study
  podbench run my_study/a.toml           # one of your files -> results/a
""")
    _add_study_options(r, "scenario files or folders of them, or a bundled study (chapter4) or "
                          "scenario (chapter4/beam_forced) by name when no such path exists "
                          "(default: chapter4); the claims.toml beside the scenarios is judged "
                          "into FINDINGS.md")
    r.add_argument("-o", "--out", default=None, metavar="DIR",
                   help="output folder (default results/<folder name> for a folder, "
                        "results/<file name> for a single file, the names joined by '+' for "
                        "several, e.g. results/chapter4 or results/beam_forced, in the "
                        "current folder); replaced as a whole, so it must not exist, be "
                        "empty, or be a previous podbench output (holding summary.csv) of "
                        "the same scenarios or fewer: any other folder or a file is refused")
    r.add_argument("--no-figures", action="store_true", help="skip the figures")
    r.add_argument("--figure-format", choices=("png", "svg", "pdf"), default="png",
                   help="format of OUT/figures/* (default png, 150 dpi; svg and pdf are "
                        "vector graphics); report.html embeds the figures in any format")


def _add_regress(sub) -> None:
    """``podbench regress``."""
    g = _command(
        sub, "regress", "re-run the study and compare every error with the baseline",
        "Re-run the scenarios (no figures, nothing written to results/ except "
        "with --update) and compare every error column with the baseline table's rows of "
        "those scenarios (another study's rows are not judged). An error is worse when "
        "it exceeds base·(1 + rtol) + atol. Exit 0 when "
        "nothing got worse, 1 with a readable diff when something did, 2 on "
        "unusable input.",
        _EPILOG)
    _add_study_options(g, "scenario files or folders of them, or a bundled study or scenario "
                          "by name (default: chapter4 and chapter5, the studies of "
                          "results/baseline.csv); claims are not judged and nothing is written")
    g.add_argument("--baseline", default=str(DEFAULT_BASELINE), metavar="CSV",
                   help=f"baseline table (default {DEFAULT_BASELINE})")
    g.add_argument("--rtol", type=_tolerance, default=0.01,
                   help="relative tolerance, finite and >= 0 (default 0.01)")
    g.add_argument("--atol", type=_tolerance, default=1e-6,
                   help="absolute tolerance, finite and >= 0 (default 1e-6)")
    g.add_argument("--update", action="store_true",
                   help="write this run's table as the new baseline (deliberately) and exit 0")
    g.add_argument("--table", default=None, metavar="CSV",
                   help="compare this existing summary.csv instead of re-running (its rows "
                        "of the study named, else the scenarios it holds)")


def _add_sweep(sub) -> None:
    """``podbench sweep``."""
    w = _command(
        sub, "sweep", "run scenarios over noise levels, mode counts, seeds and solvers",
        "Run every point of the scenarios' [sweep] axes — noise levels × mode "
        "counts × seeds (× deconvolution solvers) × structures × methods — and "
        "write DIR/<scenario name>/sweep.csv (one row per point, method and "
        "target; columns as summary.csv plus noise, modes, seed, solver) and "
        "sweep.md (median and max over seeds). Noise is what a laboratory meets: "
        "Gaussian per measured channel, standard deviation = level × RMS of that "
        "channel's own record, on every sensor row of W and on the loaded rows "
        "of F only (noise_model = \"per_channel\"; \"per_entry_rms\" is the "
        "former whole-matrix model), seeded by (seed, scenario, structure, case, "
        "quantity, channel); targets are noise-free (see podbench.noise and "
        "docs/noise.md). The --noise/--n-modes/--seeds/"
        "--solvers options replace the file's axes. The table is identical "
        "whether the points run serially, in --jobs local processes or on a Dask "
        "cluster (--scheduler). A mode count a POD method cannot use (more than the "
        "sensors, or than ML's and MDS's training cases) is refused before any work; "
        "a fit that fails at run time is a row (status failed: ...), but a point none "
        "of whose rows was measured makes the command exit 2, after writing the tables.",
        _EPILOG + """
Examples:
  podbench sweep                                   # the bundled sweeps, --jobs auto
  podbench sweep sweeps/beam_forced_noise --jobs 1
  podbench sweep chapter4/beam_forced --noise 0,0.01 --seeds 0-4 --solvers ls,tls-dt
  podbench sweep --scheduler tcp://10.0.0.5:8786   # needs pip install 'podbench[dask]'

[sweep] table of a scenario file (every field optional):
  noise = [0.0, 0.01, 0.05]   seeds = [0, 1, 2]   n_modes = [3, 4]
  solvers = ["ls", "tls-dt"]  noise_on = ["W", "F"]   coupled_train = "first"
n_modes replaces every method's k; MDS and ML (k = number of training sets) train on their
first k cases ("first") or on all of them ("all"). See podbench.harness.sweep.
""")
    w.add_argument("paths", nargs="*", metavar="PATH",
                   help="scenario files or folders of them, or a bundled study or scenario by "
                        f"name (default: the bundled {SWEEPS_STUDY})")
    _add_jobs(w, "processes for the points, or auto (default auto: the cores available, at "
                 "most 8; processes beyond this one start only after 2 s of work; the table "
                 "does not depend on N); not with --scheduler", None)
    w.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the points on a Dask distributed cluster, e.g. "
                        "tcp://host:8786 (workers need podbench and the same project folder "
                        "at the same path); replaces --jobs, which it refuses")
    w.add_argument("--noise", default=None, metavar="LIST",
                   help="noise levels in [0, 1], comma-separated: std = level × each "
                        "channel's RMS (e.g. 0,0.01,0.05 for 0, 1 and 5 %%)")
    w.add_argument("--n-modes", default=None, metavar="LIST",
                   help="mode counts k, comma-separated (e.g. 3,4,5)")
    w.add_argument("--seeds", default=None, metavar="LIST",
                   help="noise seeds: comma-separated integers and ranges (e.g. 0-4 or 0,3,7)")
    w.add_argument("--solvers", default=None, metavar="LIST",
                   help="deconvolution solvers for SL, ML and MR, comma-separated (e.g. ls,tls-dt; "
                        "podbench list shows them)")
    w.add_argument("-o", "--out", default="results", metavar="DIR",
                   help="output root: each scenario writes DIR/<scenario name>/sweep.csv and "
                        "sweep.md (default results); DIR/<scenario name> must not exist, be "
                        "empty, or be a previous sweep output (holding sweep.csv)")
    _add_cache_options(w, cache_help="noise is added after loading, so sweep and run share "
                                     "entries",
                       engine_help="override the scenarios' integration engine")
    _add_debug(w)


def _add_experiment(sub) -> None:
    """``podbench experiment``."""
    x = _command(
        sub, "experiment", "write (or --check) the records of a virtual experiment",
        "Simulate the laboratory tests of an experiment.toml (podbench.experiments: the "
        "tests, their loads, per-channel noise levels), and write one record file per "
        "test, noise level and case under data/ beside it (each data/<test> folder "
        "replaced atomically). The study's scenarios read those files back like "
        "measurements. With --check nothing is written: the committed files are "
        "compared byte for byte with a fresh generation (exit 1 when they differ).",
        """
Examples:
  podbench experiment chapter5           # the bundled Chapter 5 tests -> its data/
  podbench experiment my_study/          # my_study/experiment.toml -> my_study/data/
  podbench experiment chapter5 --check   # are the committed records up to date?
""")
    x.add_argument("path", help="an experiment.toml, its folder, or a bundled study by name")
    x.add_argument("--check", action="store_true",
                   help="compare with a fresh generation instead of writing")
    _add_debug(x)


def _add_predict(sub) -> None:
    """``podbench predict``."""
    pr = sub.add_parser(
        "predict", help="fit a method on training records, predict target records",
        description=textwrap.fill(
            "Fit METHOD (any name podbench methods lists, e.g. ML, MDS, POVR, SL, FIR-LS, "
            "ERA, ML-TC) on the --train record files and predict every --target file: "
            "OUT/errors.csv (target, method, total_error = ‖ŷ − y‖_F/‖y‖_F where the target "
            "holds outputs, units, error:<channel> per output channel: ‖ŷ_c − y_c‖/‖y_c‖, "
            "left empty for a channel whose measured output is zero throughout, where a "
            "relative error is undefined, with a note on stdout), OUT/<target "
            "stem>.npz with the prediction y_hat (n_out × n; W_hat too for displacements), "
            "dt, units, quantity, output_channels, and OUT/config.json (the fitted "
            "configuration). Records: input/output files (.npz/.mat with inputs, outputs, "
            "dt, input_channels, output_channels, input_units, output_units; CSV with "
            "columns t [s], u:<channel> [unit], y:<channel> [unit]; UFF 58 with one dataset "
            "per channel, ID line 1 u:<channel> or y:<channel>) or displacement/force files "
            "(W in in, F in lbf, dt; a free response W, dt, w0 without F for MDS and POVR: "
            "there the methods are the dissertation's, the POMs of W and the modal forces "
            "U^T F, Eqs. 3.43-3.49, solved by --solver, default auto). With --coverage, "
            "each prediction gets a band (lower, upper) and an error estimate. Every file is "
            "checked before any fitting; OUT is written whole or not at all.",
            width=88),
        epilog="""
Examples:
  podbench predict --method ML --train a.npz b.npz c.npz --target x.npz --out pred/
  podbench predict --method FIR-LS --train ev*.npz --target new.npz --out pred/ \\
      --input-units m/s^2 --output-units m/s^2     # files without unit variables
  podbench predict --method ML --train a.csv b.csv c.csv --target x.csv --out pred/ \\
      --coverage 0.9                               # 90 % bands: lower, upper in x.npz
  podbench predict --method MDS --train free0.npz free1.npz free2.npz \\
      --target free3.npz --out pred/ --coverage 0.9   # free responses: W, dt, w0
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_fit_arguments(pr, required=False)
    pr.add_argument("--model", default=None, metavar="MODEL.npz",
                    help="predict with a model saved by podbench fit (instead of --method "
                         "and --train)")
    pr.add_argument("--target", nargs="+", required=True, metavar="FILE")
    pr.add_argument("--out", required=True, metavar="DIR",
                    help="output folder (new, empty, or a previous predict output)")
    pr.add_argument("--coverage", type=float, default=None, metavar="P",
                    help="prediction band coverage in (0, 1), e.g. 0.9: adds lower and "
                         "upper to every OUT/<target stem>.npz and error_estimate, coverage "
                         "to errors.csv; calibrated by leave-one-record-out over the "
                         "training records (at least 3; on displacement/force files as "
                         "model.predict(target, coverage=P) of ML or SL)")


def _add_fit_arguments(p, *, required: bool) -> None:
    """The arguments of a fit, shared by ``podbench fit`` (``required``: --method and
    --train) and ``podbench predict`` (where --model may replace them); both check them
    with the same code (:func:`podbench.harness.predict.command_line_estimator`)."""
    p.add_argument("--method", required=required, default=None,
                   help="a registered method (podbench methods; letter case aside): ML, "
                        "FIR-LS, ERA, DMDc, OpInf, mdof on measured inputs; ML, SL (one "
                        "training file), MR on displacement/force files; MDS, POVR (one "
                        "training file) on free responses; configurations such as ML-TC")
    p.add_argument("--train", nargs="+", required=required, default=None, metavar="FILE")
    p.add_argument("--solver", default="auto",
                   help="ML's kernel: auto (the kernel over one period when the training "
                        "files carry period_samples, a periodic excitation in steady "
                        "state; else the TC prior with >= 3 training records), ls, tc "
                        "(truncated kernel, lags by leave-one-record-out), or a "
                        "deconvolution solver name (block, cgls, ...) for the kernel over "
                        "the whole record (records of one length); on displacement/force "
                        "files the deconvolution solver of ML/SL/MR (auto: podbench methods "
                        "auto); refused for a method without one")
    p.add_argument("--n-modes", type=_positive_int, default=None, metavar="K",
                   help="number of modes: the POMs of a POD method, order 2K of ERA; "
                        "refused for a method without one")
    p.add_argument("--units", choices=("SI", "inch-lbf"), default=None,
                   help="convert every record to this unit system when it is read")
    p.add_argument("--input-units", default=None, metavar="UNIT",
                   help="units of the inputs for files that carry none (e.g. m/s^2)")
    p.add_argument("--output-units", default=None, metavar="UNIT",
                   help="units of the outputs for files that carry none")
    p.add_argument("--debug", action="store_true",
                   help="show the Python traceback of an internal error (exit code 3)")


def _add_fit(sub) -> None:
    """``podbench fit``."""
    ft = sub.add_parser(
        "fit", help="fit a method on training records and save the model",
        description=textwrap.fill(
            "Fit METHOD on the --train record files (read and checked as podbench predict "
            "reads them) and write OUT/model.npz (the fitted model: arrays plus a JSON "
            "header with format_version, no pickles), OUT/model.json (its readable summary: "
            "parameters, training files with SHA-256, dt, channels, units, what the fit "
            "chose, how its state-space realization and modes were chosen) and "
            "OUT/modes.csv (mode, frequency_hz, damping_ratio, shape:<channel>: the physical "
            "modes, sorted by frequency). podbench predict --model OUT/model.npz predicts "
            "with it.", width=88),
        epilog="""
Examples:
  podbench fit --method ML --train a.npz b.npz c.npz --out chain_ml/
  podbench fit --method ERA --train a.npz b.npz c.npz --n-modes 5 --out chain_era/
  podbench predict --model chain_ml/model.npz --target x.npz --out pred/
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_fit_arguments(ft, required=True)
    ft.add_argument("--out", required=True, metavar="DIR",
                    help="output folder (new, empty, or a previous fit output)")


def cmd_fit(args) -> int:
    import json

    api.fit(args.method, args.train, args.out, solver=args.solver, n_modes=args.n_modes,
            input_units=args.input_units, output_units=args.output_units, units=args.units)
    summary = json.loads((Path(args.out) / "model.json").read_text())
    name = summary.get("configuration") or summary["method"]
    if name != summary["method"]:  # a registered configuration: name it and its method
        name = f"{name} ({summary['method']})"
    print(f"{name}: model -> {args.out}/model.npz (summary model.json)")
    if summary.get("modes_table"):
        why = ""
        if not summary["modes_count"]:  # an empty table: say what the rule left out
            why = f" (none kept: {'; '.join(summary.get('modes_rule') or ['see model.json'])})"
        print(f"{_plural(summary['modes_count'], 'physical mode')} -> {args.out}/modes.csv"
              f"{why}")
    else:
        print(f"no modes.csv: {summary.get('modes_reason', '')}")
    return 0


def _add_list(sub) -> None:
    """``podbench list``."""
    ls = sub.add_parser("list", help="list structures, scenarios, methods and solvers",
                        description="List the structures and scenarios bundled with podbench "
                                    "and those of the current folder (./structures, "
                                    "PODBENCH_STRUCTURES, ./scenarios), each with where it "
                                    "comes from, the built-in methods, the deconvolution "
                                    "solvers and the runners a study file may name "
                                    "([study] runner). podbench methods shows the methods' "
                                    "and solvers' parameters.")
    _add_debug(ls)


def _add_methods(sub) -> None:
    """``podbench methods``."""
    m = _command(
        sub, "methods", "the methods' and solvers' parameters: what each admits, default, "
                        "meaning",
        "Show the parameters of the built-in identification methods and deconvolution "
        "solvers, as a scenario file's [[methods]] options (and solver_options) give them: "
        "for each its name, its default, what it admits and what it does. Generated from "
        "the declarations every check uses (podbench/sysid/params.py: the classes' "
        "_parameter_constraints, constructor defaults and docstrings), so what is shown is "
        "what a scenario file is checked against. Without NAME: every method and solver, "
        "each parameter's first sentence; with NAME: the whole description.",
        """Examples:
  podbench methods                 # every method and solver, briefly
  podbench methods ML tls-appendix # the multiple-load method and the appendix TLS in full
""")
    m.add_argument("names", nargs="*", metavar="NAME",
                   help="a method as a scenario names it (ML, SL, MDS, ERA, ML-TC, ...) or a "
                        "deconvolution solver (block, tls, cgls, ...); podbench methods "
                        "without NAME lists every one")
    _add_debug(m)


def _entry_name(name: str) -> str:
    """The :func:`entries` name ``name`` means (a class name or another letter case is
    accepted when it is unambiguous)."""
    known = entries()
    name = _deconvolution.current_name(name)  # a former name: its solver (warns)
    if name in known:
        return name
    found = [k for k in known if name.lower() == k.lower()] or [
        k for k, cls in known.items() if name.lower() == cls.__name__.lower()
        and not (k in registry.REGISTRY and registry.REGISTRY[k].configuration)]
    if len(found) == 1:
        return found[0]
    raise UnknownNameError(f"{name}: not a built-in method or solver"
                           f"{did_you_mean(name, known)} (podbench methods lists them)")


def cmd_methods(args) -> int:
    names = [_entry_name(n) for n in args.names]  # every name checked before printing
    if not names:
        print("Parameters of the built-in methods and deconvolution solvers, as a scenario's\n"
              "[[methods]] options give them (podbench methods NAME: the whole description).\n")
    for name in names or entries():
        print(_paramdocs.parameter_help(name, full=bool(names)))
        print()
    return 0


def _plural(n: int, word: str, plural: str | None = None) -> str:
    """``1 response``, ``2 responses``."""
    return f"{n} {word if n == 1 else (plural or word + 's')}"


def _cache(args):
    return None if args.no_cache else args.cache


def cmd_predict(args) -> int:
    if args.model is None and (args.method is None or args.train is None):
        raise InputError("predict: give --method and --train (fit and predict), or --model "
                         "(a model saved by podbench fit)")
    rows = api.predict(args.method, args.train, args.target, args.out, solver=args.solver,
                       n_modes=args.n_modes, coverage=args.coverage,
                       input_units=args.input_units, output_units=args.output_units,
                       units=args.units, model=args.model).rows
    for r in rows:
        band = (f", error_estimate {r['error_estimate'] or '(none: ' + r['note'] + ')'}, "
                f"coverage {r['coverage'] or '(no outputs)'}" if "error_estimate" in r else "")
        if band and r["error_estimate"] and r["note"]:  # an estimate that may be low
            band += f" (note: {r['note']})"
        none = "(none: the target holds no outputs, or they are zero throughout)"
        print(f"{r['target']}: {r['method']} total_error {r['total_error'] or none}"
              f"{band}")
        zero = [k.removeprefix("error:") for k, v in r.items()
                if k.startswith("error:") and v == "" and r["total_error"] != ""]
        if zero:  # ‖y_c‖ = 0: no relative error to write
            print(f"  note: {r['target']}: {_plural(len(zero), 'output channel')} measured "
                  f"zero throughout ({', '.join(zero)}): error:<channel> left empty, a "
                  "relative error is undefined there")
    print(f"{_plural(len(rows), 'prediction')} -> {args.out}/")
    return 0


def _claims_line(claims) -> str:
    """The run's last word on the claims, counted as FINDINGS.md's headline counts them: the
    text's claims once each (an entry with its ``part_of`` parts), then how many variants
    were judged besides them (the text's claims apart from podbench's variants)."""
    verdicts = [v for _, _, v in _claims.text_claims(claims)]
    n_variants = sum(bool(e.claim.variant) for e in claims)
    whose = "the text's " if n_variants else ""
    rest = _claims.counts_words(verdicts).split(", ", 2)  # reproduced, not reproduced, others
    line = f"claims: {rest[0].split()[0]} of {whose}{len(verdicts)} reproduced"
    line += "".join(f", {w}" for w in rest[1:] if not w.startswith("0 "))
    if n_variants:
        line += f"; {_plural(n_variants, 'variant')} also judged"
    return line


def cmd_run(args) -> int:
    res = api.run(args.paths, out=args.out, jobs=args.jobs, cache=_cache(args),
                  engine=args.engine, figures=not args.no_figures,
                  figure_format=args.figure_format, progress=Progress(quiet=args.quiet),
                  command=api.command_line(args.argv))
    out, df = res.out, res.summary
    print(f"{_plural(len(df), 'row')} from {_plural(len(res.scenarios), 'scenario')} in "
          f"{res.seconds:.1f} s ({_plural(res.simulated, 'response')} simulated, "
          f"{res.cached} from the cache) -> {out}/summary.csv")
    if res.claims is not None:
        print(f"{_claims_line(res.claims)} -> {out}/FINDINGS.md")
    failed = df[df.status != "ok"]
    if len(failed):
        see = "summary.md" if (out / "summary.md").is_file() else "summary.csv"
        print(f"note: {_plural(len(failed), 'row has', 'rows have')} a failed method or twin "
              f"(see {see})")
    if len(failed) == len(df) > 0:  # nothing measured: a mistake in the scenario, not a result
        first = failed.iloc[0]
        raise InputError(f"every row failed, nothing was measured; the first, {first.structure} "
                         f"/ {first.method}: {first.status} (all: {out}/{see})")
    paths, _ = api.resolve_study(args.paths)
    parts = [p for p in paths if not Path(p).is_dir()]
    if parts and not args.out:
        for folder in dict.fromkeys(Path(p).resolve().parent for p in parts):
            study_out = api.DEFAULT_RESULTS / folder.name
            kept = f", {study_out}/ left as it was" if study_out.is_dir() else ""
            print(f"part of the study in {display_path(folder)}: written to {out}/{kept}")
    tables = importlib.import_module("podbench.harness.tables")  # pandas: on first use
    slow = tables.slowest_method(out / tables.TIMING_FILE)
    if slow is not None:
        print(f"slowest method: {slow[0]}, {slow[1]:.1f} s of the methods' {slow[2]:.1f} s "
              f"(wall clock per method: {out / tables.TIMING_FILE}, not tracked)")
    if (out / "report.html").is_file():  # the studies with their own runner write none
        print(f"report: {out / 'report.html'}")
    return 0


def cmd_experiment(args) -> int:
    got = api.experiment(args.path, check=args.check)
    files = got.differ if got.checked else got.written
    if args.check:
        for f in files:
            print(f"differs: {f}")
        print(f"{len(files)} record file(s) differ from a fresh generation" if files
              else "every record file equals a fresh generation")
        return 1 if files else 0
    folders = sorted({display_path(Path(f).parent.parent) for f in files})
    print(f"{len(files)} record files written under {', '.join(folders)}")
    return 0


def cmd_regress(args) -> int:
    got = api.regress(args.paths, baseline=args.baseline, rtol=args.rtol, atol=args.atol,
                      update=args.update, table=args.table, jobs=args.jobs,
                      cache=_cache(args), engine=args.engine,
                      progress=Progress(quiet=args.quiet))
    if got.updated:
        print(f"baseline updated: {args.baseline} ({got.rows} rows)")
        return 0
    assert got.comparison is not None
    print(got.comparison.report(args.rtol, args.atol))
    return 1 if got.failed else 0


MAX_LISTED_METHODS = 6
"""``podbench list`` names at most this many method labels of a scenario, then counts them."""


def _toml_summary(f: Path, depth: int = 0) -> tuple[str, dict]:
    """``(kind, table)`` of one file as ``podbench list`` shows it, read as TOML only (the
    listing does not import the methods; ``podbench run`` checks every field): kind
    ``"own"`` (a ``[study]`` naming its runner), ``"scenario"`` or ``"unreadable"``."""
    try:
        _, d = load_toml(f, display_path(f), InputError)
    except InputError as exc:
        return "unreadable", {"error": str(exc)}
    study = d.get("study")
    if isinstance(study, dict) and isinstance(study.get("runner"), str):
        return "own", study
    sc = d.get("scenario")
    base = sc.get("base") if isinstance(sc, dict) else None
    if isinstance(base, str) and (f.parent / base).is_file() and depth < 8:
        kind, parent = _toml_summary(f.parent / base, depth + 1)  # scenario.base: inherited
        if kind == "scenario":
            merged = {**parent, **d}
            merged["scenario"] = {**parent.get("scenario", {}), **sc}
            return "scenario", merged
    return "scenario", d


def _methods_text(d: dict) -> str:
    """The method labels of a scenario table, summarised past :data:`MAX_LISTED_METHODS`."""
    methods = d.get("methods", [])
    labels = [str(m.get("label", m.get("method", "?"))) for m in methods
              if isinstance(m, dict)] if isinstance(methods, list) else []
    if len(labels) <= MAX_LISTED_METHODS:
        return ", ".join(labels)
    return f"{len(labels)} methods: {', '.join(labels[:3])}, …"


def _list_scenarios(folder: Path, indent: str, runners: dict | None = None) -> None:
    """One line per scenario of ``folder`` (name, title, structures, methods); a study file
    with its own runner is named with it (and recorded in ``runners``)."""
    for f in sorted(folder.glob("*.toml")):
        if f.name in ("claims.toml", "experiment.toml"):
            continue
        kind, d = _toml_summary(f)
        if kind == "unreadable":
            print(f"{indent}{f.stem}: (unreadable: {_one_line(d['error'], 200)})")
            continue
        if kind == "own":
            print(f"{indent}{f.stem}: {d.get('title', '')} [its own runner: {d['runner']}]")
            if runners is not None:
                runners.setdefault(d["runner"], f"{d.get('title', '')} ({f.stem})")
            continue
        sc = d.get("scenario", {}) if isinstance(d.get("scenario"), dict) else {}
        structures = ", ".join(map(str, sc.get("structures", [])))
        sweep = "; [sweep]" if "sweep" in d else ""
        print(f"{indent}{sc.get('name', f.stem)}: {sc.get('title', '')} [{structures}; "
              f"{_methods_text(d)}{sweep}]")
    if (folder / "claims.toml").is_file():
        print(f"{indent}(claims: claims.toml, judged into FINDINGS.md)")


def _names_in(folder: Path) -> list[str]:
    """Structure names of one folder (``sub/name`` for files in sub-folders)."""
    if not folder.is_dir():
        return []
    return sorted(p.relative_to(folder).with_suffix("").as_posix()
                  for p in folder.rglob("*.toml"))


def cmd_list(args) -> int:
    """Structures, scenarios, methods, solvers and runners; each structure and study once
    (in a checkout ./structures and ./scenarios are the bundled folders)."""
    bundled = bundled_structures()
    local = Path("structures")
    folders = ([local] if local.is_dir() and local.resolve() != bundled.resolve() else []) + [
        Path(d) for d in os.environ.get("PODBENCH_STRUCTURES", "").split(os.pathsep)
        if d and Path(d).resolve() not in (bundled.resolve(), local.resolve())]
    shadow = set()
    for d in folders:
        names = _names_in(d)
        where = "./structures" if d == local else f"{d} (PODBENCH_STRUCTURES)"
        print(f"structures in {where}:")
        for name in names:
            print(f"  {name}")
        if not names:
            print("  (none)")
        shadow |= set(names)
    print(f"structures bundled with podbench ({display_path(bundled)}):")
    for name in _names_in(bundled):
        print(f"  {name}" + ("  (a local file of this name comes first)" if name in shadow
                             else ""))
    _list_local_scenarios()
    runners: dict = {}
    for name, d in bundled_studies().items():
        cmd = "sweep" if name == SWEEPS_STUDY else "run"
        if _own_runner(d):
            print(f"study bundled with podbench: {name} ({display_path(d)}; podbench run "
                  f"{name}):")
        else:
            print(f"scenarios bundled with podbench: {name} ({display_path(d)}; "
                  f"podbench {cmd} {name}, or {name}/<scenario> for one):")
        _list_scenarios(d, "  ", runners)
    print("methods (podbench methods NAME: the parameters):")
    for e in registry.ENTRIES:
        fixed = ", ".join(f"{k}={v!r}" for k, v in e.params.items())
        print(f"  {e.name}: {e.cls.__name__}{f'({fixed})' if fixed else ''} — {e.summary}")
    print("  module:Class or file.py:Class (your own; see podbench.methods.PODMethod)")
    print("deconvolution solvers: " + ", ".join(available_solvers()))
    print("study runners (a study file's [study] runner = \"<name>\"; the bundled study "
          "using each):")
    for name, title in runners.items():
        print(f"  {name}: {title}")
    return 0


def _list_local_scenarios() -> None:
    """The studies of ./scenarios, unless it is the bundled folder (a checkout)."""
    local_sc = Path("scenarios")
    if not local_sc.is_dir() or local_sc.resolve() == bundled_scenarios().resolve():
        return
    studies = [d for d in sorted(local_sc.iterdir()) if d.is_dir() and any(d.glob("*.toml"))]
    if any(local_sc.glob("*.toml")):
        studies.insert(0, local_sc)
    for d in studies:
        print(f"scenarios in ./{d.as_posix()} (podbench run {d.as_posix()}):")
        _list_scenarios(d, "  ")


def _own_runner(folder: Path) -> bool:
    """Whether a study folder is one study file with its own runner."""
    files = [f for f in folder.glob("*.toml") if f.name not in ("claims.toml",
                                                                "experiment.toml")]
    return len(files) == 1 and _toml_summary(files[0])[0] == "own"


def _list_arg(text, name: str, kind):
    """Parse a comma-separated option (``--noise 0,0.01``; ``--seeds 0-4``)."""
    if text is None:
        return None
    out: list = []
    for item in text.split(","):
        item = item.strip()
        try:
            if kind is int and "-" in item[1:]:
                lo, hi = item.split("-", 1)
                lo, hi = int(lo), int(hi)
                if hi < lo:
                    raise ValueError
                out.extend(range(lo, hi + 1))
            elif kind is str:
                if not item:
                    raise ValueError
                out.append(item)
            else:
                out.append(kind(item))
        except ValueError:
            what = {float: "numbers", int: "integers or ranges a-b", str: "names"}[kind]
            raise InputError(f"--{name}: cannot read {item!r} in {text!r} (expected a "
                         f"comma-separated list of {what})") from None
        if len(out) > _MAX_LIST:
            raise InputError(f"--{name}: {text!r} gives more than {_MAX_LIST} values")
    minimum = _LIST_MINIMUM.get(name)
    for v in out:
        if kind is float and not math.isfinite(v):
            raise InputError(f"--{name}: expected finite numbers, got {v!r} in {text!r}")
        if minimum is not None and v < minimum:
            raise InputError(f"--{name}: expected values >= {minimum:g}, got {v!r} in {text!r}")
        if name == "noise" and v > 1:  # std = level × the channel's RMS: 5 is 500 %
            raise InputError(f"--noise: expected levels in [0, 1] (std = level × each "
                             f"channel's RMS), got {v:g} in {text!r}{noise_level_hint(v)}")
    seen = set()
    for v in out:
        if v in seen:
            raise InputError(f"--{name}: {v!r} is listed twice in {text!r}")
        seen.add(v)
    return out


_MAX_LIST = 10_000
_LIST_MINIMUM = {"noise": 0.0, "n-modes": 1, "seeds": 0}
"""Smallest value of each numeric list option: noise levels are relative (>= 0), a POD basis
has at least one mode, noise seeds are non-negative (``numpy.random.SeedSequence``)."""


def cmd_sweep(args) -> int:
    res = api.sweep(args.paths, out=args.out, noise=_list_arg(args.noise, "noise", float),
                    n_modes=_list_arg(args.n_modes, "n-modes", int),
                    seeds=_list_arg(args.seeds, "seeds", int),
                    solvers=_list_arg(args.solvers, "solvers", str), jobs=args.jobs,
                    scheduler=args.scheduler, cache=_cache(args), engine=args.engine,
                    progress=Progress(quiet=args.quiet))
    df = res.table
    where = (f"Dask scheduler {args.scheduler}" if args.scheduler
             else _plural(res.jobs, "process", "processes") + " at most" * (res.jobs > 1))
    print(f"{_plural(len(df), 'row')} from {_plural(df.attrs.get('tasks', 0), 'point')} in "
          f"{res.seconds:.1f} s on {where} ({_plural(df.attrs.get('simulated', 0), 'response')} "
          f"simulated, {df.attrs.get('cached', 0)} from the cache)")
    for name, csv_path in res.written.items():
        print(f"  {name} -> {csv_path} and sweep.md")
    failed = df[df.status != "ok"]
    if len(failed):
        print(f"note: {_plural(len(failed), 'row has', 'rows have')} a failed method or twin "
              "(see sweep.md)")
    _refuse_dead_points(df, res.written)
    return 0


def _refuse_dead_points(df, written) -> None:
    """A sweep point none of whose rows was measured is a configuration mistake (the
    scientific failures, an ill-conditioned fit, leave the point's other rows): an error
    counting them, after the tables are written for inspection."""
    point = ["scenario", "structure", "noise", "modes", "seed"]
    dead = df.groupby(point, sort=False)["status"].agg(lambda s: bool((s != "ok").all()))
    if not dead.any():
        return
    sc, structure, noise, k, seed = dead[dead].index[0]
    first = df[(df.scenario == sc) & (df.structure == structure) & (df.noise == noise)
               & (df.modes == k) & (df.seed == seed)].iloc[0]
    raise InputError(
        f"{int(dead.sum())} of {len(dead)} sweep points measured nothing (every row failed); "
        f"the first, {sc} × {structure}, noise {noise:g}, k {'own' if k < 0 else k}, seed "
        f"{seed}: {first.method}: {first.status} (all: {written.get(sc, 'sweep.csv')})")


def _one_line(text: object, limit: int = 1000) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


_PARAMETER = re.compile(r"[Pp]arameter `(\w+)`( = )?")


def _as_flags(message: str, parser) -> str:
    """An API error as the command line says it: a Python parameter the command has as an
    option (``Parameter `n_modes```) named by its flag (``--n-modes``)."""
    flags = {a.dest: a.option_strings[-1] for sub in _subparsers(parser)
             for a in sub._actions if a.option_strings}
    if not message.startswith(("Parameter", "parameter")):
        return message

    def flag(m):
        f = flags.get(m.group(1))
        return m.group(0) if f is None else f + (" " if m.group(2) else "")

    return _PARAMETER.sub(flag, message)


def _option_elsewhere(parser, option: str) -> str:
    """``" (--coverage is an option of podbench predict)"`` for an option another command
    takes, else ""."""
    name = option.split("=", 1)[0]
    where = [p.prog for p in _subparsers(parser)[1:]
             if any(name in a.option_strings for a in p._actions)]
    return f" ({name} is an option of {' and '.join(where)})" if where else ""


def _subparsers(parser) -> list:
    out = [parser]
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            out += list(a.choices.values())
    return out


def main(argv=None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    parser = _parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:  # named by the subcommand, with the commands that take such an option
            raise _ArgError(f"podbench {args.command}" if args.command else "podbench",
                            f"unrecognized arguments: {' '.join(extra)}"
                            f"{_option_elsewhere(parser, extra[0])}")
    except _ArgError as exc:
        print(f"{exc.prog}: error: {_one_line(exc)} (see {exc.prog} --help)", file=sys.stderr)
        return 2
    if args.command is None:
        parser.print_help()
        return 2
    args.argv = list(sys.argv[1:] if argv is None else argv)  # shown in the report

    prog = f"podbench {args.command}"

    one_line_warnings(prog)
    try:
        return {"run": cmd_run, "regress": cmd_regress, "sweep": cmd_sweep,
                "list": cmd_list, "experiment": cmd_experiment,
                "predict": cmd_predict, "methods": cmd_methods,
                "fit": cmd_fit}[args.command](args)
    except PodbenchError as exc:
        print(f"{prog}: error: {_one_line(_as_flags(str(exc), parser))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        out = getattr(args, "out", None)  # outputs are written whole or not at all
        kept = f"{out}/ was left as it was" if out else "nothing was left half-written"
        print(f"{prog}: interrupted; {kept}", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout stopped (podbench list | head): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except MemoryError as exc:
        print(f"{prog}: error: out of memory ({_one_line(exc, 300) or 'MemoryError'}); reduce "
              "n_samples, the structures or --jobs", file=sys.stderr)
        return 2
    except OSError as exc:  # permission denied, disk full, a path that is a folder, ...
        if getattr(args, "debug", False):
            traceback.print_exc()
        what = exc.strerror or str(exc) or type(exc).__name__
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"{prog}: error: {_one_line(where + what)}", file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback with --debug
        if getattr(args, "debug", False):
            traceback.print_exc()
        lines = [ln for ln in str(exc).splitlines() if ln.strip()]
        msg = _one_line(lines[-1] if lines else "", 300)  # a worker's traceback: its last line
        print(f"{prog}: internal error: {type(exc).__name__}: {msg} (this is a bug; rerun "
              "with --debug for the traceback)", file=sys.stderr)
        return 3


def reference_markdown() -> str:
    """The command-line reference (docs/reference/cli.md): every command's ``--help``, as the
    parser prints it at 100 columns."""
    parser = _parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        parts = ["# Command line\n\nGenerated from the parser (`podbench <command> --help`); "
                 "tests/test_docs_site.py checks that it is current.\n\n```text\n"
                 + parser.format_help() + "```\n"]
        for name, sp in subs.choices.items():
            parts.append(f"\n## podbench {name}\n\n```text\n{sp.format_help()}```\n")
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old
    return "".join(parts)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
