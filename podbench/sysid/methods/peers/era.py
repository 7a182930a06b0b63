"""Eigensystem Realization Algorithm with observer/Kalman filter identification (ERA/OKID).

From several forced records that start at rest, OKID (Juang, Phan, Horta & Longman 1993,
"Identification of observer/Kalman filter Markov parameters") fits, by least squares over
all records stacked, the ARX form of a system with an observer

    ``y_j = D u_j + Σ_{i=1}^{p} (α_i u_{j−i} + β_i y_{j−i})``                       (1)

(``y = Uᵀw``, ``u = Uᵀf`` in a basis ``U``; samples before ``t_0`` are zero: rest). Its
transfer function ``H(z) = (I − β(z))⁻¹ (D + α(z))`` gives the system Markov parameters by

    ``h_0 = D``,  ``h_j = α_j + Σ_{i=1}^{min(j, p)} β_i h_{j−i}``  (``α_j = 0`` for ``j > p``). (2)

ERA (Juang & Pappa 1985) factors the block Hankel matrix ``H(0) = [h_{a+b+1}]`` (``s × s``
blocks) by the SVD ``H(0) = P Σ Qᵀ`` and, truncated to order ``N``,

    ``A = Σ_N^{-1/2} P_Nᵀ H(1) Q_N Σ_N^{-1/2}``, ``B = Σ_N^{1/2} Q_Nᵀ E_in``,
    ``C = E_outᵀ P_N Σ_N^{1/2}``, ``D = h_0``                                           (3)

with ``H(1) = [h_{a+b+2}]``. A new load is predicted by simulating ``(A, B, C, D)`` from rest
with its modal forces, ``Ŵ = U Ŷ``. For a linear time-invariant system sampled by any
one-step map (Newmark included), ``k = m``, enough lags (``p·k ≥`` the state dimension) and
``N`` equal to the state dimension, the prediction is exact.

**Free decay** (``excitation="displacement"`` or ``"velocity"``, beside MDS). A free response
of a linear time-invariant system sampled by a one-step map is ``x_{t+1} = A x_t``,
``y_t = C x_t``, and its initial state is linear in the initial profile, ``x_0 = B u`` with
``u = Uᵀx0`` (``x0 = w0``, in, or ``v0``, in/s). Hence

    ``y_t = h_t u``,  ``h_t = C A^t B``  (``k × k``, ``t = 0 … n−1``),               (4)

the free-decay "Markov parameters". From ``R ≥ k`` records with independent profiles,
stacked as ``Y_t = [¹y_t … ᴿy_t]`` and ``X_0 = [¹u … ᴿu]``,

    ``h_t = Y_t X_0⁺``                                                              (5)

(MDS's ``Φ(t)``, Eq. 3.27/3.32). ERA factors the Hankel matrix ``H(0) = [h_{a+b}]`` of these
(the sequence shifted by one against the forced case, ``h_t`` playing ``h_{t+1}``) and (3)
gives ``(A, B, C)`` of order ``N``. A new profile ``ũ = Uᵀx̃0`` is predicted by
``ŷ_t = C A^t x̂_0`` with ``x̂_0 = B ũ``: the initial state of order ``N`` that (4) ties to
the profile (for displacements it carries the zero initial velocity the records had, which
a least-squares fit ``C x̂_0 ≈ ũ`` of the first sample alone would not know). Unlike MDS's
``Φ(t_i)``, one per sample of the training records, the realization predicts any length.
For a linear structure, ``k = m`` and ``N`` = the state dimension (``2m`` for Newmark's
``(w, ẇ)``) the prediction is exact.
"""

from __future__ import annotations

import numpy as np

from podbench.errors import InputError, RecordTooShortError
from podbench.sysid.methods.base import ArrayForm
from podbench.sysid.methods.free import MDS, first_column_w0
from podbench.sysid.methods.peers._common import HOLDOUT, INPUTS, INT_OR_NONE, PeerMethod, simulate
from podbench.sysid.params import Interval, Options
from podbench.sysid.statespace import era_realization, realize, simulate_blocks

__all__ = ["ERA", "okid_markov", "era_realization", "free_markov", "excited_inputs",
           "ERA_BLOCKS"]

ERA_BLOCKS = 1.0
"""Hankel block rows of ERA on measured records (s of Markov parameters): the ``blocks`` its
configurations on measured inputs give (half of a 60-s record at 100 Hz would be a
9000 × 9000 SVD)."""

_EXCITATIONS = ("forced", "displacement", "velocity")
_X0 = {"displacement": "w0", "velocity": "v0"}


def free_markov(Ys, X0) -> np.ndarray:
    """Free-decay Markov parameters ``h_t = Y_t X_0⁺`` (Eq. 5).

    Parameters
    ----------
    Ys : (R, k, n) ndarray
        Outputs of ``R`` free decays (in).
    X0 : (R, k) ndarray
        Their initial profiles in the basis (in or in/s).

    Returns
    -------
    (n, k, k) ndarray
        ``h_t`` (dimensionless for displacements, s for velocities).
    """
    return np.einsum("rkt,rl->tkl", Ys, np.linalg.pinv(X0.T))


def simulate_free(A, B, C, X0, n: int) -> np.ndarray:
    """``y_t = C A^t B u`` for the profiles ``X0`` (``(R, k)``); returns ``(R, k, n)``."""
    X = B @ X0.T  # (N, R)
    out = np.empty((X0.shape[0], C.shape[0], n))
    with np.errstate(over="ignore", invalid="ignore"):
        for t in range(n):
            out[:, :, t] = (C @ X).T
            X = A @ X
    return out


def _regressors(Ys, Us, lags: int):
    """Rows ``[u_j, u_{j−1}, y_{j−1}, …, u_{j−p}, y_{j−p}]`` of (1) for every record and
    sample (zero before ``t_0``); returns ``(Phi, Y)``, ``(R·n, dim)`` and ``(R·n, k_out)``."""
    R, k_out, n = Ys.shape
    k_in = Us.shape[1]
    Upad = np.concatenate([np.zeros((R, k_in, lags)), Us], axis=2)
    Ypad = np.concatenate([np.zeros((R, k_out, lags)), Ys], axis=2)
    blocks = [Upad[:, :, lags : lags + n]]
    for i in range(1, lags + 1):
        blocks.append(Upad[:, :, lags - i : lags - i + n])
        blocks.append(Ypad[:, :, lags - i : lags - i + n])
    Phi = np.concatenate(blocks, axis=1)  # (R, dim, n)
    return (Phi.transpose(0, 2, 1).reshape(R * n, -1),
            Ys.transpose(0, 2, 1).reshape(R * n, k_out))


#: Relative singular-value cut of OKID's least squares (Eq. 1): directions of the regressor
#: below 1e-8 of its largest singular value are dropped. NumPy's default cut (machine epsilon
#: times the larger dimension) keeps directions that carry only round-off, which the observer
#: recursion (Eq. 2) amplifies until the chosen order depends on the round-off of the
#: records. The rule: round-off (1e-16 relative) amplified by at most 1/rcond stays two
#: digits below the tables' sixth significant digit. The recursion itself still amplifies
#: round-off where ERA cannot model the structure (the measurements: docs/peers.md, "Round-off
#: in ERA/OKID").
OKID_RCOND = 1e-8


def excited_inputs(Us, rcond: float = OKID_RCOND):
    """An orthonormal basis ``Q`` (``k_in × r``) of the input directions the records excite
    (left singular vectors of all records' inputs side by side with singular values above
    ``rcond`` of the largest), or None when they excite all ``k_in``.

    The Markov parameters' response to an input direction no record excites is not
    determined by the records: the least squares of Eq. 1 leaves it at its minimum norm,
    zero up to round-off, and the recursion of Eq. 2 amplifies that round-off (a band's
    refit on fewer records than input directions is such a case: docs/peers.md, "Round-off
    in ERA/OKID"). Identified in the excited directions (``u → Qᵀu``, ``h = h̃ Qᵀ``), the
    response to the rest is exactly zero: what the records say about it."""
    Um = np.asarray(Us, dtype=float).transpose(1, 0, 2).reshape(Us.shape[1], -1)
    if Um.size == 0:
        return None
    Ul, sv, _ = np.linalg.svd(Um, full_matrices=False)
    r = int(np.sum(sv > rcond * sv[0])) if sv[0] > 0 else 0
    return None if r in (0, Us.shape[1]) else Ul[:, :r]


def okid_markov(Ys, Us, lags: int, n_markov: int, rcond: float = OKID_RCOND):
    """System Markov parameters from forced records that start at rest (OKID, Eqs. 1–2).

    Parameters
    ----------
    Ys : (R, k_out, n) ndarray
        Outputs of ``R`` records.
    Us : (R, k_in, n) ndarray
        Their inputs (``u_j`` at ``t_j``, zero state at ``t_0``).
    lags : int
        Observer order ``p``.
    n_markov : int
        Number of Markov parameters returned (``h_0 … h_{n_markov−1}``).
    rcond : float
        Relative singular-value cut of the least squares (:data:`OKID_RCOND`), and of the
        inputs' directions: in directions no record excites (:func:`excited_inputs`) the
        Markov parameters are zero.

    Returns
    -------
    h : (n_markov, k_out, k_in) ndarray
    residual : float
        ``‖Φθ − Y‖ / ‖Y‖`` of the least-squares fit of (1).
    """
    R, k_out, _ = Ys.shape
    Q = excited_inputs(Us, rcond)
    if Q is not None:  # identify in the excited input directions only (see excited_inputs)
        h, residual = okid_markov(Ys, np.einsum("ia,rin->ran", Q, Us), lags, n_markov, rcond)
        return h @ Q.T, residual
    k_in = Us.shape[1]
    # one scale for outputs and one for inputs (in and lbf differ by orders of magnitude);
    # the minimum-norm solution is then not decided by the units
    sy = float(np.sqrt(np.mean(Ys**2))) or 1.0
    su = float(np.sqrt(np.mean(Us**2))) or 1.0
    Phi, Y = _regressors(Ys / sy, Us / su, lags)
    theta, *_ = np.linalg.lstsq(Phi, Y, rcond=rcond)
    ny = float(np.linalg.norm(Y))
    residual = float(np.linalg.norm(Phi @ theta - Y) / ny) if ny > 0 else 0.0
    T = theta.T  # (k_out, dim)
    D = T[:, :k_in]
    alpha, beta = [], []
    pos = k_in
    for _ in range(lags):
        alpha.append(T[:, pos : pos + k_in])
        beta.append(T[:, pos + k_in : pos + k_in + k_out])
        pos += k_in + k_out
    h = np.zeros((n_markov, k_out, k_in))
    h[0] = D
    for j in range(1, n_markov):
        acc = alpha[j - 1].copy() if j <= lags else np.zeros((k_out, k_in))
        for i in range(1, min(j, lags) + 1):
            acc += beta[i - 1] @ h[j - i]
        h[j] = acc
    return h * (sy / su), residual


class ERA(PeerMethod):
    """ERA/OKID peer: a discrete state-space realization identified from forced records.

    Parameters
    ----------
    n_modes : int, optional
        ``k``, the size of the output/input basis: the POMs of all training records side by
        side (default: as many as training records), or ``basis.shape[1]``.
    order : int, optional
        State dimension ``N`` of the realization. None (default): chosen by the hold-out
        rule over ``1 … max_order``: identify from the first ``1 − holdout`` of every
        training record, simulate every training record from rest with its whole force,
        take the order with the smallest error over the last ``holdout`` of the samples
        (the smallest order within 1 % of the best); then identify again from the whole records.
    max_order : int
        Largest order the rule considers (40), and through it the default ``lags``.
    lags : int, optional
        Observer order ``p`` of Eq. 1. None: ``ceil(max(max_order, order)/k)``, so that a
        deadbeat observer of any order considered exists (Juang et al. 1993: ``p·k ≥ N``).
    holdout : float
        Fraction of each training record held out by the order rule (0.25).
    rcond : float
        Relative singular-value cut of OKID's least squares (Eq. 1; default
        :data:`OKID_RCOND` = 1e-8): smaller singular values carry round-off only, which the
        observer recursion amplifies (the order rule's choice then depends on the BLAS
        kernel).
    excitation : {"forced", "displacement", "velocity"}
        ``"forced"`` (default): ERA/OKID from forced records that start at rest.
        ``"displacement"`` / ``"velocity"``: ERA from free decays (Eqs. 4–5; records with
        ``w0`` or ``v0``, beside MDS); ``lags`` is then unused and the order rule holds out
        the last ``holdout`` of every decay.
    blocks : float, optional
        Hankel block rows (and columns) of the forced realization, in seconds of Markov
        parameters, at most half the record. None (default): half the record (the Markov
        parameters a record holds).
    inputs : {"auto", "modal", "measured"}
        The records' inputs as modal forces ``Uᵀ F`` (forces at the output sensors) or as
        measured (a base acceleration: the outputs in the POMs of all training outputs,
        ``k = n_out`` by default, records of different lengths zero-padded); ``"auto"``:
        modal when every record's inputs are forces at its output channels
        (:data:`~podbench.sysid.methods.forced.INPUTS`).

    Attributes
    ----------
    modes_ : (m, k) ndarray
        The basis (POMs of all training records, or ``basis``).
    A_, B_, C_, D_ : ndarrays
        The discrete realization (``x_{j+1} = A x_j + B u_j``, ``y_j = C x_j + D u_j``;
        ``u`` in lbf, ``y`` in in, both in the basis).
    markov_ : (L, k, k) ndarray
        System Markov parameters of Eq. 2 (in/lbf).
    hankel_sv_ : (s·k,) ndarray
        Singular values of ``H(0)``.
    order_, lags_ : int
    holdout_errors_ : (max_order,) ndarray or None
        Hold-out error of every order the rule tried (None when ``order`` is given).
    fit_residual_ : float
        Relative residual of the OKID least squares (Eq. 1) on the whole records.
    """

    abbreviation = "ERA"
    #: a free decay's ``predict(x0_new)`` (:mod:`podbench.sysid.methods.arrays`)
    array_form = ArrayForm(target="x0")
    #: the observer recursion (Eq. 2) amplifies the records' round-off (:data:`OKID_RCOND`):
    #: a study may write its errors at the digits a probed refit leaves in place
    amplifies_round_off = True
    floor_digits = 3
    """Significant digits its estimates are determined to: the observer recursion (Eq. 2)
    amplifies the records' round-off past the tables' sixth digit (measured between CPUs
    on the peers study, 3e-6…2.3e-5 relative: docs/noise.md), three digits put the
    written digit at least 40× above that floor."""
    _parameter_constraints = {"n_modes": INT_OR_NONE, "order": INT_OR_NONE,
                              "max_order": [Interval("integer", 1)], "lags": INT_OR_NONE,
                              "holdout": HOLDOUT,
                              "rcond": [Interval("number", 0, 1, closed="left")],
                              "excitation": [Options(*_EXCITATIONS)],
                              "blocks": [None, Interval("number", 0, closed="neither")],
                              "inputs": INPUTS}

    def __init__(self, *, n_modes=None, order=None, max_order=40, lags=None, holdout=0.25,
                 rcond=OKID_RCOND, excitation="forced", blocks=None, inputs="auto"):
        super().__init__(n_modes=n_modes, holdout=holdout, inputs=inputs)
        self.order = order
        self.max_order = max_order
        self.lags = lags
        self.rcond = rcond
        self.excitation = excitation
        self.blocks = blocks

    @property
    def excitation_kind(self) -> str:  # type: ignore[override]
        """``"free"`` for the free-decay variant, else ``"forced"``."""
        return "forced" if self.excitation == "forced" else "free"

    def required_fields(self) -> tuple[str, ...]:
        if self.excitation in _X0:
            return ("W", _X0[self.excitation])
        return super().required_fields()

    def refusal(self, records) -> str | None:
        return None if self.excitation in _X0 else super().refusal(records)

    def _modal(self, records) -> bool:
        # free decays are stacked as the modal-force records are: one shape
        return self.excitation in _X0 or super()._modal(records)

    def _training_records(self, records, name: str = "records"):
        if self.excitation in _X0:  # a displacement decay without w0 starts at W[:, 0]
            records = first_column_w0(records, self.excitation)
        return super()._training_records(records, name)

    def coupled_twin(self):
        """ML in the peer's basis (forced), MDS (free decay)."""
        if self.excitation in _X0:

            return MDS(excitation=self.excitation, n_modes=self.n_modes)
        return super().coupled_twin()

    # ------------------------------------------------------------------ identification
    def _lags(self, k: int) -> int:
        if self.lags is not None:
            return int(self.lags)
        top = max(self.max_order, self.order or 0)
        return int(np.ceil(top / k))

    def _blocks(self, n: int, dt: float) -> int:
        """Hankel block rows = columns: ``blocks`` seconds, at most half the record (the
        Markov parameters a record of ``n`` samples holds, ``h_1 … h_{n−1}``)."""
        half = max(1, (n - 1) // 2)
        if self.blocks is None:
            return half
        return max(1, min(int(round(self.blocks / dt)), half))

    def _order(self, Ys, Us, rank_cap: int, identify, respond, hankel: str):
        """``(order, hold-out errors)``: ``order`` if given (at most ``rank_cap``, the rows
        of ``hankel``), else the hold-out rule's choice over ``1 … max_order``."""
        if self.order is None:
            candidates = list(range(1, min(self.max_order, rank_cap) + 1))
            return self._select_by_holdout(Ys, Us, candidates, identify, respond,
                                           self.holdout)
        if self.order > rank_cap:
            raise InputError(f"Parameter `order`: {self.order} exceeds the {rank_cap} rows of "
                             f"{hankel}")
        return self.order, None

    def _factor(self, Ys, Us, lags, blocks):
        h, residual = okid_markov(Ys, Us, lags, 2 * blocks + 1, self.rcond)
        if not np.all(np.isfinite(h)):
            raise np.linalg.LinAlgError("OKID Markov parameters are not finite")
        return h, residual, era_realization(h, blocks)

    def _fit(self, records, basis) -> None:
        if self.excitation in _X0:
            self._fit_free(records, basis)
        else:
            super()._fit(records, basis)

    def command_line_params(self, records, *, solver: str = "auto", n_modes=None,
                            period: int | None = None) -> dict:
        """On measured inputs the Hankel matrix of :data:`ERA_BLOCKS` seconds. ``--n-modes
        K`` means K modes, as for every method: the realization order ``2K`` (a mode is a
        complex pole pair), not the size of the basis."""
        out = super().command_line_params(records, solver=solver, n_modes=None)
        if n_modes is not None:
            out["order"] = 2 * int(n_modes)
        if self.excitation == "forced" and not self._modal(records):
            out.update(inputs="measured", blocks=ERA_BLOCKS)
        return out

    def _realize_forced(self, Ys, Us, dt: float) -> dict:
        """OKID (Eqs. 1–2) and ERA (Eq. 3) from records in basis coordinates, the order by
        the hold-out rule: the realization and what was chosen."""
        k, n = Ys.shape[1], Ys.shape[2]
        lags = self._lags(k)
        if n < lags + 2:  # OKID's regression: at least two rows past the lags per record
            raise RecordTooShortError(f"ERA: a record of {n} samples is too short for OKID's "
                                      f"{lags} lags (need at least {lags + 2})", n, lags + 2)
        blocks = self._blocks(n, dt)
        factors: dict = {}  # the truncated records' factorization, shared by all orders

        def identify(Yf, Uf, cand):
            if not factors:
                factors["f"] = self._factor(Yf, Uf, lags, blocks)
            h, _, (P, sv, Qt, H1) = factors["f"]
            return realize(P, sv, Qt, H1, h[0], min(cand, int(np.sum(sv > 0))))

        def respond(mdl, Uin):  # every candidate order: by blocks (the loop's result)
            A, B, C, D = mdl
            return simulate_blocks(A, B, C, D, Uin)

        order, errors = self._order(Ys, Us, blocks * k, identify, respond,
                                    f"the Hankel matrix ({blocks} blocks of {k})")
        h, residual, (P, sv, Qt, H1) = self._factor(Ys, Us, lags, blocks)
        return {"model": realize(P, sv, Qt, H1, h[0], order), "markov": h, "sv": sv,
                "order": int(order), "lags": int(lags), "blocks": int(blocks),
                "errors": errors, "residual": residual}

    def _fit_modal(self, records, basis) -> None:
        """``(A, B, C, D)`` from forced records that start at rest (``W`` in in, ``F`` in
        lbf at the sensors, one ``dt`` in s), in the POMs of all training records."""
        U, povs, pocs, Ys, Us = self._modal_data(records, basis)
        r = self._realize_forced(Ys, Us, records[0].dt)
        self._set_basis(U, povs, pocs, records[0].dt)
        self.A_, self.B_, self.C_, self.D_ = r["model"]
        self.markov_ = r["markov"]
        self.hankel_sv_ = r["sv"]
        self.order_ = r["order"]
        self.lags_ = r["lags"]
        self.holdout_errors_ = r["errors"]
        self.fit_residual_ = r["residual"]

    def _identify_measured(self, Ys, Us, records) -> tuple:
        """``(A, B, C, D)`` from measured inputs (padded records in the outputs' POMs)."""
        r = self._realize_forced(Ys, Us, records[0].dt)
        self.A_, self.B_, self.C_, self.D_ = r["model"]
        self.order_, self.lags_ = r["order"], r["lags"]
        return r["model"], {"order": r["order"], "lags": r["lags"], "blocks": r["blocks"],
                            "fit_residual": float(r["residual"])}

    def _respond(self, model, Uin):
        return simulate(*model, Uin)

    def _model(self):
        return self.A_, self.B_, self.C_, self.D_

    def _fit_free(self, recs, basis) -> None:
        """ERA from free decays (Eqs. 4–5, then 3); the order by the hold-out rule."""
        U, povs, pocs = self._basis(recs, basis)
        field = _X0[self.excitation]
        k = U.shape[1]
        Ys = np.stack([U.T @ r.W for r in recs])  # (R, k, n)
        X0 = np.stack([U.T @ getattr(r, field) for r in recs])  # (R, k)
        if np.linalg.matrix_rank(X0) < k:
            raise InputError(f"ERA: the {len(recs)} initial profiles span fewer than k = {k} "
                             "directions of the basis; give more independent free decays or "
                             "fewer modes (`n_modes`)")
        n = Ys.shape[2]
        # the profile as an impulse at t_0, so that the shared hold-out rule can cut records
        Us = np.zeros_like(Ys)
        Us[:, :, 0] = X0

        def factor(Yf, X0f):
            h = free_markov(Yf, X0f)
            hh = np.concatenate([np.zeros((1, k, k)), h])  # hh[t+1] = h_t = C A^t B
            blocks = max(1, (hh.shape[0] - 1) // 2)
            return h, era_realization(hh, blocks)

        def respond(mdl, Uin):
            A, B, C = mdl
            return simulate_free(A, B, C, Uin[:, :, 0], Uin.shape[2])

        h, (P, sv, Qt, H1) = factor(Ys, X0)
        cache: dict = {}

        def identify(Yf, Uf, cand):
            if not cache:
                cache["f"] = factor(Yf, Uf[:, :, 0])
            _, (Pf, svf, Qtf, H1f) = cache["f"]
            N = min(cand, int(np.sum(svf > 0)))
            return realize(Pf, svf, Qtf, H1f, np.zeros((k, k)), N)[:3]

        order, errors = self._order(Ys, Us, P.shape[1], identify, respond,
                                    "the free-decay Hankel matrix")
        A, B, C, D = realize(P, sv, Qt, H1, np.zeros((k, k)), order)
        Yhat = simulate_free(A, B, C, X0, n)
        ny = float(np.linalg.norm(Ys))
        self._set_basis(U, povs, pocs, recs[0].dt)
        self.A_, self.B_, self.C_, self.D_ = A, B, C, D
        self.markov_ = h
        self.hankel_sv_ = sv
        self.order_ = int(order)
        self.lags_ = 0
        self.n_samples_ = n
        self.holdout_errors_ = errors
        self.fit_residual_ = float(np.linalg.norm(Yhat - Ys) / ny) if ny > 0 else 0.0

    def _predict_free(self, record) -> np.ndarray:
        rec = self._target_record(record, fields=False)
        x = getattr(rec, _X0[self.excitation])
        if x is None and self.excitation == "displacement" and rec.W is not None:
            x = rec.W[:, 0]
        if x is None:
            raise InputError(f"Parameter `record.{_X0[self.excitation]}`: ERA predicts a "
                             "free decay from its initial profile; the record has none")
        n = rec.n_samples or self.n_samples_
        m = self.modes_.shape[0]
        if x.shape != (m,):
            raise InputError(f"Parameter `x0_new`: expected shape ({m},) (one value per "
                             f"sensor), got {x.shape}")
        u = (self.modes_.T @ x)[None]
        return self.modes_ @ simulate_free(self.A_, self.B_, self.C_, u, n)[0]

    def _predict(self, record) -> np.ndarray:
        """Response to the forces of ``record`` (from rest): ``Ŵ = U Ŷ``, ``(m, n')`` in.
        Free decay: the response to the record's ``w0`` / ``v0`` (or a profile array),
        ``Ŵ_t = U C A^t B Uᵀx̃0``, as many samples as the record's ``W`` (or the training
        records')."""
        if self.excitation in _X0:
            return self._predict_free(record)
        return super()._predict(record)

    @property
    def diagnostics_(self) -> dict:
        """``n_modes``, ``order`` and ``lags`` (the rules' choices), ``fit_residual`` (OKID),
        ``holdout_error`` (of the chosen order), ``hankel_sv_ratio`` ``σ_{N+1}/σ_1`` and
        ``spectral_radius`` of ``A``. ``fit_residual`` of the free variant: the realization's
        relative error on the training decays. Measured inputs: ``n_modes`` and ``info_``."""
        out = super().diagnostics_
        if self._measured():
            return out
        out["order"] = self.order_
        out["lags"] = self.lags_
        sv = self.hankel_sv_
        N = self.order_
        out["hankel_sv_ratio"] = float(sv[N] / sv[0]) if N < sv.size and sv[0] > 0 else 0.0
        out["spectral_radius"] = float(np.max(np.abs(np.linalg.eigvals(self.A_))))
        if self.holdout_errors_ is not None:
            out["holdout_error"] = float(self.holdout_errors_[N - 1])
        return out

