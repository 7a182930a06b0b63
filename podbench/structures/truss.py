"""The satellite truss of dissertation §4.2: 50 two-bay elements of 21 pin-jointed tubes.

Geometry (Table 4.1, Fig. 4.50)
-------------------------------
The cross-section is an equilateral triangle of side ``a`` in the X2–X3 plane (X1 runs along
the truss, X2 is vertical, X3 out of the plane of motion): one top joint at height
``y_t = a/√3`` above the centroid and two bottom joints at ``y_b = −a/(2√3)``,
``X3 = ∓a/2``. A truss *element* is two bays of length ``b`` long, so it has three
cross-sectional *faces* (left, middle, right) at ``X1 = 0, b, 2b``. Its 21 members:

* 6 longerons (D = 3 in, t = 0.04 in), one per joint line per bay: ``1, 2, 3`` in bay 1 and
  ``1', 2', 3'`` in bay 2 (1 = top line, 2 = bottom line at X3 = −a/2, 3 = at X3 = +a/2);
* 9 battens (D = 1 in, t = 0.02 in), the three sides of each face's triangle:
  ``7, 8, 9`` on the left face, ``4, 5, 6`` on the middle face, ``7', 8', 9'`` on the right
  face (first = top–bottom(−), second = top–bottom(+), third = bottom–bottom);
* 6 diagonals (D = 1 in, t = 0.02 in, length ``√(a² + b²)`` = 13.86 ft for a = b = 9.8 ft;
  Table 4.1 rounds to 13.9 ft), one per rectangular side panel per bay: ``10, 11`` in the two
  upper side panels and ``12`` in the bottom panel of bay 1, primed in bay 2. Default
  pattern ``"mirrored"``: bay 1's side diagonals run from the bottom joints of the left face
  up to the top joint of the middle face, bay 2's from there down to the bottom joints of
  the right face (a Warren pattern, each element symmetric about its middle face);
  ``"parallel"`` repeats bay 1's direction in bay 2.

Which member carries which number in Fig. 4.50 is not recoverable from the text; the
numbering above is this module's. Adjacent elements share their boundary face and each
element keeps its own end-face battens, so a shared face carries two coincident sets of
battens (the literal assembly of 50 elements of 21 members each).

Kinematics (Fig. 4.51)
----------------------
Planar motion in X1–X2. Each face has three coordinates: ``d_top`` (X2 displacement of the
top joint), ``d_bot`` (X2 displacement of both bottom joints, assumed equal by symmetry)
and ``theta`` (rotation of the face about X3, so a joint at height ``y`` above the centroid
moves axially by ``−y·θ``). Out-of-plane displacements are zero. A joint's displacement is
``d = T_joint (d_top, d_bot, θ)`` with ::

    T_top    = [[0, 0, −y_t], [1, 0, 0], [0, 0, 0]]
    T_bottom = [[0, 0, −y_b], [0, 1, 0], [0, 0, 0]]

An element's nine coordinates are, in Fig. 4.51's names, ``Δ1, Δ2, Θ1`` (left face:
top, bottom, rotation), ``Δ3, Δ4, Θ2`` (middle), ``Δ5, Δ6, Θ3`` (right).

Member matrices
---------------
Linear bar: strain energy ``½ (EA/L) (eᵀ(d_j − d_i))²`` with ``e`` the unit vector from
joint i to joint j; consistent bar mass ``ρAL/6 · [[2I, I], [I, 2I]]`` on the 3-D joint
displacements ``(d_i, d_j)``. With ``B`` the map from the element's nine coordinates to
``(d_i, d_j)``: ``K_e = Σ (EA/L) gᵀg`` with ``g = eᵀ(B_j − B_i)``, ``M_e = Σ Bᵀ m B``.

Assembly and boundary conditions
--------------------------------
50 elements share boundary faces: 101 faces × 3 = 303 coordinates, face ``f`` at
``X1 = f·b`` holding coordinates ``3f, 3f+1, 3f+2``. Pinned ends fix ``d_top`` and
``d_bot`` of faces 0 and 100 (the rotations stay free): 299 DOFs, ordered by face:
DOF 0 = ``face0.theta``, DOFs ``1 + 3(f−1) + c`` for faces 1..99, DOF 298 =
``face100.theta``.

Fracture
--------
§4.2: "the stiffness matrix for the 10th truss element from the left boundary was removed from
the global stiffness matrix to simulate a fracture (i.e. the 10th truss element breaks off and
disappears). As a result, the remaining truss sections on the right and left of the break are
free to exhibit rigid-body rotation around each pinned end." Two models
(``fracture_model``):

* ``"element"`` (default, the reading of the whole passage): the element breaks off and
  disappears. A :class:`StiffnessEvent` at t = 3 s with ``delta_K = −K_e10`` and
  ``delta_M = −M_e10`` (assembled), and ``removed_dofs`` the free coordinates of the faces
  only element 10 holds (its middle face 19; also face 0's or face 2n's rotation for the
  first or last element). Those coordinates leave the model: they are held at zero and their
  sensors read 0 from the event on (W keeps its 299 rows). After the event K, M restricted
  to the remaining coordinates have exactly two zero eigenvalues, the rigid rotations of the
  left (faces 0–18) and right (faces 20–100) parts about their pins.
* ``"stiffness_only"`` (the literal first clause): only ``delta_K = −K_e10``. The element's
  mass and its middle face stay; face 19 then has no stiffness at all and K has five zero
  eigenvalues (the two rotations and face 19's three coordinates, tied to faces 18 and 20
  only through element 10's kept consistent mass, so face 19 drifts without bound).

Units: inch, lbf, second; masses lbf·s²/in; rotations rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from podbench.core.validation import check_choice, check_positive
from podbench.errors import InputError
from podbench.structures.beam import density_from_lbm_per_ft3
from podbench.structures.structure import StiffnessEvent, Structure

__all__ = [
    "COORDINATES",
    "ELEMENT_COORDINATES",
    "TubeSection",
    "TrussMember",
    "element_members",
    "truss_element_matrices",
    "satellite_truss",
    "face_dof",
    "truss_dof",
    "dissertation_dof_element",
    "FRACTURE_MODELS",
    "member_strain_matrix",
]

#: ``fracture_model`` choices of :func:`satellite_truss` (see the module docstring).
FRACTURE_MODELS = ("element", "stiffness_only")

#: The three coordinates of a face, in their order within the face.
COORDINATES = ("d_top", "d_bot", "theta")

#: Fig. 4.51's names of an element's nine coordinates → (local face 0/1/2, coordinate).
ELEMENT_COORDINATES = {
    "d1": (0, "d_top"), "d2": (0, "d_bot"), "theta1": (0, "theta"),
    "d3": (1, "d_top"), "d4": (1, "d_bot"), "theta2": (1, "theta"),
    "d5": (2, "d_top"), "d6": (2, "d_bot"), "theta3": (2, "theta"),
}

_JOINTS = ("top", "bot-", "bot+")


@dataclass(frozen=True)
class TubeSection:
    """Hollow circular section: outer diameter and wall thickness (in)."""

    outer_diameter: float
    thickness: float

    def __post_init__(self):
        check_positive(self.outer_diameter, "outer_diameter")
        check_positive(self.thickness, "thickness")
        if 2 * self.thickness > self.outer_diameter:
            raise InputError(
                f"Parameter `thickness`: {self.thickness!r} in exceeds half the outer "
                f"diameter {self.outer_diameter!r} in"
            )

    @property
    def area(self) -> float:
        """Cross-sectional area ``π t (D − t)`` (in²)."""
        return float(np.pi * self.thickness * (self.outer_diameter - self.thickness))


@dataclass(frozen=True)
class TrussMember:
    """One member of a truss element: joint ``(face, joint)`` to joint ``(face, joint)``.

    Faces are the element's local faces 0 (left), 1 (middle), 2 (right); joints are "top",
    "bot-" (X3 = −a/2) and "bot+" (X3 = +a/2).
    """

    label: str
    group: str  # "longeron" | "batten" | "diagonal"
    face_i: int
    joint_i: str
    face_j: int
    joint_j: str


def element_members(diagonal_pattern: str = "mirrored") -> tuple[TrussMember, ...]:
    """The 21 members of one truss element (see the module docstring for the numbering)."""
    check_choice(diagonal_pattern, "diagonal_pattern", ("mirrored", "parallel"))
    m = []
    for bay, prime in ((0, ""), (1, "'")):
        for k, joint in enumerate(_JOINTS):
            m.append(TrussMember(f"{k + 1}{prime}", "longeron", bay, joint, bay + 1, joint))
    sides = (("top", "bot-"), ("top", "bot+"), ("bot-", "bot+"))
    for face, labels in ((0, ("7", "8", "9")), (1, ("4", "5", "6")), (2, ("7'", "8'", "9'"))):
        for lab, (ji, jj) in zip(labels, sides, strict=True):
            m.append(TrussMember(lab, "batten", face, ji, face, jj))
    # bay 1: bottom joints of the left face up to the top joint of the middle face;
    # bottom panel from bot- (left) to bot+ (middle)
    bay1 = (("10", "bot-", "top"), ("11", "bot+", "top"), ("12", "bot-", "bot+"))
    for lab, ji, jj in bay1:
        m.append(TrussMember(lab, "diagonal", 0, ji, 1, jj))
    for lab, ji, jj in bay1:
        if diagonal_pattern == "parallel":
            m.append(TrussMember(lab + "'", "diagonal", 1, ji, 2, jj))
        else:  # mirrored about the middle face
            m.append(TrussMember(lab + "'", "diagonal", 1, jj, 2, ji))
    return tuple(m)


def _joint_geometry(side: float):
    y_t = side / np.sqrt(3.0)
    y_b = -side / (2.0 * np.sqrt(3.0))
    pos = {"top": (y_t, 0.0), "bot-": (y_b, -side / 2.0), "bot+": (y_b, side / 2.0)}
    T = {
        "top": np.array([[0.0, 0.0, -y_t], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        "bot-": np.array([[0.0, 0.0, -y_b], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]),
    }
    T["bot+"] = T["bot-"]
    return pos, T


def truss_element_matrices(*, bay_length: float, side: float, E: float, density: float,
                           longeron: TubeSection, batten: TubeSection,
                           diagonal: TubeSection, diagonal_pattern: str = "mirrored"):
    """Stiffness and mass of one truss element in its nine coordinates.

    Parameters
    ----------
    bay_length, side : float
        Bay length ``b`` and triangle side ``a`` (in).
    E : float
        Young's modulus (psi).
    density : float
        Mass density (lbf·s²/in⁴).
    longeron, batten, diagonal : TubeSection
        Member sections.
    diagonal_pattern : {"mirrored", "parallel"}
        Direction of the bay-2 diagonals.

    Returns
    -------
    Ke, Me : (9, 9) ndarray
        In the coordinates ``(Δ1, Δ2, Θ1, Δ3, Δ4, Θ2, Δ5, Δ6, Θ3)`` (in, in, rad, …):
        ``Ke`` in lbf/in (lbf·in/rad …), ``Me`` in lbf·s²/in (…).
    table : list of dict
        Per member: label, group, length (in), area (in²), mass (lbf·s²/in), EA/L (lbf/in).
    """
    b = check_positive(bay_length, "bay_length")
    a = check_positive(side, "side")
    E = check_positive(E, "E")
    rho = check_positive(density, "density")
    sections = {"longeron": longeron, "batten": batten, "diagonal": diagonal}
    pos, T = _joint_geometry(a)
    Ke = np.zeros((9, 9))
    Me = np.zeros((9, 9))
    table = []
    mass_block = np.block([[2 * np.eye(3), np.eye(3)], [np.eye(3), 2 * np.eye(3)]]) / 6.0
    for mem in element_members(diagonal_pattern):
        xi = np.array([mem.face_i * b, *pos[mem.joint_i]])
        xj = np.array([mem.face_j * b, *pos[mem.joint_j]])
        length = float(np.linalg.norm(xj - xi))
        e = (xj - xi) / length
        A = sections[mem.group].area
        Bi = np.zeros((3, 9))
        Bj = np.zeros((3, 9))
        Bi[:, 3 * mem.face_i:3 * mem.face_i + 3] = T[mem.joint_i]
        Bj[:, 3 * mem.face_j:3 * mem.face_j + 3] = T[mem.joint_j]
        g = e @ (Bj - Bi)
        k = E * A / length
        m = rho * A * length
        Ke += k * np.outer(g, g)
        B = np.vstack([Bi, Bj])
        Me += m * (B.T @ mass_block @ B)
        table.append({"label": mem.label, "group": mem.group, "length": length, "area": A,
                      "mass": m, "EA/L": k})
    Ke = 0.5 * (Ke + Ke.T)
    Me = 0.5 * (Me + Me.T)
    return Ke, Me, table


# ---------------------------------------------------------------------------- DOF numbering
def _free_coordinates(n_elements: int, supports: str = "pinned") -> np.ndarray:
    n_faces = 2 * n_elements + 1
    fixed = {0, 1, 3 * (n_faces - 1), 3 * (n_faces - 1) + 1} if supports == "pinned" else set()
    return np.array([c for c in range(3 * n_faces) if c not in fixed], dtype=np.int64)


def face_dof(face: int, coordinate: str, *, n_elements: int = 50) -> int:
    """Global DOF index (0-based) of ``coordinate`` ("d_top", "d_bot", "theta") of a face.

    Faces are numbered 0..2·n_elements from the left pin. Raises InputError for a pinned
    coordinate (``d_top``/``d_bot`` of the end faces).
    """
    n_elements = check_positive(n_elements, "n_elements", integer=True)
    n_faces = 2 * n_elements + 1
    if isinstance(face, bool) or not isinstance(face, (int, np.integer)) or not (
            0 <= face < n_faces):
        raise InputError(f"Parameter `face`: expected an integer in [0, {n_faces - 1}], "
                         f"got {face!r}")
    check_choice(coordinate, "coordinate", COORDINATES)
    c = 3 * int(face) + COORDINATES.index(coordinate)
    free = _free_coordinates(n_elements)
    k = int(np.searchsorted(free, c))
    if k >= free.size or free[k] != c:
        raise InputError(f"face {face} `{coordinate}` is pinned (not a DOF)")
    return k


def truss_dof(element: int, coordinate: str = "d2", *, n_elements: int = 50) -> int:
    """Global DOF index (0-based) of Fig. 4.51's coordinate of a truss element.

    Parameters
    ----------
    element : int
        Element number counted from the left boundary, 1-based as in Tables 4.2–4.3.
    coordinate : str
        One of "d1".."d6", "theta1".."theta3" (``Δ2`` = bottom joints of the element's
        left face, the coordinate the dissertation loads).

    Examples
    --------
    >>> truss_dof(23, "d2")   # "Δ2 on the 23rd truss element" (the dissertation's DOF 140)
    131
    """
    n_elements = check_positive(n_elements, "n_elements", integer=True)
    if isinstance(element, bool) or not isinstance(element, (int, np.integer)) or not (
            1 <= element <= n_elements):
        raise InputError(f"Parameter `element`: expected an integer in [1, {n_elements}], "
                         f"got {element!r}")
    check_choice(coordinate, "coordinate", tuple(ELEMENT_COORDINATES))
    local, name = ELEMENT_COORDINATES[coordinate]
    return face_dof(2 * (int(element) - 1) + local, name, n_elements=n_elements)


def dissertation_dof_element(dof: int) -> int:
    """The element a DOF number of Tables 4.2–4.3 describes ("Δ2 on element e").

    The tables' DOF numbers follow ``DOF = 6e + 2`` (140 ↔ element 23, 50 ↔ 8, 20 ↔ 3,
    290 ↔ 48). That is not the position of element e's Δ2 in the 299-DOF numbering used
    here (nor, exactly, in any face-by-face numbering of the constrained model); podbench
    maps the tables' loads by (element, coordinate) through :func:`truss_dof`.
    """
    if (dof - 2) % 6:
        raise InputError(f"Parameter `dof`: {dof} is not of the form 6e + 2")
    return (dof - 2) // 6


def _member_row(mem: TrussMember, bay: float, side: float) -> np.ndarray:
    """``g / L``: the member's axial strain in the element's nine coordinates."""
    pos, T = _joint_geometry(side)
    xi = np.array([mem.face_i * bay, *pos[mem.joint_i]])
    xj = np.array([mem.face_j * bay, *pos[mem.joint_j]])
    length = float(np.linalg.norm(xj - xi))
    e = (xj - xi) / length
    Bi = np.zeros((3, 9))
    Bj = np.zeros((3, 9))
    Bi[:, 3 * mem.face_i:3 * mem.face_i + 3] = T[mem.joint_i]
    Bj[:, 3 * mem.face_j:3 * mem.face_j + 3] = T[mem.joint_j]
    return e @ (Bj - Bi) / length


def member_strain_matrix(structure: Structure, members) -> np.ndarray:
    """``E`` with ``ε = E q``: the axial strain (elongation / length, positive in tension)
    ``ε = eᵀ(d_j − d_i)/L`` of truss members, one row per member over the structure's DOFs.

    ``members``: ``(element, label)`` pairs, the element 1-based from the left pin and the
    label of :func:`element_members` (``"1"`` the top longeron of bay 1, ``"10"`` a
    diagonal, …). The joint displacements ``d`` follow from the face coordinates by Fig.
    4.51's kinematics (module docstring); pinned coordinates are zero. Then
    ``Σ_members EA L ε² = qᵀ K q`` (the strain energy, twice)."""
    md = structure.metadata
    if "free_coordinates" not in md or "bay_length" not in md:
        raise InputError(f"structure {structure.name!r}: member strain needs the satellite "
                         "truss (its metadata: free_coordinates, bay_length, side)")
    n = int(md["n_elements"])
    lookup = {m.label: m for m in element_members(str(md["diagonal_pattern"]))}
    col = {int(c): k for k, c in enumerate(md["free_coordinates"])}
    pairs = list(members)
    E = np.zeros((len(pairs), structure.n_dofs))
    for i, (element, label) in enumerate(pairs):
        if not (isinstance(element, (int, np.integer)) and 1 <= element <= n):
            raise InputError(f"Parameter `members`: element {element!r} not in [1, {n}]")
        if str(label) not in lookup:
            raise InputError(f"Parameter `members`: unknown member label {label!r} (one of "
                             f"{', '.join(lookup)})")
        row = _member_row(lookup[str(label)], float(md["bay_length"]), float(md["side"]))
        for local, g in enumerate(row):
            k = col.get(6 * (int(element) - 1) + local)
            if k is not None and g != 0.0:
                E[i, k] += g
    return E


# ---------------------------------------------------------------------------- the truss
def satellite_truss(
    *,
    name: str = "satellite_truss",
    n_elements: int = 50,
    bay_length: float = 9.8 * 12.0,
    side: float = 9.8 * 12.0,
    E: float = 1.0e7,
    density: float | None = None,
    longeron: TubeSection = TubeSection(3.0, 0.04),
    batten: TubeSection = TubeSection(1.0, 0.02),
    diagonal: TubeSection = TubeSection(1.0, 0.02),
    diagonal_pattern: str = "mirrored",
    supports: str = "pinned",
    fracture_element: int | None = 10,
    fracture_time: float = 3.0,
    fracture_model: str = "element",
    description: str = "",
    source: str = "",
) -> Structure:
    """The §4.2 satellite truss, pinned at both ends, with element ``fracture_element``
    breaking at ``fracture_time`` (see the module docstring).

    Parameters
    ----------
    n_elements : int
        Number of two-bay elements (50).
    bay_length, side : float
        Bay length and triangle side, in (9.8 ft = 117.6 in each, Table 4.1).
    E : float
        Young's modulus, psi (1e7).
    density : float, optional
        Mass density, lbf·s²/in⁴; default 112.3 lbm/ft³ converted with g0 = 386.0886 in/s².
    longeron, batten, diagonal : TubeSection
        Table 4.1's sections (3 × 0.04 in, 1 × 0.02 in, 1 × 0.02 in).
    diagonal_pattern : {"mirrored", "parallel"}
        See :func:`element_members`.
    supports : {"pinned", "free"}
        "pinned" (§4.2) fixes ``d_top`` and ``d_bot`` of the two end faces (299 DOFs);
        "free" keeps all ``3·(2·n_elements + 1)`` coordinates (303 DOFs; two rigid-body
        modes), for checks. :func:`truss_dof` and :func:`face_dof` number the pinned truss.
    fracture_element : int or None
        1-based element that breaks (None: no fracture, an LTI truss).
    fracture_time : float
        Time of the fracture, s.
    fracture_model : {"element", "stiffness_only"}
        ``"element"``: the element disappears (its stiffness and mass go, the coordinates
        only it connected leave the model and read 0); ``"stiffness_only"``: only its
        stiffness is removed (see the module docstring).

    Returns
    -------
    Structure
        ``6·n_elements − 1`` DOFs (299), every DOF a sensor; ``dof_labels`` like
        ``"face44.d_bot"``; ``sensor_positions`` = X1 of each DOF's face (in). ``metadata``
        holds ``n_elements``, ``n_faces``, ``face_x``, ``free_coordinates`` (the 303-numbering
        coordinate of each DOF), ``members`` (one element's member table), ``member_mass``
        (total mass of all members), ``fracture_element``, ``fracture_model``,
        ``removed_dofs`` (the DOFs the fracture removes), ``element_K``/``element_M``
        (9×9), ``y_top``/``y_bottom``.
    """
    n = check_positive(n_elements, "n_elements", integer=True)
    check_choice(supports, "supports", ("pinned", "free"))
    check_choice(fracture_model, "fracture_model", FRACTURE_MODELS)
    rho = density_from_lbm_per_ft3(112.3) if density is None else check_positive(
        density, "density")
    Ke, Me, table = truss_element_matrices(
        bay_length=bay_length, side=side, E=E, density=rho, longeron=longeron, batten=batten,
        diagonal=diagonal, diagonal_pattern=diagonal_pattern)
    n_faces = 2 * n + 1
    free = _free_coordinates(n, supports)
    P = sp.csr_matrix((np.ones(free.size), (np.arange(free.size), free)),
                      shape=(free.size, 3 * n_faces))
    K = _assemble_constrained(((e, Ke) for e in range(n)), P)
    M = _assemble_constrained(((e, Me) for e in range(n)), P)
    K = ((K + K.T) * 0.5).tocsr()
    M = ((M + M.T) * 0.5).tocsr()

    events: tuple[StiffnessEvent, ...] = ()
    removed: tuple[int, ...] = ()
    if fracture_element is not None:
        event = _fracture_event(fracture_element, fracture_time, fracture_model, Ke, Me, P,
                                free, n)
        events, removed = (event,), event.removed_dofs

    face_x = np.arange(n_faces) * float(bay_length)
    dof_labels = tuple(f"face{c // 3}.{COORDINATES[c % 3]}" for c in free)
    _, T = _joint_geometry(float(side))
    metadata = {
        "n_elements": n,
        "n_faces": n_faces,
        "face_x": face_x,
        "free_coordinates": free,
        "members": table,
        "member_mass": n * sum(r["mass"] for r in table),
        "fracture_element": fracture_element,
        "fracture_model": fracture_model if fracture_element is not None else None,
        "removed_dofs": np.asarray(removed, dtype=np.int64),
        "element_K": Ke,
        "element_M": Me,
        "y_top": -T["top"][0, 2],
        "y_bottom": -T["bot-"][0, 2],
        "bay_length": float(bay_length),
        "side": float(side),
        "density": rho,
        "diagonal_pattern": diagonal_pattern,
        "supports": supports,
    }
    return Structure(
        name=name, M=M, K=K, sensor_dofs=np.arange(free.size), events=events,
        sensor_positions=face_x[free // 3], sensor_labels=dof_labels, dof_labels=dof_labels,
        description=description, source=source, metadata=metadata,
    )


def _assemble_constrained(blocks, P: sp.csr_matrix) -> sp.csr_matrix:
    """``P A Pᵀ``: the 9 × 9 element blocks ``(e, block)`` added at coordinates
    ``6e … 6e + 8`` (element ``e`` spans faces ``2e … 2e + 2``), then restricted to the free
    coordinates by the selection matrix ``P`` (free × all coordinates)."""
    n_coord = P.shape[1]
    rows, cols, vals = [], [], []
    for e, blk in blocks:
        idx = np.arange(6 * e, 6 * e + 9)
        r, c = np.meshgrid(idx, idx, indexing="ij")
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(blk.ravel())
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_coord, n_coord))
    return (P @ A @ P.T).tocsr()


def _fracture_event(fracture_element, fracture_time, model: str, Ke: np.ndarray,
                    Me: np.ndarray, P: sp.csr_matrix, free: np.ndarray, n: int) -> StiffnessEvent:
    """The :class:`StiffnessEvent` of element ``fracture_element`` (1-based, checked) breaking
    at ``fracture_time`` (s): ``delta_K = −K_e``; with ``model = "element"`` also
    ``delta_M = −M_e`` and the DOFs of the faces only this element holds removed (see the
    module docstring)."""
    if isinstance(fracture_element, bool) or not isinstance(
            fracture_element, (int, np.integer)) or not 1 <= fracture_element <= n:
        raise InputError(f"Parameter `fracture_element`: expected an integer in [1, {n}], "
                         f"got {fracture_element!r}")
    time = check_positive(fracture_time, "fracture_time", allow_zero=True)
    element = int(fracture_element)
    e = element - 1
    dK = _assemble_constrained([(e, Ke)], P)
    dK = (-(dK + dK.T) * 0.5).tocsr()
    if model == "stiffness_only":
        return StiffnessEvent(
            time=time, delta_K=dK,
            description=f"element {element} breaks: its stiffness is removed "
                        "(its mass stays)")
    dM = _assemble_constrained([(e, Me)], P)
    dM = (-(dM + dM.T) * 0.5).tocsr()
    # faces held by this element only: its middle face, and an end face of the truss
    n_faces = 2 * n + 1
    own = {2 * e + 1} | ({0} if e == 0 else set()) | ({n_faces - 1} if e == n - 1 else set())
    removed = tuple(int(k) for k in np.flatnonzero(np.isin(free // 3, sorted(own))))
    return StiffnessEvent(
        time=time, delta_K=dK, delta_M=dM, removed_dofs=removed,
        description=f"element {element} breaks off and disappears: its "
                    f"stiffness and mass are removed and DOFs {list(removed)} (faces "
                    f"{sorted(own)}) leave the model")
