"""Bounds from the text on a parameter the text does not state.

Where the dissertation does not give a parameter (Fig. 4.3's tip-mass law) but describes its
consequence in words, a ``[[bounds]]`` table of a claims file turns the words into a
measurable property of the structure and says which variants of a sensitivity study the
words admit. The verdicts of :mod:`podbench.study.sensitivity` are then reported over the
admitted part of the parameter's range, not at one pick.

Format (in ``claims.toml``)::

    [[bounds]]
    structure = "ltv_beam"               # the varied base structure
    measure = "mass_diagonal_spread"     # a name of MEASURES
    reference = "lti_beam"               # admitted: statistic(measure) > reference's value
    statistic = "mean"                   # over the record: "mean", "min" or "max"
    alternative = "min"                  # the other reading, kept and reported beside it
    source = "§4.1.1"
    quote = "..."                        # the words bounded (verbatim)
    reading = "..."                      # how the words became the inequality, and why

Measures (functions of a :class:`~podbench.fem.structure.Structure` and the sample times of
a scenario's record, one value per sample):

``mass_diagonal_spread``
    s(t) = max_i M_ii(t) / min_i M_ii(t) over the *measured* DOFs i (the sensors'
    DOFs, the vertical translations of the beams). The rotational DOFs are left out: their
    diagonal terms are in lbf·s²·in, not lbf·s²/in, and no sensor reads them. For the
    cantilevers of §4.1 (consistent mass, 24 elements of mass m_e) the interior terms are
    312/420·m_e and the tip's is 156/420·m_e + m(t), so s = 2 on the LTI beam (the tip term is
    half the others) and s(t) = max(r, 1/r), r = 0.5 + 24·m(t)/(312/420·m_b), on the LTV beam.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.errors import ScenarioFileError
from podbench.study.resolve import resolve_structure

__all__ = ["Bound", "MEASURES", "STATISTICS", "mass_diagonal_spread", "parse_bounds",
           "evaluate_bounds", "bound_for"]


def mass_diagonal_spread(structure, times) -> np.ndarray:
    """``s(t) = max/min`` of the diagonal of ``M(t)`` over the measured DOFs (dimensionless),
    one value per time in ``times`` (s). A sensor on a constrained point is ignored."""
    dofs = np.unique(structure.sensor_dofs[structure.sensor_dofs >= 0])
    if dofs.size == 0:
        raise ScenarioFileError(f"structure {structure.name!r}: no measured DOF, so no "
                                "mass_diagonal_spread")
    base = structure.M.diagonal()[dofs]
    times = np.asarray(times, dtype=float)
    d = np.broadcast_to(base, (times.size, dofs.size)).copy()
    vm = structure.variable_mass
    if vm is not None and vm.dof in set(dofs.tolist()):
        d[:, int(np.flatnonzero(dofs == vm.dof)[0])] += vm(times)
    if structure.events:  # a mass that changes at an event: the full M(t) at each time
        d = np.array([structure.mass(t).diagonal()[dofs] for t in times])
    return d.max(axis=1) / d.min(axis=1)


MEASURES = {"mass_diagonal_spread": mass_diagonal_spread}
STATISTICS = {"mean": np.mean, "min": np.min, "max": np.max}


@dataclass(frozen=True)
class Bound:
    structure: str
    measure: str
    reference: str
    statistic: str
    alternative: str
    source: str
    quote: str
    reading: str


def parse_bounds(top) -> list[Bound]:
    """The ``[[bounds]]`` tables of a claims file (``top``: its :class:`Table`)."""
    out: list[Bound] = []
    for t in top.tables("bounds", []):
        b = Bound(structure=t.string("structure"),
                  measure=t.string("measure", choices=tuple(MEASURES)),
                  reference=t.string("reference"),
                  statistic=t.string("statistic", choices=tuple(STATISTICS)),
                  alternative=t.string("alternative", choices=tuple(STATISTICS)),
                  source=t.string("source"), quote=t.string("quote"),
                  reading=t.string("reading"))
        if any(o.structure == b.structure for o in out):
            t.fail("structure", f'"{b.structure}" is bounded twice')
        t.close()
        out.append(b)
    return out


def bound_for(bounds, structure: str) -> Bound | None:
    return next((b for b in bounds if b.structure == structure), None)


def evaluate_bounds(bound: Bound, scenario, variant_names) -> dict:
    """The measure of the reference structure and of each named variant of ``scenario``,
    over the scenario's record (``n_samples`` times ``dt``).

    Returns ``{"reference": {stat: value}, "points": {variant: {stat: value, "admitted":
    bool, "admitted_alternative": bool}}}``; a variant is admitted when its ``statistic`` of
    the measure exceeds the reference's (the reference is time-invariant for the beams, so
    its statistics coincide; the same statistic is compared)."""

    times = np.arange(scenario.n_samples) * scenario.dt
    fn = MEASURES[bound.measure]

    def stats(structure):
        s = fn(structure, times)
        return {k: float(f(s)) for k, f in STATISTICS.items()}

    ref = stats(resolve_structure(bound.reference, scenario, "bounds.reference"))
    points = {}
    for name in variant_names:
        st = stats(resolve_structure(name, scenario))
        st["admitted"] = st[bound.statistic] > ref[bound.statistic]
        st["admitted_alternative"] = st[bound.alternative] > ref[bound.alternative]
        points[name] = st
    return {"reference": ref, "points": points}
