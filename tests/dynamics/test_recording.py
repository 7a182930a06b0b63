"""Recording only outputs (``newmark(record=R)``) and applying loads through a sparse map
(``force_map``): the same numbers as the full DOF histories, on the §4.1 beams (LTI, LTV with
the Sherman–Morrison tip mass, NL with Newton) and the satellite truss (sparse LU, fracture)."""

import importlib

import numpy as np
import pytest
import scipy.sparse as sp
from dynamics_systems import chain

from podbench.dynamics import newmark, simulate
from podbench.dynamics.excitations import Pulse, StaticDisplacement
from podbench.dynamics.newmark import DENSE_MAX_DOFS
from podbench.errors import DimensionError, InputError
from podbench.structures import load_structure

DT_BEAM, N_BEAM = 1e-4, 300
simulate_module = importlib.import_module("podbench.dynamics.simulate")  # not the function


@pytest.fixture(scope="module")
def beams():
    return {name: load_structure(name) for name in ("lti_beam", "ltv_beam", "nl_beam")}


def _rel(x, ref):
    return np.linalg.norm(x - ref) / np.linalg.norm(ref)


def _beam_case(beams, name):
    s, lti = beams[name], beams["lti_beam"]
    q0 = StaticDisplacement([(17, 300.0), (24, -260.0)], reference=lti).dof_vector(s)
    v0 = np.zeros(s.n_dofs)
    v0[-2] = 5.0  # in/s at the tip
    F = Pulse(23.0, 500.0, 5e-4).sample(s, N_BEAM, DT_BEAM)  # (25, n) lbf at the sensors
    return s, q0, v0, F


@pytest.mark.parametrize("name", ["lti_beam", "ltv_beam", "nl_beam"])
def test_sensor_recording_equals_full_histories_on_the_beams(beams, name):
    s, q0, v0, F = _beam_case(beams, name)
    S = s.sensor_matrix()
    full = newmark(s, q0, v0, s.to_dofs(F), DT_BEAM)
    rec = newmark(s, q0, v0, F, DT_BEAM, force_map=S.T, record=S)
    assert rec.q.shape == rec.v.shape == rec.a.shape == (s.n_sensors, N_BEAM)
    for x in ("q", "v", "a"):
        assert _rel(getattr(rec, x), S @ getattr(full, x)) < 1e-12, x
    np.testing.assert_array_equal(rec.newton_iterations, full.newton_iterations)
    # the cases exercise what they are meant to: a moving tip mass, Newton iterations
    if name == "ltv_beam":
        m = s.variable_mass(np.arange(N_BEAM) * DT_BEAM)
        assert np.ptp(m) > 0.1 * m.mean()
    if name == "nl_beam":
        assert rec.newton_iterations[1:].min() >= 1
        linear = newmark(s.linear_twin(), q0, v0, F, DT_BEAM, force_map=S.T, record=S)
        assert _rel(linear.q, rec.q) > 1e-3  # the cubic spring matters at this amplitude


@pytest.mark.parametrize("name", ["lti_beam", "nl_beam"])
def test_dense_output_and_force_maps(beams, name):
    """A general dense R (combinations of DOFs) and a dense force map give the same numbers
    as R applied to the full histories."""
    s, q0, v0, F = _beam_case(beams, name)
    rng = np.random.default_rng(7)
    R = rng.normal(size=(3, s.n_dofs))
    full = newmark(s, q0, v0, s.to_dofs(F), DT_BEAM)
    rec = newmark(s, q0, v0, F, DT_BEAM, force_map=s.sensor_matrix().T.toarray(), record=R)
    for x in ("q", "v", "a"):
        assert _rel(getattr(rec, x), R @ getattr(full, x)) < 1e-12, x


def test_force_map_alone_equals_dof_load_array_bit_for_bit(beams):
    s, q0, v0, F = _beam_case(beams, "ltv_beam")
    a = newmark(s, q0, v0, s.to_dofs(F), DT_BEAM)
    b = newmark(s, q0, v0, F, DT_BEAM, force_map=sp.csc_matrix(s.sensor_matrix().T))
    for x in ("q", "v", "a"):
        np.testing.assert_array_equal(getattr(a, x), getattr(b, x))


@pytest.mark.heavy
def test_truss_with_fracture_on_the_sparse_path():
    s = load_structure("satellite_truss")
    assert s.n_dofs > DENSE_MAX_DOFS and s.events  # sparse LU, one refactorization
    dt, n = 0.05, 100  # the fracture at 3 s is sample 60
    rng = np.random.default_rng(8)
    q0 = np.linalg.solve(s.K.toarray(), rng.normal(size=s.n_dofs))
    F = np.zeros((s.n_sensors, n))
    F[5, 1:4] = 20.0
    sensors = np.array([0, 17, 101, 298])
    R = sp.csr_matrix((np.ones(4), (np.arange(4), sensors)), shape=(4, s.n_dofs))
    full = newmark(s, q0, np.zeros(s.n_dofs), s.to_dofs(F), dt)
    rec = newmark(s, q0, np.zeros(s.n_dofs), F, dt, force_map=s.sensor_matrix().T, record=R)
    for x in ("q", "v", "a"):
        assert _rel(getattr(rec, x), getattr(full, x)[sensors]) < 1e-12, x


@pytest.mark.parametrize("engine", ["newmark", "exudyn"])
def test_simulate_without_dof_histories_returns_the_same_response(beams, engine):
    s, q0, v0, F = _beam_case(beams, "lti_beam")
    kw = dict(initial_displacement=q0, initial_velocity=v0, force=F, engine=engine)
    a = simulate(s, N_BEAM, DT_BEAM, dof_histories=True, **kw)
    b = simulate(s, N_BEAM, DT_BEAM, dof_histories=False, **kw)
    assert a.q.shape == a.qd.shape == (s.n_dofs, N_BEAM)
    assert b.q is None and b.qd is None
    np.testing.assert_array_equal(b.W, a.W)
    for x in ("F", "w0", "v0", "t"):
        np.testing.assert_array_equal(getattr(b, x), getattr(a, x))
    assert np.abs(a.W).max() > 0.01  # a real response (in)


def test_simulate_default_drops_dof_histories_above_the_limit(monkeypatch, beams):
    s = beams["lti_beam"]
    assert simulate(s, 50, DT_BEAM).q.shape == (s.n_dofs, 50)  # 48 × 50 below the limit
    monkeypatch.setattr(simulate_module, "DOF_HISTORY_LIMIT", s.n_dofs * 50 - 1)
    r = simulate(s, 50, DT_BEAM, initial_displacement=np.linalg.solve(s.K.toarray(),
                                                                      np.ones(s.n_dofs)))
    assert r.q is None and r.W.shape == (s.n_sensors, 50)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"record": np.zeros((2, 3))}, DimensionError, r"record.*\(p, 4\).*\(2, 3\)"),
        ({"record": np.zeros(4)}, DimensionError, r"record.*\(p, 4\)"),
        ({"record": np.full((1, 4), np.nan)}, InputError, "record.*NaN"),
        ({"record": "sensors"}, InputError, "record.*numeric"),
        ({"force_map": sp.identity(3)}, DimensionError, r"force_map.*\(4, 4\).*\(3, 3\)"),
    ],
)
def test_bad_record_or_force_map(kwargs, error, match):
    with pytest.raises(error, match=match):
        newmark(chain(4), np.zeros(4), np.zeros(4), np.zeros((4, 10)), 0.01, **kwargs)


def test_bad_dof_histories():
    with pytest.raises(InputError, match="dof_histories"):
        simulate(chain(4), 10, 0.01, dof_histories="no")


@pytest.mark.parametrize("n", [1, 255, 256, 257, 700])
def test_block_recording_equals_per_sample_products(beams, n):
    # sparse load and output maps are applied by blocks of CHUNK samples: every sample's
    # numbers equal the products of that sample's vectors (block boundaries included)
    s, q0, v0, _ = _beam_case(beams, "nl_beam")
    F = Pulse(23.0, 500.0, 5e-4).sample(s, n, DT_BEAM)
    S = s.sensor_matrix()
    full = newmark(s, q0, v0, F, DT_BEAM, force_map=S.T)
    rec = newmark(s, q0, v0, F, DT_BEAM, force_map=S.T, record=S)
    for name in ("q", "v", "a"):
        assert np.array_equal(getattr(rec, name), S @ getattr(full, name))


def test_blocks_shrink_on_large_structures(monkeypatch):
    # the buffered blocks hold at most BLOCK_FLOATS numbers per history: on a large
    # structure (here forced by a small budget) the blocks are a few samples, same numbers
    nm = importlib.import_module("podbench.dynamics.newmark")  # not the function

    s = load_structure("nl_beam")
    F = Pulse(23.0, 500.0, 5e-4).sample(s, 40, DT_BEAM)
    S = s.sensor_matrix()
    q0 = v0 = np.zeros(s.n_dofs)
    ref = newmark(s, q0, v0, F, DT_BEAM, force_map=S.T, record=S)
    monkeypatch.setattr(nm, "BLOCK_FLOATS", 3 * s.n_dofs)
    assert nm._chunk(s.n_dofs) == 3
    small = newmark(s, q0, v0, F, DT_BEAM, force_map=S.T, record=S)
    assert np.array_equal(small.q, ref.q) and np.array_equal(small.a, ref.a)
