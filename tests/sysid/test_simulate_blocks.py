"""The blocked zero-state simulation against the sample-by-sample recursion."""

import numpy as np
import pytest

from podbench.sysid.methods.peers._common import simulate
from podbench.sysid.statespace import simulate_blocks


def _system(rng, N, m, p, radius):
    M = rng.standard_normal((N, N))
    A = radius * M / np.max(np.abs(np.linalg.eigvals(M)))
    return A, rng.standard_normal((N, m)), rng.standard_normal((p, N)), rng.standard_normal((p, m))


@pytest.mark.parametrize(("N", "m", "p", "R", "n", "block"),
                         [(6, 1, 3, 2, 1000, 128), (8, 2, 2, 1, 7, 128), (4, 1, 1, 3, 300, 7),
                          (5, 2, 3, 1, 128, 128), (3, 1, 2, 2, 257, 64)])
def test_blocks_equal_the_loop(N, m, p, R, n, block):
    """Every sample, any block length (shorter or longer than the record, dividing it or
    not), one record or several: the loop's result to round-off."""
    rng = np.random.default_rng(N * n)
    A, B, C, D = _system(rng, N, m, p, 0.99)
    U = rng.standard_normal((R, m, n))
    ref = simulate(A, B, C, D, U)
    got = simulate_blocks(A, B, C, D, U, block=block)
    assert got.shape == ref.shape
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    one = simulate_blocks(A, B, C, D, U[0], block=block)
    np.testing.assert_allclose(one, ref[0], rtol=0, atol=1e-12 * np.abs(ref).max())


def test_blocks_impulse_is_markov():
    """A unit impulse returns the Markov parameters D, CB, CAB, CA²B, … exactly as defined."""
    rng = np.random.default_rng(1)
    A, B, C, D = _system(rng, 4, 1, 2, 0.9)
    u = np.zeros((1, 20))
    u[0, 0] = 1.0
    y = simulate_blocks(A, B, C, D, u, block=6)
    markov = [D[:, 0]] + [(C @ np.linalg.matrix_power(A, i - 1) @ B)[:, 0] for i in range(1, 20)]
    np.testing.assert_allclose(y.T, np.array(markov), atol=1e-13)
