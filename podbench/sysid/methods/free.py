"""Free-response methods (§3.2): POV recalculation (POVR) and the multiple data set method (MDS).

Both predict the response to a new initial displacement ``w̃0`` (in) or a new initial
velocity ``ẇ̃0`` (in/s) from responses to other initial conditions; neither needs Δt.
"""

from __future__ import annotations

import numpy as np

from podbench.core.records import Record, is_record
from podbench.core.validation import condition_number
from podbench.errors import IllConditionedError
from podbench.sysid.methods.bands import diagonal_inconsistency, diagonal_split
from podbench.sysid.methods.base import (
    BASES,
    ENERGY,
    MAX_COND,
    N_MODES,
    TOL,
    ArrayForm,
    PODMethod,
    as_int_list,
    check_energy,
    check_max_cond,
    check_n_modes,
    check_profile,
    check_profiles,
    check_tol,
    modal_share_too_small,
    per_record_basis,
    select_basis,
)
from podbench.sysid.params import Options

__all__ = ["POVR", "MDS"]

_EXCITATIONS = ("displacement", "velocity")
EXCITATIONS: list = [Options(*_EXCITATIONS)]
_X0 = {"displacement": "w0", "velocity": "v0"}  # the record field each excitation reads
# (noun, symbol, what of the POC is divided by) per excitation, for messages
_WORD = {
    "displacement": ("displacement", "w0", "value"),
    "velocity": ("velocity", "v0", "derivative"),
}


def first_column_w0(records, excitation: str) -> list:
    """The records as a list; for displacements a record without ``w0`` gets ``W[:, 0]``
    (the response's first sample is its initial displacement)."""
    recs = [records] if is_record(records) else list(records)
    if excitation != "displacement":
        return recs
    return [Record(W=r.W, w0=np.asarray(r.W, dtype=float)[:, 0])
            if getattr(r, "w0", None) is None else r for r in recs]


#: The dissertation's array forms: ``POVR().fit(W, x0)``, ``MDS().fit([W…], x0=[…])``,
#: ``predict(x0_new)`` (:mod:`podbench.sysid.methods.arrays`).
_ONE_RESPONSE = ArrayForm(positional=("x0",), target="x0")
_RESPONSES = ArrayForm(positional=("x0",), sets=True, target="x0")


class _FreeMethod(PODMethod):
    """What POVR and MDS share: the record field of the excitation, and a displacement
    record without ``w0`` taken to start at ``W[:, 0]``."""

    excitation: str

    def required_fields(self) -> tuple[str, ...]:
        return ("W", _X0[self.excitation]) if self.excitation in _X0 else ("W",)

    def _training_records(self, records, name: str = "records") -> list[Record]:
        return super()._training_records(first_column_w0(records, self.excitation), name)

    def _new_profile(self, record):
        self._check_is_fitted()
        if is_record(record):
            return getattr(self._target_record(record), _X0[self.excitation])
        return record

    @property
    def initial_field(self) -> str:
        """``"w0"`` or ``"v0"``, by ``excitation``."""
        return _X0.get(self.excitation, "w0")

    def projection_share(self, record) -> float | None:
        """The share of a target's initial displacement outside the basis,
        ``ρ = ‖(I − UUᵀ) w̃0‖ / ‖w̃0‖``: the relative error of the prediction at ``t = 0``,
        which no method in the basis ``U`` can avoid (its prediction lies in the span of
        ``U``; the truth starts at ``w̃0``); used by the error estimate
        (:data:`~podbench.sysid.methods.bands.PROJECTION_SHARE`). None for an initial
        velocity (the response starts at rest: nothing of it is known)."""
        if self.excitation != "displacement":
            return None
        x = check_profile(self._new_profile(record), self.modes_.shape[0], "x0_new")
        scale = float(np.linalg.norm(x))
        if scale == 0:
            return None
        return float(np.linalg.norm(x - self.modes_ @ (self.modes_.T @ x))) / scale

    def _predict(self, record) -> np.ndarray:
        """Response (in, ``(m, n)``) to the target's new initial displacement ``w0`` (in) or
        velocity ``v0`` (in/s) by ``excitation``: Eq. 3.11 (POVR), Eqs. 3.28–3.29 (MDS)."""
        x = check_profile(self._new_profile(record), self.modes_.shape[0], "x0_new")
        return self.modes_ @ self._modal_histories(x)

    def _modal_histories(self, x: np.ndarray) -> np.ndarray:
        """The modal response ``(k, n)`` to the new profile ``x`` by the method's rule."""
        raise NotImplementedError


class POVR(_FreeMethod):
    """Proper orthogonal value recalculation (§3.2.1–3.2.2, Eqs. 3.11–3.18, 3.24).

    The POMs ``u_j`` and POC histories ``v_j`` of one response are kept and only the POVs
    change (Eq. 3.11): ``W̃ = Σ_j σ̃_j u_j v_jᵀ`` with

    * initial displacement (Eq. 3.13): ``σ̃_j = u_jᵀ w̃0 / v_{j,0}``;
    * initial velocity (Eqs. 3.17–3.18): ``v̇_{j,0} = u_jᵀ ẇ0 / σ_j`` and
      ``σ̃_j = u_jᵀ ẇ̃0 / v̇_{j,0}``.

    Both are computed as ``σ̃_j = σ_j · (u_jᵀ x̃0) / (u_jᵀ x0)`` (Eq. 3.24), where ``x0`` is
    the training initial profile. For a displacement ``x0`` defaults to ``W[:, 0]``, and then
    ``u_jᵀ x0 = σ_j v_{j,0}`` makes this Eq. 3.13 exactly (as in the MATLAB). POVR assumes
    the modal state-transition matrices ``Φ11`` / ``Φ12`` are diagonal in the POM basis
    (identity-proportional mass, light proportional damping): see :class:`MDS` otherwise.

    Parameters
    ----------
    n_modes : int, optional
        Number of POMs ``k``. Default: the smallest ``k`` whose POVs hold ``energy`` of the
        signal (Eq. 2.3, σ-based); with ``basis`` given, ``basis.shape[1]``.
    excitation : {"displacement", "velocity"}
        Kind of initial condition used for training and prediction.
    energy : float
        Cumulative energy fraction used when ``n_modes`` is None (default 0.99).
    tol : float
        Guard on the divisor ``u_jᵀ x0`` (the initial POC value ``σ_j v_{j,0}`` or
        derivative ``σ_j v̇_{j,0}``): ``fit`` raises :class:`IllConditionedError` if
        ``|u_jᵀ x0| <= tol·‖x0‖₂`` for some mode (default 1e-6), i.e. when the training
        initial condition has (almost) no share in a mode that the response contains.

    Attributes
    ----------
    modes_ : (m, k) ndarray
        POMs ``u_j``.
    povs_ : (k,) ndarray
        POVs ``σ_j`` of the training response (in).
    pocs_ : (n, k) ndarray
        POC histories ``v_j`` (dimensionless).
    initial_coordinates_ : (k,) ndarray
        ``u_jᵀ x0`` (in or in/s): ``σ_j v_{j,0}`` (displacement) or ``σ_j v̇_{j,0}``
        (velocity).
    Phi_ : (n, k, k) ndarray
        The diagonal ``Φ11(t_i)`` (displacement, Eq. 3.21) or ``Φ12(t_i)`` (velocity, s)
        POVR implies: ``σ_j v_j(t_i) / (u_jᵀ x0)`` on the diagonal.
    n_modes_ : int

    Examples
    --------
    >>> model = POVR(n_modes=3, excitation="displacement").fit(W, w0)  # doctest: +SKIP
    >>> W_new = model.predict(w0_new)                                  # doctest: +SKIP
    """

    abbreviation = "POVR"
    excitation_kind = "free"
    n_records = (1, 1)
    array_form = _ONE_RESPONSE
    _parameter_constraints = {"n_modes": N_MODES, "excitation": EXCITATIONS,
                              "energy": ENERGY, "tol": TOL}

    def __init__(self, *, n_modes=None, excitation="displacement", energy=0.99, tol=1e-6):
        self.n_modes = n_modes
        self.excitation = excitation
        self.energy = energy
        self.tol = tol

    def coupled_twin(self) -> MDS:
        """MDS for the same excitation (Φ11 / Φ12 without the diagonal assumption)."""
        return MDS(excitation=self.excitation, n_modes=self.n_modes)

    def _fit(self, records, basis) -> None:
        """One free response (``W`` in in; ``w0`` in in or ``v0`` in in/s by ``excitation``;
        a displacement record without ``w0`` starts at ``W[:, 0]``)."""
        rec = records[0]
        self._identify(rec.W, check_profile(getattr(rec, _X0[self.excitation]),
                                            rec.W.shape[0], "x0"), basis)

    def _identify(self, W, x0, basis) -> None:
        n_modes = check_n_modes(self.n_modes)
        energy = check_energy(self.energy)
        tol = check_tol(self.tol)
        word, sym, what = _WORD[self.excitation]
        U, povs, pocs = select_basis(W, n_modes, basis, energy=energy)
        scale = float(np.linalg.norm(x0))
        if scale == 0:
            raise IllConditionedError(
                f"Parameter `x0`: the initial {word} profile is zero; POVR cannot scale the "
                "POVs (Eqs. 3.13/3.17)"
            )
        a = U.T @ x0
        bad = modal_share_too_small(a, scale, tol)
        if np.any(bad):
            j = int(np.flatnonzero(bad)[0])
            raise IllConditionedError(
                f"POVR: the initial POC {what} of mode(s) {as_int_list(bad)} is too small to "
                f"divide by: |u_jᵀ{sym}| = {abs(a[j]):.3g} <= tol·‖{sym}‖ = {tol * scale:.3g} "
                f"(tol = {tol:g}). The training initial {word} barely excites this mode, so "
                "the response in it comes from modal coupling, which POVR ignores; use MDS "
                "(several data sets) or fewer modes"
            )
        k, n = U.shape[1], W.shape[1]
        self._set_basis(U, povs, pocs)
        self.initial_coordinates_ = a
        Phi = np.zeros((n, k, k))
        idx = np.arange(k)
        Phi[:, idx, idx] = (pocs * povs) / a
        self.Phi_ = Phi

    def new_povs(self, x0_new) -> np.ndarray:
        """Recalculated POVs ``σ̃_j`` for a new initial profile (Eqs. 3.13 / 3.17), (k,)."""
        self._check_is_fitted()
        x = check_profile(x0_new, self.modes_.shape[0], "x0_new")
        return self.povs_ * (self.modes_.T @ x) / self.initial_coordinates_

    def diagonal_inconsistency(self, record) -> float:
        """How far the new initial profile's modal coordinates ``Uᵀx0'`` are from the
        training ones ``Uᵀx0`` in pattern
        (:func:`~podbench.sysid.methods.bands.diagonal_inconsistency`): the model-form term
        of POVR's band, which one record cannot cross-validate."""
        self._check_is_fitted()
        x = check_profile(self._new_profile(record), self.modes_.shape[0], "x0_new")
        return diagonal_inconsistency(self.initial_coordinates_, self.modes_.T @ x)

    def diagonal_parts(self, record) -> tuple[np.ndarray, np.ndarray]:
        """``(Ŵ_⊥, T²)`` of :func:`~podbench.sysid.methods.bands.diagonal_split` for the
        new initial profile: POVR's response (in) to the part of ``Uᵀx0'`` outside the
        training coordinates ``Uᵀx0``, and the squared response (in²) to each mode's share
        of that part applied in the training pattern (Eq. 3.24, exact on that pattern)."""
        self._check_is_fitted()
        x = check_profile(self._new_profile(record), self.modes_.shape[0], "x0_new")
        scale = self.povs_ / self.initial_coordinates_
        return diagonal_split(self.initial_coordinates_, self.modes_.T @ x,
                              lambda b: self.modes_ @ ((scale * b)[:, None] * self.pocs_.T))

    def _modal_histories(self, x: np.ndarray) -> np.ndarray:
        """``σ̃_j v_j`` (Eq. 3.11), ``(k, n)``."""
        return self.new_povs(x)[:, None] * self.pocs_.T


class MDS(_FreeMethod):
    """Multiple data set method (§3.2.3, Eqs. 3.25–3.33).

    With the POMs ``U`` (``m × k``) of the first data set, every data set ``j`` is projected,
    ``ʲV̂ᵀ = Uᵀ ʲW`` (Eq. 3.25), and its initial profile too, ``ʲv̂0 = Uᵀ ʲx0``
    (Eq. 3.31). At every sample ``t_i``

        ``Φ(t_i) = [¹V̂(:, i) … ᵏV̂(:, i)] V̂0⁻¹``,   ``V̂0 = [¹v̂0 … ᵏv̂0]``

    (Eqs. 3.27 / 3.32; ``Φ11`` for displacements, ``Φ12`` for velocities) and the new
    response is ``W̃(:, i) = U Φ(t_i) Uᵀ x̃0`` (Eqs. 3.28–3.29, 3.33). No diagonal assumption:
    for a linear system and ``k`` equal to the number of sensors the prediction is exact.

    ``k`` is the number of data sets by default (as in the dissertation). With more data
    sets than modes, ``V̂0⁻¹`` becomes the pseudo-inverse (least squares over the data sets),
    an extension of the dissertation.

    Parameters
    ----------
    excitation : {"displacement", "velocity"}
        Kind of initial condition of every data set (``w0`` or ``v0``), used for training
        and prediction.
    n_modes : int, optional
        ``k``; default the number of data sets (or ``basis.shape[1]``). Must not exceed the
        number of data sets.
    max_cond : float
        ``fit`` raises :class:`IllConditionedError` if the 2-norm condition number of
        ``V̂0`` exceeds this (default 1e10): the initial profiles are (nearly) linearly
        dependent in the POM basis.
    basis : {"first", "all"}
        Where the POMs come from when ``fit`` gets no ``basis=``: ``"first"`` (default, the
        dissertation's) the POMs of the first data set; ``"all"`` the leading POMs of all
        data sets side by side, ``[¹W ²W …]`` (beyond the dissertation). ``fit(…, basis=U)``
        overrides both. (POVR has one data set: there the two coincide.)

    Attributes
    ----------
    modes_ : (m, k) ndarray
        POMs of the first data set (or of all, ``basis="all"``).
    povs_ : (k,) ndarray
        POVs of the first data set (in).
    pocs_ : (n, k) ndarray
        POC histories of the first data set.
    initial_coordinates_ : (k, n_sets) ndarray
        ``V̂0`` (in or in/s).
    Phi_ : (n, k, k) ndarray
        ``Φ11(t_i)`` (dimensionless) or ``Φ12(t_i)`` (s).
    condition_number_ : float
        2-norm condition number of ``V̂0``.
    n_modes_ : int
    """

    abbreviation = "MDS"
    excitation_kind = "free"
    coupled = True
    records_per_mode = True
    array_form = _RESPONSES
    _parameter_constraints = {"excitation": EXCITATIONS, "n_modes": N_MODES,
                              "max_cond": MAX_COND, "basis": BASES}

    def __init__(self, *, excitation="displacement", n_modes=None, max_cond=1e10,
                 basis="first"):
        self.excitation = excitation
        self.n_modes = n_modes
        self.max_cond = max_cond
        self.basis = basis

    def _fit(self, records, basis) -> None:
        """Several free responses (``W`` in in; ``w0`` in in or ``v0`` in in/s by
        ``excitation``), all of one shape."""
        self._identify([r.W for r in records],
                       [getattr(r, _X0[self.excitation]) for r in records], basis)

    def _identify(self, Ws, x0, basis) -> None:
        n_modes = check_n_modes(self.n_modes)
        max_cond = check_max_cond(self.max_cond)
        n_sets = len(Ws)
        m, n = Ws[0].shape
        word, sym, _ = _WORD[self.excitation]
        X0 = np.column_stack(check_profiles(x0, n_sets, m, "x0"))
        too_few = ("MDS: fewer data sets ({n_sets}) than modes ({k}); Φ (k × k) needs at least "
                   "k = {k} responses to linearly independent initial " + word + "s (Eq. 3.26)")
        U, povs, pocs = per_record_basis(Ws, n_modes, basis, self.basis, too_few)
        k = U.shape[1]
        V0 = U.T @ X0  # k × n_sets
        s = np.linalg.svd(V0, compute_uv=False)
        cond = condition_number(s)
        if not cond <= max_cond:
            raise IllConditionedError(
                f"MDS: the initial {word} profiles are (nearly) linearly dependent in the POM "
                f"basis: condition number of V̂0 = Uᵀ[{sym}¹ … {sym}ᴺ] is {cond:.3g} > "
                f"max_cond = {max_cond:g}; use linearly independent initial {word}s"
            )
        Vh = np.stack([U.T @ Wj for Wj in Ws])  # n_sets × k × n
        V0_inv = np.linalg.solve(V0, np.eye(k)) if n_sets == k else np.linalg.pinv(V0)
        # Φ(t_i) = [¹V̂(:,i) … ᴺV̂(:,i)] V̂0⁻¹ for every i at once
        self.Phi_ = np.einsum("jki,jl->ikl", Vh, V0_inv)
        self._set_basis(U, povs, pocs)
        self.initial_coordinates_ = V0
        self.condition_number_ = cond

    def fold_predictions(self, records, basis, frozen=None) -> list[np.ndarray] | None:
        """The leave-one-record-out predictions of a prediction band
        (:mod:`~podbench.sysid.methods.bands`): record ``j`` predicted by a copy of this
        model fitted in ``basis`` to the other records, without refitting. Each fold's
        prediction is linear in the other records: ``W̃_j = U Σ_l c_l V̂_l`` with
        ``V̂_l = Uᵀ ˡW`` and ``c = V̂0,j⁻¹ Uᵀ ʲx0`` (``V̂0,j`` the fold's initial coordinates,
        Eqs. 3.27–3.29), so the projections are computed once and each fold solves one
        small system — the refit's prediction to round-off. None (refit each fold, which
        raises the fold's own error) when a fold's ``V̂0`` fails ``max_cond`` or has fewer
        columns than ``basis`` (frozen choices: MDS has none)."""
        recs = self._training_records(records)
        U = np.asarray(basis, dtype=float)
        k, n_sets = U.shape[1], len(recs)
        max_cond = check_max_cond(self.max_cond)
        x0 = [getattr(r, _X0[self.excitation]) for r in recs]
        targets = [getattr(r, _X0[self.excitation], None) for r in records]
        if n_sets - 1 < k or any(x is None for x in targets):
            return None
        X0 = np.column_stack(check_profiles(x0, n_sets, U.shape[0], "x0"))
        V0 = U.T @ X0  # k × N
        Vh = np.einsum("mk,jmn->jkn", U, np.stack([np.asarray(r.W, float) for r in recs]))
        out = []
        for j in range(n_sets):
            rest = [l for l in range(n_sets) if l != j]
            V0j = V0[:, rest]
            if not condition_number(np.linalg.svd(V0j, compute_uv=False)) <= max_cond:
                return None
            V0_inv = np.linalg.solve(V0j, np.eye(k)) if n_sets - 1 == k else np.linalg.pinv(V0j)
            c = V0_inv @ (U.T @ check_profile(targets[j], U.shape[0], "x0_new"))
            out.append(U @ np.einsum("l,lkn->kn", c, Vh[rest]))
        return out

    def _modal_histories(self, x: np.ndarray) -> np.ndarray:
        """``Φ(t_i) Uᵀ x̃0`` at every sample (Eqs. 3.28–3.29), ``(k, n)``."""
        return (self.Phi_ @ (self.modes_.T @ x)).T
