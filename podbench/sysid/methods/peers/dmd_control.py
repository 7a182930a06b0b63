"""Dynamic mode decomposition with control (DMDc, Proctor, Brunton & Kutz 2016) via PyDMD.

On the delay coordinates of :func:`~podbench.methods.peers._common.delay_coordinates`
(state ``z_j = [y_j; …; y_{j−d+1}]``, step input ``v_j = [u_{j+1}; …; u_{j+1−d}]``, ``y =
Uᵀw``, ``u = Uᵀf``), DMDc fits ``z_{j+1} ≈ A z_j + B v_j`` over the snapshot pairs of all
training records: the SVD of ``Ω = [Z; V]`` and the rank-``r`` POD basis ``Û`` of the
shifted snapshots give ``Ã = Ûᵀ Z' Ṽ Σ̃⁻¹ Ũ_1ᵀ Û`` and ``B̃ = Ûᵀ Z' Ṽ Σ̃⁻¹ Ũ_2ᵀ`` (PyDMD's
``DMDBUnknownOperator``, the algorithm of ``pydmd.DMDc`` with B unknown). PyDMD's ``DMDc``
class takes one trajectory, and the pairs that join one record to the next would be false
transitions, so the operator is called on the pairs of every record stacked. A new load is
predicted by simulating ``x̃_{j+1} = Ã x̃_j + B̃ v_j`` from rest, ``ŷ_j = (Û x̃_j)_{1:k}``.

Why delays: a state of ``k`` displacement coordinates alone holds no velocity, so a linear
map of it cannot carry ``k`` oscillating modes; two successive displacements can (``d = 2``,
the default, fixed by this argument before any measurement). ``d = 1`` is plain DMDc on the
POD coordinates.
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

__all__ = ["DMDc"]

#: Relative singular-value cut of ``Ω = [Z; V]`` when ``svd_rank_omega`` is None (the
#: default): the rank passed to PyDMD is the number of singular values above 1e-8 of the
#: largest. Without a cut (−1) the pseudo-inverse of Ω keeps round-off directions, and the
#: hold-out errors of the full-rank candidate depend on the round-off (docs/peers.md,
#: "Round-off in ERA/OKID"); the same rule as ERA's cut (round-off stays below the tables'
#: digits).
OMEGA_RCOND = 1e-8

#: PyDMD's rank: an int >= -1 (0: optimal hard threshold, -1: none) or an energy fraction.
_PYDMD_RANK: list = [Interval("integer", -1), Interval("number", 0, 1, closed="neither")]


class DMDc(PeerMethod):
    """DMD with control (PyDMD) on the delay coordinates of an output/input basis.

    Parameters
    ----------
    n_modes : int, optional
        ``k``, the size of the output/input basis: the POMs of all training records side by
        side (default: as many as training records), or ``basis.shape[1]``.
    delays : int
        Number ``d`` of successive outputs in the state (2).
    svd_rank : int or float, optional
        PyDMD's ``svd_rank`` (truncation of the shifted snapshots; an int ``r``, an energy
        fraction in (0, 1), 0 for PyDMD's optimal hard threshold, −1 for none). None
        (default): chosen by the hold-out rule over ``r = 1 … d·k`` (identify from the first
        ``1 − holdout`` of every training record, simulate every training record from rest,
        the smallest ``r`` within 1 % of the best error over the last ``holdout``).
    svd_rank_omega : int or float, optional
        PyDMD's ``svd_rank_omega`` (truncation of ``Ω = [Z; V]``; −1: none). None
        (default): the singular values of Ω above :data:`OMEGA_RCOND` = 1e-8 of the largest
        (those below carry round-off only).
    holdout : float
        Fraction of each training record held out by the rank rule (0.25).
    inputs : {"auto", "modal", "measured"}
        The records' inputs as modal forces or as measured (as ERA's; delay coordinates
        then need as many inputs as output modes).

    Attributes
    ----------
    modes_ : (m, k) ndarray
    Atilde_ : (r, r) ndarray
    Btilde_ : (r, (d+1)·k) ndarray
    basis_ : (d·k, r) ndarray
        PyDMD's POD basis ``Û`` of the shifted snapshots.
    rank_ : int
    eigs_ : (r,) complex ndarray
        DMD eigenvalues (discrete, per sample).
    """

    abbreviation = "DMDc"
    _requires = ("pydmd", "DMDc", "PyDMD")
    _parameter_constraints = {"n_modes": INT_OR_NONE, "delays": DELAYS,
                              "svd_rank": [None, *_PYDMD_RANK],
                              "svd_rank_omega": [None, *_PYDMD_RANK],
                              "holdout": HOLDOUT, "inputs": INPUTS}

    def __init__(self, *, n_modes=None, delays=2, svd_rank=None, svd_rank_omega=None,
                 holdout=0.25, inputs="auto"):
        super().__init__(n_modes=n_modes, holdout=holdout, inputs=inputs)
        self.delays = delays
        self.svd_rank = svd_rank
        self.svd_rank_omega = svd_rank_omega

    def _identify(self, Ys, Us, rank):
        dmdc = require("pydmd.dmdc", "DMDc", "PyDMD")
        Z, V = delay_coordinates(Ys, Us, self.delays)
        X = np.hstack(list(Z[:, :, :-1]))
        Y = np.hstack(list(Z[:, :, 1:]))
        I = np.hstack(list(V[:, :, :-1]))  # noqa: E741 - PyDMD's name for the inputs
        omega = self.svd_rank_omega
        if omega is None:
            sv = np.linalg.svd(np.vstack([X, I]), compute_uv=False)
            omega = max(1, int(np.sum(sv > OMEGA_RCOND * sv[0])))
        op = dmdc.DMDBUnknownOperator(svd_rank=rank, svd_rank_omega=omega, tlsq_rank=0)
        Ur, Bfull = op.compute_operator(X, Y, I)
        Atilde = np.real_if_close(op.as_numpy_array)
        Btilde = Ur.conj().T @ Bfull
        return np.real(Atilde), np.real(Btilde), np.real(Ur)

    def _respond(self, model, Uin):
        Atilde, Btilde, Ur = model
        return self._respond_delayed(Atilde, Btilde, Ur[:Uin.shape[-2]], Uin)

    def _fit_modal(self, records, basis) -> None:
        """``(Ã, B̃)`` from forced records that start at rest."""
        (Atilde, Btilde, Ur), _ = self._fit_by_rule(
            records, basis, self.svd_rank, lambda k: list(range(1, self.delays * k + 1)))
        self.Atilde_, self.Btilde_, self.basis_ = Atilde, Btilde, Ur
        self.rank_ = int(Atilde.shape[0])
        self.eigs_ = np.linalg.eigvals(Atilde)

    def _identify_measured(self, Ys, Us, records) -> tuple:
        return self._delay_rule_measured(Ys, Us, records,
                                         list(range(1, self.delays * Ys.shape[1] + 1)), "rank")

    def _model(self):
        return self.Atilde_, self.Btilde_, self.basis_

    @property
    def diagnostics_(self) -> dict:
        """``n_modes``, ``rank`` (the rule's choice), ``delays``, ``fit_residual`` (training
        records simulated from rest), ``holdout_error``, ``spectral_radius``. Measured
        inputs: ``n_modes`` and ``info_``."""
        out = super().diagnostics_
        if self._measured():
            return out
        out["rank"] = self.rank_
        out["delays"] = int(self.delays)
        out["spectral_radius"] = float(np.max(np.abs(self.eigs_)))
        if self.holdout_errors_ is not None:
            out["holdout_error"] = float(self.holdout_errors_[self.rank_ - 1])
        return out
