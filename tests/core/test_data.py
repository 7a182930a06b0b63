"""The Response container checks the sampling convention t_j = j·dt once, at construction."""

import numpy as np
import pytest

from podbench.core.response import Response
from podbench.errors import InputError


def _response(t, dt):
    n = len(t)
    W = np.ones((2, n))
    return Response(t=t, W=W, F=0 * W, w0=W[:, 0], v0=0 * W[:, 0], dt=dt)


def test_times_that_follow_dt_are_accepted_within_roundoff():
    n, dt = 5000, 1e-4
    t = np.cumsum(np.r_[0.0, np.full(n - 1, dt)])  # summed steps: roundoff ~1e-16 relative
    assert _response(t, dt).dt == dt
    assert _response(np.linspace(0.0, (n - 1) * dt, n), dt).n_samples == n


@pytest.mark.parametrize("t, dt, match", [
    (np.arange(10) * 2e-4, 1e-4, r"t\[1\] = 0.0002 s instead of 0.0001 s"),   # dt disagrees
    (np.arange(10) * 1e-4 + 1e-4, 1e-4, r"t\[0\] = 0.0001 s instead of 0 s"),  # t_0 != 0
    (np.r_[np.arange(9) * 1e-4, 1.0], 1e-4, r"t\[9\]"),                         # a jump
    (np.arange(10) * 1e-4, 0.0, r"Parameter `dt`: must be positive"),
    (np.arange(10) * 1e-4, -1e-4, r"Parameter `dt`: must be positive"),
    (np.arange(10) * 1e-4, float("nan"), r"Parameter `dt`: must be finite"),
])
def test_times_that_disagree_with_dt_are_one_line_errors(t, dt, match):
    with pytest.raises(InputError, match=match) as e:
        _response(t, dt)
    assert "\n" not in str(e.value)
