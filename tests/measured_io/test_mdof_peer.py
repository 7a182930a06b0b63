"""mdof as a peer: the OKID recursion fault of mdof 0.0.23 and its workaround."""

import numpy as np
import pytest

mdof = pytest.importorskip("mdof")

from podbench.core.records import Record  # noqa: E402
from podbench.sysid.methods.mdof_peer import Mdof, modal_simulate, okid_fixed  # noqa: E402


def _system():
    rng = np.random.default_rng(0)
    A = np.diag([0.9, 0.8, -0.5, 0.3])
    return A, rng.normal(size=(4, 2)), rng.normal(size=(3, 4)), rng.normal(size=(3, 2))


def _markov(sys, m):
    A, B, C, D = sys
    return np.stack([D] + [C @ np.linalg.matrix_power(A, k - 1) @ B for k in range(1, m + 1)],
                    axis=2)


@pytest.mark.heavy
def test_okid_recursion_fault_and_fix():
    """On an exact 4-state system mdof's okid is right for h_0, h_1 and wrong from h_2 on
    (its loop drops Ȳ2[k−1]·D); with the term restored every h_k is exact."""
    sys = _system()
    u = np.random.default_rng(1).normal(size=(2, 600))
    y = modal_simulate(*sys, u)
    true = _markov(sys, 20)
    rel = [lambda H, k=k: np.abs(H[:, :, k] - true[:, :, k]).max() / np.abs(true[:, :, k]).max()
           for k in range(21)]
    H = mdof.markov.okid(u, y, m=20)
    Hf = okid_fixed()(u, y, m=20)
    assert rel[1](H) < 1e-12
    if mdof.__version__ == "0.0.23" if hasattr(mdof, "__version__") else True:
        assert min(rel[k](H) for k in range(2, 11)) > 0.1
    assert max(rel[k](Hf) for k in range(21)) < 1e-10


def test_modal_simulate_equals_the_state_recursion():
    A, B, C, D = _system()
    u = np.random.default_rng(2).normal(size=(2, 50))
    x = np.zeros(4)
    y = np.empty((3, 50))
    for j in range(50):
        y[:, j] = C @ x + D @ u[:, j]
        x = A @ x + B @ u[:, j]
    np.testing.assert_allclose(modal_simulate(A, B, C, D, u), y, atol=1e-12)


@pytest.mark.heavy
@pytest.mark.parametrize("method", ["srim", "okid-era"])
def test_mdof_peer_predicts_an_exact_system(method):
    """Both workarounds in place: the exact system is recovered (order 4)."""
    sys = _system()
    rng = np.random.default_rng(3)
    recs = []
    for j, n in enumerate((800, 900, 700, 1000)):
        u = rng.normal(size=(2, n))
        u[:, -300:] = 0.0  # records end at rest (0.9^300 < 1e-13): joined end to end exactly
        recs.append(Record(u=u, y=modal_simulate(*sys, u), dt=0.01, input_units="m/s^2",
                             output_units="m/s^2", name=f"r{j}"))
    m = Mdof(method=method, order=4, horizon=0.1, markov=0.3).fit(recs[:3])
    err = np.linalg.norm(m.predict(recs[3]) - recs[3].y) / np.linalg.norm(recs[3].y)
    assert err < 1e-6


def test_a_failed_realization_is_one_line_naming_the_horizon(monkeypatch):
    """When mdof's SRIM finds no model (the zero-state B, D least squares does not converge
    on an unstable realization, as at a 20-sample horizon on the F-16's level 3), the fit
    raises one line naming `horizon`, not numpy's LinAlgError."""
    from podbench.errors import ConvergenceError
    from podbench.sysid.methods import mdof_peer

    def fails(*args):
        raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")

    monkeypatch.setattr(mdof_peer, "_bd_zero_state", fails)
    sys = _system()
    u = np.random.default_rng(4).normal(size=(2, 300))
    recs = [Record(u=u, y=modal_simulate(*sys, u), dt=0.01, input_units="m/s^2",
                   output_units="m/s^2", name="r0")]
    with pytest.raises(ConvergenceError, match=r"^Parameter `horizon`: mdof-SRIM failed at a "
                                               r"horizon of 10 samples \(0\.1 s\): SVD did not "
                                               r"converge .*; try a longer horizon$"):
        Mdof(method="srim", order=4, horizon=0.1).fit(recs)
