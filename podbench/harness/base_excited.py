"""The base-excited study's run: identification of structures shaken at the base.

The study file (``scenarios/base_excited/base_excited.toml``) is read by
:mod:`podbench.study.base_excited`. For every structure and output quantity, the records are
simulated from rest (:func:`podbench.dynamics.base_excitation.simulate_base`, Newmark),
converted to SI where they are made (:func:`podbench.core.records.convert`), every method
is fitted on the training records and predicts every target; the error is
``‖ŷ − y‖_F / ‖y‖_F`` over every output channel and the whole record.

The base motions (:func:`~podbench.study.base_excited.base_motion`) have the peak
``A = resultant / (rᵀ M r)``: the base acceleration whose inertial load ``−M r ü_g`` has the
Chapter 4 pulse's resultant.

Methods (registered names, :mod:`podbench.sysid.registry`): ML (``ML-whole``: the kernel
over the whole record by least squares from the measured inputs, ``k`` = every output
channel), ML-k (``k`` = the number of training records, Chapter 4's rule for ML), FIR-LS
(``FIR-LS-whole``: one whole-record kernel per output channel, no POD), FIR-LS-half (a
kernel of half the record: the truncation ablation), SL and MR (refused, with their
reasons), and the peers ERA (Hankel of half the record, the forced peer's rule), DMDc,
OpInf on the measured inputs.

Harness layer: it knows the structures, motions and methods; the methods see only records;
:mod:`podbench.report.base_excited` writes the results.
"""

from __future__ import annotations

import time

import numpy as np

from podbench.core.records import Record, convert
from podbench.core.threads import single_blas_thread
from podbench.dynamics.base_excitation import influence_vector, simulate_base
from podbench.errors import InputError
from podbench.harness.digits import determined, probe_perturbation
from podbench.structures import load_structure
from podbench.study.base_excited import (  # the study file's reader, named here too
    OUTPUT_UNITS,
    STUDY,
    TABLE,
    BaseStudy,
    StructureSpec,
    base_motion,
    load_study,
    study_file,
)
from podbench.sysid import registry

__all__ = ["STUDY", "TABLE", "study_file", "load_study", "base_motion", "make_records",
           "run_study", "METHODS", "BaseStudy", "StructureSpec"]

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


METHODS = (("ML", "ML-whole"), ("ML-k", "ML-k"), ("FIR-LS", "FIR-LS-whole"),
           ("FIR-LS-half", "FIR-LS-half"), ("SL", "SL"), ("MR", "MR"), ("ERA", "ERA"),
           ("DMDc", "DMDc"), ("OpInf", "OpInf"))
"""The study's methods: (label, registered name). What a configuration leaves to its caller
the study gives from its records (:func:`_methods`): ``n_modes`` the number of training
records (``ML-k``, labelled ``ML-k<N>``), ``n_lags`` half the record (``FIR-LS-half``)."""


def _methods(n_train: int, spec: StructureSpec) -> dict:
    """label → the registry entry and the parameters the study supplies."""
    own = {"n_modes": n_train, "n_lags": spec.n_samples // 2}
    out = {}
    for label, name in METHODS:
        entry = registry.lookup(name)
        params = {p: own[p] for p in entry.supplied}
        out[f"{label}{n_train}" if "n_modes" in params else label] = (entry, params)
    return out


def _one(make, train, targets) -> tuple[list, dict, float, bool]:
    """Fit ``make = (entry, params)`` and predict every target: the predictions, what the
    fit chose (``info_``), the seconds and whether the method amplifies round-off."""
    entry, params = make
    t0 = time.perf_counter()
    model = entry.build(**params).fit(train)
    preds = [model.predict(g) for g in targets]
    return (preds, dict(getattr(model, "info_", {})), time.perf_counter() - t0,
            bool(model.amplifies_round_off))


def _errors(probe: bool, make, train, targets, preds, where: tuple) -> list[float]:
    """Relative errors ``‖ŷ − y‖/‖y‖`` of ``preds``; for a method that amplifies round-off
    (``probe``: :attr:`~podbench.sysid.methods.PODMethod.amplifies_round_off`) each at the
    significant digits on which the fit on the probed records
    (:func:`podbench.harness.digits.probe_perturbation` of every training output) agrees."""
    errs = [float(np.linalg.norm(yh - g.y) / np.linalg.norm(g.y))
            for g, yh in zip(targets, preds, strict=True)]
    if not probe:
        return errs
    probed = [r.replace(y=probe_perturbation(r.y, *where, str(r.name))) for r in train]
    again, _, _, _ = _one(make, probed, targets)
    return [determined(e, float(np.linalg.norm(yh - g.y) / np.linalg.norm(g.y)))
            for e, g, yh in zip(errs, targets, again, strict=True)]


def run_study(study=None, progress=None, keep_series: bool = True) -> dict:
    """Run the study (a :class:`~podbench.study.base_excited.BaseStudy`, or the path of its
    file, default the bundled one); returns ``rows`` (one per structure, output, method,
    target), ``fits``, ``timing`` and (``keep_series``) the target records and predictions
    for the figures."""
    st = study if isinstance(study, BaseStudy) else load_study(study)
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
                        preds, info, secs, probe = _one(make, train, targets)
                    except InputError as exc:
                        for g in targets:
                            rows.append({**base, "target": g.name, "status": "refused",
                                         "total_error": "", "note": str(exc)})
                        continue
                    timing.append({**base, "seconds": secs})
                    fits.append({**base, **{k: v for k, v in info.items()
                                            if isinstance(v, (int, str))}})
                    errs = _errors(probe, make, train, targets, preds, (spec.label, output))
                    for g, yh, err in zip(targets, preds, errs, strict=True):
                        rows.append({**base, "target": g.name, "status": "ok",
                                     "total_error": err, "note": ""})
                        if keep_series:
                            series[(spec.label, output, label, g.name)] = (g, yh)
    return {"study": st, "rows": rows, "fits": fits, "timing": timing, "series": series,
            "seconds": time.perf_counter() - t_all}
