"""Time integration of structures: average-acceleration Newmark and an exudyn cross-check.

``simulate(structure, n_samples, dt, initial_displacement, initial_velocity, force, engine)``
returns a :class:`podbench.data.Response`. See ``docs/dynamics.md``.
"""

from podbench.dynamics.newmark import NewmarkResult, newmark
from podbench.dynamics.simulate import ENGINES, simulate

__all__ = ["simulate", "newmark", "NewmarkResult", "ENGINES"]
