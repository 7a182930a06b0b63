"""Euler–Bernoulli cantilever beams (dissertation §4.1, §5): LTI, time-varying tip mass, cubic
spring, the one-sided rubber band of §5.2.

Hermite-cubic elements with consistent mass, two DOFs per node: the vertical displacement
``w`` (in) and the rotation ``θ`` (rad). The root node is clamped and removed, so a beam of
``n`` elements has ``2 n`` DOFs ordered ``(w_1, θ_1, w_2, θ_2, …, w_n, θ_n)`` (node 1 is the
first free node, node ``n`` the tip). Sensors read ``w`` at every node, root included
(``sensor_dofs = -1`` there: the clamp reads zero), as in the dissertation's 25-point
snapshot matrices.

Units: inch, lbf, second; mass density in lbf·s²/in⁴ (:func:`density_from_lbm_per_ft3`
converts the dissertation's lbm/ft³).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from podbench.core.validation import check_choice, check_positive
from podbench.errors import InputError
from podbench.structures.laws import scaled_law
from podbench.structures.structure import CubicSpring, OneSidedSpring, Structure, VariableMass

__all__ = [
    "G0_IN_PER_S2",
    "density_from_lbm_per_ft3",
    "bending_stiffness",
    "tip_stiffness",
    "beam_mass",
    "k3_matching_linear",
    "tip_mass_law",
    "beam_element_matrices",
    "cantilever_beam",
    "modal_damping_matrix",
    "MODAL_DAMPING_MAX_DOFS",
]

#: Standard gravity 9.80665 m/s² in in/s² (= 9.80665 / 0.0254): 1 lbm = 1/G0 lbf·s²/in.
G0_IN_PER_S2 = 9.80665 / 0.0254


def density_from_lbm_per_ft3(rho_lbm_ft3: float) -> float:
    """Mass density in lbf·s²/in⁴ from lbm/ft³: ``ρ = ρ_lbm / 1728 / g0``, g0 = 386.0886 in/s².

    A weight density in lbf/ft³ (as §4.1 writes "500 lbf/ft³") gives the same number.
    """
    check_positive(rho_lbm_ft3, "rho_lbm_ft3")
    return float(rho_lbm_ft3) / 1728.0 / G0_IN_PER_S2


def bending_stiffness(E: float, width: float, depth: float) -> float:
    """Bending stiffness ``EI = E·width·depth³/12`` (lbf·in²) of a rectangular section bent
    about the axis along ``width`` (E in psi, width and depth in in)."""
    return E * width * depth**3 / 12.0


def tip_stiffness(*, length: float, width: float, depth: float, E: float) -> float:
    """Static tip stiffness ``3 EI / L³`` (lbf/in) of a cantilever: the force at the free end
    per unit tip deflection (Euler–Bernoulli, clamped root)."""
    return 3.0 * bending_stiffness(E, width, depth) / length**3


def beam_mass(*, length: float, width: float, depth: float, density: float) -> float:
    """Mass ``ρ·width·depth·L`` (lbf·s²/in) of a prismatic beam (density in lbf·s²/in⁴)."""
    return density * width * depth * length


def k3_matching_linear(k_linear: float, w_ref: float) -> float:
    """Cubic coefficient ``k3 = k_linear / w_ref²`` (lbf/in³) whose force ``k3 w³`` equals the
    linear force ``k_linear w`` at the deflection ``w = w_ref`` (in).

    The NL beam's cubic spring (Fig. 4.2, not in the text) is stated this way: matched to the
    beam's own tip stiffness :func:`tip_stiffness` at a chosen tip deflection.
    """
    return k_linear / w_ref**2


def tip_mass_law(law: str, *, scale: str = "absolute", length: float, width: float,
                 depth: float, density: float, **params):
    """The time law ``m(t)`` of a tip mass (the LTV beam, Fig. 4.3).

    Parameters
    ----------
    law : {"constant", "sine", "linear"}
        :func:`podbench.fem.laws.scaled_law` with ``params`` (``value``; ``mean``,
        ``amplitude``, ``period``, ``phase``; ``initial``, ``final``, ``duration``).
    scale : {"absolute", "beam_mass"}
        Masses in ``params`` are in lbf·s²/in (``"absolute"``) or multiples of the beam's
        mass :func:`beam_mass` (``"beam_mass"``).
    length, width, depth, density : float
        The beam (in, lbf·s²/in⁴), for ``scale = "beam_mass"``.
    """
    check_choice(scale, "scale", ("absolute", "beam_mass"))
    factor = (beam_mass(length=length, width=width, depth=depth, density=density)
              if scale == "beam_mass" else 1.0)
    return scaled_law(law, factor, **params)


def beam_element_matrices(EI: float, rho_A: float, le: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of a Hermite-cubic Euler–Bernoulli element.

    Parameters
    ----------
    EI : float
        Bending stiffness (lbf·in²).
    rho_A : float
        Mass per unit length (lbf·s²/in²).
    le : float
        Element length (in).

    Returns
    -------
    ke, me : (4, 4) ndarray
        In the local DOFs ``(w_i, θ_i, w_j, θ_j)`` (in, rad, in, rad): ``ke`` in lbf/in
        (lbf·in/rad etc.), ``me`` in lbf·s²/in.
    """
    L = le
    ke = EI / L**3 * np.array([
        [12.0, 6 * L, -12.0, 6 * L],
        [6 * L, 4 * L**2, -6 * L, 2 * L**2],
        [-12.0, -6 * L, 12.0, -6 * L],
        [6 * L, 2 * L**2, -6 * L, 4 * L**2],
    ])
    me = rho_A * L / 420.0 * np.array([
        [156.0, 22 * L, 54.0, -13 * L],
        [22 * L, 4 * L**2, 13 * L, -3 * L**2],
        [54.0, 13 * L, 156.0, -22 * L],
        [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
    ])
    return ke, me


#: Largest model for which :func:`modal_damping_matrix` builds its dense ``n × n`` matrix
#: (a 2000-DOF matrix is 32 MB; the dense eigenproblem grows as the cube).
MODAL_DAMPING_MAX_DOFS = 2000


def modal_damping_matrix(M, K, ratios) -> np.ndarray:
    """Viscous damping with prescribed modal damping ratios: ``C = M Φ diag(2 ζ_r ω_r) Φᵀ M``.

    ``Φ`` holds the mass-normalized eigenvectors of ``K φ = ω² M φ`` (``Φᵀ M Φ = I``), so
    ``Φᵀ C Φ = diag(2 ζ_r ω_r)``: every undamped mode keeps its shape and decays with ratio
    ``ζ_r`` (damped frequency ``ω_r √(1 − ζ_r²)``). This is classical (proportional) damping,
    the usual model of a lightly damped bare metal structure whose modes are measured one
    by one.

    Parameters
    ----------
    M, K : (n, n) sparse or dense
        Mass (lbf·s²/in) and stiffness (lbf/in) of the constrained model.
    ratios : float or sequence of float
        ``ζ`` (fraction of critical, ``0 <= ζ < 1``) of every mode, or of modes 1, 2, … in
        ascending frequency; modes beyond the list take its last value.

    Returns
    -------
    (n, n) ndarray
        ``C`` in lbf·s/in, symmetric positive semi-definite.
    """
    n = M.shape[0]
    if n > MODAL_DAMPING_MAX_DOFS:
        raise InputError(f"Parameter `modal_ratio`: modal damping builds a dense {n} x {n} "
                         f"matrix; at most {MODAL_DAMPING_MAX_DOFS} DOFs are supported")
    z = np.atleast_1d(np.asarray(ratios, dtype=float))
    if z.ndim != 1 or z.size == 0 or z.size > n or not np.all(np.isfinite(z)) or \
            np.any(z < 0) or np.any(z >= 1):
        raise InputError(f"Parameter `modal_ratio`: expected one ratio or 1 to {n} ratios "
                         f"in [0, 1), got {ratios!r}")
    Md = M.toarray() if sp.issparse(M) else np.asarray(M, dtype=float)
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K, dtype=float)
    import scipy.linalg

    w2, phi = scipy.linalg.eigh(Kd, Md)
    omega = np.sqrt(np.clip(w2, 0.0, None))
    zeta = np.concatenate([z, np.full(n - z.size, z[-1])])
    B = Md @ phi
    C = (B * (2.0 * zeta * omega)) @ B.T
    return 0.5 * (C + C.T)


def sensor_nodes(sensors, length: float, n: int) -> np.ndarray:
    """Node indices (0 = root, n = tip) of sensor positions (in) that lie on nodes."""
    x = np.asarray(sensors, dtype=float)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise InputError(f"Parameter `sensors`: expected a non-empty list of positions (in), "
                         f"got {sensors!r}")
    le = length / n
    idx = np.rint(x / le).astype(np.int64)
    off = np.abs(idx * le - x) > 1e-9 * length
    if np.any(off) or np.any(idx < 0) or np.any(idx > n):
        bad = float(x[np.flatnonzero(off | (idx < 0) | (idx > n))[0]])
        raise InputError(f"Parameter `sensors`: position {bad!r} in is not a node of the "
                         f"{n}-element beam (nodes every {le:g} in from 0 to {length:g} in)")
    if np.unique(idx).size != idx.size or np.any(np.diff(idx) <= 0):
        raise InputError(f"Parameter `sensors`: positions must be strictly increasing, got "
                         f"{list(map(float, x))}")
    return idx


def cantilever_beam(
    *,
    name: str = "cantilever_beam",
    length: float = 24.0,
    width: float = 1.0,
    depth: float = 0.75,
    E: float = 29.0e6,
    density: float | None = None,
    n_elements: int = 24,
    tip_mass=None,
    tip_k3: float | None = None,
    tip_dashpot: float | None = None,
    tip_band: dict | None = None,
    sensors=None,
    modal_damping=None,
    description: str = "",
    source: str = "",
) -> Structure:
    """A clamped–free Euler–Bernoulli beam, optionally with tip mass, cubic spring, dashpot.

    Defaults are the steel beam of §4.1: 24 × 1 × 0.75 in, E = 29e6 psi, 500 lbm/ft³,
    24 elements, bending about the weak axis (``I = width·depth³/12``).

    Parameters
    ----------
    name : str
        Structure name.
    length, width, depth : float
        Length, width (out of the bending plane) and depth (in the bending plane), in.
    E : float
        Young's modulus, psi (lbf/in²).
    density : float, optional
        Mass density, lbf·s²/in⁴; default steel 500 lbm/ft³ (see
        :func:`density_from_lbm_per_ft3`).
    n_elements : int
        Number of equal elements.
    tip_mass : callable, optional
        Time law ``m(t)`` (lbf·s²/in) of a point mass on the tip's ``w`` DOF that moves with
        the tip (no ``ṁ v`` term), e.g. :class:`podbench.fem.laws.SineLaw`.
    tip_k3 : float, optional
        Coefficient (lbf/in³) of a grounded cubic spring ``g = k3 w_tip³`` at the tip.
    tip_dashpot : float, optional
        Grounded viscous dashpot (lbf·s/in) on the tip ``w`` DOF.
    tip_band : dict, optional
        The rubber band of §5.2, a grounded one-sided spring on the tip ``w`` DOF
        (:class:`podbench.fem.OneSidedSpring`): ``k`` (lbf/in), ``side`` (``"positive"``:
        stiff when the tip moves in +w, the band being attached on the −w side;
        ``"negative"`` the reverse; or ±1), optional ``slack`` and ``prestretch`` (in, at most
        one non-zero; default 0, the text's words) and ``twin`` (the linear twin's rule:
        ``"tangent"``, ``"free"``, ``"two_sided"``).
    sensors : sequence of float, optional
        Positions (in from the root) of the measured points, strictly increasing, each on a
        node (else ``InputError``); only the ``w`` DOFs there are measured (a sensor at 0
        reads the clamp: 0). Default: every node. Forces live on the sensors (the
        dissertation's ``F`` has the rows of ``W``), so a load must act at a sensor.
    modal_damping : float or sequence of float, optional
        Modal damping ratios ``ζ`` (:func:`modal_damping_matrix`), added to the dashpot.
    description, source : str
        Stored on the structure.

    Returns
    -------
    Structure
        ``2·n_elements`` DOFs and ``n_elements + 1`` sensors (``w`` at every node, the root
        reading 0), or the ``sensors`` given. ``metadata`` holds ``tip_dof``,
        ``tip_stiffness`` (3EI/L³, lbf/in),
        ``beam_mass`` (ρAL, lbf·s²/in), ``EI``, ``rho_A``, ``length`` and ``density``.
    """
    length = check_positive(length, "length")
    width = check_positive(width, "width")
    depth = check_positive(depth, "depth")
    E = check_positive(E, "E")
    rho = density_from_lbm_per_ft3(500.0) if density is None else check_positive(
        density, "density")
    n = check_positive(n_elements, "n_elements", integer=True)

    EI = bending_stiffness(E, width, depth)
    rho_A = rho * width * depth
    K, M = _assemble_clamped(*beam_element_matrices(EI, rho_A, length / n), n)

    tip = 2 * (n - 1)
    C = _tip_dashpot_matrix(tip, 2 * n, tip_dashpot)
    variable_mass = _tip_variable_mass(tip, tip_mass)
    nonlinear = _tip_springs(tip, tip_k3, tip_band)
    if modal_damping is not None:
        Cm = sp.csr_matrix(modal_damping_matrix(M, K, modal_damping))
        C = Cm if C is None else (C + Cm).tocsr()

    nodes_x = np.linspace(0.0, length, n + 1)
    dof_labels = tuple(f"{q}@{nodes_x[i + 1]:g}in" for i in range(n) for q in ("w", "theta"))
    nodes = np.arange(n + 1) if sensors is None else sensor_nodes(sensors, length, n)
    x = nodes_x[nodes]
    sensor_dofs = np.where(nodes == 0, -1, 2 * (nodes - 1)).astype(np.int64)
    sensor_labels = tuple(f"w@{xi:g}in" for xi in x)
    metadata = {
        "tip_dof": tip,
        "tip_stiffness": tip_stiffness(length=length, width=width, depth=depth, E=E),
        "beam_mass": rho_A * length,
        "EI": EI,
        "rho_A": rho_A,
        "length": length,
        "density": rho,
        "n_elements": n,
        **_tip_metadata(tip_k3, tip_dashpot, nonlinear, modal_damping),
    }
    return Structure(
        name=name, M=M, K=K, C=C, sensor_dofs=sensor_dofs, variable_mass=variable_mass,
        nonlinear=nonlinear, sensor_positions=x, sensor_labels=sensor_labels,
        dof_labels=dof_labels, description=description, source=source, metadata=metadata,
    )


def _assemble_clamped(ke: np.ndarray, me: np.ndarray, n: int) -> tuple[sp.csr_matrix,
                                                                         sp.csr_matrix]:
    """``K``, ``M`` of ``n`` equal elements, node ``e`` joined to ``e + 1``, the root node's
    two DOFs (clamped) removed; symmetrized exactly (summation order can leave 1-ulp
    differences)."""
    nd = 2 * (n + 1)  # before clamping
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    kv: list[np.ndarray] = []
    mv: list[np.ndarray] = []
    local_r, local_c = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    for e in range(n):
        rows.append((2 * e + local_r).ravel())
        cols.append((2 * e + local_c).ravel())
        kv.append(ke.ravel())
        mv.append(me.ravel())
    r, c = np.concatenate(rows), np.concatenate(cols)
    K = sp.csr_matrix((np.concatenate(kv), (r, c)), shape=(nd, nd))[2:, 2:]
    M = sp.csr_matrix((np.concatenate(mv), (r, c)), shape=(nd, nd))[2:, 2:]
    return ((K + K.T) * 0.5).tocsr(), ((M + M.T) * 0.5).tocsr()


def _tip_dashpot_matrix(tip: int, n_dofs: int, tip_dashpot: float | None) -> sp.csr_matrix | None:
    """``C`` of a grounded dashpot (lbf·s/in) on the tip ``w`` DOF (None without one)."""
    if tip_dashpot is None:
        return None
    c = check_positive(tip_dashpot, "tip_dashpot", allow_zero=True)
    return sp.csr_matrix(([c], ([tip], [tip])), shape=(n_dofs, n_dofs))


def _tip_variable_mass(tip: int, tip_mass) -> VariableMass | None:
    """The tip point mass ``m(t)`` moving with the tip ``w`` DOF (None without one)."""
    if tip_mass is None:
        return None
    if not callable(tip_mass):
        raise InputError(f"Parameter `tip_mass`: expected a callable m(t), got {tip_mass!r}")
    return VariableMass(
        dof=tip, law=tip_mass,
        description=f"tip point mass moving with the tip w DOF: {tip_mass}",
    )


def _tip_springs(tip: int, tip_k3: float | None,
                 tip_band: dict | None) -> tuple[CubicSpring | OneSidedSpring, ...]:
    """The grounded nonlinear tip springs: cubic ``k3 w³``, then the §5.2 band."""
    nonlinear: tuple[CubicSpring | OneSidedSpring, ...] = ()
    if tip_k3 is not None:
        nonlinear = (CubicSpring(dof=tip, k3=check_positive(tip_k3, "tip_k3", allow_zero=True)),)
    if tip_band is not None:
        nonlinear = nonlinear + (_tip_band(tip, tip_band),)
    return nonlinear


def _tip_metadata(tip_k3: float | None, tip_dashpot: float | None,
                  springs: tuple[CubicSpring | OneSidedSpring, ...], modal_damping) -> dict:
    """The tip elements and damping recorded in ``metadata`` (``springs``: the band last)."""
    metadata: dict[str, object] = {}
    if tip_k3 is not None:
        metadata["k3"] = float(tip_k3)
    if tip_dashpot is not None:
        metadata["tip_dashpot"] = float(tip_dashpot)
    band = springs[-1] if springs else None
    if isinstance(band, OneSidedSpring):
        metadata["tip_band"] = {"k": band.k, "side": band.side, "slack": band.slack,
                                "prestretch": band.prestretch, "twin": band.twin}
    if modal_damping is not None:
        metadata["modal_damping"] = (float(modal_damping) if np.ndim(modal_damping) == 0
                                     else [float(z) for z in modal_damping])
    return metadata


_SIDES = {"positive": 1, "negative": -1, 1: 1, -1: -1}


def _tip_band(tip: int, spec) -> OneSidedSpring:
    """The :class:`OneSidedSpring` of ``cantilever_beam(tip_band=spec)`` on DOF ``tip``."""
    if not isinstance(spec, dict):
        raise InputError(f"Parameter `tip_band`: expected a dict with `k`, `side`, ... "
                         f"got {spec!r}")
    unknown = sorted(set(spec) - {"k", "side", "slack", "prestretch", "twin"})
    if unknown:
        raise InputError(f"Parameter `tip_band`: unknown field(s) {', '.join(unknown)}")
    if "k" not in spec:
        raise InputError("Parameter `tip_band`: the stiffness `k` (lbf/in) is required")
    side = spec.get("side", "positive")
    if isinstance(side, bool) or side not in _SIDES:
        raise InputError(f"Parameter `tip_band.side`: expected \"positive\", \"negative\", "
                         f"+1 or -1, got {side!r}")
    return OneSidedSpring(
        dof=tip, k=check_positive(spec["k"], "tip_band.k", allow_zero=True),
        side=_SIDES[side],
        slack=check_positive(spec.get("slack", 0.0), "tip_band.slack", allow_zero=True),
        prestretch=check_positive(spec.get("prestretch", 0.0), "tip_band.prestretch",
                                  allow_zero=True),
        twin=spec.get("twin", "tangent"),
    )
