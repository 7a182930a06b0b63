"""Operator inference (OpInf, Peherstorfer & Willcox 2016) via the ``opinf`` package.

A linear discrete model with input on the delay coordinates of
:func:`~podbench.methods.peers._common.delay_coordinates` (state ``z_j``, step input
``v_j``; ``y = Uᵀw``, ``u = Uᵀf``)

    ``z_{j+1} = Â z_j + B̂ v_j``

is inferred by Tikhonov-regularized least squares over the snapshot pairs of all training
records, ``min ‖D Ôᵀ − Z'ᵀ‖² + λ²‖Ôᵀ‖²`` with ``D = [Zᵀ Vᵀ]`` (``opinf.models.DiscreteModel``
with ``LinearOperator`` and ``InputOperator``, ``opinf.lstsq.L2Solver``). States and inputs
are scaled by their RMS first, so ``λ`` is relative to the data. A new load is predicted by
simulating the model from rest.

Why delays: see :mod:`podbench.methods.peers.dmd_control` (``d = 2`` by default: two
successive displacements carry the velocity; ``d = 1`` is OpInf on the POD coordinates).
"""

from __future__ import annotations

import numpy as np

from podbench.sysid.methods.peers._common import (
    DELAYS,
    HOLDOUT,
    INPUTS,
    INT_OR_NONE,
    PeerMethod,
    delay_coordinates,
    require,
)
from podbench.sysid.params import Interval

__all__ = ["OpInf"]

#: Regularizers the hold-out rule tries, ``λ = ρ·σ_1(D)``, simplest (strongest) first. No
#: ``ρ = 0``: the unregularized least squares keeps directions that carry only round-off, so
#: its hold-out error (and with it the rule's choice inside the bands' folds) would depend on
#: the round-off (docs/peers.md, "Round-off in ERA/OKID"); the weakest, ``ρ = 1e-10``, bounds
#: the amplification of round-off.
REG_GRID = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)


class OpInf(PeerMethod):
    """Operator inference (opinf): a linear discrete model with input, Tikhonov-regularized.

    Parameters
    ----------
    n_modes : int, optional
        ``k``, the size of the output/input basis: the POMs of all training records side by
        side (default: as many as training records), or ``basis.shape[1]``.
    delays : int
        Number ``d`` of successive outputs in the state (2).
    regularizer : float, optional
        ``ρ``, with ``λ = ρ·σ_1(D)`` (``σ_1``: largest singular value of the scaled data
        matrix). None (default): chosen by the hold-out rule over :data:`REG_GRID` (identify
        from the first ``1 − holdout`` of every training record, simulate every training
        record from rest; the strongest within 1 % of the smallest error over the last
        ``holdout``).
    holdout : float
        Fraction of each training record held out by the rule (0.25).
    inputs : {"auto", "modal", "measured"}
        The records' inputs as modal forces or as measured (as ERA's; delay coordinates
        then need as many inputs as output modes).

    Attributes
    ----------
    modes_ : (m, k) ndarray
    A_ : (d·k, d·k) ndarray
    B_ : (d·k, (d+1)·k) ndarray
        The inferred operators in physical units (``z`` in in, ``v`` in lbf).
    regularizer_ : float
        The ``ρ`` used.
    """

    abbreviation = "OpInf"
    _requires = ("opinf", "OpInf", "opinf")
    _parameter_constraints = {"n_modes": INT_OR_NONE, "delays": DELAYS,
                              "regularizer": [None, Interval("number", 0)], "holdout": HOLDOUT,
                              "inputs": INPUTS}

    def __init__(self, *, n_modes=None, delays=2, regularizer=None, holdout=0.25,
                 inputs="auto"):
        super().__init__(n_modes=n_modes, holdout=holdout, inputs=inputs)
        self.delays = delays
        self.regularizer = regularizer

    def _identify(self, Ys, Us, rho):
        opinf = require("opinf", "OpInf", "opinf")
        Z, V = delay_coordinates(Ys, Us, self.delays)
        sz = float(np.sqrt(np.mean(Z**2))) or 1.0
        sv = float(np.sqrt(np.mean(V**2))) or 1.0
        X = np.hstack(list(Z[:, :, :-1])) / sz
        Xn = np.hstack(list(Z[:, :, 1:])) / sz
        I = np.hstack(list(V[:, :, :-1])) / sv  # noqa: E741 - the inputs, as opinf names them
        s1 = float(np.linalg.norm(np.vstack([X, I]), 2))
        model = opinf.models.DiscreteModel(
            operators=[opinf.operators.LinearOperator(), opinf.operators.InputOperator()],
            solver=opinf.lstsq.L2Solver(regularizer=rho * s1),
        )
        model.fit(X, nextstates=Xn, inputs=I)
        A = np.asarray(model.operators[0].entries)
        B = np.asarray(model.operators[1].entries) * (sz / sv)
        return A, B

    def _respond(self, model, Uin):
        A, B = model
        return self._respond_delayed(A, B, np.eye(Uin.shape[-2], A.shape[0]), Uin)

    def _fit_modal(self, records, basis) -> None:
        """``(Â, B̂)`` from forced records that start at rest."""
        (A, B), rho = self._fit_by_rule(records, basis, self.regularizer,
                                        lambda k: list(REG_GRID))
        self.A_, self.B_ = A, B
        self.regularizer_ = float(rho)

    def _identify_measured(self, Ys, Us, records) -> tuple:
        return self._delay_rule_measured(Ys, Us, records, list(REG_GRID), "regularizer")

    def _model(self):
        return self.A_, self.B_

    @property
    def diagnostics_(self) -> dict:
        """``n_modes``, ``regularizer`` (the rule's choice ``ρ``), ``delays``,
        ``fit_residual`` (training records simulated from rest), ``holdout_error``,
        ``spectral_radius``. Measured inputs: ``n_modes`` and ``info_``."""
        out = super().diagnostics_
        if self._measured():
            return out
        out["regularizer"] = self.regularizer_
        out["delays"] = int(self.delays)
        out["spectral_radius"] = float(np.max(np.abs(np.linalg.eigvals(self.A_))))
        if self.holdout_errors_ is not None:
            out["holdout_error"] = float(self.holdout_errors_[REG_GRID.index(self.regularizer_)]) \
                if self.regularizer_ in REG_GRID else float("nan")
        return out
