"""exudyn as an independent cross-check of the podbench integrator."""

import sys

import numpy as np
import pytest
from dynamics_systems import cantilever, chain, chain_event, tip_mass

from podbench.dynamics import simulate
from podbench.errors import InputError
from podbench.excitations import Pulse
from podbench.fem import CubicSpring

pytest.importorskip("exudyn")


def _rel(a, b):
    return np.linalg.norm(a.W - b.W) / np.linalg.norm(a.W)


def _both(s, **kw):
    return simulate(s, engine="newmark", **kw), simulate(s, engine="exudyn", **kw)


CHAIN_KW = {
    "n_samples": 300, "dt": 0.01,
    "initial_displacement": np.array([0.01, 0.0, -0.02, 0.03]),
    "initial_velocity": np.array([0.0, 1.0, 0.0, 0.0]),
    "force": Pulse(2, 50.0, 0.05, by="dof"),
}


@pytest.mark.parametrize(
    ("extra", "tol"),
    [
        ({}, 1e-12),
        ({"nonlinear": (CubicSpring(3, 2e6),)}, 1e-9),
        ({"variable_mass": tip_mass(3)}, 1e-12),
        ({"events": (chain_event(4, 1.0),)}, 1e-12),
        ({"nonlinear": (CubicSpring(3, 2e6),), "variable_mass": tip_mass(3),
          "events": (chain_event(4, 1.0),)}, 1e-9),
    ],
    ids=["linear", "cubic", "variable-mass", "fracture", "all"],
)
def test_exudyn_agrees_on_chain_with_nonproportional_damping(extra, tol):
    s = chain(4, **extra)
    a, b = _both(s, **CHAIN_KW)
    assert b.engine == "exudyn"
    assert _rel(a, b) < tol
    # a meaningful comparison: the feature changes the response far above the tolerance
    if extra:
        assert _rel(a, simulate(chain(4), **CHAIN_KW)) > 1e-3


def test_exudyn_agrees_on_beam_with_pulse():
    s = cantilever()
    q0 = np.linalg.solve(s.K.toarray(), np.eye(s.n_dofs)[-2] * 100.0)
    a, b = _both(s, n_samples=500, dt=1e-4, initial_displacement=q0,
                 force=Pulse(11.0, 500.0, 5e-4))
    assert _rel(a, b) < 1e-10


def test_exudyn_sparse_path_agrees():
    s = chain(230, events=(chain_event(230, 0.5),))
    q0 = np.zeros(230)
    q0[::7] = 0.01
    a, b = _both(s, n_samples=100, dt=0.01, initial_displacement=q0)
    assert _rel(a, b) < 1e-10


def test_exudyn_writes_no_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    simulate(chain(3), 20, 0.01, initial_displacement=np.ones(3) * 0.01, engine="exudyn")
    assert list(tmp_path.iterdir()) == []


def test_missing_exudyn_gives_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "exudyn", None)  # import exudyn -> ImportError
    with pytest.raises(InputError, match="engine='exudyn' requires the exudyn package"):
        simulate(chain(3), 10, 0.01, engine="exudyn")
