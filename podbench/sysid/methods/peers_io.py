"""The peers (ERA/OKID, DMDc, OpInf) on input/output records, in the same coordinates as ML.

Outputs ``y`` are projected on the ``k`` leading POMs of the training outputs (``k = n_out``
by default, as ML), the inputs ``u`` enter as measured (no modal projection: they are not
at the outputs). The peers' own identification code runs unchanged
(:mod:`podbench.methods.peers`); what differs from their forced-record form:

* records of different lengths are zero-padded at the end to the longest training record
  (the peers stack records of one length). A record that ends at rest is unchanged by it;
  a measured record that ends quiet but not at rest gets a small error: stated, not hidden.
* ERA's Hankel matrix has ``blocks`` block rows (default :data:`ERA_BLOCKS` seconds), not
  half the record: half of a 60-s record at 100 Hz would be a 9000 × 9000 SVD.
* DMDc and OpInf build delay coordinates in which inputs and outputs have one dimension:
  they need ``n_in = k``; otherwise refused with that message.

Their hyper-parameters (order, rank, regularization) are chosen by their own hold-out rule
on the training records.
"""

from __future__ import annotations

import numpy as np

from podbench.core.records import check_records
from podbench.errors import InputError
from podbench.sysid.methods.inputs import IOMethod, given_basis, io_records
from podbench.sysid.methods.peers import ERA, DMDc, OpInf
from podbench.sysid.methods.peers._common import simulate
from podbench.sysid.methods.peers.era import era_realization, okid_markov, realize
from podbench.sysid.methods.peers.operator_inference import REG_GRID

__all__ = ["ERAIO", "DMDcIO", "OpInfIO", "ERA_BLOCKS"]

ERA_BLOCKS = 1.0
"""Hankel block rows of ERA on measured records, in seconds of Markov parameters."""


def _padded(recs, U):
    n = max(r.n_samples for r in recs)
    Ys = np.zeros((len(recs), U.shape[1], n))
    Us = np.zeros((len(recs), recs[0].n_inputs, n))
    for j, r in enumerate(recs):
        Ys[j, :, : r.n_samples] = U.T @ r.y
        Us[j, :, : r.n_samples] = r.u
    return Ys, Us


class IOPeer(IOMethod):
    coupled = False

    def _respond_io(self, u: np.ndarray) -> np.ndarray:  # each peer's own model
        raise NotImplementedError

    def _basis(self, recs):
        Y = np.hstack([r.y for r in recs])
        Uall, s, _ = np.linalg.svd(Y, full_matrices=False)
        k = recs[0].n_outputs
        return Uall[:, :k], s[:k]

    def _peer(self):
        raise NotImplementedError

    def _check_square(self, recs, k):
        if recs[0].n_inputs != k:
            raise InputError(f"{self.abbreviation}: delay coordinates need as many inputs as "
                             f"output modes ({recs[0].n_inputs} inputs, {k} modes)")

    def fit(self, records, basis=None):
        recs = io_records(records)
        check_records(recs)
        U, povs = self._basis(recs) if basis is None else given_basis(recs, basis)
        Ys, Us = _padded(recs, U)
        self.model_, self.info_ = self._identify_io(Ys, Us, recs)
        self.modes_ = U
        self.povs_ = povs
        self.n_modes_ = U.shape[1]
        self.dt_ = recs[0].dt
        self.reference_ = recs[0]
        return self

    def predict(self, record, coverage=None) -> np.ndarray:
        rec = self._target(record)
        return self.modes_ @ self._respond_io(rec.u)


class ERAIO(IOPeer):
    """ERA/OKID (:class:`podbench.methods.ERA`) on input/output records; order by the
    peers' hold-out rule (1 … ``max_order``), observer order ``ceil(max_order/k)``."""

    abbreviation = "ERA"

    def __init__(self, *, max_order=40, lags=None, blocks=ERA_BLOCKS, holdout=0.25,
                 feedthrough="auto"):
        self.max_order = max_order
        self.lags = lags
        self.blocks = blocks
        self.holdout = holdout
        self.feedthrough = feedthrough

    def _identify_io(self, Ys, Us, recs):

        peer = ERA(max_order=self.max_order, lags=self.lags, holdout=self.holdout)
        peer._validate_params()
        k, n = Ys.shape[1], Ys.shape[2]
        lags = peer._lags(k)
        blocks = max(1, min(int(round(self.blocks / recs[0].dt)), (n - 1) // 2))
        cache = {}

        def identify(Yf, Uf, order):
            if not cache:
                h, _ = okid_markov(Yf, Uf, lags, 2 * blocks + 1)
                cache["f"] = (h, era_realization(h, blocks))
            h, (P, sv, Qt, H1) = cache["f"]
            return realize(P, sv, Qt, H1, h[0], min(order, int(np.sum(sv > 0))))

        cands = list(range(1, min(self.max_order, blocks * k) + 1))
        order, errors = peer._select_by_holdout(Ys, Us, cands, identify,
                                                lambda m, u: simulate(*m, u), self.holdout)
        h, residual = okid_markov(Ys, Us, lags, 2 * blocks + 1)
        P, sv, Qt, H1 = era_realization(h, blocks)
        model = realize(P, sv, Qt, H1, h[0], order)
        return model, {"order": int(order), "lags": int(lags), "blocks": int(blocks),
                       "fit_residual": float(residual)}

    def _respond_io(self, u):
        return simulate(*self.model_, u)


class _DelayPeer(IOPeer):
    def __init__(self, *, delays=2, holdout=0.25, feedthrough="auto"):
        self.delays = delays
        self.holdout = holdout
        self.feedthrough = feedthrough

    def _identify_io(self, Ys, Us, recs):
        self._check_square(recs, Ys.shape[1])
        peer = self._peer_class()(delays=self.delays, holdout=self.holdout)
        peer._validate_params()
        cands = self._candidates(Ys.shape[1])
        choice, _ = peer._select_by_holdout(Ys, Us, cands, peer._identify, peer._respond,
                                            self.holdout)
        self.peer_ = peer
        return peer._identify(Ys, Us, choice), {self._choice_name: choice}

    def _respond_io(self, u):
        return self.peer_._respond(self.model_, u)


class DMDcIO(_DelayPeer):
    """DMDc (:class:`podbench.methods.DMDc`, PyDMD) on input/output records."""

    abbreviation = "DMDc"
    _choice_name = "rank"

    @staticmethod
    def _peer_class():

        return DMDc

    def _candidates(self, k):
        return list(range(1, self.delays * k + 1))


class OpInfIO(_DelayPeer):
    """OpInf (:class:`podbench.methods.OpInf`, opinf) on input/output records."""

    abbreviation = "OpInf"
    _choice_name = "regularizer"

    @staticmethod
    def _peer_class():

        return OpInf

    def _candidates(self, k):

        return list(REG_GRID)
