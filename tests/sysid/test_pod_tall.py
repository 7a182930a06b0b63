"""POD of tall snapshot matrices (m ≫ n): the method of snapshots against the full SVD.

The issue's size (m = 100,000 sensors × n = 2,000 samples) is measured by
``python benchmarks/run.py`` (benchmarks/README.md); here a smaller tall matrix with a
separated spectrum checks the 1e-8 agreement, and tracemalloc checks that the memory stays
proportional to m·n (no m × m matrix).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from podbench.sysid.pod import method_of_snapshots, pod, snapshot_svd

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _tall(m, n, r, decay, seed):
    rng = np.random.default_rng(seed)
    U = np.linalg.qr(rng.standard_normal((m, r)))[0]
    V = np.linalg.qr(rng.standard_normal((n, r)))[0]
    s = decay ** np.arange(r)
    return (U * s) @ V.T, s


def test_method_of_snapshots_equals_full_svd_leading_modes_on_a_tall_matrix():
    """m = 30,000, n = 300, σ_i = 0.8^i (ratio of neighbours 1.25): the leading 12 modes
    (σ_12/σ_1 = 0.09, well above the sqrt(eps) precision limit of the squared spectrum)."""
    W, s = _tall(30_000, 300, 60, 0.8, seed=4)
    k = 12
    a, b = method_of_snapshots(W, k), snapshot_svd(W, k)
    np.testing.assert_allclose(a.povs, s[:k], rtol=1e-10)
    np.testing.assert_allclose(a.povs, b.povs, rtol=1e-10)
    # every mode, as a unit vector, to 1e-8 in the 2-norm (signs fixed by the convention)
    assert np.max(np.linalg.norm(a.modes - b.modes, axis=0)) < 1e-8
    assert np.max(np.linalg.norm(a.pocs - b.pocs, axis=0)) < 1e-8
    np.testing.assert_allclose(a.modes.T @ a.modes, np.eye(k), atol=1e-12)
    assert pod(W, k).modes.shape == (30_000, k)  # "auto": m > 20 n → method of snapshots


def test_method_of_snapshots_memory_is_linear_in_m():
    """Peak traced memory (numpy allocations) for m = 400,000, n = 8: an m × m matrix would
    need 1.3 TB; the method needs the n × n correlation and the m × k modes."""
    rng = np.random.default_rng(9)
    m, n, k = 400_000, 8, 4
    W = rng.standard_normal((m, n))
    tracemalloc.start()
    try:
        p = method_of_snapshots(W, k)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert p.modes.shape == (m, k)
    # the modes themselves are 8·m·k bytes = 12.8 MB; allow a few m·n-sized temporaries
    assert peak < 4 * W.nbytes, f"peak {peak / 1e6:.1f} MB for W of {W.nbytes / 1e6:.1f} MB"
