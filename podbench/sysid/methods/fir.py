"""The multi-input FIR least-squares baseline: ML's measured-input kernel without the POD.

Each output channel is a least-squares FIR of all measured inputs (Chapter 6's baseline for
records whose inputs are not at the outputs); its lag length is chosen from a grid of lag
lengths by leave-one-record-out on the training records (``n_lags="auto"``). It is
:class:`~podbench.sysid.methods.MultipleLoad` on measured inputs in the output channels
themselves (the identity basis), so ML with ``k = n_out`` and no prior equals it to
round-off.
"""

from __future__ import annotations

import numpy as np

from podbench.sysid.methods.forced import N_LAGS, MultipleLoad
from podbench.sysid.methods.inputs import LAG_GRID
from podbench.sysid.params import Boolean, InstanceOf, Options

__all__ = ["FIRLeastSquares"]


class FIRLeastSquares(MultipleLoad):
    """The multi-input FIR least-squares baseline in the output channels (no POD).

    Parameters
    ----------
    n_lags : None, int or "auto"
        Kernel length: None (the whole record, by least squares; records of one length),
        an int (samples), or "auto" (from ``lag_grid`` by leave-one-record-out; default).
    lag_grid : tuple of float
        Lag lengths (s) for ``n_lags="auto"`` (:data:`~podbench.sysid.methods.inputs.LAG_GRID`).
    feedthrough : "auto", True or False
        Keep lag 0 (``"auto"``: for acceleration outputs).
    """

    abbreviation = "FIR-LS"
    coupled = False
    array_form = None
    _parameter_constraints = {
        "n_lags": N_LAGS,
        "lag_grid": [InstanceOf((tuple, list), "a sequence of lag lengths (s)")],
        "feedthrough": [Options("auto"), Boolean()]}

    def __init__(self, *, n_lags="auto", lag_grid=LAG_GRID, feedthrough="auto"):
        self.n_lags = n_lags
        self.lag_grid = lag_grid
        self.feedthrough = feedthrough

    # ML's hyperparameters this baseline fixes: no POD, no prior, least squares
    @property
    def prior(self):
        return None

    @property
    def n_modes(self):
        return None

    @property
    def solver(self):
        return "ls"

    @property
    def solver_options(self):
        return None

    @property
    def inputs(self):
        return "measured"

    def command_line_params(self, records, *, solver: str = "auto", n_modes=None,
                            period: int | None = None) -> dict:
        """ML's command-line parameters restricted to those FIR-LS has (its inputs, solver
        and basis are fixed)."""
        out = super().command_line_params(records, solver=solver, n_modes=n_modes)  # no period
        names = self._get_param_names()
        return {k: v for k, v in out.items() if k in names}

    def _measured_basis(self, recs) -> tuple[np.ndarray, np.ndarray]:
        m = recs[0].n_outputs
        return np.eye(m), np.linalg.norm(np.hstack([r.y for r in recs]), axis=1)
