"""Virtual experiments: laboratory records simulated once, with per-channel noise, written to
files that a study then reads back like any measurement (:mod:`podbench.measured`).

Chapter 5 of the dissertation identifies a beam from *measured* records (laser vibrometer,
load cell). podbench cannot measure, so it plays the laboratory: it simulates the tests on a
structure model, adds noise the way the instruments would (:mod:`podbench.noise`: per
measured channel, on measured channels only, keyed streams), and writes one file per test.
The study's scenarios read those files through ``[cases.x] file = ...``, the path a real
laboratory's data would take; only the generator ever sees the model.

An experiment file (``experiment.toml`` beside the study's scenarios; units inch, lbf,
second)::

    [experiment]
    name = "chapter5"                    # keys the noise streams
    noise_levels = [0.0, 0.01, 0.05]     # relative per-channel noise (podbench.noise), each
                                         # level a folder noise_<100·level>pct/
    noise_seed = 0
    noise_on = ["W", "F"]                # measured quantities that get noise
    precision = "float32"                # or "float64": how W and F are stored (see below)

    [tests.linear_beam]                  # one test campaign on one structure
    structure = "aluminium_beam"         # a structure name or a path (relative to this file)
    n_samples = 1024
    dt = 1.0e-4                          # s
    # set = { "damping.modal_ratio" = 0.0 }   # optional: structure fields replaced
    # noise_levels = [0.0]               # optional: this test's own levels
    [tests.linear_beam.cases.load4.force]   # a table, or an array of them (summed)
    kind = "pulse"                       # podbench.excitations, as in scenario files
    location = 4.0
    amplitude = 2.0
    duration = 5.0e-4
    shape = "half_sine"
    hits = [[3.0e-3, 0.4]]

**One strike per sensor row** (§5.1: "The shaker was used in order to apply the same load six
times while the laser vibrometer measured the displacement of one point each time"). Fields
of a test (``strikes`` and ``force_record`` may also stand in ``[experiment]`` as defaults)::

    strikes = "per_sensor"       # or "one" (default): one strike seen by every sensor
    force_record = "first"       # which load-cell record forms F (per_sensor only):
                                 # "first" (the load cell of strike 1) or "mean" (of all)
    amplitude_scatter = 0.05     # relative std of each strike's peak (default 0)
    hit_jitter = 1.0             # std of each rebound's delay, in samples (default 0)
    cases_from = "linear_beam"   # optional: the cases of another test (instead of [cases])

With ``strikes = "per_sensor"`` strike ``k`` (k = 1 … number of sensors) is simulated on its
own and row ``k − 1`` of ``W`` is sensor ``k − 1``'s response to it; the load cell records
a force at every strike. ``force_record``: the text gives one force record per case ("This
procedure was repeated for all three load cases to extract the applied force data": one
inertial-load subtraction, one force, per load case), so the main reading takes the load
cell of one strike, the first; ``"mean"`` (the average of the six load-cell records) is the
named alternative. The text says "the same load six times": the strikes are identical
unless ``amplitude_scatter`` or ``hit_jitter`` (not stated by the text; studied over a range)
make them differ. Strike ``k`` is the case's force with every contact's amplitude times
``1 + amplitude_scatter·z_k`` and every rebound (``hits``) delayed by
``hit_jitter·dt·z_{k,h}`` (standard normal draws of :func:`podbench.noise.noise_generator`
keyed ``(seed, experiment name, structure name, case, "strike", k)``, the same draws at
every scatter level); the first contact stays one sample after ``t = 0`` (the acquisition
reads as triggered by it). A rebound jittered to a delay <= 0 is an error naming
``hit_jitter``.

Noise with one strike per row: vibrometer channel ``i`` is keyed as before (it is measured
only during strike ``i + 1``); the load cell of strike 1 uses the case's key, that of strike
``k > 1`` the key ``(…, case, "strike<k>")``. Identical strikes with ``force_record =
"first"`` therefore give exactly the records of ``strikes = "one"`` (clean and noisy): the
per-channel noise is already independent row by row, and the rows of identical strikes are
the rows of one strike.

It writes ``data/<test>/noise_<p>pct/<case>.npz`` (relative to the experiment file) for
every level and case; ``noise_0pct`` holds the clean records, the truth that only a virtual
experiment has (a scenario may use it as a second target). The noise of a case is keyed
``(seed, experiment name, structure name, case)`` and is the
same standard-normal pattern at every level (common random numbers), so the levels differ
only by the level.

``precision = "float32"`` stores W and F rounded to single precision (24-bit mantissa, finer
than the 16-bit converters of a laboratory acquisition system; it halves the files); the
rounding is applied before writing, so the file holds exactly what the generator returns
(round trip exact). Everything is deterministic: the same file gives byte-identical data,
written atomically (a temporary folder replaces ``data/<test>`` when complete).

Regenerating over committed records keeps each record that the check below calls the same
(its bytes stay; :func:`write_experiment`).

Command line: ``podbench experiment <folder or experiment.toml>`` (``--check`` compares the
files with a fresh generation instead of writing: byte for byte, or, for a record written on
another CPU, ``W`` and ``F`` to :data:`CHECK_ULPS` single-precision steps of each channel's
peak — another CPU's round-off moves the last bits).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from podbench.core.atomic import replace_dir
from podbench.core.recordfiles import record_bytes
from podbench.core.records import Record
from podbench.core.response import Response
from podbench.errors import InputError, ScenarioFileError, StructureFileError
from podbench.structures.spec import MISSING, Table

__all__ = ["EXPERIMENT_FILE", "Experiment", "TestCampaign", "load_experiment",
           "level_folder", "generate", "generate_seeds", "seed_dependent", "strike_forces",
           "write_experiment", "check_experiment"]

from podbench.core.threads import single_blas_thread
from podbench.dynamics import simulate
from podbench.dynamics.excitations import excitation_from_dict
from podbench.structures import load_structure
from podbench.study.scenarios import EXPERIMENT_FILE, read_excitation, read_study_file
from podbench.sysid.noise import NoiseSpec, noise_generator, noisy

PRECISIONS = ("float32", "float64")
_NOISE_ON = ("W", "F")


STRIKES = ("one", "per_sensor")
FORCE_RECORDS = ("first", "mean")


@dataclass(frozen=True)
class TestCampaign:
    """The tests of one structure: cases (excitation tables), sampling, truth cases, and
    how the strikes are recorded (module docstring: one strike per sensor row)."""

    name: str
    structure: str
    n_samples: int
    dt: float
    cases: dict
    overrides: dict
    noise_levels: tuple[float, ...] | None = None
    strikes: str = "one"
    force_record: str = "first"
    amplitude_scatter: float = 0.0
    hit_jitter: float = 0.0


@dataclass(frozen=True)
class Experiment:
    name: str
    path: Path
    noise_levels: tuple[float, ...]
    noise_seed: int
    noise_on: tuple[str, ...]
    precision: str
    tests: dict

    @property
    def folder(self) -> Path:
        return self.path.parent


def level_folder(level: float) -> str:
    """``noise_<100·level>pct`` (``noise_0pct``, ``noise_0.5pct``, ``noise_5pct``)."""
    return f"noise_{100.0 * float(level):g}pct"


def load_experiment(path) -> Experiment:
    """Read and check an experiment file (one-line errors naming the file and field)."""

    path = Path(path)
    if path.is_dir():
        path = path / EXPERIMENT_FILE
    shown = str(path)
    _, doc = read_study_file(path, shown, "experiment")
    try:
        top = Table(doc, file=shown)
        e = top.table("experiment", required=True)
        name = e.string("name")
        levels = _levels(e, MISSING)
        seed = e.integer("noise_seed", 0, minimum=0)
        on = e.strings("noise_on", list(_NOISE_ON))
        for i, q in enumerate(on):
            if q not in _NOISE_ON:
                e.fail(f"noise_on[{i}]", f'expected "W" or "F" (measured channels), got "{q}"')
        precision = e.string("precision", "float64", choices=PRECISIONS)
        strikes0 = e.string("strikes", "one", choices=STRIKES)
        record0 = e.string("force_record", "first", choices=FORCE_RECORDS)
        e.close()
        tests: dict[str, TestCampaign] = {}
        tt = top.table("tests", required=True)
        for tname in list(tt.data):
            tests[tname] = _parse_test(tt.table(tname, required=True), tname, tests,
                                       strikes0, record0)
        tt.close()
        if not tests:
            top.fail("tests", "expected at least one [tests.<name>] table")
        top.close()
    except StructureFileError as exc:
        raise ScenarioFileError(str(exc)) from None
    return Experiment(name, path.resolve(), tuple(levels), seed, tuple(on), precision, tests)


def _parse_test(t: Table, tname: str, tests: dict, strikes0: str, record0: str) -> TestCampaign:
    """One ``[tests.<name>]`` table (``tests``: those above it, for ``cases_from``);
    ``strikes0`` and ``record0`` are the experiment's defaults."""
    structure = t.string("structure")
    n = t.integer("n_samples", minimum=2, maximum=10_000_000)
    dt = t.number("dt", positive=True)
    cases = _test_cases(t, tests)
    overrides = t.raw("set", {})
    if not isinstance(overrides, dict):
        t.fail("set", f"expected a table of dotted structure fields, got {overrides!r}")
    own = _levels(t, None)
    strikes = t.string("strikes", strikes0, choices=STRIKES)
    record = t.string("force_record", record0, choices=FORCE_RECORDS)
    scatter = t.number("amplitude_scatter", 0.0, nonnegative=True)
    if not scatter < 0.5:
        t.fail("amplitude_scatter", f"expected a relative scatter below 0.5, got "
                                    f"{scatter!r}")
    jitter = t.number("hit_jitter", 0.0, nonnegative=True)
    if strikes == "one":
        given = {"amplitude_scatter": scatter > 0, "hit_jitter": jitter > 0,
                 "force_record": t.has("force_record")}
        for key, bad in given.items():
            if bad:
                t.fail(key, 'needs strikes = "per_sensor" (one strike per sensor '
                            'row); with strikes = "one" every sensor sees one strike')
    t.close()
    return TestCampaign(tname, structure, n, dt, cases, dict(overrides),
                        None if own is None else tuple(own), strikes, record, scatter, jitter)


def _test_cases(t: Table, tests: dict) -> dict:
    """A test's cases: its ``[tests.<name>.cases]`` (force tables), or ``cases_from`` a test
    above it."""
    if t.has("cases_from"):
        src = t.string("cases_from")
        if src not in tests:
            t.fail("cases_from", f'"{src}" is not a test defined above this one '
                                 f"(known: {', '.join(tests) or 'none'})")
        if t.has("cases"):
            t.fail("cases", "give either `cases` or `cases_from`, not both")
        return dict(tests[src].cases)
    ct = t.table("cases", required=True)
    cases = {}
    for cname in list(ct.data):
        c = ct.table(cname, required=True)
        force = read_excitation(c, "force", many=True)
        if not force:
            c.fail("force", "expected a force table or an array of force tables "
                            "(a test starts at rest and is struck)")
        c.string("description", "", nonempty=False)
        c.close()
        cases[cname] = force
    ct.close()
    if not cases:
        t.fail("cases", "expected at least one case")
    return cases


def _levels(t: Table, default):
    levels = t.numbers("noise_levels", default, nonnegative=True)
    if levels is None:
        return None
    for i, lv in enumerate(levels):
        if not lv < 1.0:
            t.fail(f"noise_levels[{i}]", f"expected a relative level below 1, got {lv!r}")
    if len({level_folder(x) for x in levels}) != len(levels):
        t.fail("noise_levels", f"a level is listed twice: {levels}")
    return levels


def _structure(exp: Experiment, test: TestCampaign):

    entry = test.structure
    where = f"{exp.path}: field `tests.{test.name}`"
    try:
        src = exp.folder / entry if entry.endswith(".toml") else entry
        s = load_structure(src, overrides=test.overrides) if test.overrides else \
            load_structure(src)
    except (InputError, StructureFileError) as exc:
        raise ScenarioFileError(f"{where}: {exc}") from None
    if s.metadata.get("unit_system") == "SI":  # the W/F record files carry no units
        raise ScenarioFileError(f"{where}: structure {s.name!r} is in SI; an experiment "
                                "writes the dissertation's W/F records, in inch–lbf only")
    return s


def _round(a: np.ndarray, precision: str) -> np.ndarray:
    return a.astype(np.float32).astype(np.float64) if precision == "float32" else a


def generate(exp: Experiment) -> dict:
    """The records of every test, level and case: ``{(test, level_folder, case):
    Response}`` in a fixed order (tests, levels, cases)."""
    return {key[1:]: rec for key, rec in generate_seeds(exp, (exp.noise_seed,)).items()}


def seed_dependent(test: TestCampaign, level: float) -> bool:
    """Whether the records of ``test`` at noise ``level`` change with the noise seed (noise,
    or strike scatter drawn from the seed)."""
    return level > 0 or test.amplitude_scatter > 0 or test.hit_jitter > 0


def generate_seeds(exp: Experiment, seeds, wanted=None) -> dict:
    """The records of every seed in ``seeds`` (each as :func:`generate` with ``noise_seed``
    that seed): ``{(seed, test, level_folder, case): Response}`` in a fixed order (seeds,
    tests, levels, cases). ``wanted`` (a set of ``(test, level_folder)``, default all)
    limits the tests and levels. A simulation is shared by the seeds whose strikes are the
    same (a test without strike scatter is simulated once), so more seeds cost only their
    noise."""

    tests = [t for t in exp.tests.values()
             if wanted is None or any(w[0] == t.name for w in wanted)]
    structures = {t.name: _structure(exp, t) for t in tests}
    loads = {}  # every structure and load checked before anything is simulated
    for seed in seeds:
        e = replace(exp, noise_seed=int(seed))
        for test in tests:
            s = structures[test.name]
            for cname, forces in test.cases.items():
                loads[(seed, test.name, cname)] = _strike_loads(e, test, s, cname, forces)
    out = {}
    runs: dict = {}  # (test, force bytes) -> clean simulation, shared by the seeds
    for seed in seeds:
        for test in tests:
            s = structures[test.name]
            clean = {cname: _strike_responses(s, test, cname, loads[(seed, test.name, cname)],
                                              simulate, runs)
                     for cname in test.cases}
            for level in test.noise_levels or exp.noise_levels:
                folder = level_folder(level)
                if wanted is None or (test.name, folder) in wanted:
                    for cname, (r, Fs) in clean.items():
                        out[(seed, test.name, folder, cname)] = _noisy_record(
                            exp, test, s, cname, r, Fs, level, int(seed))
    return out


def _strike_loads(exp: Experiment, test: TestCampaign, s, cname: str, forces) -> list:
    """The sampled force of every strike of a case (errors name the case's force field)."""
    Fs = []
    for strike in strike_forces(exp, test, s, cname, forces):
        F = np.zeros((s.n_sensors, test.n_samples))
        for i, d in enumerate(strike):
            try:
                F += excitation_from_dict(d).sample(s, test.n_samples, test.dt)
            except InputError as exc:
                raise ScenarioFileError(
                    f"{exp.path}: field `tests.{test.name}.cases.{cname}.force"
                    f"{f'[{i}]' if len(forces) > 1 else ''}`: {exc}") from None
        Fs.append(F)
    return Fs


def _noisy_record(exp: Experiment, test: TestCampaign, s, cname: str, r, Fs, level: float,
                  seed: int) -> Response:
    """The record of one case at one noise level and seed, rounded to the precision."""
    spec = NoiseSpec(level, seed=seed, on=exp.noise_on)
    f_spec = NoiseSpec(level, seed=seed, on=("F",) if "F" in exp.noise_on else ())
    m = noisy(r, spec, exp.name, s.name, cname)  # W rows; strike 1's load cell
    F = np.asarray(m.F)
    if test.strikes == "per_sensor" and test.force_record == "mean":
        cells = [F] + [np.asarray(noisy(_record(np.zeros_like(Fk), Fk, test.dt, cname),
                                        f_spec, exp.name, s.name, cname, f"strike{k}").F)
                       for k, Fk in enumerate(Fs[1:], start=2)]
        F = np.mean(cells, axis=0)
    W, F = _round(np.asarray(m.W), exp.precision), _round(F, exp.precision)
    return _record(W, F, test.dt, cname)


def strike_forces(exp: Experiment, test: TestCampaign, structure, case: str,
                  forces) -> list[tuple[dict, ...]]:
    """The force tables of every strike of ``case``: one strike (the case's tables) with
    ``strikes = "one"``; with ``"per_sensor"`` one per sensor row, strike ``k`` (list index
    ``k − 1``) scaled by ``1 + amplitude_scatter·z_k`` with every rebound delayed by
    ``hit_jitter·dt·z_{k,h}`` (module docstring; draws keyed ``(seed, experiment,
    structure, case, "strike", k)``)."""

    if test.strikes == "one":
        return [tuple(forces)]
    out = []
    for k in range(1, structure.n_sensors + 1):
        if test.amplitude_scatter == 0 and test.hit_jitter == 0:
            out.append(tuple(forces))
            continue
        g = noise_generator(exp.noise_seed, exp.name, structure.name, case, "strike", str(k))
        factor = 1.0 + test.amplitude_scatter * float(g.standard_normal())
        strike = []
        for d in forces:
            d = dict(d)
            if "amplitude" in d and isinstance(d["amplitude"], (int, float)):
                d["amplitude"] = float(d["amplitude"]) * factor
            hits = d.get("hits")
            if isinstance(hits, list) and hits:
                z = g.standard_normal(len(hits))
                moved = []
                for (delay, rel), zh in zip(hits, z, strict=True):
                    delay = float(delay) + test.hit_jitter * test.dt * float(zh)
                    if not delay > 0:
                        raise ScenarioFileError(
                            f"{exp.path}: field `tests.{test.name}.hit_jitter`: strike {k} of "
                            f"case {case} puts a rebound at {delay:.3g} s, not after the "
                            "first contact (use a smaller jitter)")
                    moved.append([delay, rel])
                d["hits"] = moved
            strike.append(d)
        out.append(tuple(strike))
    return out


def _strike_responses(s, test: TestCampaign, cname: str, Fs, simulate, runs=None):
    """``(Response, strike forces)``: the clean record of a case, its ``W`` row ``i`` from
    strike ``i + 1`` (one strike per sensor row) and ``F`` the first strike's load. Identical
    strikes are simulated once (``runs``: the simulations so far, shared between calls and
    between tests: keyed by the structure entry and its overrides, the sampling and the
    force, so two tests of one structure with the same strikes — the same scatter draws read
    with another ``force_record`` — share them)."""
    runs = {} if runs is None else runs

    def run(F):
        key = (test.structure, repr(sorted(test.overrides.items())), test.n_samples,
               float(test.dt).hex(), F.tobytes())
        if key not in runs:
            runs[key] = simulate(s, n_samples=test.n_samples, dt=test.dt, force=F, label=cname)
        return runs[key]

    first = run(Fs[0])
    if len(Fs) == 1:
        return first, Fs
    W = np.array([np.asarray(run(F).W)[i] for i, F in enumerate(Fs)])
    return _record(W, Fs[0], test.dt, cname), Fs


def _record(W, F, dt, label) -> Response:
    n = W.shape[1]
    return Response(t=np.arange(n) * dt, W=W, F=F, w0=W[:, 0].copy(),
                    v0=np.zeros(W.shape[0]), dt=dt, label=label)


def _sensor_info(exp: Experiment, test: TestCampaign):
    s = _structure(exp, test)
    return list(s.sensor_labels), s.sensor_positions


def _npz_bytes(rec: Response, labels, positions) -> bytes:
    """The record file's bytes (:func:`podbench.core.recordfiles.record_bytes`): ``W``,
    ``F``, ``dt``, the sensor labels and positions, zip members stamped with a fixed time."""
    return record_bytes(Record(W=rec.W, F=rec.F, dt=rec.dt), "npz", sensors=labels,
                        sensor_positions=positions, deterministic=True)


def _files(exp: Experiment) -> dict:
    """``{relative path: bytes}`` of every file the experiment writes (computed with one BLAS
    thread, as the harness computes: the bytes do not depend on the core count)."""

    with single_blas_thread():
        records = generate(exp)
    info = {name: _sensor_info(exp, t) for name, t in exp.tests.items()}
    files = {}
    for (test, folder, stem), rec in records.items():
        labels, positions = info[test]
        files[Path("data") / test / folder / f"{stem}.npz"] = _npz_bytes(rec, labels, positions)
    return files


def write_experiment(path) -> list[Path]:
    """Generate and write every record of the experiment file ``path`` (a file or its folder);
    each ``data/<test>`` folder is replaced atomically. A record already there that
    :func:`check_experiment` calls the same (:data:`CHECK_ULPS`: another CPU's round-off
    moved its last bits) is kept byte for byte, so regenerating the committed records leaves
    them unchanged on any CPU. Returns the files written."""
    exp = load_experiment(path)
    files = _files(exp)
    written = []
    for test in exp.tests:
        dest = exp.folder / "data" / test
        dest.parent.mkdir(parents=True, exist_ok=True)
        with replace_dir(dest, keep=_same_record_bytes) as tmp:
            for rel, data in files.items():
                if rel.parts[1] != test:
                    continue
                target = tmp / Path(*rel.parts[2:])
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
                written.append(exp.folder / rel)
    return written


#: How far a fresh generation may differ from a committed record and still be "the same":
#: in units of the single-precision spacing (2⁻²³) of each channel's peak. The records are
#: byte-identical on one machine; another CPU's round-off changes the last bits of the
#: simulation, and the single-precision rounding of a value next to a rounding boundary
#: then moves by one float32 step (docs/noise.md gives the measured differences).
CHECK_ULPS = 8


def _same_record(path: Path, data: bytes) -> bool:
    """True when the committed file holds the generated record: the same bytes, or the same
    arrays with ``W`` and ``F`` equal per channel to :data:`CHECK_ULPS` float32 steps of the
    channel's peak (a record generated on another CPU)."""
    return _same_record_bytes(path.read_bytes(), data)


def _same_record_bytes(old: bytes, data: bytes) -> bool:
    """:func:`_same_record` on the committed file's bytes ``old``."""
    if old == data:
        return True
    try:
        with np.load(io.BytesIO(old), allow_pickle=False) as a, \
                np.load(io.BytesIO(data), allow_pickle=False) as b:
            if sorted(a.files) != sorted(b.files):
                return False
            for k in a.files:
                x, y = a[k], b[k]
                if x.shape != y.shape or x.dtype != y.dtype:
                    return False
                if k in ("W", "F"):
                    peak = np.max(np.abs(y), axis=-1, keepdims=True) if y.size else y
                    if not np.all(np.abs(x - y) <= CHECK_ULPS * 2.0**-23 * peak):
                        return False
                elif not np.array_equal(x, y):
                    return False
    except (OSError, ValueError):
        return False
    return True


def check_experiment(path) -> list[str]:
    """Files that differ from a fresh generation (missing, changed or extra), as relative
    paths; empty when the committed data are what the experiment file generates (byte for
    byte on the machine that wrote them; to :data:`CHECK_ULPS` float32 steps elsewhere)."""
    exp = load_experiment(path)
    files = _files(exp)
    bad = [str(rel) for rel, data in files.items()
           if not (exp.folder / rel).is_file() or not _same_record(exp.folder / rel, data)]
    for test in exp.tests:
        root = exp.folder / "data" / test
        if root.is_dir():
            for f in sorted(root.rglob("*.npz")):
                if f.relative_to(exp.folder) not in files:
                    bad.append(str(f.relative_to(exp.folder)))
    return bad


