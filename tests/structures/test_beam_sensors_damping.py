"""Beam sensor subsets and modal damping (the §5.1 aluminium beam): real numbers against the
full model, the quadratic eigenproblem and Euler–Bernoulli theory."""

import numpy as np
import pytest
import scipy.linalg

from podbench.dynamics import simulate
from podbench.dynamics.excitations import Pulse
from podbench.errors import InputError, StructureFileError
from podbench.structures import load_structure
from podbench.structures.beam import cantilever_beam, density_from_lbm_per_ft3, modal_damping_matrix

AL = dict(length=20.0, width=1.0, depth=0.125, E=10.0e6,
          density=density_from_lbm_per_ft3(168.48), n_elements=20)
SENSORS = [0, 4, 8, 12, 16, 20]


def _modal_ratios(s, k):
    """ζ and ω (rad/s) of the k lowest modes from the state-space eigenvalues of (M, C, K)."""
    M, C, K = (A.toarray() for A in (s.M, s.damping_matrix(), s.K))
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))][:k]
    return -lam.real / np.abs(lam), np.abs(lam)


def test_sensor_subset_rows_equal_the_full_models_rows():
    full = cantilever_beam(**AL)
    sub = cantilever_beam(**AL, sensors=SENSORS)
    assert sub.n_sensors == 6 and full.n_sensors == 21
    assert list(sub.sensor_positions) == SENSORS
    assert sub.sensor_dofs[0] == -1 and list(sub.sensor_dofs[1:]) == [6, 14, 22, 30, 38]
    n, dt = 300, 1e-4
    kw = dict(n_samples=n, dt=dt)
    Ff = Pulse(8.0, 2.0, 5e-4, shape="half_sine", hits=[[2.5e-3, 0.4]]).sample(full, n, dt)
    Fs = Pulse(8.0, 2.0, 5e-4, shape="half_sine", hits=[[2.5e-3, 0.4]]).sample(sub, n, dt)
    rf, rs = simulate(full, force=Ff, **kw), simulate(sub, force=Fs, **kw)
    assert rs.W.shape == (6, n)
    np.testing.assert_allclose(rs.W, rf.W[SENSORS], rtol=0, atol=1e-14 * np.abs(rf.W).max())
    assert np.all(rs.W[0] == 0.0) and np.abs(rs.W[5]).max() > 1e-4
    with pytest.raises(InputError, match="no sensor"):  # a load must act at a sensor
        Pulse(6.0, 1.0, 5e-4).sample(sub, n, dt)


@pytest.mark.parametrize("bad, words", [([0, 4.5], "4.5 in is not a node"),
                                        ([0, 8, 4], "strictly increasing"),
                                        ([0, 21], "not a node")])
def test_sensor_positions_off_nodes_are_refused(bad, words):
    with pytest.raises(InputError, match=words):
        cantilever_beam(**AL, sensors=bad)


def test_modal_damping_gives_the_stated_ratios_and_frequencies():
    s = cantilever_beam(**AL, modal_damping=[0.005, 0.01, 0.02])
    w2 = scipy.linalg.eigh(s.K.toarray(), s.M.toarray(), eigvals_only=True)[:5]
    zeta, wn = _modal_ratios(s, 5)
    np.testing.assert_allclose(zeta, [0.005, 0.01, 0.02, 0.02, 0.02], rtol=1e-7)
    np.testing.assert_allclose(wn, np.sqrt(w2), rtol=1e-9)  # |λ| = ω of the undamped modes
    # the decay rate of mode 1 is ζ ω: 0.005 · 2π · 10.045 = 0.3156 1/s
    assert -np.log(np.exp(-zeta[0] * wn[0])) == pytest.approx(0.005 * 2 * np.pi * 10.0455, 1e-4)
    C = modal_damping_matrix(s.M, s.K, 0.0)
    assert np.abs(C).max() == 0.0


@pytest.mark.parametrize("bad", [1.0, -0.1, [], [0.1] * 41])
def test_modal_damping_bad_ratios(bad):
    with pytest.raises(InputError, match="modal_ratio"):
        modal_damping_matrix(cantilever_beam(**AL).M, cantilever_beam(**AL).K, bad)


def test_bundled_aluminium_beam_f1_and_record_length():
    s = load_structure("aluminium_beam")
    assert s.n_dofs == 40 and s.n_sensors == 6
    assert list(s.sensor_positions) == SENSORS
    m = s.metadata
    # Euler–Bernoulli: f1 = (β1 L)² / (2π L²) √(EI/ρA), β1 L = 1.8751040687
    f_eb = 1.8751040687**2 / (2 * np.pi * 20.0**2) * np.sqrt(m["EI"] / m["rho_A"])
    f1 = s.natural_frequencies(1)[0]
    assert f1 == pytest.approx(f_eb, rel=1e-6)
    assert f1 == pytest.approx(10.0455, abs=1e-3)
    # §5.1's reading: 1024 samples at 0.1 ms = 0.1024 s, within 3 % of the period 0.09955 s
    assert 1024 * 1e-4 / (1 / f1) == pytest.approx(1.0287, abs=1e-3)
    zeta, _ = _modal_ratios(s, 3)
    np.testing.assert_allclose(zeta, 0.005, rtol=1e-7)


BEAM = """\
name = "foo"
kind = "cantilever_beam"
units = "inch, lbf, second"
description = "test"

[beam]
length = 20.0
width = 1.0
depth = 0.125
E = 10.0e6
density_lbm_per_ft3 = 168.48
n_elements = 20
{extra}
"""


@pytest.mark.parametrize("extra, field", [
    ("sensors = [0, 4.5]", "beam.sensors"),
    ("sensors = []", "beam.sensors"),
    ('sensors = [0, "a"]', "beam.sensors[1]"),
    ("[damping]\nmodal_ratio = 1.5", "damping.modal_ratio"),
    ("[damping]\nmodal_ratio = [0.01, 1.0]", "damping.modal_ratio[1]"),
    ("[damping]\nmodal_ratio = -0.01", "damping.modal_ratio"),
    ("[damping]\nratio = 0.01", "damping"),
])
def test_bad_structure_fields_give_one_line(tmp_path, extra, field):
    p = tmp_path / "foo.toml"
    p.write_text(BEAM.format(extra=extra))
    with pytest.raises(StructureFileError) as ei:
        load_structure(p)
    msg = str(ei.value)
    assert "\n" not in msg and "foo.toml" in msg and field in msg, msg
