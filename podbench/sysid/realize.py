"""Fitted methods as discrete state-space models ``(A, B, C, D, Δt)``, and their modes.

What each fitted method is as a state-space model (read from its fitted attributes, so that
any class with them realizes):

* **a kernel** (the forced POD methods: ML, SL, MR's forced part on displacement/force
  records, ``kernel_`` (k, k, n); ML and the FIR baseline on input/output records,
  ``kernel_`` (k, n_in, L) from lag ``first_lag_``): its Markov parameters
  ``h[p] = Δt·kernel[:, :, p]`` (Eq. 3.39's Δt; ``h[0] = D``, ``h[p] = C A^{p−1} B``) are
  realized by ERA (:func:`podbench.sysid.statespace.era_realization`, the realization code
  the substructuring and realization solvers share) in the method's POC coordinates, and
  mapped to the channels: ``y = U (C x + D u)`` and, where the inputs are forces at the
  sensors, ``u = Uᵀ F``. SL's and MR's kernels are diagonal (their assumption): the
  diagonal is realized. Order: ``order`` if given, else the **lag rule**: the lowest even
  order whose realized Markov parameters reproduce the kernel over *all* its lags within
  1 % of the best of the orders up to the numerical rank of the Hankel matrix (singular
  values above :data:`~podbench.sysid.components.KERNEL_RANK_TOL` of the largest;
  directions below are round-off of the kernel), at most :data:`MAX_ORDER` (reproduction
  errors below 1e-9 count as equal: the peers' hold-out tolerances,
  :data:`~podbench.sysid.methods.peers._common.HOLDOUT_RTOL`). ERA builds its Hankel matrix
  from the first lags only (at most
  :data:`~podbench.sysid.deconvolution.realization.MAX_HANKEL_ROWS` rows), so the later lags
  judge the order on data the realization did not use. A kernel that a pole solver returned
  (``"realization"``, ``"subspace"``) is a low-order model: the rule finds its order. The
  other orders of the same Hankel matrix give the stabilization check of
  :mod:`podbench.sysid.modal`.
* **ERA/OKID** (``A_, B_, C_, D_`` in the basis, or ``model_ = (A, B, C, D)`` on
  input/output records): the model itself, outputs mapped by ``U`` (and inputs by ``Uᵀ`` on
  displacement/force records). Its Markov parameters (``markov_`` where kept) give the
  stabilization check; a model without them gets the hard criteria only.
* **free responses** (POVR, MDS: ``Phi_`` (n, k, k), ``Φ(t_i)``; ERA's free-decay variant):
  the autonomous model ``x_{j+1} = A x_j``, ``ŵ_j = U C x_j``, started at ``x_0 = X₀ x̃0``
  from the new initial displacement (in) or velocity (in/s) ``x̃0`` (``X₀ = B Uᵀ``): ERA of
  the free-decay sequence ``Φ(t_i) = C A^i B`` (the free variant of
  :mod:`podbench.sysid.methods.peers.era`, Eq. 5). No ``B`` and ``D``: a free response has
  no input. Their records need ``dt`` (a frequency needs the sampling interval).

Not realized, each with its one-line reason: a superposition (realize its parts); DMDc and
OpInf (delay coordinates whose step input holds the next force sample ``u_{j+1}``: no causal
``(A, B, C, D)`` in the sampled inputs).

The realized model reproduces the method's own prediction where the method's model is
exactly of the realized order (clean records of a linear structure, a kernel over the whole
record, ``k`` = the number of sensors): :class:`StateSpaceModel` ``.respond``. A truncated
kernel (``n_lags``) or a noisy one is approximated by the order its own later lags
support.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)

from podbench.core.modeshapes import ModeSet
from podbench.errors import InputError
from podbench.sysid.components import KERNEL_RANK_TOL
from podbench.sysid.deconvolution.realization import MAX_HANKEL_ROWS
from podbench.sysid.methods.peers._common import HOLDOUT_FLOOR, HOLDOUT_RTOL
from podbench.sysid.modal import discrete_modes, physical_modes
from podbench.sysid.statespace import era_realization, realize

__all__ = ["StateSpaceModel", "to_statespace", "kernel_markov", "markov_parameters",
           "POLE_SOLVERS", "MAX_ORDER", "COPIES_RULES"]

POLE_SOLVERS = ("realization", "subspace")
"""Deconvolution solvers whose kernel is a low-order pole model."""

MAX_ORDER = 200
"""Largest realization order the lag rule tries (100 complex pole pairs)."""

COPIES_RULES = ("merge", "each")
"""How :meth:`StateSpaceModel.modes` reads a pole the realization holds several times:
one mode shaped by its residue (``"merge"``, the rule), or every copy a mode (``"each"``,
the named variant)."""


@dataclass(frozen=True, eq=False)
class StateSpaceModel:
    """A discrete state-space model ``x_{j+1} = A x_j + B u_j``, ``y_j = C x_j + D u_j``
    sampled at ``dt`` (s), from rest (``x_0 = 0``); or, without ``B`` and ``D``, the
    autonomous model of free responses started at ``x_0 = x0_map @ x̃0``.

    Attributes
    ----------
    A : (N, N) ndarray
    B : (N, n_in) ndarray or None
    C : (n_out, N) ndarray
    D : (n_out, n_in) ndarray or None
    dt : float
        Sampling interval (s).
    x0_map : (N, n_out) ndarray or None
        Free models: the initial state of an initial profile at the outputs.
    input_channels, output_channels : tuple of str
    input_units, output_units : str
        Units of ``u`` (or of the initial profile) and of ``y``.
    method : str
        The method realized (its abbreviation).
    realization : str
        How (e.g. ``"ERA of the kernel, order 10"``).
    notes : tuple of str
    """

    A: np.ndarray
    B: np.ndarray | None
    C: np.ndarray
    D: np.ndarray | None
    dt: float
    x0_map: np.ndarray | None = None
    input_channels: tuple[str, ...] = ()
    output_channels: tuple[str, ...] = ()
    input_units: str = ""
    output_units: str = ""
    method: str = ""
    realization: str = ""
    notes: tuple[str, ...] = ()
    realize_at: Callable[[int], tuple] | None = field(default=None, repr=False)

    @property
    def order(self) -> int:
        """The state dimension ``N``."""
        return int(self.A.shape[0])

    @property
    def is_free(self) -> bool:
        """True for the autonomous model of free responses (no ``B``, ``D``)."""
        return self.B is None

    def respond(self, u) -> np.ndarray:
        """Zero-state response to the inputs ``u`` (n_in × n): ``y`` (n_out × n)."""
        B, D = self.B, self.D
        if B is None or D is None:
            raise InputError(f"{self.method}: a free-response model has no input; use "
                             "respond_free(x0, n)")
        u = np.asarray(u, dtype=float)
        if u.ndim != 2 or u.shape[0] != B.shape[1]:
            raise InputError(f"Parameter `u`: expected ({B.shape[1]}, n) inputs, got "
                             f"{u.shape}")
        x = np.zeros(self.order)
        BU = B @ u
        X = np.empty((self.order, u.shape[1]))
        for j in range(u.shape[1]):
            X[:, j] = x
            x = self.A @ x + BU[:, j]
        return self.C @ X + D @ u

    def respond_free(self, x0, n: int) -> np.ndarray:
        """The free response (n_out × n) to the initial profile ``x0`` (n_out,)."""
        if not self.is_free:
            raise InputError(f"{self.method}: a forced model responds to inputs; use respond(u)")
        x = self.x0_map @ np.asarray(x0, dtype=float)
        out = np.empty((self.C.shape[0], int(n)))
        for j in range(int(n)):
            out[:, j] = self.C @ x
            x = self.A @ x
        return out

    def all_modes(self) -> ModeSet:
        """Every oscillatory pole of ``A`` with its shape at the outputs
        (:func:`podbench.sysid.modal.discrete_modes`)."""
        return discrete_modes(self.A, self.C, self.dt, self.output_channels,
                              source=f"{self.method}: {self.realization}")

    def modes(self, criteria: dict | None = None, *, copies: str = "merge") -> ModeSet:
        """The physical modes (:func:`podbench.sysid.modal.physical_modes`: hard criteria
        and stability at higher orders of the same realization).

        ``copies``: ``"merge"`` (the rule), a pole the realization holds several times is
        one mode shaped by its residue (:mod:`podbench.sysid.modal`, *One pole, one mode*;
        the input map ``B``, or ``x0_map`` of a free model, gives the residue); the named
        variant ``"each"``, every copy a mode of its own shape ``C ψ`` (the former reading:
        for a diagonal kernel one mode per POC holding the pole, shaped by that POM)."""
        if copies not in COPIES_RULES:
            raise InputError(f"Parameter `copies`: expected one of {list(COPIES_RULES)}, "
                             f"got {copies!r}")
        B = self.B if self.B is not None else self.x0_map
        out = physical_modes(self.A, self.C, self.dt, self.output_channels,
                             realize_at=self.realize_at, criteria=criteria,
                             source=f"{self.method}: {self.realization}",
                             B=B if copies == "merge" else None)
        return out.with_notes(*self.notes)

    def to_dlti(self) -> scipy.signal.dlti:
        """The model as :class:`scipy.signal.dlti` (``dt`` in s)."""
        if self.is_free:
            raise InputError(f"{self.method}: a free-response model has no input, and "
                             "scipy.signal.dlti needs one (use A, C and x0_map)")
        return scipy.signal.dlti(self.A, self.B, self.C, self.D, dt=self.dt)

    def to_control(self):
        """The model as python-control's ``StateSpace`` (needs the ``control`` package)."""
        if self.is_free:
            raise InputError(f"{self.method}: a free-response model has no input, and "
                             "control.StateSpace needs one (use A, C and x0_map)")
        try:
            import control  # type: ignore[import-untyped]
        except ImportError:
            raise InputError("to_control needs python-control: pip install control") from None
        return control.ss(self.A, self.B, self.C, self.D, self.dt)


# ---------------------------------------------------------------------------- ERA
def _era_factors(h: np.ndarray):
    """ERA's Hankel factors of the Markov parameters ``h`` (L, p, q): block rows as many as
    the lags allow with at most :data:`MAX_HANKEL_ROWS` rows."""
    L, p, q = h.shape
    s = max(1, min((L - 1) // 2, MAX_HANKEL_ROWS // max(p, q)))
    if L < 3:
        raise InputError(f"a kernel of {L} lags is too short to realize (ERA needs 3)")
    P, sv, Qt, H1 = era_realization(h[: 2 * s + 1], s)
    rank = int(np.sum(sv > KERNEL_RANK_TOL * sv[0])) if sv.size and sv[0] > 0 else 0
    return (P, sv, Qt, H1, h[0]), rank


def _realizer(factors, out_map: np.ndarray):
    """``order → (A, U C, B)`` from ERA's factors (the stabilization check's other orders;
    ``B`` in the method's coordinates: a residue's left singular vectors do not depend on
    the inputs' orthonormal map)."""
    P, sv, Qt, H1, D = factors

    def at(order: int):
        if order > sv.size:
            raise InputError(f"order {order} exceeds the Hankel matrix's {sv.size} rows")
        A, B, C, _ = realize(P, sv, Qt, H1, D, order)
        return A, out_map @ C, B

    return at


def kernel_markov(method) -> tuple[np.ndarray, str]:
    """The Markov parameters ``h[p]`` (L, k_out, k_in) of a fitted kernel method in its POC
    coordinates (module docstring) and what they are, in words. Trailing lags that are
    exactly zero are dropped: a truncated kernel (``n_lags``) is zero by construction beyond
    its lags, and the last lags of a kernel over the whole record are undetermined (zero,
    the minimum-norm solution) when the forces start after the first sample; neither is
    data a realization should reproduce."""
    K = np.asarray(method.kernel_, dtype=float)
    dt = float(method.dt_)
    first = getattr(method, "first_lag_", None)
    if first is not None:  # input/output records: kernel_[:, :, j] is lag first + j
        h = np.zeros((K.shape[2] + int(first), K.shape[0], K.shape[1]))
        h[int(first):] = dt * K.transpose(2, 0, 1)
        what = "kernel (measured inputs → POC histories)"
    else:
        h = dt * K.transpose(2, 0, 1)
        what = "kernel (modal forces → POC histories)"
        if not getattr(method, "coupled", True):
            idx = np.arange(K.shape[0])
            diag = np.zeros_like(h)
            diag[:, idx, idx] = h[:, idx, idx]
            h, what = diag, "diagonal kernel (modal forces → POC histories)"
    nonzero = np.flatnonzero(np.any(h.reshape(h.shape[0], -1) != 0, axis=1))
    last = int(nonzero[-1]) + 1 if nonzero.size else 0
    return h[: max(last, 3)], what


def _is_pole_model(method) -> bool:
    info = getattr(method, "solver_info_", None)
    if info is None:
        info = getattr(method, "info_", None)
    infos = info if isinstance(info, list) else [info]
    dicts = [i for i in infos if isinstance(i, dict)]
    if not dicts or len(dicts) != len(infos):
        return False
    return all((i.get("choice") in POLE_SOLVERS or i.get("solver") in POLE_SOLVERS)
               and "order" in i for i in dicts)


def markov_parameters(A, B, C, D, n: int) -> np.ndarray:
    """``h[0] = D``, ``h[p] = C A^{p−1} B`` for ``p < n``: (n, n_out, n_in), by the
    eigen-decomposition of ``A`` (by the recursion where its eigenvectors are
    ill-conditioned)."""
    A, B, C, D = (np.asarray(x, dtype=float) for x in (A, B, C, D))
    h = np.empty((n, C.shape[0], B.shape[1]))
    h[0] = D
    if n < 2:
        return h
    lam, V = np.linalg.eig(A)
    if A.size == 0:
        h[1:] = 0.0
    elif np.linalg.cond(V) < 1e10:
        with np.errstate(over="ignore", invalid="ignore"):
            powers = lam[:, None] ** np.arange(n - 1)[None, :]
            h[1:] = np.einsum("on,nl,ni->loi", C @ V, powers, np.linalg.solve(V, B)).real
    else:
        X = B.copy()
        with np.errstate(over="ignore", invalid="ignore"):
            for p in range(1, n):
                h[p] = C @ X
                X = A @ X
    return h


def _reproduction_error(factors, order: int, h: np.ndarray) -> float:
    P, sv, Qt, H1, D = factors
    A, B, C, D = realize(P, sv, Qt, H1, D, order)
    hN = markov_parameters(A, B, C, D, h.shape[0])
    if not np.all(np.isfinite(hN)):
        return float("inf")
    with np.errstate(over="ignore", invalid="ignore"):
        err = float(np.linalg.norm(hN - h) / max(float(np.linalg.norm(h)), 1e-300))
    return err if np.isfinite(err) else float("inf")


def _kernel_order(order, factors, rank: int, h: np.ndarray) -> tuple[int, str]:
    """The realization order: given, or the lag rule (module docstring)."""
    rows = factors[1].size
    if isinstance(order, str) and order == "rank":
        N = max(2, min(rank, rows, MAX_ORDER) // 2 * 2)
        return N, (f"order {N} (the numerical rank of the kernel's Hankel matrix, even, at "
                   f"most {MAX_ORDER})")
    if order is not None:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
            raise InputError(f"Parameter `order`: expected an integer >= 1, got {order!r}")
        if order > rows:
            raise InputError(f"Parameter `order`: {order} exceeds the {rows} rows of the "
                             "kernel's Hankel matrix")
        return int(order), f"order {int(order)} (given)"
    top = min(rank, rows, MAX_ORDER)
    cands = list(range(2, top + 1, 2)) or [max(top, 1)]
    errors = np.array([_reproduction_error(factors, N, h) for N in cands])
    if not np.any(np.isfinite(errors)):
        raise InputError("no realization order reproduces the kernel with finite Markov "
                         "parameters")
    bound = max(float(np.min(errors)) * (1.0 + HOLDOUT_RTOL), HOLDOUT_FLOOR)
    i = int(np.flatnonzero(errors <= bound)[0])
    return cands[i], (f"order {cands[i]} (the lowest whose Markov parameters reproduce the "
                      f"kernel's {h.shape[0]} lags within 1 % of the best of orders 2-{top}: "
                      f"relative error {errors[i]:.3g})")


# ---------------------------------------------------------------------------- channels
def _io_sides(method, m_out: int, free: str | None = None) -> dict:
    """Channels and units of the realized model's inputs and outputs."""
    ref = getattr(method, "reference_", None)
    if ref is not None and hasattr(ref, "input_channels"):
        return {"input_channels": tuple(ref.input_channels),
                "output_channels": tuple(ref.output_channels),
                "input_units": str(ref.input_units), "output_units": str(ref.output_units)}
    chans = tuple(str(i) for i in range(m_out))
    in_units = {"displacement": "in", "velocity": "in/s"}.get(free or "", "lbf")
    return {"input_channels": chans, "output_channels": chans, "input_units": in_units,
            "output_units": "in"}


def _realize_kernel(method, order) -> StateSpaceModel:
    h, what = kernel_markov(method)
    U = np.asarray(method.modes_, dtype=float)
    factors, rank = _era_factors(h)
    P, sv, Qt, H1, D0 = factors
    N, how = _kernel_order(order, factors, rank, h)
    A, B, C, D = realize(P, sv, Qt, H1, D0, N)
    sides = _io_sides(method, U.shape[0])
    on_forces = getattr(method, "first_lag_", None) is None  # u = Uᵀ F at the sensors
    Bf, Df = (B @ U.T, U @ D @ U.T) if on_forces else (B, U @ D)
    notes = (("the kernel is a pole solver's model (its order chosen by the solver's own "
              "hold-out rule): the order check passes its poles by construction",)
             if _is_pole_model(method) else ())
    return StateSpaceModel(A, Bf, U @ C, Df, float(method.dt_), None, method=_name(method),
                           realization=f"ERA of the {what}, {how}", notes=notes,
                           realize_at=_realizer(factors, U), **sides)


def _realize_era(method) -> StateSpaceModel:
    U = np.asarray(method.modes_, dtype=float)
    free = getattr(method, "excitation", "forced")
    if hasattr(method, "C_"):
        A, B, C, D = method.A_, method.B_, method.C_, method.D_
    else:
        A, B, C, D = (np.asarray(x, dtype=float) for x in method.model_)
    markov = getattr(method, "markov_", None)
    at: Callable | None = None
    notes: tuple[str, ...] = ()
    if markov is not None:
        hh = np.asarray(markov, dtype=float)
        if free != "forced":  # free decays: hh[t + 1] = h_t (the class's own layout)
            hh = np.concatenate([np.zeros((1,) + hh.shape[1:]), hh])
        at = _realizer(_era_factors(hh)[0], U)
    else:
        notes = ("the fitted model keeps no Markov parameters: no stabilization check",)
    name, dt = _name(method), float(method.dt_)
    how = f"the method's own realization, order {A.shape[0]}"
    if free in ("displacement", "velocity"):
        return StateSpaceModel(A, None, U @ C, None, dt, B @ U.T, method=name,
                               realization=how, notes=notes, realize_at=at,
                               **_io_sides(method, U.shape[0], free))
    sides = _io_sides(method, U.shape[0])
    if hasattr(method, "C_") and getattr(method, "inputs_", "modal") != "measured":
        # inputs are the modal forces Uᵀ F
        return StateSpaceModel(A, B @ U.T, U @ C, U @ D @ U.T, dt, None, method=name,
                               realization=how, notes=notes, realize_at=at, **sides)
    return StateSpaceModel(A, B, U @ C, U @ D, dt, None, method=name, realization=how,
                           notes=notes, realize_at=at, **sides)


def _free_dt(method, dt):
    if dt is not None:
        return float(dt)
    if getattr(method, "dt_", None) is not None:
        return float(method.dt_)
    recs = getattr(method, "training_records_", None) or []
    dts = [getattr(r, "dt", None) for r in recs]
    if dts and dts[0] is not None:
        return float(dts[0])
    raise InputError(f"{_name(method)}: the training records carry no dt; give `dt` (s): "
                     "a mode's frequency needs the sampling interval")


def _realize_free(method, order, dt) -> StateSpaceModel:
    Phi = np.asarray(method.Phi_, dtype=float)  # (n, k, k): Φ(t_i)
    U = np.asarray(method.modes_, dtype=float)
    k = Phi.shape[1]
    hh = np.concatenate([np.zeros((1, k, k)), Phi])  # hh[t + 1] = Φ(t_t) = C A^t B
    factors, rank = _era_factors(hh)
    P, sv, Qt, H1, D0 = factors
    N, how = _kernel_order(order, factors, rank, hh)
    A, B, C, _ = realize(P, sv, Qt, H1, D0, N)
    excitation = getattr(method, "excitation", "displacement")
    return StateSpaceModel(A, None, U @ C, None, _free_dt(method, dt), B @ U.T,
                           method=_name(method),
                           realization=f"ERA of the free-decay matrices Φ(t_i), {how}",
                           realize_at=_realizer(factors, U),
                           **_io_sides(method, U.shape[0], excitation))


def _is_state_space(method) -> bool:
    """ERA's fitted realization (``A_ … D_``) or a 4-tuple ``model_`` of an input/output
    peer (not a delay-coordinate model: those have ``delays``)."""
    if all(hasattr(method, a) for a in ("A_", "B_", "C_", "D_")):
        return True
    model = getattr(method, "model_", None)
    return isinstance(model, tuple) and len(model) == 4 and not hasattr(method, "delays")


def _name(method) -> str:
    return str(getattr(method, "abbreviation", "") or type(method).__name__)


def to_statespace(method, *, order: int | None = None,
                  dt: float | None = None) -> StateSpaceModel:
    """The fitted ``method`` as a discrete state-space model (module docstring).

    Parameters
    ----------
    method : fitted estimator
        A fitted podbench method (or any class with the same fitted attributes).
    order : int or "rank", optional
        Realization order of a kernel or free-decay sequence (default: the module
        docstring's lag rule; ``"rank"``: the numerical rank of the Hankel matrix, even, at
        most :data:`MAX_ORDER`, one realization instead of the lag rule's one per order).
        Not used for a method that is a state-space model itself (ERA).
    dt : float, optional
        Sampling interval (s) of a free-response method whose records carry none.

    Raises
    ------
    InputError
        One line: not fitted, or a method that has no state-space form (and why).
    """
    if not hasattr(method, "modes_"):
        raise InputError(f"{_name(method)}: not fitted; call fit before to_statespace")
    if hasattr(method, "parts_"):
        raise InputError(f"{_name(method)}: a superposition of methods; realize each of its "
                         "parts (`parts_`)")
    if _is_state_space(method):
        if order is not None:
            raise InputError(f"Parameter `order`: {_name(method)} is a state-space model of "
                             "its own order; `order` applies to kernels")
        return _realize_era(method)
    if hasattr(method, "Phi_"):
        return _realize_free(method, order, dt)
    if hasattr(method, "kernel_"):
        return _realize_kernel(method, order)
    raise InputError(f"{_name(method)}: no state-space form here (its model lives in delay "
                     "coordinates whose step input holds the next sample u_(j+1): no causal "
                     "(A, B, C, D) in the sampled inputs)")
