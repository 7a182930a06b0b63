"""Command line: ``podbench run | regress | sweep | list | experiment | predict``.

Exit codes: 0 success; 1 ``regress`` found an error that got worse; 2 unusable input (a
missing path, a malformed scenario/structure/claims file, an unknown name, a bad option, an
unwritable output), reported on one line; 3 an internal error (a bug: one line, ``--debug``
shows the traceback); 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import textwrap
import time
import traceback
from pathlib import Path

DEFAULT_STUDY = "chapter4"
#: What `podbench regress` re-runs without a PATH (the committed baseline holds their rows):
#: the numerical study and the noisy-measurement study.
REGRESS_STUDIES = ("chapter4", "chapter5")
"""The bundled study ``run`` and ``regress`` run without a path (``podbench/bundled/``)."""
DEFAULT_SWEEPS = "sweeps"
"""The bundled folder of sweep scenarios ``sweep`` runs without a path."""
DEFAULT_BASELINE = Path("results") / "baseline.csv"
DEFAULT_CACHE = Path(".podbench_cache")
DEFAULT_RESULTS = Path("results")

_EPILOG = """\
Units are inch, lbf and second throughout. Errors are relative (fractions of ‖W‖_F of the
target) and the norm percent errors follow Eq. 4.2 of Allison (2007); README.md defines
every column. Exit codes: 0 ok, 1 regression found (regress), 2 unusable input (one line
naming the file and field, or the option), 3 internal error (a bug; --debug shows the
traceback), 130 interrupted.
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
    from . import __version__

    p.add_argument("--version", action="version", version=f"podbench {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    def common(sp, paths_help):
        sp.add_argument("paths", nargs="*", metavar="PATH", help=paths_help)
        sp.add_argument("-j", "--jobs", type=_positive_int, default=1, metavar="N",
                        help="worker processes for the (scenario, structure) units "
                             "(default 1; results do not depend on N)")
        sp.add_argument("--cache", default=str(DEFAULT_CACHE), metavar="DIR",
                        help=f"truth-data cache folder (default {DEFAULT_CACHE}); entries are "
                             "keyed by the content of structure and scenario")
        sp.add_argument("--no-cache", action="store_true", help="simulate everything afresh")
        sp.add_argument("--engine", choices=("newmark", "exudyn"), default=None,
                        help="override the scenarios' integration engine (default: each "
                             "scenario's own, normally newmark)")
        sp.add_argument("-q", "--quiet", action="store_true",
                        help="no progress on stderr (neither the bar nor the plain lines)")
        sp.add_argument("--debug", action="store_true",
                        help="show the Python traceback of an internal error (exit code 3)")

    r = sub.add_parser(
        "run", help="run scenarios and write tables, figures and findings",
        description=textwrap.fill(
                    "Simulate the truth data (cached), fit every method of every scenario, "
                    "predict every target and write OUT/summary.csv, OUT/summary.md, "
                    "OUT/fits.csv, OUT/figures/*.png and (with a claims.toml beside the "
                    "scenarios) OUT/FINDINGS.md. OUT is replaced as a whole only when "
                    "everything is written. A part of a study (a scenario file given alone) "
                    "is written to its own folder, results/<file name>, never over the "
                    "study's results/<study>; an existing OUT that holds scenarios this run "
                    "does not produce is refused.", width=88),
        epilog=_EPILOG + """
Examples:
  podbench run                           # the bundled Chapter 4 study -> results/chapter4
  podbench run chapter4/beam_forced      # one bundled scenario -> results/beam_forced
  podbench run my_study/                 # your folder of scenarios -> results/my_study
  podbench run my_study/a.toml           # one of your files -> results/a
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    common(r, "scenario files or folders of them, or a bundled study (chapter4) or scenario "
              "(chapter4/beam_forced) by name when no such path exists (default: chapter4); "
              "the claims.toml beside the scenarios is judged into FINDINGS.md")
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

    g = sub.add_parser(
        "regress", help="re-run the study and compare every error with the baseline",
        description="Re-run the scenarios (no figures, nothing written to results/ except "
                    "with --update) and compare every error column with the baseline table. "
                    "An error is worse when new > base·(1 + rtol) + atol. Exit 0 when "
                    "nothing got worse, 1 with a readable diff when something did, 2 on "
                    "unusable input.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    common(g, "scenario files or folders of them, or a bundled study or scenario by name "
              "(default: chapter4 and chapter5, the studies of results/baseline.csv); claims "
              "are not judged and nothing is written")
    g.add_argument("--baseline", default=str(DEFAULT_BASELINE), metavar="CSV",
                   help=f"baseline table (default {DEFAULT_BASELINE})")
    g.add_argument("--rtol", type=_tolerance, default=0.01,
                   help="relative tolerance, finite and >= 0 (default 0.01)")
    g.add_argument("--atol", type=_tolerance, default=1e-6,
                   help="absolute tolerance, finite and >= 0 (default 1e-6)")
    g.add_argument("--update", action="store_true",
                   help="write this run's table as the new baseline (deliberately) and exit 0")
    g.add_argument("--table", default=None, metavar="CSV",
                   help="compare this existing summary.csv instead of re-running")

    w = sub.add_parser(
        "sweep", help="run scenarios over noise levels, mode counts, seeds and solvers",
        description=textwrap.fill(
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
                    "cluster (--scheduler).", width=88),
        epilog=_EPILOG + """
Examples:
  podbench sweep                                   # the bundled sweeps, 1 process
  podbench sweep sweeps/beam_forced_noise --jobs 2
  podbench sweep chapter4/beam_forced --noise 0,0.01 --seeds 0-4 --solvers ls,tls
  podbench sweep --scheduler tcp://10.0.0.5:8786   # needs pip install 'podbench[dask]'

[sweep] table of a scenario file (every field optional):
  noise = [0.0, 0.01, 0.05]   seeds = [0, 1, 2]   n_modes = [3, 4]
  solvers = ["ls", "tls"]     noise_on = ["W", "F"]   coupled_train = "first"
n_modes replaces every method's k; MDS and ML (k = number of training sets) train on their
first k cases ("first") or on all of them ("all"). See podbench.harness.sweep.
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    w.add_argument("paths", nargs="*", metavar="PATH",
                   help="scenario files or folders of them, or a bundled study or scenario by "
                        f"name (default: the bundled {DEFAULT_SWEEPS})")
    w.add_argument("-j", "--jobs", type=_positive_int, default=1, metavar="N",
                   help="local worker processes (default 1; the table does not depend on N)")
    w.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the points on a Dask distributed cluster, e.g. "
                        "tcp://host:8786 (workers need podbench and the same project folder "
                        "at the same path); replaces --jobs")
    w.add_argument("--noise", default=None, metavar="LIST",
                   help="relative noise levels, comma-separated (e.g. 0,0.01,0.05)")
    w.add_argument("--n-modes", default=None, metavar="LIST",
                   help="mode counts k, comma-separated (e.g. 3,4,5)")
    w.add_argument("--seeds", default=None, metavar="LIST",
                   help="noise seeds: comma-separated integers and ranges (e.g. 0-4 or 0,3,7)")
    w.add_argument("--solvers", default=None, metavar="LIST",
                   help="deconvolution solvers for SL, ML and MR, comma-separated (e.g. ls,tls; "
                        "podbench list shows them)")
    w.add_argument("-o", "--out", default="results", metavar="DIR",
                   help="output root: each scenario writes DIR/<scenario name>/sweep.csv and "
                        "sweep.md (default results); DIR/<scenario name> must not exist, be "
                        "empty, or be a previous sweep output (holding sweep.csv)")
    w.add_argument("--cache", default=str(DEFAULT_CACHE), metavar="DIR",
                   help=f"truth-data cache folder (default {DEFAULT_CACHE}); noise is added "
                        "after loading, so sweep and run share entries")
    w.add_argument("--no-cache", action="store_true", help="simulate everything afresh")
    w.add_argument("--engine", choices=("newmark", "exudyn"), default=None,
                   help="override the scenarios' integration engine")
    w.add_argument("-q", "--quiet", action="store_true",
                   help="no progress on stderr (neither the bar nor the plain lines)")
    w.add_argument("--debug", action="store_true",
                   help="show the Python traceback of an internal error (exit code 3)")

    x = sub.add_parser(
        "experiment", help="write (or --check) the records of a virtual experiment",
        description=textwrap.fill(
            "Simulate the laboratory tests of an experiment.toml (podbench.experiments: the "
            "tests, their loads, per-channel noise levels), and write one record file per "
            "test, noise level and case under data/ beside it (each data/<test> folder "
            "replaced atomically). The study's scenarios read those files back like "
            "measurements. With --check nothing is written: the committed files are "
            "compared byte for byte with a fresh generation (exit 1 when they differ).",
            width=88),
        epilog="""
Examples:
  podbench experiment chapter5           # the bundled Chapter 5 tests -> its data/
  podbench experiment my_study/          # my_study/experiment.toml -> my_study/data/
  podbench experiment chapter5 --check   # are the committed records up to date?
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    x.add_argument("path", help="an experiment.toml, its folder, or a bundled study by name")
    x.add_argument("--check", action="store_true",
                   help="compare with a fresh generation instead of writing")
    x.add_argument("--debug", action="store_true",
                   help="show the Python traceback of an internal error (exit code 3)")

    pr = sub.add_parser(
        "predict", help="fit a method on training records, predict target records",
        description=textwrap.fill(
            "Fit METHOD on the --train record files and predict every --target file: "
            "OUT/errors.csv (target, method, total_error = ‖ŷ − y‖_F/‖y‖_F where the target "
            "holds outputs, units) and OUT/<target stem>.npz with the prediction W_hat "
            "(n_out × n). Records: input/output files (inputs, outputs, dt, "
            "input_channels, output_channels, input_units, output_units) or W/F files. "
            "Every file is checked before any fitting; OUT is written whole or not at all.",
            width=88),
        epilog="""
Examples:
  podbench predict --method ML --train a.npz b.npz c.npz --target x.npz --out pred/
  podbench predict --method FIR-LS --train ev*.npz --target new.npz --out pred/ \
      --input-units m/s^2 --output-units m/s^2     # files without unit variables
""", formatter_class=argparse.RawDescriptionHelpFormatter)
    pr.add_argument("--method", required=True,
                    help="ML, FIR-LS, ERA, DMDc, OpInf (SL, MR: refused where they do not "
                         "apply, with the reason)")
    pr.add_argument("--train", nargs="+", required=True, metavar="FILE")
    pr.add_argument("--target", nargs="+", required=True, metavar="FILE")
    pr.add_argument("--out", required=True, metavar="DIR",
                    help="output folder (new, empty, or a previous predict output)")
    pr.add_argument("--solver", default="auto",
                    help="ML's kernel: auto (TC prior with >= 3 training records), ls, tc "
                         "(truncated kernel, lags by leave-one-record-out), or a "
                         "deconvolution solver name (block, cgls, ...) for the kernel over "
                         "the whole record (records of one length)")
    pr.add_argument("--n-modes", type=_positive_int, default=None, metavar="K")
    pr.add_argument("--coverage", type=float, default=None, metavar="P",
                    help="prediction band coverage (not available yet: refused)")
    pr.add_argument("--units", choices=("SI", "inch-lbf"), default=None,
                    help="convert every record to this unit system when it is read")
    pr.add_argument("--input-units", default=None, metavar="UNIT",
                    help="units of the inputs for files that carry none (e.g. m/s^2)")
    pr.add_argument("--output-units", default=None, metavar="UNIT",
                    help="units of the outputs for files that carry none")
    pr.add_argument("--debug", action="store_true",
                    help="show the Python traceback of an internal error (exit code 3)")

    ls = sub.add_parser("list", help="list structures, scenarios, methods and solvers",
                        description="List the structures and scenarios bundled with podbench "
                                    "and those of the current folder (./structures, "
                                    "PODBENCH_STRUCTURES, ./scenarios), each with where it "
                                    "comes from, the built-in methods and the deconvolution "
                                    "solvers.")
    ls.add_argument("--debug", action="store_true",
                    help="show the Python traceback of an internal error (exit code 3)")
    return p


class _Usage(Exception):
    pass


def _scenario_paths(paths, default=(DEFAULT_STUDY,)):
    """The paths to run (a bundled study or scenario where a name is not an existing path;
    the bundled studies ``default`` without ``paths``) and their scenario files."""
    from ._resources import bundled_studies, resolve_bundled
    from .scenarios import find_scenarios

    resolved = []
    for p in paths or ([default] if isinstance(default, str) else list(default)):
        if not paths or not Path(p).exists():
            b = resolve_bundled(p)
            if b is None:
                names = ", ".join(bundled_studies())
                raise _Usage(f"{p}: no such file or folder, nor a bundled study or scenario "
                             f"(bundled studies: {names}; podbench list shows every scenario)")
            resolved.append(b)
        else:
            resolved.append(Path(p))
    return resolved, find_scenarios(resolved)


def _whole_study(claims_path, scenarios) -> bool:
    """Whether ``scenarios`` holds every scenario of the claims file's folder."""
    from .scenarios import find_scenarios

    return {p.stem for p in find_scenarios([Path(claims_path).parent])} <= set(scenarios)


def _claims_path(paths):
    from .scenarios import CLAIMS_FILE

    dirs = {Path(p).resolve() if Path(p).is_dir() else Path(p).resolve().parent for p in paths}
    found = [d / CLAIMS_FILE for d in sorted(dirs) if (d / CLAIMS_FILE).is_file()]
    if len(found) != 1:
        return None
    return found[0]


def _writable_folder(path, option: str) -> Path:
    """``path`` after checking, before any work, that it is a folder or can be created as one:
    not a file, not under a file, its nearest existing ancestor writable."""
    p = Path(path).expanduser()
    if p.exists() and not p.is_dir():
        raise _Usage(f"{option} {path}: exists and is not a folder")
    a = p.absolute()
    while not a.exists() and a != a.parent:
        a = a.parent
    if not a.is_dir():
        raise _Usage(f"{option} {path}: {a} is a file, so no folder can be made under it")
    if not os.access(a, os.W_OK | os.X_OK):
        raise _Usage(f"{option} {path}: {a} is not writable")
    return p


def _output_folder(path, option: str, marker: str, *, also=()) -> Path:
    """Check an output folder that podbench fills (or replaces): it must not exist, be empty,
    or be a previous podbench output (holding ``marker``), so that a mistyped ``--out ~``
    cannot replace a home folder; ``marker`` and ``also`` must not be folders."""
    p = _writable_folder(path, option)
    if p.is_dir():
        for name in (marker, *also):
            if (p / name).exists() and not (p / name).is_file():
                raise _Usage(f"{option} {path}: {p / name} is a folder, not a file")
        if not (p / marker).is_file() and any(p.iterdir()):
            raise _Usage(f"{option} {path}: a non-empty folder that is not a podbench output "
                         f"(no {marker} in it); give a new or empty folder")
    return p


def _default_out(paths) -> Path:
    """``results/<folder name>`` for a folder, ``results/<file stem>`` for a single scenario
    file (a part of a study never goes over the study's folder), names joined by ``+``."""
    names = [Path(p).resolve().name if Path(p).is_dir() else Path(p).stem for p in paths]
    return DEFAULT_RESULTS / "+".join(dict.fromkeys(names))


def _scenarios_held(out: Path) -> set[str]:
    """The scenarios of a previous output's ``summary.csv`` (empty if none or unreadable)."""
    import csv

    try:
        with open(out / "summary.csv", newline="", encoding="utf-8") as fh:
            return {row["scenario"] for row in csv.DictReader(fh) if row.get("scenario")}
    except (OSError, UnicodeDecodeError, KeyError, csv.Error):
        return set()


def _refuse_partial_over(out: Path, names, option: str) -> None:
    """Refuse to replace an output holding scenarios this run does not produce (running
    one scenario of a study must not replace the whole study's results)."""
    lost = sorted(_scenarios_held(out) - set(names))
    if lost:
        shown = ", ".join(lost[:4]) + (f" and {len(lost) - 4} more" if len(lost) > 4 else "")
        raise _Usage(f"{option} {out}: holds the results of {len(lost)} scenario"
                     f"{'s' if len(lost) != 1 else ''} this run does not produce ({shown}); "
                     "replacing it would lose them: give another --out, or run them all")


def _plural(n: int, word: str, plural: str | None = None) -> str:
    """``1 response``, ``2 responses``."""
    return f"{n} {word if n == 1 else (plural or word + 's')}"


def _load_all(files) -> dict:
    from .scenarios import load_scenario

    scenarios = {}
    for f in files:
        sc = load_scenario(f)
        if sc.name in scenarios:
            raise _Usage(f"{f}: a second scenario named {sc.name!r}")
        scenarios[sc.name] = sc
    return scenarios


def _progress(args):
    from .harness.progress import Progress

    return Progress(quiet=args.quiet)


def _run(args, files, *, figures: bool, progress=None):
    from .harness.runner import run_study

    if args.jobs < 1:
        raise _Usage(f"--jobs: expected a positive integer, got {args.jobs}")
    if not args.no_cache:
        _writable_folder(args.cache, "--cache")
    t0 = time.perf_counter()
    results = run_study(files, jobs=args.jobs, cache_dir=None if args.no_cache else args.cache,
                        engine=args.engine, progress=progress or _progress(args),
                        keep_series=figures)
    return results, time.perf_counter() - t0


def cmd_predict(args) -> int:
    from .predict import predict_files

    out = _output_folder(args.out, "--out", "errors.csv")
    rows = predict_files(args.method, args.train, args.target, out, solver=args.solver,
                         n_modes=args.n_modes, coverage=args.coverage,
                         input_units=args.input_units, output_units=args.output_units,
                         units=args.units)
    for r in rows:
        print(f"{r['target']}: {r['method']} total_error {r['total_error'] or '(no outputs)'}")
    print(f"{_plural(len(rows), 'prediction')} -> {out}/")
    return 0


def cmd_painter_street(args) -> int:
    """``podbench run painter_street``: the measured-bridge study (podbench.painter_street)."""
    from .painter_street import run_study, write_study

    out = Path(args.out) if args.out else DEFAULT_RESULTS / "painter_street"
    _output_folder(out, "--out", "summary.csv")
    t0 = time.perf_counter()
    say = None if args.quiet else (lambda m: print(f"painter_street: {m}", file=sys.stderr))
    res = run_study(progress=say)
    if args.no_figures:
        res["no_figures"] = True
    write_study(res, out)
    print(f"{_plural(len(res['rows']), 'row')} from {len(res['records']['three'])} events in "
          f"{time.perf_counter() - t0:.1f} s -> {out}/summary.csv, {out}/FINDINGS.md")
    return 0


def cmd_run(args) -> int:
    from ._resources import display_path

    if [str(p).rstrip("/") for p in args.paths] == ["painter_street"] \
            and not Path("painter_street").exists():
        return cmd_painter_street(args)
    from .harness.report import write_study
    from .harness.runner import response_counts

    paths, files = _scenario_paths(args.paths)
    out = Path(args.out) if args.out else _default_out(paths)
    _output_folder(out, "--out", "summary.csv")
    scenarios = _load_all(files)
    _refuse_partial_over(out, scenarios, "--out")
    claims = _claims_path(paths)
    claims_file = None
    if claims is not None:  # read (and checked) before any simulation
        from .harness.claims import load_claims_file

        claims_file = load_claims_file(claims)
    progress = _progress(args)
    results, secs = _run(args, files, figures=not args.no_figures, progress=progress)
    linked = None
    if claims_file is not None:  # the claims' sensitivity study, judged with the same code
        from .harness.sensitivity import run_linked

        linked = run_linked(claims_file, scenarios, jobs=args.jobs,
                            cache_dir=None if args.no_cache else args.cache,
                            engine=args.engine, progress=progress)
    nonlinearity = None
    if claims_file is not None and claims_file.nonlinearity is not None \
            and _whole_study(claims, scenarios):  # §5.2's checks: only on a whole-study run
        from .harness.nonlinearity_study import run_checks

        spec = claims_file.nonlinearity
        nonlinearity = (spec, run_checks(spec, jobs=args.jobs, progress=progress,
                                         cache_dir=None if args.no_cache else args.cache))
    df, evaluated = write_study(results, out, scenarios=scenarios, claims_path=claims,
                                figures=not args.no_figures, jobs=args.jobs,
                                figure_format=args.figure_format, progress=progress,
                                command=shlex.join(["podbench", *map(str, args.argv)]),
                                sensitivity=linked, nonlinearity=nonlinearity)
    n_sim, n_cached = response_counts(results)
    print(f"{_plural(len(df), 'row')} from {_plural(len(scenarios), 'scenario')} in {secs:.1f} s "
          f"({_plural(n_sim, 'response')} simulated, {n_cached} from the cache) -> "
          f"{out}/summary.csv")
    if evaluated is not None:
        n_ok = sum(e["verdict"] == "reproduced" for e in evaluated)
        print(f"claims: {n_ok} of {len(evaluated)} reproduced -> {out}/FINDINGS.md")
    failed = df[df.status != "ok"]
    if len(failed):
        print(f"note: {_plural(len(failed), 'row has', 'rows have')} a failed method or twin "
              "(see summary.md)")
    parts = [p for p in paths if not Path(p).is_dir()]
    if parts and not args.out:
        folders = dict.fromkeys(Path(p).resolve().parent for p in parts)
        for folder in folders:
            print(f"part of the study in {display_path(folder)}: written to {out}/, "
                  f"{DEFAULT_RESULTS / folder.name}/ left as it was")
    return 0


def cmd_experiment(args) -> int:
    from ._resources import display_path, resolve_bundled
    from .experiments import check_experiment, write_experiment

    path = Path(args.path)
    if not path.exists():
        b = resolve_bundled(args.path)
        if b is None or not b.is_dir():
            raise _Usage(f"{args.path}: no such file or folder, nor a bundled study")
        path = b
    if args.check:
        bad = check_experiment(path)
        for f in bad:
            print(f"differs: {f}")
        print(f"{len(bad)} record file(s) differ from a fresh generation" if bad
              else "every record file equals a fresh generation")
        return 1 if bad else 0
    written = write_experiment(path)
    folders = sorted({display_path(f.parent.parent) for f in written})
    print(f"{len(written)} record files written under {', '.join(folders)}")
    return 0


def cmd_regress(args) -> int:
    from .harness.regress import compare, read_table
    from .harness.report import atomic_write_text, summary_table, table_csv

    files = None
    if not args.table:
        files = _scenario_paths(args.paths, REGRESS_STUDIES)[1]  # missing paths first
    baseline = Path(args.baseline)
    if args.update:  # checked before any work: the new baseline can be written
        if baseline.is_dir():
            raise _Usage(f"--baseline {args.baseline}: is a folder, not a CSV file")
        if baseline.parent.exists() and not baseline.parent.is_dir():
            raise _Usage(f"--baseline {args.baseline}: {baseline.parent} is a file, not a folder")
        _writable_folder(baseline.parent, "--baseline")
    elif not baseline.is_file():
        raise _Usage(f"{args.baseline}: no such baseline (create it with --update)")
    base = None if args.update else read_table(args.baseline)
    if args.table:
        new = read_table(args.table)
    else:
        _load_all(files)
        results, _ = _run(args, files, figures=False)
        new = summary_table(results)
    if args.update:
        atomic_write_text(args.baseline, table_csv(new))
        print(f"baseline updated: {args.baseline} ({len(new)} rows)")
        return 0
    cmp = compare(new, base, rtol=args.rtol, atol=args.atol)
    print(cmp.report(args.rtol, args.atol))
    return 1 if cmp.failed else 0


def _list_scenarios(folder: Path, indent: str) -> None:
    from .errors import PodbenchError
    from .scenarios import CLAIMS_FILE, NOT_SCENARIOS, load_scenario

    for f in sorted(folder.glob("*.toml")):
        if f.name in NOT_SCENARIOS:
            continue
        try:
            sc = load_scenario(f)
        except PodbenchError as exc:
            print(f"{indent}{f.stem}: (unreadable: {_one_line(exc, 200)})")
            continue
        methods = ", ".join(m.label for m in sc.reported_methods())
        sweep = "; [sweep]" if getattr(sc, "sweep", None) else ""
        print(f"{indent}{sc.name}: {sc.title} [{', '.join(sc.structures)}; {methods}{sweep}]")
    if (folder / CLAIMS_FILE).is_file():
        print(f"{indent}(claims: {CLAIMS_FILE}, judged into FINDINGS.md)")


def _names_in(folder: Path) -> list[str]:
    """Structure names of one folder (``sub/name`` for files in sub-folders)."""
    if not folder.is_dir():
        return []
    return sorted(p.relative_to(folder).with_suffix("").as_posix()
                  for p in folder.rglob("*.toml"))


def cmd_list(args) -> int:
    from ._resources import bundled_structures, bundled_studies, display_path
    from .deconvolution import available_solvers
    from .fem.files import structure_dirs
    from .methods import BUILTIN_METHODS

    bundled = bundled_structures()
    local = Path("structures")
    folders = ([local] if local.is_dir() else []) + [
        d for d in structure_dirs() if d.resolve() != bundled.resolve()]
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
    local_sc = Path("scenarios")
    if local_sc.is_dir():
        studies = [d for d in sorted(local_sc.iterdir()) if d.is_dir() and any(d.glob("*.toml"))]
        if any(local_sc.glob("*.toml")):
            studies.insert(0, local_sc)
        for d in studies:
            print(f"scenarios in ./{d.as_posix()} (podbench run {d.as_posix()}):")
            _list_scenarios(d, "  ")
    for name, d in bundled_studies().items():
        cmd = "sweep" if name == DEFAULT_SWEEPS else "run"
        print(f"scenarios bundled with podbench: {name} ({display_path(d)}; "
              f"podbench {cmd} {name}, or {name}/<scenario> for one):")
        _list_scenarios(d, "  ")
    print("methods:")
    for name, cls in BUILTIN_METHODS.items():
        est = cls()
        twin = est.coupled_twin()
        what = "coupled" if est.coupled else f"diagonal; coupled twin {_twin_name(twin)}"
        print(f"  {name}: {cls.__name__} ({est.excitation_kind}; {what})")
    print("  superposition (sum of other methods; MR's coupled twin)")
    print("  module:Class or file.py:Class (your own; see podbench.methods.PODMethod)")
    print("deconvolution solvers: " + ", ".join(available_solvers()))
    return 0


def _twin_name(est) -> str:
    parts = getattr(est, "parts", None)
    if parts:
        return " + ".join(_twin_name(p) for p in parts)
    if getattr(est, "excitation", None):
        return f"{est.abbreviation} ({est.excitation})"
    return est.abbreviation


def _list_arg(text, name: str, kind):
    """Parse a comma-separated option (``--noise 0,0.01``; ``--seeds 0-4``)."""
    if text is None:
        return None
    out = []
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
            raise _Usage(f"--{name}: cannot read {item!r} in {text!r} (expected a "
                         f"comma-separated list of {what})") from None
        if len(out) > _MAX_LIST:
            raise _Usage(f"--{name}: {text!r} gives more than {_MAX_LIST} values")
    minimum = _LIST_MINIMUM.get(name)
    for v in out:
        if kind is float and not math.isfinite(v):
            raise _Usage(f"--{name}: expected finite numbers, got {v!r} in {text!r}")
        if minimum is not None and v < minimum:
            raise _Usage(f"--{name}: expected values >= {minimum:g}, got {v!r} in {text!r}")
    seen = set()
    for v in out:
        if v in seen:
            raise _Usage(f"--{name}: {v!r} is listed twice in {text!r}")
        seen.add(v)
    return out


_MAX_LIST = 10_000
_LIST_MINIMUM = {"noise": 0.0, "n-modes": 1, "seeds": 0}
"""Smallest value of each numeric list option: noise levels are relative (>= 0), a POD basis
has at least one mode, noise seeds are non-negative (``numpy.random.SeedSequence``)."""


def cmd_sweep(args) -> int:
    from .deconvolution import available_solvers
    from .harness.sweep import run_sweep, write_sweep
    from .scenarios import SolverChoice, load_scenario

    if args.jobs < 1:
        raise _Usage(f"--jobs: expected a positive integer, got {args.jobs}")
    if args.scheduler is not None and args.jobs != 1:
        raise _Usage("--jobs and --scheduler: give one (the Dask cluster sets the parallelism)")
    axes = {"noise": _list_arg(args.noise, "noise", float),
            "n_modes": _list_arg(args.n_modes, "n-modes", int),
            "seeds": _list_arg(args.seeds, "seeds", int)}
    solvers = _list_arg(args.solvers, "solvers", str)
    if solvers is not None:
        for name in solvers:
            if name not in available_solvers():
                raise _Usage(f"--solvers: unknown solver {name!r}; solvers: "
                             f"{', '.join(available_solvers())}")
        axes["solvers"] = [SolverChoice(label=n, solver=n) for n in solvers]
    _, files = _scenario_paths(args.paths, default=DEFAULT_SWEEPS)
    if not args.no_cache:
        _writable_folder(args.cache, "--cache")
    _writable_folder(args.out, "--out")
    for f in files:  # each scenario writes OUT/<name>/sweep.csv, sweep.md
        _output_folder(Path(args.out) / load_scenario(f).name, "--out", "sweep.csv",
                       also=("sweep.md",))
    t0 = time.perf_counter()
    scenarios, df = run_sweep(files, jobs=args.jobs, scheduler=args.scheduler,
                              cache_dir=None if args.no_cache else args.cache,
                              engine=args.engine, progress=_progress(args), **axes)
    secs = time.perf_counter() - t0
    where = (f"Dask scheduler {args.scheduler}" if args.scheduler
             else _plural(args.jobs, "process", "processes"))
    print(f"{_plural(len(df), 'row')} from {_plural(df.attrs.get('tasks', 0), 'point')} in "
          f"{secs:.1f} s on {where} ({_plural(df.attrs.get('simulated', 0), 'response')} "
          f"simulated, {df.attrs.get('cached', 0)} from the cache)")
    for name, sc in scenarios.items():
        csv, _ = write_sweep(df[df["scenario"] == name].reset_index(drop=True),
                             Path(args.out) / name, sc)
        print(f"  {name} -> {csv} and sweep.md")
    failed = df[df.status != "ok"]
    if len(failed):
        print(f"note: {_plural(len(failed), 'row has', 'rows have')} a failed method or twin "
              "(see sweep.md)")
    return 0


def _one_line(text: str, limit: int = 1000) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def main(argv=None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except _ArgError as exc:
        print(f"{exc.prog}: error: {_one_line(exc)} (see {exc.prog} --help)", file=sys.stderr)
        return 2
    if args.command is None:
        parser.print_help()
        return 2
    args.argv = list(sys.argv[1:] if argv is None else argv)  # shown in the report
    from .errors import PodbenchError

    prog = f"podbench {args.command}"
    from ._warnfmt import one_line_warnings

    one_line_warnings(prog)
    try:
        return {"run": cmd_run, "regress": cmd_regress, "sweep": cmd_sweep,
                "list": cmd_list, "experiment": cmd_experiment,
                "predict": cmd_predict}[args.command](args)
    except (_Usage, PodbenchError) as exc:
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; results/ was left as it was", file=sys.stderr)
        return 130
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
