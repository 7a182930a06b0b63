"""Excitations: initial displacements from static loads, initial velocities from impulses, and
force histories (pulses, user arrays, sums). Units: inch, lbf, second.

Two kinds of object, both accepted by :func:`podbench.dynamics.simulate`:

* initial states (``initial_displacement=``, ``initial_velocity=``) have a
  ``dof_vector(structure) -> (n_dofs,)`` method: :class:`StaticDisplacement`,
  :class:`ImpulseVelocity` (and the functions :func:`static_displacement`,
  :func:`impulse_velocity` returning the vectors directly);
* forces (``force=``) have a ``sample(structure, n_samples, dt) -> (n_sensors, n_samples)``
  method: :class:`Pulse`, :class:`ForceHistory`, :class:`Combined` (also ``pulse_a + pulse_b``).

Every object has ``to_dict()`` and :func:`excitation_from_dict` rebuilds it, so scenario files
can name excitations.

Locations
---------
A load's ``location`` is resolved on the structure (see :func:`resolve_dof`):

* a string: a sensor label (``structure.sensor_labels``) or a DOF label
  (``structure.dof_labels``);
* a number with ``by="position"`` (default): a position in inches along a 1-D structure,
  matched to ``structure.sensor_positions`` within 1e-9 in (error if no sensor, or more
  than one, is there: the truss has three sensors per face position);
* an integer with ``by="dof"``: a 0-based DOF index (the dissertation's truss tables count
  DOFs from 1: subtract one, or use the truss's DOF labels).

Forces are sampled at the sensors (the force matrix ``F`` of Eq. 3.37 lives on the same points
as ``W``), so a force location must be measured by a sensor.

Sampling convention for forces
------------------------------
Sample ``j`` is at ``t_j = j·dt``. ``F[:, j]`` enters the Newmark equilibrium at ``t_j``;
``F[:, 0]`` enters only through the initial acceleration. The forced-response methods model
the response as a causal convolution ``x = Δt Σ c[p] q[s−p]`` (Eq. 3.39), which the Newmark
response matches exactly only when ``f_0 = 0``. Therefore a :class:`Pulse` starts by default
one sample after ``t = 0`` (``start = dt``), so every pulse's first sample is zero.
"""

from __future__ import annotations

import numbers
from typing import Any, cast

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg

from podbench.core.hints import did_you_mean
from podbench.core.validation import as_finite_array, check_choice, check_positive
from podbench.dynamics.newmark import newmark
from podbench.errors import DimensionError, IllConditionedError, InputError, UnknownNameError
from podbench.structures.structure import Structure

__all__ = [
    "resolve_dof",
    "resolve_sensor",
    "static_displacement",
    "impulse_velocity",
    "StaticDisplacement",
    "ImpulseVelocity",
    "Pulse",
    "ForceHistory",
    "Combined",
    "excitation_from_dict",
    "POSITION_TOLERANCE",
]

POSITION_TOLERANCE = 1e-9
"""Tolerance (in) when matching a position to ``structure.sensor_positions``."""

_BY = ("position", "dof")


# ---------------------------------------------------------------------------- locations
def _describe(location, by) -> str:
    if isinstance(location, str):
        return f"label {location!r}"
    return f"{'position' if by == 'position' else 'DOF'} {location!r}"


def _labels_text(labels, most: int = 12) -> str:
    """``mass0, mass1, …`` (at most ``most``, then how many more)."""
    labels = list(labels)
    head = ", ".join(map(str, labels[:most]))
    return head + (f", … ({len(labels) - most} more)" if len(labels) > most else "")


def resolve_sensor(structure: Structure, location, *, by: str = "position") -> int:
    """Row of the sensor at ``location`` (see the module docstring for the forms accepted).

    Raises
    ------
    InputError
        No sensor at that location.
    """
    check_choice(by, "by", _BY)
    s = structure
    if isinstance(location, str):
        if location in s.sensor_labels:
            return s.sensor_labels.index(location)
        if location in s.dof_labels:
            dof = s.dof_labels.index(location)
            rows = np.flatnonzero(s.sensor_dofs == dof)
            if rows.size:
                return int(rows[0])
            raise InputError(
                f"Location {location!r}: DOF {dof} of structure {s.name!r} is not measured "
                "by any sensor (forces are sampled at the sensors)"
            )
        raise InputError(
            f"Location {location!r}: no sensor or DOF of structure {s.name!r} has this label"
            f"{did_you_mean(location, s.sensor_labels)} (sensors: "
            f"{_labels_text(s.sensor_labels)})"
        )
    if isinstance(location, bool) or not isinstance(location, numbers.Real):
        raise InputError(f"Location {location!r}: expected a number or a label")
    if by == "position":
        if s.sensor_positions is None:
            raise InputError(
                f"Location {location!r}: structure {s.name!r} has no sensor positions; "
                "use by='dof' or a label"
            )
        hits = np.flatnonzero(np.abs(s.sensor_positions - float(location)) <= POSITION_TOLERANCE)
        lo, hi = float(s.sensor_positions.min()), float(s.sensor_positions.max())
        if hits.size == 0 and not lo - POSITION_TOLERANCE <= float(location) <= hi + (
                POSITION_TOLERANCE):
            raise InputError(
                f"Location {location!r} in is off the structure {s.name!r} (sensor positions "
                f"{lo:g} … {hi:g} in)"
            )
        if hits.size == 0:
            near = float(s.sensor_positions[np.argmin(np.abs(s.sensor_positions - location))])
            raise InputError(
                f"Location {location!r} in: no sensor of structure {s.name!r} within "
                f"{POSITION_TOLERANCE:g} in (nearest sensor at {near:g} in; sensor positions "
                f"span [{lo:g}, {hi:g}] in)"
            )
        if hits.size > 1:
            labels = [s.sensor_labels[i] for i in hits] if s.sensor_labels else list(hits)
            raise InputError(
                f"Location {location!r} in: {hits.size} sensors of structure {s.name!r} are "
                f"at this position ({', '.join(map(str, labels))}); use a label or by='dof'"
            )
        return int(hits[0])
    dof = _dof_index(s, location)
    rows = np.flatnonzero(s.sensor_dofs == dof)
    if rows.size == 0:
        raise InputError(
            f"Location DOF {dof}: not measured by any sensor of structure {s.name!r} "
            "(forces are sampled at the sensors)"
        )
    return int(rows[0])


def _dof_index(s: Structure, location) -> int:
    if isinstance(location, bool) or not isinstance(location, numbers.Integral):
        raise InputError(f"Location {location!r}: with by='dof' expected an integer DOF index")
    dof = int(location)
    if not 0 <= dof < s.n_dofs:
        raise InputError(
            f"Location DOF {dof}: outside [0, {s.n_dofs - 1}] for structure {s.name!r}"
        )
    return dof


def resolve_dof(structure: Structure, location, *, by: str = "position") -> int:
    """0-based DOF index loaded at ``location`` (see the module docstring).

    Raises
    ------
    InputError
        Unknown location, or a sensor on a constrained point (a load there does nothing).
    """
    check_choice(by, "by", _BY)
    s = structure
    if isinstance(location, str) and location in s.dof_labels and location not in s.sensor_labels:
        return s.dof_labels.index(location)
    if by == "dof" and not isinstance(location, str):
        return _dof_index(s, location)
    row = resolve_sensor(s, location, by=by)
    dof = int(s.sensor_dofs[row])
    if dof < 0:
        raise InputError(
            f"Location {_describe(location, by)}: sensor {row} of structure {s.name!r} is on a "
            "constrained point; a load there is taken by the support"
        )
    return dof


def _at(field: str, exc: InputError) -> InputError:
    """``exc`` with ``field`` prepended to its ``field`` attribute (the dotted path, inside
    the excitation's table, of the entry at fault; see :func:`check_excitation`)."""
    inner = getattr(exc, "field", None)
    # InputError declares no `field`: it is attached here, read with getattr by the callers
    cast(Any, exc).field = f"{field}.{inner}" if inner else field
    return exc


def _check_locations(structure: Structure, pairs, name: str, by: str) -> None:
    for i, (loc, _) in enumerate(pairs):
        try:
            resolve_dof(structure, loc, by=by)
        except InputError as exc:
            raise _at(f"{name}[{i}]", exc) from None


def _check_loads(loads, name: str) -> list[tuple[object, float]]:
    try:
        pairs = [(loc, val) for loc, val in loads]
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"Parameter `{name}`: expected a list of (location, force_lbf) pairs ({exc})"
        ) from None
    if not pairs:
        raise InputError(f"Parameter `{name}`: at least one (location, force_lbf) pair is needed")
    out = []
    for loc, val in pairs:
        if isinstance(val, bool) or not isinstance(val, numbers.Real) or not np.isfinite(
                float(val)):
            raise InputError(f"Parameter `{name}`: force at {loc!r} must be a finite number")
        out.append((loc, float(val)))
    return out


def _load_vector(structure: Structure, loads, by: str) -> np.ndarray:
    f = np.zeros(structure.n_dofs)
    for loc, val in loads:
        f[resolve_dof(structure, loc, by=by)] += val
    return f


def _solve(A: sp.spmatrix, b: np.ndarray, what: str) -> np.ndarray:
    try:
        x = scipy.sparse.linalg.splu(sp.csc_matrix(A)).solve(b)
    except RuntimeError as exc:
        raise IllConditionedError(f"{what} is singular ({exc})") from None
    if not np.all(np.isfinite(x)):
        raise IllConditionedError(f"{what} is singular (the solution is not finite)")
    return x


def _check_reference(structure: Structure, reference: Structure | None) -> Structure:
    if reference is None:
        return structure
    if not isinstance(reference, Structure):
        raise InputError(
            f"Parameter `reference`: expected a Structure, got {type(reference).__name__}"
        )
    if reference.n_dofs != structure.n_dofs:
        raise DimensionError(
            f"Parameter `reference`: structure {reference.name!r} has {reference.n_dofs} DOFs, "
            f"structure {structure.name!r} has {structure.n_dofs}"
        )
    return reference


def _check_reference_and_locations(structure: Structure, reference: Structure | None, pairs,
                                   name: str, by: str) -> None:
    """The ``check`` of an initial state: the reference structure (field ``reference``), then
    every load location on it (fields ``<name>[i]``)."""
    try:
        ref = _check_reference(structure, reference)
    except InputError as exc:
        raise _at("reference", exc) from None
    _check_locations(ref, pairs, name, by)


# ---------------------------------------------------------------------------- initial states
class StaticDisplacement:
    """Initial displacement from static point loads: ``q0 = K(0)⁻¹ f`` (in).

    Parameters
    ----------
    loads : list of (location, force_lbf)
        Point loads (lbf). §4.1.1's ``w_0`` is ``[(17, 300), (18, 200), (24, -260)]``.
    by : {"position", "dof"}
        How numeric locations are read (see the module docstring).
    reference : Structure, optional
        Structure whose stiffness ``K(0)`` gives the profile (default: the simulated one).
        The dissertation computes every beam's initial displacements on the LTI beam and
        applies them to all three beams (§4.1.1): pass ``reference=lti_beam``. The reference
        must have the same DOFs as the simulated structure. Nonlinear elements and variable
        mass of the reference are ignored (a linear static solve with ``K(0)``).
    """

    kind = "static_displacement"

    def __init__(self, loads, *, by: str = "position", reference: Structure | None = None):
        self.loads = _check_loads(loads, "loads")
        self.by = check_choice(by, "by", _BY)
        self.reference = reference

    def check(self, structure: Structure) -> None:
        """Check, without solving, that the loads can be applied for ``structure``.

        Raises
        ------
        InputError
            With a ``field`` attribute (``"reference"``, ``"loads[1]"``) naming the entry.
        """
        _check_reference_and_locations(structure, self.reference, self.loads, "loads", self.by)

    def dof_vector(self, structure: Structure) -> np.ndarray:
        """``q0`` (n_dofs,) in inches (radians for rotations)."""
        ref = _check_reference(structure, self.reference)
        f = _load_vector(ref, self.loads, self.by)
        return _solve(ref.stiffness(0.0), f, f"The stiffness matrix K(0) of {ref.name!r}")

    def to_dict(self) -> dict:
        d = {"kind": self.kind, "loads": [list(p) for p in self.loads], "by": self.by}
        if self.reference is not None:
            d["reference"] = self.reference.name
        return d

    def __repr__(self) -> str:
        ref = f", reference={self.reference.name!r}" if self.reference is not None else ""
        return f"StaticDisplacement({self.loads!r}, by={self.by!r}{ref})"


class ImpulseVelocity:
    """Initial velocity from impulses: a force ``F`` acting for ``duration`` (lbf, s).

    Two definitions of the velocity the impulse gives the structure at rest (``velocity``):

    * ``"ideal"``: ``v0 = M(0)⁻¹ J`` with ``J = F·duration`` (lbf·s), the velocity an ideal
      (instantaneous) impulse imparts;
    * ``"measured"``: the velocity change measured on the model. The reference structure is
      integrated from rest (podbench's Newmark, step ``dt``) under the rectangular pulse
      :class:`Pulse` ``(location, F, duration)`` (default start, one step after t = 0), and
      ``v0`` is the velocity of every DOF at the first sample after the pulse (sample ``j1``
      of :meth:`Pulse.window`, ``t = duration + dt``). Up to that sample the trapezoidal
      impulse of the sampled force is exactly ``F·duration``. The displacement at that
      sample is not kept (the result is a velocity profile).

    The dissertation's "1000-lbf impulses" (beams, §4.1.1) and "1125-lbf impulses" (truss,
    §4.2.1) state a force, not an impulse, and the velocity changes are "measured". The
    scenario files state which duration and definition they use and why
    (``scenarios/chapter4/beam_free_velocity.toml``; docs/structures.md has the NL beam's
    tip maxima under each reading). ``duration`` is always explicit.

    Parameters
    ----------
    impulses : list of (location, force_lbf)
        Forces (lbf) and where they act.
    duration : float
        Time (s) the force acts; ``J = force · duration``.
    by, reference
        As in :class:`StaticDisplacement`; the structure used is the reference (the beams'
        profiles are computed on the LTI beam, §4.1.1).
    velocity : {"ideal", "measured"}
        Definition of the velocity change (see above); default ``"ideal"``.
    dt : float, optional
        Integration step (s) of the ``"measured"`` definition (required there, e.g. the
        scenario's 1e-4 s); must divide ``duration`` into whole steps within 1e-9.
    """

    kind = "impulse_velocity"
    VELOCITIES = ("ideal", "measured")

    def __init__(
        self, impulses, duration: float, *, by: str = "position",
        reference: Structure | None = None, velocity: str = "ideal", dt: float | None = None,
    ):
        self.impulses = _check_loads(impulses, "impulses")
        self.duration = check_positive(duration, "duration")
        self.by = check_choice(by, "by", _BY)
        self.reference = reference
        self.velocity = check_choice(velocity, "velocity", self.VELOCITIES)
        self.dt = None if dt is None else check_positive(dt, "dt")
        if self.velocity == "measured":
            if self.dt is None:
                raise InputError("Parameter `dt`: velocity='measured' needs the integration "
                                 "step dt (s)")
            steps = self.duration / self.dt
            if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
                raise InputError(
                    f"Parameter `duration`: {self.duration!r} s is not a whole number of "
                    f"steps dt = {self.dt!r} s (velocity='measured')"
                )

    def check(self, structure: Structure) -> None:
        """As :meth:`StaticDisplacement.check` (fields ``reference``, ``impulses[i]``)."""
        _check_reference_and_locations(structure, self.reference, self.impulses, "impulses",
                                       self.by)

    def dof_vector(self, structure: Structure) -> np.ndarray:
        """``v0`` (n_dofs,) in in/s (rad/s for rotations)."""
        ref = _check_reference(structure, self.reference)
        if self.velocity == "ideal":
            J = self.duration * _load_vector(ref, self.impulses, self.by)
            return _solve(ref.mass(0.0), J, f"The mass matrix M(0) of {ref.name!r}")

        dt = self.dt
        if dt is None:  # __init__ requires dt; only reached if it was set to None since
            raise InputError("Parameter `dt`: velocity='measured' needs the integration "
                             "step dt (s)")
        f = _load_vector(ref, self.impulses, self.by)
        j0, j1 = Pulse(0, 1.0, self.duration, by="dof").window(dt)
        F = np.zeros((ref.n_dofs, j1 + 1))
        F[:, j0:j1] = f[:, None]
        zero = np.zeros(ref.n_dofs)
        return newmark(ref, zero, zero, F, dt).v[:, j1].copy()

    def to_dict(self) -> dict:
        d = {
            "kind": self.kind, "impulses": [list(p) for p in self.impulses],
            "duration": self.duration, "by": self.by,
        }
        if self.velocity != "ideal":
            d["velocity"] = self.velocity
        if self.dt is not None:
            d["dt"] = self.dt
        if self.reference is not None:
            d["reference"] = self.reference.name
        return d

    def __repr__(self) -> str:
        ref = f", reference={self.reference.name!r}" if self.reference is not None else ""
        extra = f", velocity={self.velocity!r}, dt={self.dt!r}" if self.velocity != "ideal" else ""
        return (
            f"ImpulseVelocity({self.impulses!r}, duration={self.duration!r}, by={self.by!r}"
            f"{ref}{extra})"
        )


def static_displacement(
    structure: Structure, loads, *, by: str = "position", reference: Structure | None = None
) -> np.ndarray:
    """``q0 = K(0)⁻¹ f`` (n_dofs,) for point loads; see :class:`StaticDisplacement`."""
    return StaticDisplacement(loads, by=by, reference=reference).dof_vector(structure)


def impulse_velocity(
    structure: Structure, impulses, duration: float, *, by: str = "position",
    reference: Structure | None = None, velocity: str = "ideal", dt: float | None = None,
) -> np.ndarray:
    """``v0`` (n_dofs,) of impulses ``F`` acting for ``duration``: ``M(0)⁻¹ F·duration``
    (``velocity="ideal"``) or measured on the model (``"measured"``, step ``dt``); see
    :class:`ImpulseVelocity`."""
    return ImpulseVelocity(impulses, duration, by=by, reference=reference, velocity=velocity,
                           dt=dt).dof_vector(structure)


# ---------------------------------------------------------------------------- forces
class _Force:
    """Base of force excitations: ``sample(structure, n_samples, dt)`` and ``+``."""

    kind = ""

    def sample(self, structure: Structure, n_samples: int, dt: float) -> np.ndarray:
        raise NotImplementedError

    def check(self, structure: Structure, n_samples: int, dt: float) -> None:
        """Check, cheaply, that the force can be sampled for ``structure`` on ``n_samples``
        samples of ``dt`` and loads at least one of them.

        Raises
        ------
        InputError
            With a ``field`` attribute naming the entry at fault (e.g. ``"location"``).
        """
        self.sample(structure, n_samples, dt)

    def __add__(self, other):
        if not isinstance(other, _Force):
            return NotImplemented
        return Combined(self, other)


def _sample_checks(n_samples, dt):
    n_samples = check_positive(n_samples, "n_samples", integer=True)
    dt = check_positive(dt, "dt")
    return n_samples, dt


class Pulse(_Force):
    """A point load of given shape and duration at one sensor (lbf).

    Sample ``j`` (``t_j = j·dt``) is loaded when ``start <= t_j < start + duration``; both
    edges are compared with a half-step tolerance (``t_j >= start − dt/2`` and
    ``t_j < start + duration − dt/2``) so that floating-point error cannot move an edge.
    A rectangular pulse of 0.5 ms at dt = 0.1 ms thus loads 5 samples (§4.1.3: 500 lbf on the
    beams); 0.4 s at dt = 0.05 s loads 8 samples (§4.2.2: 225 lbf on the truss).

    Parameters
    ----------
    location
        Where the load acts (a sensor: see the module docstring).
    amplitude : float
        Peak force (lbf); negative values push the other way.
    duration : float
        Length of the pulse (s).
    start : float, optional
        Time (s) of the first loaded sample. Default ``None``: one time step after ``t = 0``
        (``start = dt``), so the first force sample ``f_0`` is zero (see the module docstring
        for why). Pass ``start=0.0`` to load from the first sample on.
    shape : {"rectangular", "half_sine", "triangle"}
        ``P``; ``P sin(π τ / duration)``; ``P (1 − |2τ/duration − 1|)``, with
        ``τ = t_j − start``.
    by : {"position", "dof"}
        How a numeric ``location`` is read.
    hits : list of (delay_s, rel_amp), optional
        Further impacts of the same shape and duration at the same point, as an impact
        hammer gives them when it bounces (double and triple hits): hit ``k`` starts
        ``delay_s`` (> 0) after the first and has amplitude ``rel_amp × amplitude``. They are
        part of the excitation (the truth is simulated with them), not a measurement error.
        Overlapping hits add. Scenario files: ``hits = [[2.0e-3, 0.3], [4.5e-3, 0.1]]``.
    """

    kind = "pulse"
    SHAPES = ("rectangular", "half_sine", "triangle")

    def __init__(
        self, location, amplitude: float, duration: float, *, start: float | None = None,
        shape: str = "rectangular", by: str = "position", hits=(),
    ):
        if isinstance(amplitude, bool) or not isinstance(amplitude, numbers.Real) or not (
            np.isfinite(amplitude)
        ):
            raise InputError(f"Parameter `amplitude`: expected a finite number, got {amplitude!r}")
        self.location: Any = location
        self.amplitude: float = float(amplitude)
        self.duration: float = check_positive(duration, "duration")
        self.start: float | None = None if start is None else check_positive(
            start, "start", allow_zero=True)
        self.shape: str = check_choice(shape, "shape", self.SHAPES)
        self.by: str = check_choice(by, "by", _BY)
        self.hits: tuple[tuple[float, float], ...] = _check_hits(hits)

    def window(self, dt: float, start: float | None = None) -> tuple[int, int]:
        """First loaded sample and one past the last: ``(j0, j1)`` (of the first hit, or of
        a hit starting at ``start``)."""
        if start is None:
            start = dt if self.start is None else self.start
        j0 = int(np.ceil(start / dt - 0.5))
        j1 = int(np.ceil((start + self.duration) / dt - 0.5))
        return j0, j1

    def _starts(self, dt: float) -> list[tuple[float, float]]:
        """``(start_s, amplitude_lbf)`` of every hit, the first one first."""
        start = dt if self.start is None else self.start
        return [(start, self.amplitude)] + [(start + d, r * self.amplitude)
                                            for d, r in self.hits]

    def history(self, n_samples: int, dt: float) -> np.ndarray:
        """The load at ``t_j`` (n_samples,) in lbf."""
        n_samples, dt = _sample_checks(n_samples, dt)
        out = np.zeros(n_samples)
        for start, amp in self._starts(dt):
            j0, j1 = self.window(dt, start)
            j = np.arange(j0, min(j1, n_samples))
            tau = j * dt - start
            if self.shape == "rectangular":
                val = np.full(j.size, amp)
            elif self.shape == "half_sine":
                val = amp * np.sin(np.pi * tau / self.duration)
            else:
                val = amp * (1.0 - np.abs(2.0 * tau / self.duration - 1.0))
            out[j] += val
        return out

    def check(self, structure: Structure, n_samples: int, dt: float) -> None:
        n_samples, dt = _sample_checks(n_samples, dt)
        try:
            self._row(structure)
        except InputError as exc:
            raise _at("location", exc) from None
        j0, j1 = self.window(dt)
        if j1 <= j0:
            raise _at("duration", InputError(
                f"Pulse: a duration of {self.duration:g} s loads no sample at dt = {dt:g} s "
                "(a sample is loaded when start <= t_j < start + duration, half a step "
                "tolerance)"))
        if j0 >= n_samples:
            start = dt if self.start is None else self.start
            raise _at("start", InputError(
                f"Pulse: starts at {start:g} s, after the record's last sample at "
                f"{(n_samples - 1) * dt:g} s (n_samples = {n_samples}, dt = {dt:g} s)"))
        for k, (start, _) in enumerate(self._starts(dt)[1:]):
            if self.window(dt, start)[0] >= n_samples:
                raise _at(f"hits[{k}]", InputError(
                    f"Pulse: hit {k} starts at {start:g} s, after the record's last sample at "
                    f"{(n_samples - 1) * dt:g} s"))
        self._check_shape_fits(n_samples, dt)

    def _check_shape_fits(self, n_samples: int, dt: float) -> None:
        """A half-sine or triangle cut by the record's end is not the load its shape names
        (a rectangular pulse running past the end is a step held to the end: kept)."""
        if self.shape == "rectangular":
            return
        last = (n_samples - 1) * dt
        for k, (start, _) in enumerate(self._starts(dt)):
            if self.window(dt, start)[1] <= n_samples:
                continue
            in_s = self.duration / 1000  # the duration read as ms: a likely slip if it
            ms = (f"; a duration in ms? {self.duration:g} ms is {in_s:g} s"  # loads and fits
                  if in_s >= dt and start + in_s <= last + dt / 2 else "")
            what = "Pulse" if k == 0 else f"Pulse: hit {k - 1}"
            raise _at("duration", InputError(
                f"{what}: a {self.shape} of {self.duration:g} s from {start:g} s ends at "
                f"{start + self.duration:g} s, after the record's last sample at {last:g} s "
                f"(n_samples = {n_samples}, dt = {dt:g} s): the record would cut its "
                f"shape{ms}"))

    def _row(self, structure: Structure) -> int:
        row = resolve_sensor(structure, self.location, by=self.by)
        if structure.sensor_dofs[row] < 0:
            raise InputError(
                f"Pulse location {_describe(self.location, self.by)}: sensor {row} of "
                f"structure {structure.name!r} is on a constrained point"
            )
        return row

    def sample(self, structure: Structure, n_samples: int, dt: float) -> np.ndarray:
        """The force matrix (n_sensors, n_samples) in lbf."""
        row = self._row(structure)
        F = np.zeros((structure.n_sensors, n_samples))
        F[row] = self.history(n_samples, dt)
        return F

    def to_dict(self) -> dict:
        d = {
            "kind": self.kind, "location": self.location, "amplitude": self.amplitude,
            "duration": self.duration, "start": self.start, "shape": self.shape, "by": self.by,
        }
        if self.hits:
            d["hits"] = [list(h) for h in self.hits]
        return d

    def __repr__(self) -> str:
        hits = f", hits={[list(h) for h in self.hits]!r}" if self.hits else ""
        return (
            f"Pulse({self.location!r}, {self.amplitude!r}, {self.duration!r}, "
            f"start={self.start!r}, shape={self.shape!r}, by={self.by!r}{hits})"
        )


def _check_hits(hits) -> tuple[tuple[float, float], ...]:
    """Validate ``hits`` (pairs ``(delay_s > 0, finite rel_amp)``)."""
    if hits is None:
        return ()
    if not isinstance(hits, (list, tuple)):
        raise _at("hits", InputError(
            f"Pulse: expected `hits` as a list of [delay_s, rel_amp] pairs, got {hits!r}"))
    out = []
    for k, h in enumerate(hits):
        ok = isinstance(h, (list, tuple)) and len(h) == 2 and all(
            isinstance(x, numbers.Real) and not isinstance(x, bool) and np.isfinite(float(x))
            for x in h)
        if not ok or h[0] <= 0:
            raise _at(f"hits[{k}]", InputError(
                f"Pulse: expected a hit [delay_s > 0, rel_amp] with finite numbers, got {h!r}"))
        out.append((float(h[0]), float(h[1])))
    return tuple(out)


class ForceHistory(_Force):
    """A user force matrix (n_sensors, n_samples) in lbf, sampled at ``t_j = j·dt``."""

    kind = "force_history"

    def __init__(self, F):
        self.F = as_finite_array(F, "F", ndim=2)

    def sample(self, structure: Structure, n_samples: int, dt: float) -> np.ndarray:
        expected = (structure.n_sensors, n_samples)
        if self.F.shape != expected:
            raise DimensionError(
                f"ForceHistory: expected shape {expected} (n_sensors, n_samples) for structure "
                f"{structure.name!r}, got {self.F.shape}"
            )
        return self.F.copy()

    def check(self, structure: Structure, n_samples: int, dt: float) -> None:
        try:
            self.sample(structure, n_samples, dt)
        except InputError as exc:
            raise _at("F", exc) from None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "F": self.F.tolist()}

    def __repr__(self) -> str:
        return f"ForceHistory(shape={self.F.shape})"


class Combined(_Force):
    """The sum of several force excitations."""

    kind = "combined"

    def __init__(self, *parts):
        flat = []
        for p in parts:
            if isinstance(p, Combined):
                flat.extend(p.parts)
            elif isinstance(p, _Force):
                flat.append(p)
            else:
                raise InputError(
                    f"Combined: expected force excitations, got {type(p).__name__}"
                )
        if not flat:
            raise InputError("Combined: at least one force excitation is needed")
        self.parts = tuple(flat)

    def sample(self, structure: Structure, n_samples: int, dt: float) -> np.ndarray:
        return sum(p.sample(structure, n_samples, dt) for p in self.parts)

    def check(self, structure: Structure, n_samples: int, dt: float) -> None:
        for i, p in enumerate(self.parts):
            try:
                p.check(structure, n_samples, dt)
            except InputError as exc:
                raise _at(f"parts[{i}]", exc) from None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "parts": [p.to_dict() for p in self.parts]}

    def __repr__(self) -> str:
        return f"Combined{self.parts!r}"


# ---------------------------------------------------------------------------- from files
def excitation_from_dict(d: dict, *, structures: dict[str, Structure] | None = None):
    """Rebuild an excitation from ``to_dict()`` output (e.g. a table of a scenario file).

    Parameters
    ----------
    d : dict
        Must have ``"kind"``: one of ``static_displacement``, ``impulse_velocity``, ``pulse``,
        ``force_history``, ``combined``; the other keys are the constructor's arguments.
    structures : dict, optional
        Maps the name in a ``"reference"`` entry to a Structure.
    """
    if not isinstance(d, dict) or "kind" not in d:
        raise InputError(f"Excitation: expected a table with a 'kind' entry, got {d!r}")
    d = dict(d)
    kind = d.pop("kind")
    if "reference" in d:
        d["reference"] = _reference_structure(d.pop("reference"), kind, structures)
    try:
        built = _build_excitation(kind, d, structures)
    except KeyError as exc:
        raise InputError(f"Excitation {kind!r}: missing entry {exc}") from None
    except TypeError as exc:
        raise InputError(f"Excitation {kind!r}: {exc}") from None
    if built is not None:
        return built
    kinds = "static_displacement, impulse_velocity, pulse, force_history, combined"
    raise UnknownNameError(f"Excitation: unknown kind {kind!r}; known kinds: {kinds}")


def _reference_structure(name, kind, structures: dict[str, Structure] | None) -> Structure:
    """The structure a ``"reference"`` entry names (or the Structure given there)."""
    if isinstance(name, Structure):
        return name
    if not isinstance(name, str):
        raise _at("reference", InputError(
            f"Excitation {kind!r}: expected the name of a structure, got {name!r}"))
    if structures is None or name not in structures:
        raise _at("reference", UnknownNameError(
            f"Excitation {kind!r}: reference structure {name!r} is not among the "
            f"structures given ({sorted(structures or {})})"
        ))
    return structures[name]


def _build_excitation(kind, d: dict, structures: dict[str, Structure] | None):
    """The excitation of ``kind`` from the constructor's arguments ``d`` (None: unknown kind).
    A missing argument raises KeyError, an unexpected one TypeError."""
    if kind == "static_displacement":
        return StaticDisplacement(d.pop("loads"), **d)
    if kind == "impulse_velocity":
        return ImpulseVelocity(d.pop("impulses"), d.pop("duration"), **d)
    if kind == "pulse":
        return Pulse(d.pop("location"), d.pop("amplitude"), d.pop("duration"), **d)
    if kind == "force_history":
        return ForceHistory(d.pop("F"), **d)
    if kind == "combined":
        return _combined_from_dict(d, structures)
    return None


def _combined_from_dict(d: dict, structures: dict[str, Structure] | None) -> Combined:
    """``{"parts": [force tables]}``: every part rebuilt (fields ``parts[i]``), all forces."""
    parts = d.pop("parts")
    if d:
        raise TypeError(f"unexpected entries {sorted(d)}")
    if not isinstance(parts, (list, tuple)):
        raise _at("parts", InputError(
            f"Excitation 'combined': expected an array of force tables, got {parts!r}"))
    built = []
    for i, p in enumerate(parts):
        try:
            built.append(excitation_from_dict(p, structures=structures))
        except InputError as exc:
            raise _at(f"parts[{i}]", exc) from None
    if any(not isinstance(b, _Force) for b in built):
        raise _at("parts", InputError(
            "Excitation 'combined': every part must be a force (pulse, force_history, "
            "combined)"))
    return Combined(*built)
