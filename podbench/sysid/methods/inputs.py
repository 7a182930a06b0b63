"""POD methods on input/output records (Chapter 6): measured inputs to measured outputs.

The dissertation's forced methods take the modal forces ``q = Uᵀ F`` of forces applied at
the sensors. A structure shaken at its base, instrumented with accelerometers, has inputs
that are not at the outputs (ground accelerations) and outputs that are not displacements.
Here the kernel goes from **whatever is measured as input** to the **POC histories of
whatever is measured as output** (:class:`~podbench.core.iorecords.IORecord`):

* ML (:class:`MultipleLoadIO`): with ``U`` the ``k`` leading POMs of the training outputs
  (all records side by side), the scaled POC histories ``v = Uᵀ y`` and the measured inputs
  ``u``, Eq. 3.48 with ``u`` in place of the modal forces::

      v[s] = Δt Σ_p H[p] u[s − p]     (H[p]: k × n_in),      ŷ = U v̂.

  Every record adds its own equations, so records of different lengths train together.
  Outputs that respond at lag 0 (accelerations to a base acceleration: direct
  feedthrough) keep lag 0 (``feedthrough="auto"``: for acceleration outputs); displacement
  or strain outputs start at lag 1. ``n_lags=None`` is the dissertation's kernel over the
  whole record (records of one length, solved by :mod:`podbench.deconvolution`), an int
  truncates it to ``n_lags`` lags, ``"auto"`` chooses it from ``lag_grid`` by
  leave-one-record-out on the training records. ``prior="tc"``: the kernel-regularized
  FIR of :mod:`podbench.deconvolution.lagged` (TC prior), its decay and weight chosen by
  leave-one-record-out on the training records over a grid fixed in advance.
  With ``k = n_out`` and ``prior=None`` ML equals the FIR least-squares baseline
  (:class:`FIRLeastSquares`) to round-off: ``U`` is then a rotation of the outputs.
* SL (:class:`SingleLoadIO`): the diagonal assumption (each POC history driven by its own
  modal force ``u_iᵀ F`` only) needs a modal force per POM, i.e. forces measured at the
  output sensors. With inputs elsewhere (a base acceleration) there is no modal force and
  SL is refused with that message; with collocated forces it is the dissertation's SL.
* MR (:func:`mixed_response_io`) needs free-response records (initial conditions); a
  base-excited record from rest has none: refused.

Units: the kernel is in (output unit)/(input unit · s); training and target records must
have one unit system, one ``dt`` and the same channels (checked before any fitting, one line
naming the file and the field).
"""

from __future__ import annotations

import weakref

import numpy as np

from podbench.core.records import Record as IORecord
from podbench.core.records import check_compatible, check_records
from podbench.errors import InputError, NotFittedError
from podbench.sysid.deconvolution.lagged import lag_response, record_grams, solve_ls
from podbench.sysid.methods.base import PODMethod, make_method_solver, solve_deconvolution
from podbench.sysid.methods.forced import SingleLoad

__all__ = ["MultipleLoadIO", "SingleLoadIO", "FIRLeastSquares", "mixed_response_io",
           "LAG_GRID", "TC_GRID", "io_records"]

LAG_GRID = (0.25, 0.5, 1.0, 1.5, 2.0)
"""Lag lengths (s) that ``n_lags="auto"`` chooses from (fixed in advance)."""
TC_GRID = tuple((tau, g) for tau in (0.1, 0.2, 0.4) for g in (1e-3, 1e-2, 1e-1))
"""(decay time τ in s, relative weight γ) of the TC prior that ``prior="tc"`` chooses from."""

CV_FLOOR = 1e-9
"""Leave-one-record-out errors that differ by less than this (relative to the best, or
absolutely) are round-off: the simplest candidate (fewest lags, first in the grid) wins."""

_GRAMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def io_records(records, name: str = "records") -> list[IORecord]:
    if isinstance(records, IORecord):
        return [records]
    try:
        recs = list(records)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected IORecords") from None
    for j, r in enumerate(recs):
        if not isinstance(r, IORecord):
            raise InputError(f"Parameter `{name}[{j}]`: expected a "
                             f"podbench.core.iorecords.IORecord, got {type(r).__name__}")
    if not recs:
        raise InputError(f"Parameter `{name}`: no record given")
    return recs


def given_basis(recs, basis) -> tuple[np.ndarray, np.ndarray]:
    """``(U, povs)`` of a given basis (n_out × k) and the records' energy along it."""
    U = np.asarray(basis, dtype=float)
    m = recs[0].n_outputs
    if U.ndim != 2 or U.shape[0] != m or not 1 <= U.shape[1] <= m:
        raise InputError(f"Parameter `basis`: expected an array of shape ({m}, k), k ≤ {m}, "
                         f"got shape {U.shape}")
    return U, np.linalg.norm(U.T @ np.hstack([r.y for r in recs]), axis=1)


def _channel_grams(rec: IORecord, n_lags: int, first: int):
    """``A``, ``B_y`` and ``y yᵀ`` of a record in its output channels (cached per record)."""
    cache = _GRAMS.setdefault(rec, {})
    for (L, f), g in cache.items():
        if f == first and L >= n_lags:
            k = n_lags * rec.n_inputs
            return g[0][:k, :k], g[1][:k], g[2]
    if rec.y is None:
        raise InputError(f"{rec.name}: field `outputs`: a training record needs its outputs")
    A, B, _ = record_grams(rec.u, rec.y, n_lags, first)
    g = (A, B, rec.y @ rec.y.T)
    cache[(n_lags, first)] = g
    return g


def _grams_in(rec, U, n_lags, first):
    A, By, Y = _channel_grams(rec, n_lags, first)
    return A, By @ U, np.einsum("ik,ij,jk->k", U, Y, U)


def _chol_solve(A, B):
    """``A⁻¹B`` for symmetric positive (semi)definite ``A`` (Cholesky, else least squares)."""
    return solve_ls(A, B)


def _cv_error(grams, rows, solve=_chol_solve, ridge: float = 0.0) -> float:
    """Mean leave-one-record-out relative error of the outputs from the Grams alone:
    ``‖z_j − ẑ_j‖² = c_j − 2 θ·B_j + θ·A_jθ`` with ``θ`` fitted without record ``j``
    (``ridge``: ``+ ridge·mean(diag A)·I``)."""
    A = sum(g[0][:rows, :rows] for g in grams)
    B = sum(g[1][:rows] for g in grams)
    errs = []
    for Aj, Bj, cj in grams:
        Aj, Bj = Aj[:rows, :rows], Bj[:rows]
        Ak = A - Aj
        if ridge:
            Ak = Ak + ridge * float(np.trace(Ak)) / rows * np.eye(rows)
        th = solve(Ak, B - Bj)
        e2 = float(np.sum(cj) - 2 * np.sum(th * Bj) + np.sum(th * (Aj @ th)))
        errs.append(np.sqrt(max(e2, 0.0) / float(np.sum(cj))))
    return float(np.mean(errs))


def _simplest(scored):
    """The first candidate whose error is within :data:`CV_FLOOR` of the smallest."""
    best = min(e for _, e in scored)
    return next(c for c, e in scored if e <= best + CV_FLOOR * max(1.0, best))


def _fixed_tc(prior) -> bool:
    """``prior`` is a given TC prior ``(τ s, γ)``, both finite and > 0."""
    if isinstance(prior, str) or not isinstance(prior, (tuple, list)) or len(prior) != 2:
        return False
    try:
        vals = [float(v) for v in prior]
    except (TypeError, ValueError):
        return False
    return all(np.isfinite(v) and v > 0 for v in vals)


def _tc_factor(n_lags: int, n_in: int, dt: float, tau: float) -> np.ndarray:
    """``R`` with ``R Rᵀ = P`` (the TC prior, :func:`tc_prior`): ``K = λ^max(p,q)`` factors
    as ``R_K[p, q] = sqrt(λ^q − λ^(q+1))`` for ``q ≥ p`` (``sqrt(λ^(L−1))`` in the last
    column), ``λ = exp(−Δt/τ)``."""
    lam = float(np.exp(-dt / tau))
    w = lam ** np.arange(n_lags)
    g = np.sqrt(np.append(w[:-1] - w[1:], w[-1]))
    return np.kron(np.triu(np.ones((n_lags, n_lags))) * g[None, :], np.eye(n_in))


def _whiten(grams, R):
    """The Grams in the prior's coordinates ``θ = R φ``: ``RᵀAR``, ``RᵀB``, ``c``."""
    out = []
    for A, B, c in grams:
        M = R.T @ A @ R
        out.append((0.5 * (M + M.T), R.T @ B, c))
    return out


class IOMethod(PODMethod):
    excitation_kind = "io"
    # hyperparameters of the subclasses, and fitted state (declared for type checkers)
    feedthrough: bool | str
    lag_grid: tuple
    reference_: IORecord
    info_: dict

    def required_fields(self) -> tuple[str, ...]:
        return ("u", "y", "dt")

    def _check_is_fitted(self) -> None:
        if not hasattr(self, "modes_"):
            raise NotFittedError(f"This {type(self).__name__} instance is not fitted yet; call "
                                 "`fit` before `predict`")

    def _first(self, rec: IORecord) -> int:
        fe = self.feedthrough
        if fe == "auto":
            return 0 if rec.output_quantity == "acceleration" else 1
        if fe not in (True, False):
            raise InputError(f"Parameter `feedthrough`: expected 'auto', True or False, got {fe!r}")
        return 0 if fe else 1

    def _lag_count(self, n_lags, dt) -> list[int]:
        if n_lags == "auto":
            return sorted({max(1, int(round(t / dt))) for t in self.lag_grid})
        if isinstance(n_lags, bool) or not isinstance(n_lags, (int, np.integer)) or n_lags < 1:
            raise InputError(f"Parameter `n_lags`: expected None, 'auto' or an integer >= 1, "
                             f"got {n_lags!r}")
        return [int(n_lags)]

    def _target(self, record) -> IORecord:
        self._check_is_fitted()
        if not isinstance(record, IORecord):
            raise InputError(f"Parameter `record`: expected an IORecord, got "
                             f"{type(record).__name__}")
        check_compatible(self.reference_, record, min_samples=1)
        return record

    def _fit_fir(self, recs, U, prior):
        """The FIR kernel in the coordinates ``U``: lags and prior by the rules."""
        dt = recs[0].dt
        n_in = recs[0].n_inputs
        first = self._first(recs[0])
        Ls = self._lag_count(self.n_lags, dt)
        n_min = min(r.n_samples for r in recs)
        if Ls[0] + first > n_min:
            bad = min(recs, key=lambda r: r.n_samples)
            raise InputError(f"{bad.name}: field `inputs`: {bad.n_samples} samples, the model "
                             f"needs more than {Ls[0] + first} (n_lags)")
        Ls = [L for L in Ls if L + first <= n_min]
        Lmax = max(Ls)
        grams = [_grams_in(r, U, Lmax, first) for r in recs]
        cv = {}
        if len(Ls) > 1:
            if len(recs) < 2:
                raise InputError("Parameter `n_lags`: 'auto' chooses by leave-one-record-out "
                                 "and needs at least 2 training records; give an integer")
            for L in Ls:
                cv[("lags", L)] = _cv_error(grams, L * n_in)
            L = _simplest([(x, cv[("lags", x)]) for x in Ls])
        else:
            L = Ls[0]
        rows = L * n_in
        A = sum(g[0][:rows, :rows] for g in grams)
        B = sum(g[1][:rows] for g in grams)
        info = {"n_lags": L, "first_lag": first}
        if prior is None:
            theta = solve_ls(A, B)
        elif prior == "tc" or _fixed_tc(prior):
            grid = TC_GRID if prior == "tc" else (tuple(float(v) for v in prior),)
            if len(grid) > 1 and len(recs) < 2:
                raise InputError("Parameter `prior`: 'tc' chooses its weight by "
                                 "leave-one-record-out and needs at least 2 training records")
            # θ = R φ with R Rᵀ = P: the TC prior is a ridge on φ (posterior mean
            # φ = (RᵀAR + γ·s·I)⁻¹ RᵀB, s = trace(RᵀAR)/rows)
            sub = [(g[0][:rows, :rows], g[1][:rows], g[2]) for g in grams]
            best = None
            for tau in sorted({t for t, _ in grid}):
                R = _tc_factor(L, n_in, dt, tau)
                white = _whiten(sub, R)
                for t2, g in grid:
                    if t2 != tau:
                        continue
                    e = _cv_error(white, rows, ridge=g) if len(grid) > 1 else 0.0
                    if len(grid) > 1:
                        cv[("tc", tau, g)] = e
                    if best is None or e < best[0] - CV_FLOOR * max(1.0, best[0]):
                        best = (e, tau, g, R, white)
            _, tau, g, R, white = best
            M = sum(w[0] for w in white)
            N = sum(w[1] for w in white)
            theta = R @ solve_ls(M + g * float(np.trace(M)) / rows * np.eye(rows), N)
            info.update(tc_tau=tau, tc_gamma=g)
        else:
            raise InputError(f"Parameter `prior`: expected None, 'tc' or (tau_s, gamma) > 0, "
                             f"got {prior!r}")
        info["cv_error"] = min(cv.values()) if cv else float("nan")
        self.cv_errors_ = cv
        return theta, info

    @property
    def diagnostics_(self) -> dict:
        self._check_is_fitted()
        out: dict = {"n_modes": int(self.n_modes_)}
        out.update({k: v for k, v in self.info_.items() if isinstance(v, (int, float, str))})
        return out


class MultipleLoadIO(IOMethod):
    """ML from measured inputs to the POC histories of measured outputs (module docstring).

    Parameters
    ----------
    n_modes : int, optional
        ``k`` (default: the number of output channels).
    n_lags : None, int or "auto"
        Kernel length: None (the whole record; records of one length), an int (samples), or
        "auto" (from ``lag_grid`` by leave-one-record-out; default).
    lag_grid : tuple of float
        Lag lengths (s) for ``n_lags="auto"`` (:data:`LAG_GRID`).
    prior : None, "tc" or (tau, gamma)
        Kernel regularization: the TC prior, its decay ``τ`` (s) and relative weight ``γ``
        chosen from :data:`TC_GRID` by leave-one-record-out (``"tc"``) or given.
    feedthrough : "auto", True or False
        Keep lag 0 ("auto": for acceleration outputs).
    solver : str
        Deconvolution solver for ``n_lags=None`` (:mod:`podbench.deconvolution`).

    Attributes
    ----------
    modes_ : (n_out, k) ndarray
    kernel_ : (k, n_in, L) ndarray
        ``H[p] = kernel_[:, :, p − first_lag_]`` in (output unit)/(input unit·s).
    first_lag_ : int
    info_ : dict
        ``n_lags``, ``first_lag``, ``cv_error`` and the prior's choice.
    """

    abbreviation = "ML"
    coupled = True

    def __init__(self, *, n_modes=None, n_lags="auto", lag_grid=LAG_GRID, prior=None,
                 feedthrough="auto", solver="ls"):
        self.n_modes = n_modes
        self.n_lags = n_lags
        self.lag_grid = lag_grid
        self.prior = prior
        self.feedthrough = feedthrough
        self.solver = solver

    def _basis(self, recs):
        Y = np.hstack([r.y for r in recs])
        Uall, s, _ = np.linalg.svd(Y, full_matrices=False)
        k = self.n_modes if self.n_modes is not None else recs[0].n_outputs
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not \
                1 <= k <= Uall.shape[1]:
            raise InputError(f"Parameter `n_modes`: expected an integer in 1 … "
                             f"{Uall.shape[1]}, got {k!r}")
        return Uall[:, :k], s[:k]

    def fit(self, records, basis=None) -> MultipleLoadIO:
        """Identify the kernel from training IORecords (any lengths); returns ``self``.

        ``basis`` (n_out × k): the POMs to use instead of the records' own (the band's
        leave-one-record-out refits keep the whole fit's basis)."""
        recs = io_records(records)
        check_records(recs)
        U, povs = self._basis(recs) if basis is None else given_basis(recs, basis)
        if self.n_lags is None:
            theta, info = self._fit_full(recs, U)
        else:
            theta, info = self._fit_fir(recs, U, self.prior)
        first = info["first_lag"]
        n_in = recs[0].n_inputs
        k = U.shape[1]
        self.theta_ = theta
        self.kernel_ = theta.reshape(-1, n_in, k).transpose(2, 1, 0) / recs[0].dt
        self.first_lag_ = first
        self.modes_ = U
        self.povs_ = povs
        self.n_modes_ = k
        self.dt_ = recs[0].dt
        self.info_ = info
        self.reference_ = recs[0]
        return self

    def frozen_params(self) -> dict:
        """The choices of this fit as hyperparameters (the band's refits,
        :meth:`PODMethod.frozen_params`): ``n_lags`` chosen from ``lag_grid`` and the TC
        prior's ``(τ, γ)`` chosen from :data:`TC_GRID`."""
        self._check_is_fitted()
        params = self.get_params(deep=False)
        out: dict = {}
        if params.get("n_lags") == "auto":
            out["n_lags"] = int(self.info_["n_lags"])
        if params.get("prior") == "tc" and "tc_tau" in self.info_:
            out["prior"] = (float(self.info_["tc_tau"]), float(self.info_["tc_gamma"]))
        return out

    def _fit_full(self, recs, U):
        n = recs[0].n_samples
        for r in recs[1:]:
            if r.n_samples != n:
                raise InputError(f"{r.name}: field `inputs`: {r.n_samples} samples, "
                                 f"{recs[0].name} has {n}; n_lags=None (the kernel over the "
                                 "whole record) needs records of one length: set n_lags")
        if self.prior is not None:
            raise InputError("Parameter `prior`: needs a truncated kernel (n_lags)")
        solver = make_method_solver(self.solver, None)
        B = np.vstack([(U.T @ r.y).T for r in recs])
        X, sinfo = solve_deconvolution(solver, [r.u for r in recs], B, recs[0].dt,
                                       what="ML (measured inputs)")
        n_in = recs[0].n_inputs
        dt = recs[0].dt
        # X rows i·n + p (input i, lag p) → θ lag-major with the Δt of the convolution
        theta = X.reshape(n_in, n, -1).transpose(1, 0, 2).reshape(n * n_in, -1) * dt
        return theta, {"n_lags": n, "first_lag": 0,
                       "solver": str(sinfo.get("solver", self.solver))}

    def predict_coordinates(self, record) -> np.ndarray:
        """The predicted POC histories ``v̂`` (k × n) of a target's inputs."""
        rec = self._target(record)
        return lag_response(self.theta_, rec.u, rec.n_inputs, self.first_lag_)

    def predict(self, record, coverage=None) -> np.ndarray:
        """Predicted outputs ``ŷ = U v̂`` (n_out × n, the training output unit).

        ``coverage=c`` returns a :class:`~podbench.sysid.methods.bands.Prediction` (band and
        error estimate, calibrated by leave-one-record-out over the training records;
        handled by :class:`~podbench.sysid.methods.base.PODMethod`)."""
        return self.modes_ @ self.predict_coordinates(record)


class FIRLeastSquares(MultipleLoadIO):
    """The multi-input FIR least-squares baseline in the output channels (no POD): each
    output channel is a least-squares FIR of all inputs, lag length from ``lag_grid`` by
    leave-one-record-out on the training records (``n_lags="auto"``)."""

    abbreviation = "FIR-LS"
    coupled = False

    def __init__(self, *, n_lags="auto", lag_grid=LAG_GRID, feedthrough="auto"):
        self.n_lags = n_lags
        self.lag_grid = lag_grid
        self.feedthrough = feedthrough

    @property
    def prior(self):
        return None

    @property
    def n_modes(self):
        return None

    @property
    def solver(self):
        return "ls"

    def _basis(self, recs):
        m = recs[0].n_outputs
        return np.eye(m), np.linalg.norm(np.hstack([r.y for r in recs]), axis=1)


class SingleLoadIO(MultipleLoadIO):
    """SL on input/output records: only where its diagonal assumption has a meaning.

    SL drives each POC history by its own modal force ``u_iᵀF``; that needs forces measured
    at the output sensors (a collocated record). For inputs elsewhere (a base acceleration,
    ground motion) there is no modal force per POM and SL is refused."""

    abbreviation = "SL"
    coupled = False

    def fit(self, records, basis=None) -> SingleLoadIO:
        recs = io_records(records)
        r = recs[0]
        if not r.collocated:
            raise InputError(
                f"SL: {r.name}: the inputs ({r.input_quantity} at channels "
                f"{', '.join(r.input_channels or ())}) are not forces at the output channels "
                f"({', '.join(r.output_channels or ())}); SL's diagonal assumption pairs each "
                "POM with its own modal force u_iᵀF, which base or ground inputs do not have. "
                "Use ML (the full kernel from the measured inputs)")

        raise InputError("SL: collocated force records: use podbench.methods.SingleLoad "
                         f"(Record(W=y, F=u)); {SingleLoad.abbreviation} is the dissertation's")


def mixed_response_io(record) -> None:
    """MR needs free-response records (initial conditions); refuse input/output records."""
    raise InputError(f"MR: {getattr(record, 'name', 'record')}: the mixed-response method "
                     "identifies Φ11, Φ12 from free responses (initial displacement and "
                     "velocity) beside forced ones; a record driven from rest by measured "
                     "inputs has no initial condition to identify them from. Use ML")
