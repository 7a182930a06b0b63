"""The base-excited study: Chapter-4-style identification of structures shaken at the base.

Study file (``scenarios/base_excited/base_excited.toml``, a ``[base_excitation]`` table):
structures (each with ``dt`` s, ``n_samples``, the resultant ``resultant`` lbf of the
Chapter 4 pulse, the pulse length ``pulse`` s, and the strain channels), the training and
target base motions, the outputs. For every structure and output quantity, the records are
simulated from rest (:func:`podbench.dynamics.base_excitation.simulate_base`, Newmark),
converted to SI where they are made (:func:`podbench.core.records.convert`), every method
is fitted on the training records and predicts every target; the error is
``‖ŷ − y‖_F / ‖y‖_F`` over every output channel and the whole record.

Base motions (names ``rect_<a>T``, ``half_sine_<a>T``, ``double_T``, ``burst``; ``T`` the
structure's ``pulse``): peak ``A = resultant / (rᵀ M r)`` (the base acceleration whose
inertial load ``−M r ü_g`` has the Chapter 4 pulse's resultant), first sample 0 (podbench's
convention, pulses start one sample after t = 0). ``burst``: normal noise (seed 0) smoothed
by a moving average over ``T``, times ``exp(−t/τ)`` with τ an eighth of the record, scaled to
peak ``A``.

Methods: ML (:class:`~podbench.sysid.methods.inputs.MultipleLoadIO`, the kernel over the
whole record by least squares, ``k`` = every output channel: the IO default), ML-k (``k``
= the number of training records, Chapter 4's rule for ML), FIR-LS (one whole-record
kernel per output channel, no POD), FIR-LS-half (a kernel of half the record: the
truncation ablation), SL and MR (refused, with their reasons), and the peers ERA (Hankel of
half the record, the forced peer's rule), DMDc, OpInf
(:mod:`podbench.sysid.methods.peers_io`).

Study layer: it knows the structures, motions and methods; the methods see only records.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from podbench.core.records import Record, convert
from podbench.core.resources import bundled_scenarios
from podbench.core.threads import single_blas_thread
from podbench.core.tomlfile import load_toml, typed_field
from podbench.dynamics.base_excitation import influence_vector, simulate_base
from podbench.errors import InputError
from podbench.harness.digits import determined, probe_perturbation
from podbench.structures import load_structure
from podbench.sysid.methods.inputs import (
    FIRLeastSquares,
    MultipleLoadIO,
    SingleLoadIO,
    mixed_response_io,
)
from podbench.sysid.methods.peers_io import ERAIO, DMDcIO, OpInfIO

__all__ = ["STUDY", "TABLE", "study_file", "load_study", "base_motion", "make_records",
           "run_study", "METHODS", "BaseStudy", "StructureSpec"]

STUDY = "base_excited"
"""The study's name and its folder under ``scenarios/``."""
TABLE = "base_excitation"
"""The TOML table of a base-excited study file."""
OUTPUT_UNITS = {"absolute_acceleration": ("in/s^2", "acceleration"),
                "strain": ("strain", "strain")}
"""Output name → (the structure's unit, the quantity)."""


@dataclass(frozen=True)
class StructureSpec:
    label: str
    structure: str
    dt: float
    n_samples: int
    resultant: float
    pulse: float
    fracture: bool = True
    strain: dict = field(default_factory=dict)


@dataclass(frozen=True)
class BaseStudy:
    name: str
    title: str
    description: str
    structures: tuple
    train: tuple
    targets: tuple
    outputs: tuple
    path: str = ""


def study_file() -> Path:
    """The bundled study file."""
    return bundled_scenarios() / STUDY / f"{STUDY}.toml"


def _need(where: str, table: dict, key: str, kind):
    return typed_field(table, key, kind, where, InputError)


def _structure_spec(where: str, label: str, t: dict) -> StructureSpec:
    w = f"{where}: [{TABLE}.structures.{label}]"
    strain = {}
    if "strain_points" in t:
        strain = {"strain_points": [float(x) for x in t["strain_points"]],
                  "fibre_distance": _need(w, t, "fibre_distance", float)}
    elif "strain_member_labels" in t:
        strain = {"member_labels": [str(x) for x in t["strain_member_labels"]]}
    spec = StructureSpec(label=label, structure=str(t.get("structure", label)),
                         dt=_need(w, t, "dt", float), n_samples=_need(w, t, "n_samples", int),
                         resultant=_need(w, t, "resultant", float),
                         pulse=_need(w, t, "pulse", float),
                         fracture=bool(t.get("fracture", True)), strain=strain)
    if spec.dt <= 0 or spec.n_samples < 10 or spec.pulse <= 0:
        raise InputError(f"{w}: fields `dt`, `n_samples`, `pulse`: expected dt > 0, "
                         "n_samples ≥ 10, pulse > 0")
    return spec


def load_study(path=None) -> BaseStudy:
    """Read a base-excited study file (default: the bundled one); one line per error."""
    path = Path(path) if path is not None else study_file()
    _, spec = load_toml(path, str(path), InputError)
    where = path.name
    if TABLE not in spec:
        raise InputError(f"{where}: table `[{TABLE}]`: missing")
    t = spec[TABLE]
    structures = tuple(_structure_spec(where, k, v)
                       for k, v in _need(where, t, "structures", dict).items())
    names = list(t.get("train", [])) + list(t.get("targets", []))
    for m in names:
        base_motion(m, 1e-3, 64, 1e-2, 1.0)  # a misspelt motion: refused before any work
    outputs = tuple(t.get("outputs", ["absolute_acceleration"]))
    for o in outputs:
        if o not in OUTPUT_UNITS:
            raise InputError(f"{where}: field `outputs`: unknown {o!r} (expected some of "
                             f"{', '.join(OUTPUT_UNITS)})")
    return BaseStudy(name=str(t.get("name", STUDY)), title=str(t.get("title", "")),
                     description=str(t.get("description", "")), structures=structures,
                     train=tuple(_need(where, t, "train", list)),
                     targets=tuple(_need(where, t, "targets", list)), outputs=outputs,
                     path=str(path))


def _multiple(text: str, name: str) -> float:
    try:
        return float(text[:-1]) if text != "T" else 1.0
    except ValueError:
        raise InputError(f"base motion {name!r}: expected <kind>_<a>T, e.g. rect_2T") from None


def base_motion(name: str, dt: float, n: int, T: float, A: float) -> np.ndarray:
    """The base acceleration ``name`` (module docstring), ``n`` samples at ``dt``, peak ``A``."""
    t = np.arange(n) * dt
    on = t > dt / 2

    def rect(d):
        return A * (on & (t < dt + d - dt / 2))

    if name == "burst":
        w = max(1, int(round(T / dt)))
        noise = np.random.default_rng(0).normal(size=n)
        x = np.convolve(noise, np.ones(w) / w)[:n] * np.exp(-t / (n * dt / 8)) * on
        return A * x / np.max(np.abs(x))
    if name == "double_T":
        return rect(T) - np.roll(rect(T), int(round(2 * T / dt)))
    kind, _, mult = name.rpartition("_")
    if kind == "rect" and mult.endswith("T"):
        return rect(_multiple(mult, name) * T)
    if kind == "half_sine" and mult.endswith("T"):
        d = _multiple(mult, name) * T
        return A * np.where(on & (t < dt + d - dt / 2), np.sin(np.pi * (t - dt) / d), 0.0)
    raise InputError(f"base motion {name!r}: expected rect_<a>T, half_sine_<a>T, double_T or "
                     "burst")


def _structure(spec: StructureSpec):
    overrides = None if spec.fracture else {"fracture.time": 1.0e9}
    return load_structure(spec.structure, overrides=overrides, name=spec.label)


def make_records(spec: StructureSpec, motions, output: str) -> list[Record]:
    """One SI record per base motion: input ü_g (m/s²), outputs ``output`` (m/s² or strain)."""
    s = _structure(spec)
    r = influence_vector(s)
    A = spec.resultant / float(r @ (s.M @ r))
    kw = {}
    if output == "strain":
        if "member_labels" in spec.strain:
            n = int(s.metadata["n_elements"])
            kw["strain_members"] = [(e, lbl) for e in range(1, n + 1)
                                    for lbl in spec.strain["member_labels"]]
        else:
            kw = {k: spec.strain[k] for k in ("strain_points", "fibre_distance")}
    unit, _ = OUTPUT_UNITS[output]
    recs = []
    for m in motions:
        ag = base_motion(m, spec.dt, spec.n_samples, spec.pulse, A)
        y = simulate_base(s, ag, spec.dt, outputs=(output,), **kw)[output]
        chans = _channels(s, output, kw)
        rec = Record(u=ag[None, :], y=y, dt=spec.dt, input_units="in/s^2",
                       output_units=unit, input_channels=("base",), output_channels=chans,
                       name=m)
        recs.append(convert(rec, "SI"))
    return recs


def _channels(s, output: str, kw: dict) -> tuple:
    if output != "strain":
        return tuple(s.sensor_labels) if s.sensor_labels else None
    if "strain_members" in kw:
        return tuple(f"e{e}.m{lbl}" for e, lbl in kw["strain_members"])
    return tuple(f"x={x:g}in" for x in kw["strain_points"])


class _Refused:
    """SL and MR on base-excited records: ``fit`` raises their reason."""

    def __init__(self, which: str):
        self.which = which

    def fit(self, records):
        if self.which == "SL":
            return SingleLoadIO().fit(records)
        mixed_response_io(records[0])
        return self


def _methods(n_train: int, spec: StructureSpec) -> dict:
    half = spec.n_samples // 2
    return {
        "ML": lambda: MultipleLoadIO(n_lags=None, solver="ls"),
        f"ML-k{n_train}": lambda: MultipleLoadIO(n_modes=n_train, n_lags=None, solver="ls"),
        "FIR-LS": lambda: FIRLeastSquares(n_lags=None),
        "FIR-LS-half": lambda: FIRLeastSquares(n_lags=half),
        "SL": lambda: _Refused("SL"),
        "MR": lambda: _Refused("MR"),
        "ERA": lambda: ERAIO(blocks=spec.n_samples * spec.dt / 2),
        "DMDc": lambda: DMDcIO(),
        "OpInf": lambda: OpInfIO(),
    }


METHODS = ("ML", "ML-k", "FIR-LS", "FIR-LS-half", "SL", "MR", "ERA", "DMDc", "OpInf")
"""The study's methods (``ML-k``: ``k`` = the number of training records)."""


def _one(make, train, targets) -> tuple[list, dict, float]:
    t0 = time.perf_counter()
    model = make().fit(train)
    preds = [model.predict(g) for g in targets]
    return preds, dict(getattr(model, "info_", {})), time.perf_counter() - t0


#: Methods whose errors are written at the digits the data determine
#: (:func:`podbench.harness.digits.determined`): ERA/OKID amplifies the records' round-off
#: past the third digit (the satellite truss's burst: 91.9 against 91.8 between the OpenBLAS
#: Haswell and SkylakeX kernels).
PROBED = ("ERA",)


def _errors(label: str, make, train, targets, preds, where: tuple) -> list[float]:
    """Relative errors ``‖ŷ − y‖/‖y‖`` of ``preds``; for a :data:`PROBED` method each at the
    significant digits on which the fit on the probed records
    (:func:`podbench.harness.digits.probe_perturbation` of every training output) agrees."""
    errs = [float(np.linalg.norm(yh - g.y) / np.linalg.norm(g.y))
            for g, yh in zip(targets, preds, strict=True)]
    if label not in PROBED:
        return errs
    probed = [r.replace(y=probe_perturbation(r.y, *where, str(r.name))) for r in train]
    again, _, _ = _one(make, probed, targets)
    return [determined(e, float(np.linalg.norm(yh - g.y) / np.linalg.norm(g.y)))
            for e, g, yh in zip(errs, targets, again, strict=True)]


def run_study(path=None, progress=None, keep_series: bool = True) -> dict:
    """Run the study; returns ``rows`` (one per structure, output, method, target), ``fits``,
    ``timing`` and (``keep_series``) the target records and predictions for the figures."""
    st = load_study(path)
    rows, fits, timing, series = [], [], [], {}
    t_all = time.perf_counter()
    with single_blas_thread():
        for spec in st.structures:
            for output in st.outputs:
                if output == "strain" and not spec.strain:
                    continue
                if progress:
                    progress(f"{spec.label}: {output}")
                train = make_records(spec, st.train, output)
                targets = make_records(spec, st.targets, output)
                for label, make in _methods(len(train), spec).items():
                    base = {"structure": spec.label, "output": output, "method": label,
                            "unit": targets[0].output_units}
                    try:
                        preds, info, secs = _one(make, train, targets)
                    except InputError as exc:
                        for g in targets:
                            rows.append({**base, "target": g.name, "status": "refused",
                                         "total_error": "", "note": str(exc)})
                        continue
                    timing.append({**base, "seconds": secs})
                    fits.append({**base, **{k: v for k, v in info.items()
                                            if isinstance(v, (int, str))}})
                    errs = _errors(label, make, train, targets, preds, (spec.label, output))
                    for g, yh, err in zip(targets, preds, errs, strict=True):
                        rows.append({**base, "target": g.name, "status": "ok",
                                     "total_error": err, "note": ""})
                        if keep_series:
                            series[(spec.label, output, label, g.name)] = (g, yh)
    return {"study": st, "rows": rows, "fits": fits, "timing": timing, "series": series,
            "seconds": time.perf_counter() - t_all}
