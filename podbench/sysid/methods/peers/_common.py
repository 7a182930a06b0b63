"""What the peers share: the output/input basis, discrete state-space simulation, delay
coordinates, the time hold-out rule for hyperparameters, and the optional-import message.

Every peer works on the coordinates of one orthonormal basis ``U`` (``m × k``): outputs
``y_j = Uᵀ w_j`` (in) and inputs ``u_j = Uᵀ f_j`` (lbf), the same projection ML uses for its
modal forces (Eq. 3.47). Without ``basis=`` the basis is the ``k`` leading POMs of all the
training records side by side (``[¹W ²W …]``), ``k`` by default the number of training
records (the forces of ``n_rec`` point-load tests span at most ``n_rec`` input directions,
and ML, the twin, needs ``k ≤ n_rec``). The prediction is ``Ŵ = U Ŷ``.

Measured inputs elsewhere (``inputs="measured"``, as ML's,
:mod:`podbench.sysid.methods.inputs`): the outputs are projected on the POMs of all training
outputs (``k = n_out`` by default), the inputs enter as measured, and records of different
lengths are zero-padded at the end to the longest (a record that ends at rest is unchanged;
one that ends quiet but not at rest gets a small error: stated, not hidden).

Sampling: column ``j`` is ``t_j = j·Δt``; training and target records start at rest
(``W[:, 0] = 0``, ``F[:, 0] = 0``), so every peer simulates from a zero state.
"""

from __future__ import annotations

import importlib

import numpy as np

from podbench.core.records import check_compatible
from podbench.errors import InputError
from podbench.sysid.methods.base import PODMethod, check_n_modes, select_basis
from podbench.sysid.methods.forced import INPUTS, MultipleLoad
from podbench.sysid.methods.inputs import given_basis, measured_basis
from podbench.sysid.params import Interval
from podbench.sysid.pod import snapshot_svd

__all__ = ["PeerMethod", "require", "simulate", "holdout_split", "padded", "INPUTS"]

EXTRA_HINT = "pip install 'podbench[peers]'"

HOLDOUT_RTOL = 0.01
"""The hold-out rule takes the simplest candidate within 1 % of the best hold-out error."""
HOLDOUT_FLOOR = 1e-9
"""Hold-out errors below this are round-off: all count as equal (the simplest wins)."""


def require(module: str, method: str, what: str):
    """Import an optional dependency of a peer; one line naming the extra if it is missing.

    Raises
    ------
    InputError
        ``"<method> needs <what>: pip install 'podbench[peers]'"``.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{method} needs {what}: {EXTRA_HINT}") from None


def simulate(A, B, C, D, U_in) -> np.ndarray:
    """Zero-state response of ``x_{j+1} = A x_j + B u_j``, ``y_j = C x_j + D u_j``.

    Parameters
    ----------
    A : (N, N) ndarray
    B : (N, k_in) ndarray
    C : (k_out, N) ndarray
    D : (k_out, k_in) ndarray
    U_in : (k_in, n) or (R, k_in, n) ndarray
        Inputs of one record, or of ``R`` records at once; ``x_0 = 0``.

    Returns
    -------
    (k_out, n) or (R, k_out, n) ndarray
    """
    U_in = np.asarray(U_in, dtype=float)
    single = U_in.ndim == 2
    Us = U_in[None] if single else U_in
    R, _, n = Us.shape
    N = A.shape[0]
    X = np.zeros((N, R))
    BU = np.einsum("ik,rkn->nir", B, Us)  # (n, N, R)
    states = np.empty((n, N, R))
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(n):
            states[j] = X
            X = A @ X + BU[j]
        Y = np.einsum("oi,nir->ron", C, states) + np.einsum("ok,rkn->ron", D, Us)
    return Y[0] if single else Y


def holdout_split(n: int, holdout: float) -> int:
    """First sample of the hold-out window: ``n1 = n − round(holdout·n)`` (at least 2)."""
    return max(2, n - int(round(holdout * n)))


def relative_error(Y_hat, Y) -> float:
    """``‖Ŷ − Y‖_F / ‖Y‖_F`` (inf for a non-finite prediction)."""
    if not np.all(np.isfinite(Y_hat)):
        return float("inf")
    ny = float(np.linalg.norm(Y))
    return float(np.linalg.norm(Y_hat - Y) / ny) if ny > 0 else float(np.linalg.norm(Y_hat))


HOLDOUT: list = [Interval("number", 0.05, 0.5, closed="both")]
"""``holdout``: the fraction of each training record the hold-out rule holds out."""
INT_OR_NONE: list = [None, Interval("integer", 1)]
DELAYS: list = [Interval("integer", 1)]


def padded(recs, U) -> tuple[np.ndarray, np.ndarray]:
    """``(Ys, Us)``: every record's outputs in the basis ``U`` and its measured inputs,
    zero-padded at the end to the longest record, ``(R, k, n)`` and ``(R, n_in, n)``."""
    n = max(r.n_samples for r in recs)
    Ys = np.zeros((len(recs), U.shape[1], n))
    Us = np.zeros((len(recs), recs[0].n_inputs, n))
    for j, r in enumerate(recs):
        Ys[j, :, : r.n_samples] = U.T @ r.y
        Us[j, :, : r.n_samples] = r.u
    return Ys, Us


class PeerMethod(PODMethod):
    """Base of the peers: forced records (or measured inputs), an output/input basis, a
    forced coupled twin (ML).

    Subclasses implement ``_identify(Ys, Us, n_fit)`` (identify from the first ``n_fit``
    samples of every record, in basis coordinates; returns a model object) and
    ``_respond(model, Uin)`` (zero-state response, ``(R, k, n)``), name the hyperparameter
    the hold-out rule chooses, and ``_fit_modal`` / ``_fit_measured`` (modal forces, or
    inputs as measured: :meth:`~podbench.sysid.methods.base.PODMethod._modal`).
    """

    excitation_kind = "forced"
    coupled = False
    #: ``(module, method, library)`` of the optional library the peer wraps (checked with
    #: the hyperparameters, so a missing library fails when a scenario is read).
    _requires: tuple[str, str, str] | None = None

    def __init__(self, *, n_modes=None, holdout=0.25, inputs="auto"):
        # the hyperparameters every peer has and this base reads: the size of the basis
        # (``_basis``), the hold-out fraction of its rule (``_fit_by_rule``) and how the
        # records' inputs are read (``_fit``)
        self.n_modes = n_modes
        self.holdout = holdout
        self.inputs = inputs

    def _validate_params(self) -> None:
        super()._validate_params()
        if self._requires is not None:
            require(*self._requires)

    def required_fields(self) -> tuple[str, ...]:
        return {"modal": ("W", "F", "dt"), "measured": ("u", "y", "dt")}.get(
            self.inputs, ("W", "dt"))

    def refusal(self, records) -> str | None:
        return self._inputs_refusal(records)

    def _fit(self, records, basis) -> None:
        if self._modal(records):
            self.inputs_ = "modal"
            self._fit_modal(records, basis)
            return
        self.inputs_ = "measured"
        U, povs = measured_basis(records, self.n_modes) if basis is None else \
            given_basis(records, basis)
        Ys, Us = padded(records, U)
        self.model_, self.info_ = self._identify_measured(Ys, Us, records)
        self.modes_, self.povs_, self.n_modes_ = U, povs, U.shape[1]
        self.dt_ = records[0].dt
        self.reference_ = records[0]

    def _fit_modal(self, records, basis) -> None:
        raise NotImplementedError

    def _identify_measured(self, Ys, Us, records) -> tuple:
        """``(model, info)`` from records of measured inputs (basis coordinates, padded)."""
        raise NotImplementedError

    def _measured(self) -> bool:
        return getattr(self, "inputs_", "modal") == "measured"

    def _predict(self, record) -> np.ndarray:
        if not self._measured():
            return self._predict_modal(record)
        check_compatible(self.reference_, record, min_samples=1)
        return self.modes_ @ self._respond(self.model_, record.u)

    def _predict_modal(self, record) -> np.ndarray:
        """Response to the forces of ``record`` (from rest): ``Ŵ = U Ŷ``, ``(m, n')`` in."""
        return self.modes_ @ self._respond(self._model(), self._new_inputs(record))

    def _model(self):
        """The fitted model ``_respond`` simulates."""
        raise NotImplementedError

    @property
    def diagnostics_(self) -> dict:
        """Measured inputs: ``n_modes`` and what the rule chose (``info_``)."""
        return self._chosen_diagnostics() if self._measured() else super().diagnostics_

    def coupled_twin(self):
        """ML in the peer's basis (the POD method that identifies the full kernel ``C(t)``
        without a model order: their difference is what the peer's model form loses)."""

        return MultipleLoad(n_modes=self.n_modes, solver="block")

    def _basis(self, recs, basis):
        Wall = np.hstack([r.W for r in recs])
        n_modes = check_n_modes(self.n_modes)
        if basis is None and n_modes is None:
            n_modes = len(recs)
        if basis is not None:
            U, povs, pocs = select_basis(Wall, n_modes, basis)
        else:
            pod = snapshot_svd(Wall)
            n_modes = min(n_modes, pod.modes.shape[1])
            U, povs, pocs = pod.modes[:, :n_modes], pod.povs[:n_modes], pod.pocs[:, :n_modes]
        return U, povs, pocs

    def _modal_data(self, recs, basis):
        """The basis and the records in it: ``(U, povs, pocs, Ys, Us)``."""
        U, povs, pocs = self._basis(recs, basis)
        Ys = np.stack([U.T @ r.W for r in recs])  # (R, k, n)
        Us = np.stack([U.T @ r.F for r in recs])
        return U, povs, pocs, Ys, Us

    def _delay_rule_measured(self, Ys, Us, records, candidates, name: str) -> tuple:
        """``(model, {name: choice})`` of a delay-coordinate peer (DMDc, OpInf) on measured
        inputs: its hyperparameter by the hold-out rule among ``candidates``. Delay
        coordinates hold inputs and outputs in one dimension: ``n_in = k`` or refused."""
        k = Ys.shape[1]
        if records[0].n_inputs != k:
            raise InputError(f"{self.abbreviation}: delay coordinates need as many inputs as "
                             f"output modes ({records[0].n_inputs} inputs, {k} modes)")
        choice, _ = self._select_by_holdout(Ys, Us, candidates, self._identify, self._respond,
                                            self.holdout)
        return self._identify(Ys, Us, choice), {name: choice}

    def _respond_delayed(self, A, B, C, Uin):
        """Zero-state response of the delay model ``(A, B)`` read out by ``C`` to the basis
        inputs ``Uin`` (``(k, n)`` or ``(R, k, n)``)."""
        k = Uin.shape[-2]
        R = Uin[None] if Uin.ndim == 2 else Uin
        _, V = delay_coordinates(np.zeros_like(R), R, self.delays)
        out = simulate(A, B, C, np.zeros((k, B.shape[1])), V)
        return out[0] if Uin.ndim == 2 else out

    def _fit_by_rule(self, recs, basis, value, candidates):
        """Fit the basis and the model (``_identify``), the rule's hyperparameter ``value``
        chosen by the hold-out rule among ``candidates`` when None; sets the basis,
        ``holdout_errors_`` and ``fit_residual_`` and returns ``(model, value)``."""
        U, povs, pocs, Ys, Us = self._modal_data(recs, basis)
        errors = None
        if value is None:
            value, errors = self._select_by_holdout(Ys, Us, candidates(U.shape[1]),
                                                    self._identify, self._respond,
                                                    self.holdout)
        model = self._identify(Ys, Us, value)
        self._set_basis(U, povs, pocs, recs[0].dt)
        self.holdout_errors_ = errors
        Yh = self._respond(model, Us)
        self.fit_residual_ = float(np.linalg.norm(Yh - Ys) / np.linalg.norm(Ys))
        return model, value

    def _select_by_holdout(self, Ys, Us, candidates, identify, respond, holdout):
        """The hold-out rule: the first (simplest) candidate whose hold-out error is within
        :data:`HOLDOUT_RTOL` of the smallest (errors below :data:`HOLDOUT_FLOOR` count as
        equal: round-off).

        For each candidate (given simplest first), the model is identified from the first
        ``n1`` samples of every training record (:func:`holdout_split`), every training
        record is simulated from rest with its whole force, and the error is
        ``‖Ŷ − Y‖/‖Y‖`` over samples ``n1 … n−1`` of all records together.
        Returns ``(best, errors)``.
        """
        n = Ys.shape[2]
        n1 = holdout_split(n, holdout)
        errors = []
        for cand in candidates:
            try:
                model = identify(Ys[:, :, :n1], Us[:, :, :n1], cand)
                Yh = respond(model, Us)
                errors.append(relative_error(Yh[:, :, n1:], Ys[:, :, n1:]))
            except (np.linalg.LinAlgError, ValueError):
                errors.append(float("inf"))
        errors = np.asarray(errors)
        if not np.any(np.isfinite(errors)):
            raise InputError(f"{type(self).__name__}: no candidate of the hold-out rule gives "
                             "a finite prediction of the training records")
        bound = max(np.min(errors) * (1.0 + HOLDOUT_RTOL), HOLDOUT_FLOOR)
        return candidates[int(np.flatnonzero(errors <= bound)[0])], errors

    def _new_inputs(self, record) -> np.ndarray:
        self._check_is_fitted()
        F = self._target_record(record).F
        if F is None:
            raise InputError(f"Parameter `record.F`: {type(self).__name__} predicts from the "
                             "force matrix F (lbf) at the output sensors; the record has none")
        if F.shape[0] != self.modes_.shape[0]:
            raise InputError(f"Parameter `record.F`: {F.shape[0]} rows, the peer was fitted "
                             f"on {self.modes_.shape[0]} sensors")
        return self.modes_.T @ F


def delay_coordinates(Ys, Us, delays: int):
    """Delay-embedded states and inputs of records that start at rest.

    State ``z_j = [y_j; y_{j−1}; …; y_{j−d+1}]`` (``d·k``), step input
    ``v_j = [u_{j+1}; u_j; …; u_{j+1−d}]`` (``(d+1)·k``), so that
    ``z_{j+1} = A z_j + B v_j`` holds exactly for the average-acceleration Newmark map of
    ``d/2``-per-coordinate second-order dynamics (the implicit step uses ``f_{j+1}``).
    Samples before ``t_0`` are zero (rest).

    Returns
    -------
    Z : (R, d·k, n) ndarray
    V : (R, (d+1)·k, n) ndarray
        ``V[:, :, j]`` drives the step ``j → j+1`` (its last column uses ``u_n = 0``).
    """
    R, k, n = Ys.shape
    Ypad = np.concatenate([np.zeros((R, k, delays)), Ys], axis=2)
    Z = np.concatenate([Ypad[:, :, delays - i : delays - i + n] for i in range(delays)], axis=1)
    Upad = np.concatenate([np.zeros((R, k, delays)), Us, np.zeros((R, k, 1))], axis=2)
    V = np.concatenate([Upad[:, :, delays + 1 - i : delays + 1 - i + n]
                        for i in range(delays + 1)], axis=1)
    return Z, V
