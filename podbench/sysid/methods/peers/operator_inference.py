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

from podbench.errors import InputError
from podbench.sysid.methods.peers._common import (
    PeerMethod,
    check_holdout,
    check_int_or_none,
    delay_coordinates,
    require,
    simulate,
)

__all__ = ["OpInf"]

#: Regularizers the hold-out rule tries, ``λ = ρ·σ_1(D)``, simplest (strongest) first.
REG_GRID = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 0.0)


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

    def __init__(self, *, n_modes=None, delays=2, regularizer=None, holdout=0.25):
        self.n_modes = n_modes
        self.delays = delays
        self.regularizer = regularizer
        self.holdout = holdout

    def _validate_params(self) -> None:
        check_int_or_none(self.n_modes, "n_modes")
        if check_int_or_none(self.delays, "delays") is None:
            raise InputError("Parameter `delays`: must be an integer >= 1, got None")
        rho = self.regularizer
        if rho is not None and (isinstance(rho, bool) or not isinstance(rho, (int, float))
                                or not 0 <= rho < np.inf):
            raise InputError(f"Parameter `regularizer`: must be a number >= 0 or None, "
                             f"got {rho!r}")
        check_holdout(self.holdout)
        require("opinf", "OpInf", "opinf")

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
        k = Uin.shape[-2]
        R = Uin[None] if Uin.ndim == 2 else Uin
        _, V = delay_coordinates(np.zeros_like(R), R, self.delays)
        C = np.eye(k, A.shape[0])
        out = simulate(A, B, C, np.zeros((k, B.shape[1])), V)
        return out[0] if Uin.ndim == 2 else out

    def fit(self, records, *, basis=None) -> OpInf:
        """Infer ``(Â, B̂)`` from forced records that start at rest (``basis``: replaces the
        POMs of the training records); returns ``self``."""
        recs, U, povs, pocs, Ys, Us = self._fit_records(records, basis)
        rho, errors = self.regularizer, None
        if rho is None:
            rho, errors = self._select_by_holdout(Ys, Us, list(REG_GRID), self._identify,
                                                  self._respond, self.holdout)
        A, B = self._identify(Ys, Us, rho)
        self._set_basis(U, povs, pocs, recs[0].dt)
        self.A_, self.B_ = A, B
        self.regularizer_ = float(rho)
        self.holdout_errors_ = errors
        Yh = self._respond((A, B), Us)
        self.fit_residual_ = float(np.linalg.norm(Yh - Ys) / np.linalg.norm(Ys))
        return self

    def predict(self, record) -> np.ndarray:
        """Response to the forces of ``record`` (from rest): ``Ŵ = U Ŷ``, ``(m, n')`` in."""
        Uin = self._new_inputs(record)  # checks that the model is fitted
        return self.modes_ @ self._respond((self.A_, self.B_), Uin)

    @property
    def diagnostics_(self) -> dict:
        """``n_modes``, ``regularizer`` (the rule's choice ``ρ``), ``delays``,
        ``fit_residual`` (training records simulated from rest), ``holdout_error``,
        ``spectral_radius``."""
        out = super().diagnostics_
        out["regularizer"] = self.regularizer_
        out["delays"] = int(self.delays)
        out["spectral_radius"] = float(np.max(np.abs(np.linalg.eigvals(self.A_))))
        if self.holdout_errors_ is not None:
            out["holdout_error"] = float(self.holdout_errors_[REG_GRID.index(self.regularizer_)]) \
                if self.regularizer_ in REG_GRID else float("nan")
        return out
