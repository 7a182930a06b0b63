"""The §4.1 beams against Euler–Bernoulli theory and their stated properties."""

import pickle

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from podbench.core.resources import bundled_structures
from podbench.structures import cantilever_beam, load_structure
from podbench.structures.laws import SineLaw

# Properties stated in §4.1, converted independently of the package.
E = 29.0e6  # psi
B, H, L = 1.0, 0.75, 24.0  # in
RHO = 500.0 / 1728.0 / (9.80665 / 0.0254)  # lbm/ft³ -> lbf·s²/in⁴
EI = E * B * H**3 / 12.0
RHO_A = RHO * B * H
BETA_L = np.array([1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839])


@pytest.fixture(scope="module")
def beams():
    return {n: load_structure(n) for n in ("lti_beam", "ltv_beam", "nl_beam")}


def test_sizes(beams):
    for s in beams.values():
        assert (s.n_dofs, s.n_sensors) == (48, 25)
        np.testing.assert_array_equal(s.sensor_positions, np.arange(25.0))
        assert s.sensor_dofs[0] == -1  # clamped root reads zero
        np.testing.assert_array_equal(s.sensor_dofs[1:], 2 * np.arange(24))
        assert s.metadata["tip_dof"] == 46 and s.dof_labels[46] == "w@24in"


def test_lti_frequencies_match_euler_bernoulli(beams):
    f_theory = BETA_L**2 / (2 * np.pi) * np.sqrt(EI / (RHO_A * L**4))
    f = beams["lti_beam"].natural_frequencies(5)
    np.testing.assert_allclose(f, f_theory, rtol=5e-3)
    # first period 0.0242 s (the dissertation quotes 0.0238 s; nothing is tuned to it)
    assert 1 / f[0] == pytest.approx(0.02417, abs=1e-5)


def test_static_tip_deflection_and_rotation(beams):
    s = beams["lti_beam"]
    P = 100.0  # lbf at the tip
    f = np.zeros(s.n_dofs)
    f[s.metadata["tip_dof"]] = P
    q = spla.spsolve(s.K.tocsc(), f)
    assert q[46] == pytest.approx(P * L**3 / (3 * EI), rel=1e-6)
    assert q[47] == pytest.approx(P * L**2 / (2 * EI), rel=1e-6)
    assert s.metadata["tip_stiffness"] == pytest.approx(3 * EI / L**3, rel=1e-12)
    # the linear deflection curve P x²(3L − x)/(6EI) at every sensor
    x = s.sensor_positions
    np.testing.assert_allclose(s.observe(q), P * x**2 * (3 * L - x) / (6 * EI), rtol=1e-9)


def test_matrices_symmetric_positive_definite(beams):
    s = beams["lti_beam"]
    for A in (s.M, s.K):
        assert abs(A - A.T).max() == 0.0
        assert np.linalg.eigvalsh(A.toarray()).min() > 0
    assert s.C is None and s.is_linear and s.is_time_invariant


def test_consistent_mass_total():
    # unit vertical translation of every free node (rotations zero): the interpolated field
    # is 1 on elements 2..24 and N(ξ) = 3ξ² − 2ξ³ on element 1 (root clamped), so the
    # kinetic mass is ρA(L − le) + ρA·le·∫₀¹N² dξ = ρA(L − le) + ρA·le·13/35.
    s = cantilever_beam()
    ones = np.zeros(s.n_dofs)
    ones[0::2] = 1.0
    le = L / 24
    expected = RHO_A * (L - le) + RHO_A * le * 13.0 / 35.0
    assert ones @ (s.M @ ones) == pytest.approx(expected, rel=1e-12)
    assert s.metadata["beam_mass"] == pytest.approx(RHO_A * L, rel=1e-12)


def test_ltv_tip_mass_law(beams):
    s = beams["ltv_beam"]
    mb = RHO_A * L
    assert not s.is_time_invariant and s.variable_mass.dof == 46
    t = np.array([0.0, 0.0125, 0.025, 0.0375])
    np.testing.assert_allclose(s.variable_mass(t), mb * (1 + 0.5 * np.sin(2 * np.pi * t / 0.05)),
                               rtol=1e-12, atol=1e-15)
    dM = (s.mass(0.0125) - s.M).toarray()
    assert dM[46, 46] == pytest.approx(1.5 * mb, rel=1e-12)
    assert np.count_nonzero(dM) == 1
    # the law survives pickling (parallel runs send structures to worker processes)
    s2 = pickle.loads(pickle.dumps(s))
    np.testing.assert_array_equal(s2.variable_mass(t), s.variable_mass(t))


def test_nl_spring_and_dashpot(beams):
    s = beams["nl_beam"]
    (spring,) = s.nonlinear
    k_tip = 3 * EI / L**3
    assert spring.dof == 46
    assert spring.k3 == pytest.approx(k_tip / 0.3**2, rel=1e-12)
    assert spring.k3 == pytest.approx(2458.36, abs=0.01)
    # the cubic force equals the linear tip-stiffness force at w = 0.3 in
    assert spring.force(np.array([0.3]), None)[0] == pytest.approx(k_tip * 0.3, rel=1e-12)
    C = s.C.toarray()
    assert C[46, 46] == 0.2 and np.count_nonzero(C) == 1
    assert s.linear_twin().is_linear


def test_build_is_deterministic():
    a, b = load_structure("nl_beam"), load_structure("nl_beam")
    for x, y in ((a.M, b.M), (a.K, b.K), (a.C, b.C)):
        np.testing.assert_array_equal(x.toarray(), y.toarray())


def test_builder_rejects_bad_arguments():
    from podbench.errors import InputError

    with pytest.raises(InputError, match="n_elements"):
        cantilever_beam(n_elements=0)
    with pytest.raises(InputError, match="amplitude"):
        SineLaw(1.0, 2.0, 0.05)
    with pytest.raises(InputError, match="tip_mass"):
        cantilever_beam(tip_mass=3.0)


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        ("law = 'constant'\nvalue = 0.02", lambda t: np.full_like(t, 0.02)),
        ("law = 'linear'\ninitial = 0.0\nfinal = 2.0\nduration = 0.04\nscale = 'beam_mass'",
         lambda t: 2.0 * RHO_A * L * np.minimum(t / 0.04, 1.0)),
        ("law = 'sine'\nmean = 0.01\namplitude = -0.005\nperiod = 0.1\nphase = 1.0",
         lambda t: 0.01 - 0.005 * np.sin(2 * np.pi * t / 0.1 + 1.0)),
    ],
)
def test_tip_mass_laws_from_files(tmp_path, table, expected):
    text = (bundled_structures() / "lti_beam.toml").read_text(
        encoding="utf-8").replace('name = "lti_beam"', 'name = "tm"')
    p = tmp_path / "tm.toml"
    p.write_text(text + "\n[tip_mass]\n" + table + "\n", encoding="utf-8")
    s = load_structure(p)
    t = np.linspace(0.0, 0.06, 13)
    np.testing.assert_allclose(s.variable_mass(t), expected(t), rtol=1e-12, atol=1e-15)
    assert np.all(s.variable_mass(t) >= 0)


def test_builder_physics_tip_stiffness_beam_mass_and_matched_cubic():
    """The physics the structure files use: 3EI/L³ is the FE beam's static tip stiffness
    (Hermite cubics are exact for a tip load), ρbhL its mass, k3 matches it at w_ref."""
    import numpy as np
    import scipy.sparse.linalg as spla

    from podbench.structures.beam import (
        beam_mass,
        cantilever_beam,
        k3_matching_linear,
        tip_mass_law,
        tip_stiffness,
    )

    geom = dict(length=24.0, width=1.0, depth=0.75)
    s = cantilever_beam(E=29.0e6, density=4.5e-4, n_elements=6, **geom)
    f = np.zeros(s.n_dofs)
    f[s.metadata["tip_dof"]] = 1.0
    w_tip = spla.spsolve(s.K.tocsc(), f)[s.metadata["tip_dof"]]
    k_tip = tip_stiffness(E=29.0e6, **geom)
    assert 1.0 / w_tip == pytest.approx(k_tip, rel=1e-10)
    assert k_tip == pytest.approx(3 * 29.0e6 * (1.0 * 0.75**3 / 12) / 24.0**3, rel=1e-15)
    mass = beam_mass(density=4.5e-4, **geom)
    assert mass == pytest.approx(4.5e-4 * 1.0 * 0.75 * 24.0, rel=1e-15)
    assert s.metadata["beam_mass"] == pytest.approx(mass, rel=1e-15)
    k3 = k3_matching_linear(k_tip, 0.1)
    assert k3 * 0.1**3 == pytest.approx(k_tip * 0.1, rel=1e-14)
    law = tip_mass_law("constant", scale="beam_mass", value=2.0, density=4.5e-4, **geom)
    assert float(law(0.3)) == pytest.approx(2.0 * mass, rel=1e-15)
