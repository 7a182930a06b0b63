"""Small structures built in code for the dynamics tests (no structure files needed).

Imported by the test modules of this folder (pytest puts the folder on sys.path).
"""

import numpy as np
import scipy.sparse as sp

from podbench.structures import StiffnessEvent, Structure, VariableMass, load_structure


def cantilever() -> Structure:
    """The LTI beam of §4.1 (structures/lti_beam.toml): 48 DOFs, 25 sensors at 0..24 in."""
    return load_structure("lti_beam")


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


def chain_end_breaks_off(n: int = 5, time: float = 1.0) -> StiffnessEvent:
    """The last spring and the last mass of :func:`chain` break off and disappear at ``time``:
    the spring (k between DOFs n−2 and n−1) and its mass, 0.1 lbf·s²/in lumped on each end,
    go; DOF n−1, connected by nothing else, leaves the model."""
    k = 1000.0 * (1.0 + 0.1 * (n - 1))
    a, b = n - 2, n - 1
    dK = sp.lil_matrix((n, n))
    dK[a, a] = dK[b, b] = -k
    dK[a, b] = dK[b, a] = k
    dM = sp.lil_matrix((n, n))
    dM[a, a] = dM[b, b] = -0.1
    return StiffnessEvent(time, dK.tocsr(), "end spring and mass break off",
                          delta_M=dM.tocsr(), removed_dofs=(b,))


def tip_mass(dof: int) -> VariableMass:
    return VariableMass(dof, lambda t: 0.5 + 0.4 * np.sin(2.0 * np.pi * t), "0.5 + 0.4 sin(2πt)")

