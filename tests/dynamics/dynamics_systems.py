"""Small structures built in code for the dynamics tests (no structure files needed).

Imported by the test modules of this folder (pytest puts the folder on sys.path).
"""

import numpy as np
import scipy.sparse as sp

from podbench.fem import StiffnessEvent, Structure, VariableMass

# Steel cantilever of §4.1 (24 x 1 x 0.75 in, E = 29e6 psi, 500 lbf/ft³), used here only as a
# realistic stiff test system; the project's beams come from podbench.fem.
E_PSI = 29e6
RHO = 500.0 / 1728.0 / 386.0886  # lbf·s²/in⁴
B_IN, H_IN, L_IN = 1.0, 0.75, 24.0


def cantilever(n_el: int = 24) -> Structure:
    """Euler–Bernoulli cantilever, consistent mass, DOFs (w, θ) per free node (in, rad)."""
    le = L_IN / n_el
    EI = E_PSI * B_IN * H_IN**3 / 12.0
    rA = RHO * B_IN * H_IN
    ke = EI / le**3 * np.array(
        [[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
         [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]]
    )
    me = rA * le / 420.0 * np.array(
        [[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
         [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]]
    )
    nd = 2 * (n_el + 1)
    K = np.zeros((nd, nd))
    M = np.zeros((nd, nd))
    for e in range(n_el):
        ix = np.ix_(range(2 * e, 2 * e + 4), range(2 * e, 2 * e + 4))
        K[ix] += ke
        M[ix] += me
    K, M = K[2:, 2:], M[2:, 2:]  # clamp the root
    sensor_dofs = np.array([-1] + [2 * i for i in range(n_el)])
    return Structure(
        name="test_cantilever", M=M, K=K, sensor_dofs=sensor_dofs,
        sensor_positions=np.linspace(0.0, L_IN, n_el + 1),
        metadata={"EI": EI, "L": L_IN},
    )


def chain(n: int = 4, *, damping: bool = True, **extra) -> Structure:
    """Fixed–free chain of unequal masses (lbf·s²/in) and springs (lbf/in), non-proportional
    damping (dashpots at DOFs 0 and n−1 only)."""
    k = 1000.0 * (1.0 + 0.1 * np.arange(n))
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i > 0:
            K[i - 1, i - 1] += k[i]
            K[i - 1, i] -= k[i]
            K[i, i - 1] -= k[i]
    M = np.diag(1.0 + 0.25 * np.arange(n))
    C = None
    if damping:
        C = np.zeros((n, n))
        C[0, 0], C[-1, -1] = 0.5, 1.2
    return Structure(name="chain", M=M, K=K, C=C, sensor_dofs=np.arange(n), **extra)


def chain_event(n: int = 4, time: float = 1.0) -> StiffnessEvent:
    """Remove the spring between DOFs 1 and 2 at ``time``."""
    k = 1000.0 * 1.2
    dK = sp.lil_matrix((n, n))
    dK[1, 1] = dK[2, 2] = -k
    dK[1, 2] = dK[2, 1] = k
    return StiffnessEvent(time, dK.tocsr(), "spring 1-2 breaks")


def tip_mass(dof: int) -> VariableMass:
    return VariableMass(dof, lambda t: 0.5 + 0.4 * np.sin(2.0 * np.pi * t), "0.5 + 0.4 sin(2πt)")

