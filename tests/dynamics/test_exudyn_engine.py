"""exudyn as an independent cross-check of the podbench integrator."""

import sys
from dataclasses import replace

import numpy as np
import pytest
from dynamics_systems import cantilever, chain, chain_end_breaks_off, chain_event, tip_mass

from podbench.dynamics import simulate
from podbench.dynamics.excitations import Pulse
from podbench.errors import InputError
from podbench.structures import CubicSpring
from podbench.structures.files import load_structure

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


def test_exudyn_agrees_when_an_element_and_its_mass_disappear():
    """An event with a mass change and a removed DOF (the truss fracture's machinery): the
    removed DOF reads 0 from the event on in both engines, the rest agree to round-off."""
    s = chain(5, events=(chain_end_breaks_off(5, 1.0),))
    kw = dict(CHAIN_KW, initial_displacement=np.array([0.01, 0.0, -0.02, 0.03, 0.05]),
              initial_velocity=np.array([0.0, 1.0, 0.0, 0.0, -2.0]))
    a, b = _both(s, **kw)
    j = s.events[0].first_sample(0.01)
    assert j == 100
    for r in (a, b):
        assert np.abs(r.W[4, :j]).max() > 1e-3 and not np.any(r.W[4, j:])
    assert _rel(a, b) < 1e-12
    # the mass change matters: a stiffness-only event gives a different response
    only_k = chain(5, events=(replace(s.events[0], delta_M=None, removed_dofs=()),))
    c = simulate(only_k, **kw)
    assert np.linalg.norm(a.W[:4, j:] - c.W[:4, j:]) > 1e-3 * np.linalg.norm(c.W[:4, j:])


def test_exudyn_agrees_on_beam_with_pulse():
    s = cantilever()
    q0 = np.linalg.solve(s.K.toarray(), np.eye(s.n_dofs)[-2] * 100.0)
    a, b = _both(s, n_samples=500, dt=1e-4, initial_displacement=q0,
                 force=Pulse(11.0, 500.0, 5e-4))
    assert _rel(a, b) < 1e-10


@pytest.mark.parametrize("shape", ["rectangular", "half_sine", "triangle"])
def test_exudyn_agrees_on_nonlinear_beam_for_every_pulse_shape(shape):
    """The bundled NL beam (cubic tip spring) pushed to about 0.4 in at the tip by Chapter 4's
    beam_forced load5_half_sine: exudyn's Newton must converge (a residual judged relative to
    the step's initial one stagnated at round-off here) and agree with podbench's Newmark."""
    s = load_structure("nl_beam")
    duration = 5e-4 if shape == "rectangular" else 1.5e-3
    a, b = _both(s, n_samples=500, dt=1e-4, force=Pulse(23.0, 500.0, duration, shape=shape))
    assert np.abs(a.W).max() > 0.2  # deep in the cubic spring's range (in)
    assert _rel(a, b) < 1e-10
    # the spring matters far above the agreement level
    assert _rel(a, simulate(load_structure("lti_beam"), n_samples=500, dt=1e-4,
                            force=Pulse(23.0, 500.0, duration, shape=shape))) > 1e-3


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
