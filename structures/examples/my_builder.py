"""Example user builder for a `kind = "python"` structure file (see my_builder.toml).

A shear building: floor i (0 = first floor) moves horizontally by q_i (in); story i joins
floor i-1 (the ground for i = 0) and floor i. Nothing to install: the structure file names
this file with `path = "my_builder.py"` and the function with `builder = "my_builder:build"`.
Units: inch, lbf, second.
"""

import numpy as np


def build(n_floors, floor_mass, story_stiffness, damping_ratio=0.0):
    """Return M (lbf·s²/in), K (lbf/in), C (lbf·s/in) and the sensors as a dict.

    ``damping_ratio`` gives stiffness-proportional damping C = beta·K with
    beta = 2·zeta/omega_1 (zeta at the first mode).
    """
    n = int(n_floors)
    M = np.eye(n) * float(floor_mass)
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += story_stiffness
        if i > 0:
            K[i - 1, i - 1] += story_stiffness
            K[i - 1, i] -= story_stiffness
            K[i, i - 1] -= story_stiffness
    out = {
        "M": M,
        "K": K,
        "sensor_dofs": np.arange(n),
        "dof_labels": [f"floor{i + 1}" for i in range(n)],
    }
    if damping_ratio:
        w1 = np.sqrt(np.linalg.eigvalsh(np.linalg.solve(M, K)).min())
        out["C"] = 2.0 * damping_ratio / w1 * K
    return out
