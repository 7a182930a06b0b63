"""Truth data for base excitation (Chapter 6): a structure shaken at its supports.

A rigid base motion ``u_g(t)`` along the influence vector ``r`` (the DOF displacements of a
unit rigid support displacement) moves every DOF as ``q_abs = q + r u_g``; with ``q`` the
displacement relative to the base, the equation of motion is

    ``M q'' + C q' + K q = −M r ü_g(t)``     (the effective load, from rest),

(``C r = K r = 0`` for a rigid-body ``r``). It is integrated with podbench's Newmark (average
acceleration, :func:`podbench.dynamics.newmark.newmark`) or exudyn's (the cross-check). The
base velocity and displacement are integrated from ``ü_g`` by the same trapezoidal rule
Newmark uses for the structure, so absolute and relative quantities are consistent sample by
sample.

Outputs at the sensors ``S``: ``relative_displacement`` ``S q``, ``absolute_displacement``
``S q + (S r) u_g``, ``relative_velocity``, ``absolute_velocity``, ``absolute_acceleration``
``S q'' + (S r) ü_g`` (what an accelerometer measures), and, for the Hermite-cubic beams,
``strain`` at given points: the surface bending strain ``ε = −c κ``, ``κ = w''(x)`` from the
element's shape functions (``c`` the distance of the fibre from the neutral axis); for the
satellite truss, ``strain`` is the axial strain of chosen members (elongation / length; the
members of the fractured element read 0 from the fracture on).

Structures: the cantilever beams (transverse motion of the clamp) and the satellite truss
(both pins moving together along X2), :func:`influence_vector`; any other with ``r`` given.

Units: the structure's (inch, lbf, second): ü_g in in/s², displacements in in, strain
dimensionless. Sampling: ``t_j = j·dt``; ``ü_g[0]`` enters through the initial acceleration.
"""

from __future__ import annotations

import numpy as np

from podbench.dynamics.exudyn_engine import simulate_exudyn
from podbench.dynamics.newmark import newmark
from podbench.errors import InputError
from podbench.structures.truss import member_strain_matrix

__all__ = ["influence_vector", "ground_motion", "simulate_base", "beam_strain_matrix",
           "strain_matrix", "OUTPUTS"]

OUTPUTS = ("relative_displacement", "absolute_displacement", "relative_velocity",
           "absolute_velocity", "absolute_acceleration", "strain")


def influence_vector(structure) -> np.ndarray:
    """``r`` of a rigid transverse support motion.

    Beams (DOF labels ``w@…``, ``theta@…``): 1 on every ``w`` DOF, 0 on the rotations (a
    rigid translation of the clamp). The satellite truss (``faceN.d_top``, ``faceN.d_bot``,
    ``faceN.theta``): both pins move together along X2, the plane of motion: 1 on every
    ``d_top``/``d_bot``, 0 on the face rotations (a rigid vertical translation moves no
    member, so ``K r`` over all coordinates vanishes and only the inertia term
    ``−M r ü_g`` drives the relative motion). As for the beam clamp, the consistent mass
    coupling the free DOFs to the supports' own coordinates is not in the effective load
    (the issue's ``−M r ü_g`` on the free DOFs; zero for a lumped mass). Other structures:
    give ``r`` explicitly."""
    labels = structure.dof_labels or ()
    if labels and all(lbl.startswith(("w@", "theta@")) for lbl in labels):
        return np.array([1.0 if lbl.startswith("w@") else 0.0 for lbl in labels])
    if labels and all(lbl.startswith("face") and "." in lbl for lbl in labels):
        return np.array([1.0 if lbl.endswith((".d_top", ".d_bot")) else 0.0
                         for lbl in labels])
    raise InputError(f"structure {structure.name!r}: no beam (w@…, theta@…) or truss "
                     "(faceN.d_top, …) DOF labels; give the influence vector r explicitly")


def ground_motion(ag: np.ndarray, dt: float):
    """Base velocity and displacement from rest by Newmark's trapezoidal rule (β = 1/4)."""
    ag = np.asarray(ag, dtype=float)
    vg = np.zeros_like(ag)
    ug = np.zeros_like(ag)
    for j in range(ag.size - 1):
        vg[j + 1] = vg[j] + 0.5 * dt * (ag[j] + ag[j + 1])
        ug[j + 1] = ug[j] + dt * vg[j] + 0.25 * dt * dt * (ag[j] + ag[j + 1])
    return vg, ug


def beam_strain_matrix(structure, points, fibre_distance: float) -> np.ndarray:
    """``E`` with ``ε = E q``: surface strain ``−c w''(x)`` at ``points`` (in from the root)
    of a clamped Hermite-cubic beam (:func:`podbench.fem.beam.cantilever_beam`).

    ``w''(x) = [N1'' N2'' N3'' N4''] · [w_a θ_a w_b θ_b]`` on the element holding ``x``,
    ``ξ = (x − x_a)/l``: ``N1'' = (12ξ − 6)/l²``, ``N2'' = (6ξ − 4)/l``,
    ``N3'' = (6 − 12ξ)/l²``, ``N4'' = (6ξ − 2)/l``; the root's DOFs are clamped (zero)."""
    md = structure.metadata
    if "n_elements" not in md or "length" not in md or "EI" not in md:
        raise InputError(f"structure {structure.name!r}: strain needs a beam (n_elements, "
                         "length in its metadata)")
    n, L = int(md["n_elements"]), float(md["length"])
    le = L / n
    pts = np.atleast_1d(np.asarray(points, dtype=float))
    if np.any(pts < 0) or np.any(pts > L):
        raise InputError(f"Parameter `points`: strain points must lie in [0, {L:g}] in")
    E = np.zeros((pts.size, structure.n_dofs))
    for i, x in enumerate(pts):
        e = min(int(x // le), n - 1)
        xi = (x - e * le) / le
        B = np.array([(12 * xi - 6) / le**2, (6 * xi - 4) / le, (6 - 12 * xi) / le**2,
                      (6 * xi - 2) / le])
        dofs = [2 * (e - 1), 2 * (e - 1) + 1, 2 * e, 2 * e + 1]  # node e (a), e+1 (b)
        for d, b in zip(dofs, B, strict=True):
            if d >= 0:  # node 0 is the clamp
                E[i, d] += -fibre_distance * b
    return E


def strain_matrix(structure, *, strain_points=None, fibre_distance=None,
                  strain_members=None) -> np.ndarray:
    """``E`` with ``ε = E q``: the beams' surface bending strain at ``strain_points``
    (:func:`beam_strain_matrix`, needs ``fibre_distance``) or the truss members' axial
    strain (``strain_members``: ``(element, label)`` pairs,
    :func:`podbench.structures.truss.member_strain_matrix`)."""
    if strain_members is not None:
        return member_strain_matrix(structure, strain_members)
    if strain_points is None or fibre_distance is None:
        raise InputError("output 'strain' needs strain_points and fibre_distance (a beam) "
                         "or strain_members (the truss)")
    return beam_strain_matrix(structure, strain_points, fibre_distance)


def _outputs(structure, outputs, r, derived: bool, res, ag, dt, strain) -> dict:
    q, v, a = res
    S = structure.sensor_matrix()
    Sr = S @ r
    if derived:  # a sensor on the clamp moves with the base
        Sr[structure.sensor_dofs < 0] = 1.0
    vg, ug = ground_motion(ag, dt)
    out = {}
    for name in outputs:
        if name == "relative_displacement":
            out[name] = S @ q
        elif name == "absolute_displacement":
            out[name] = S @ q + Sr[:, None] * ug[None, :]
        elif name == "relative_velocity":
            out[name] = S @ v
        elif name == "absolute_velocity":
            out[name] = S @ v + Sr[:, None] * vg[None, :]
        elif name == "absolute_acceleration":
            if a is None:
                raise InputError("engine 'exudyn': accelerations are not returned; use newmark")
            out[name] = S @ a + Sr[:, None] * ag[None, :]
        elif name == "strain":
            out[name] = strain_matrix(structure, **strain) @ q
            _broken_members_carry_nothing(structure, out[name], strain["strain_members"], dt)
    return out


def _broken_members_carry_nothing(structure, eps: np.ndarray, members, dt: float) -> None:
    """The members of the truss's fractured element read zero strain from the fracture on
    (they are gone; the joints they joined move apart freely)."""
    broken = structure.metadata.get("fracture_element")
    if members is None or broken is None or not structure.events:
        return
    start = structure.events[0].first_sample(dt)
    for i, (element, _) in enumerate(members):
        if int(element) == int(broken):
            eps[i, start:] = 0.0


def simulate_base(structure, ag, dt: float, *, outputs=("absolute_acceleration",),
                  r=None, strain_points=None, fibre_distance=None, strain_members=None,
                  engine: str = "newmark"):
    """Response of ``structure`` to the base acceleration ``ag`` (n,), from rest.

    ``strain``: the beams' surface strain at ``strain_points`` (in from the root; fibre at
    ``fibre_distance`` in) or the truss members' axial strain (``strain_members``,
    ``(element, label)`` pairs); see :func:`strain_matrix`.

    Returns
    -------
    dict
        Output name → (n_sensors or n_points, n) array; also ``"q"`` (relative DOF
        displacements) and ``"effective_load"`` (−M r ü_g, n_dofs × n).
    """

    ag = np.asarray(ag, dtype=float)
    if ag.ndim != 1 or ag.size < 2 or not np.all(np.isfinite(ag)):
        raise InputError("Parameter `ag`: expected a finite 1-D base acceleration (≥ 2 samples)")
    bad = [o for o in outputs if o not in OUTPUTS]
    if bad:
        raise InputError(f"Parameter `outputs`: unknown {bad}; expected some of {OUTPUTS}")
    strain = dict(strain_points=strain_points, fibre_distance=fibre_distance,
                  strain_members=strain_members)
    if "strain" in outputs:  # checked before the integration
        strain_matrix(structure, **strain)
    derived = r is None
    r = influence_vector(structure) if derived else np.asarray(r, dtype=float)
    n_dofs = structure.n_dofs
    f = -(structure.M @ r)[:, None] * ag[None, :]
    z = np.zeros(n_dofs)
    states: tuple[np.ndarray, np.ndarray, np.ndarray | None]
    if engine == "newmark":
        res = newmark(structure, z, z, f, dt)
        states = (res.q, res.v, res.a)
    elif engine == "exudyn":
        # A linear step is solved by exudyn's first Newton iteration (K, C analytic); its
        # relative tolerance only decides whether it then iterates on round-off. At the
        # default 1e-10 Newton fails on the truss's load −M r ü_g on every DOF (measured);
        # at 1e-8 it agrees with podbench's Newmark to 5e-13.
        rtol = 1e-12 if structure.nonlinear else 1e-8
        q, v = simulate_exudyn(structure, z, z, f, dt, newton_rtol=rtol)
        states = (q, v, None)
    else:
        raise InputError(f"Parameter `engine`: expected 'newmark' or 'exudyn', got {engine!r}")
    out = {"q": states[0], "effective_load": f}
    out.update(_outputs(structure, outputs, r, derived, states, ag, dt, strain))
    return out
