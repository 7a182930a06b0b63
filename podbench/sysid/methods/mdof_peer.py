"""``mdof`` (BSD-2, https://github.com/chrystalchern/mdof) as a peer from structural health
monitoring: OKID-ERA and SRIM on the same input/output records as ML.

Optional: ``pip install 'podbench[mdof]'`` (tested with mdof 0.0.23). mdof identifies from
one input/output history; the training records (which start and end quiet) are joined end
to end, in the POD coordinates of their outputs (``k = n_out``, a rotation, as for the other
peers). The model is simulated from rest on the target's inputs. Hyper-parameters are
mdof's defaults where they fit these records (model order 20), fixed in advance.

What was found in mdof 0.0.23 and how it is worked around (reported, not hidden):

* ``mdof.markov.okid`` drops one term of the OKID Markov-parameter recursion: its loop
  ``for i in range(k-1)`` omits ``Ȳ2[k−1] Y[0]``, so every Markov parameter from ``h_2`` on
  is wrong (on an exact 4-state system: 50–100 % error, against 1e-14 with the term; a test
  checks both). Workaround (``fix_okid=True``, default): mdof's own ``okid`` source with
  that one loop bound corrected (``range(k)``), used only when the faulty line is present;
  ``fix_okid=False`` runs mdof as shipped.
* ``mdof.realize.srim`` returns ``B = D = 0`` (a zero model) when the identified ``A`` has
  an eigenvalue just outside the unit circle and the record is long: its output-error step
  (``influence.ac2bd``) fits an initial state beside ``B, D``, whose columns ``C A^k`` grow
  to 1e16 over thousands of samples, and least squares' relative cut-off then discards the
  input columns (measured on a 3000-sample Painter Street record: ``|λ|max = 1.014``,
  ``‖C A^N‖ = 1e16``, ``‖B‖ = 3e-11``). Workaround (``fix_srim=True``, default): SRIM's
  ``A, C`` (``find="AC"``) and ``B, D`` by least squares with the zero initial state the
  records have, every training record simulated from rest.
"""

from __future__ import annotations

import inspect

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)

from podbench import _compat
from podbench.core.records import check_compatible
from podbench.errors import ConvergenceError, InputError
from podbench.sysid.methods.base import PODMethod
from podbench.sysid.methods.inputs import measured_basis
from podbench.sysid.params import Boolean, Interval, Options

__all__ = ["Mdof", "okid_fixed", "EXTRA_HINT"]

EXTRA_HINT = "pip install 'podbench[mdof]'"
_BUG = "for i in range(k-1):"


def _mdof():
    try:
        import mdof  # noqa: F401
        from mdof import markov, realize
    except ImportError:
        raise InputError(f"the mdof peer needs the mdof package: {EXTRA_HINT}") from None
    return markov, realize


def okid_fixed():
    """mdof's ``okid`` with the Markov recursion's missing term restored (or mdof's own
    ``okid`` when its source no longer has the faulty loop)."""
    markov, _ = _mdof()
    src = inspect.getsource(markov.okid)
    if src.count(_BUG) != 1:
        return markov.okid
    ns = dict(vars(markov))
    exec(compile(src.replace(_BUG, "for i in range(k):"), markov.__file__, "exec"), ns)
    return ns["okid"]


def modal_simulate(A, B, C, D, u) -> np.ndarray:
    """Zero-state response of ``x⁺ = A x + B u``, ``y = C x + D u`` (diagonalized ``A``;
    each mode a first-order recursion by :func:`scipy.signal.lfilter`)."""
    lam, V = np.linalg.eig(A)
    Bm = np.linalg.solve(V, B)  # modal inputs
    Cm = C @ V
    drive = Bm @ u  # (N, n)
    x = np.empty_like(drive)
    for i, li in enumerate(lam):
        x[i] = scipy.signal.lfilter([0.0, 1.0], [1.0, -li], drive[i])
    with np.errstate(over="ignore", invalid="ignore"):
        return np.real(Cm @ x) + D @ u


def _bd_zero_state(A, C, Ys, Us):
    """``B, D`` by least squares, every record from rest (the srim workaround)."""
    N = A.shape[0]
    k, q = C.shape[0], Us[0].shape[0]
    lam, V = np.linalg.eig(A)
    Vinv = np.linalg.inv(V)
    cols, rhs = [], []
    for Y, U in zip(Ys, Us, strict=True):
        n = U.shape[1]
        blocks = []
        for j in range(q):  # D columns: u_j at every output
            for o in range(k):
                c = np.zeros((k, n))
                c[o] = U[j]
                blocks.append(c.ravel())
        modal = np.empty((N, q, n), dtype=complex)
        for m, lm in enumerate(lam):
            modal[m] = scipy.signal.lfilter([0.0, 1.0], [1.0, -lm], U, axis=1)
        # B columns: the output of a unit B entry (state i, input j) is
        # Σ_m (C V)[:, m] V⁻¹[m, i] · (mode m's filtered u_j)
        W = (C @ V)[:, :, None] * Vinv[None, :, :]  # (k, m, i)
        resp = np.real(np.tensordot(W, modal, axes=([1], [0])))  # (k, i, q, n)
        for i in range(N):
            for j in range(q):
                blocks.append(resp[:, i, j, :].ravel())
        cols.append(np.stack(blocks, axis=1))
        rhs.append(Y.ravel())
    theta = np.linalg.lstsq(np.vstack(cols), np.concatenate(rhs), rcond=None)[0]
    D = theta[: k * q].reshape(q, k).T
    B = theta[k * q :].reshape(N, q)
    return B, D


class Mdof(PODMethod):
    """mdof's OKID-ERA or SRIM as a peer on input/output records (module docstring).

    Parameters
    ----------
    method : "okid-era" or "srim"
        mdof's identification (``"srim"``, default).
    order : int
        Model order (mdof's default 20).
    horizon : float
        SRIM's prediction horizon / ERA's Hankel block rows, s (0.5 s).
    markov : float
        OKID's number of Markov parameters, s (2 s).
    fix_okid, fix_srim : bool
        The workarounds of the module docstring (default True).
    feedthrough : "auto", True or False
        Kept for the configurations that give it; mdof's models always have a ``D``.
    """

    excitation_kind = "io"
    takes_basis = False
    _parameter_constraints = {"method": [Options("okid-era", "srim")],
                              "order": [Interval("integer", 1)],
                              "horizon": [Interval("number", 0, closed="neither")],
                              "markov": [Interval("number", 0, closed="neither")],
                              "fix_okid": [Boolean()], "fix_srim": [Boolean()],
                              "feedthrough": [Options("auto"), Boolean()]}

    def __init__(self, *, method="srim", order=20, horizon=0.5, markov=2.0, fix_okid=True,
                 fix_srim=True, feedthrough="auto"):
        self.method = method
        self.order = order
        self.horizon = horizon
        self.markov = markov
        self.fix_okid = fix_okid
        self.fix_srim = fix_srim
        self.feedthrough = feedthrough

    @property
    def abbreviation(self):  # type: ignore[override]
        return f"mdof-{str(self.method).upper()}"

    def _validate_params(self) -> None:
        if self.method not in ("okid-era", "srim"):
            raise InputError(f"Parameter `method`: expected 'okid-era' or 'srim', got "
                             f"{self.method!r}")
        super()._validate_params()

    def required_fields(self) -> tuple[str, ...]:
        return ("u", "y", "dt")

    def _modal(self, records) -> bool:
        return False  # the inputs as measured, records of any lengths

    def _fit(self, records, basis) -> None:
        markov_mod, realize = _mdof()
        U, povs = measured_basis(records, None)
        dt = records[0].dt
        Ys = [U.T @ r.y for r in records]
        Us = [r.u for r in records]
        ycat, ucat = np.hstack(Ys), np.hstack(Us)
        no = max(2, int(round(self.horizon / dt)))
        with np.errstate(over="ignore", invalid="ignore"):
            try:
                A, B, C, D = self._realize(markov_mod, realize, ucat, ycat, Ys, Us, no, dt)
            except (np.linalg.LinAlgError, ValueError) as exc:
                A = B = C = D = None
                why = str(exc).splitlines()[0]
        if A is None or not all(np.all(np.isfinite(x)) for x in (A, B, C, D)):
            why = why if A is None else "a non-finite state-space matrix"
            raise ConvergenceError(
                f"Parameter `horizon`: {self.abbreviation} failed at a horizon of {no} samples "
                f"({self.horizon} s): {why}; try a longer horizon")
        self.model_ = tuple(np.asarray(x, dtype=float) for x in (A, B, C, D))
        self.info_ = {"order": int(np.asarray(A).shape[0]),
                      "spectral_radius": float(np.max(np.abs(np.linalg.eigvals(A)))),
                      "norm_B": float(np.linalg.norm(B)), "norm_D": float(np.linalg.norm(D))}
        self.modes_ = U
        self.povs_ = povs
        self.n_modes_ = U.shape[1]
        self.dt_ = dt
        self.reference_ = records[0]

    def _realize(self, markov_mod, realize, ucat, ycat, Ys, Us, no: int, dt: float):
        """``(A, B, C, D)`` of mdof's SRIM or OKID-ERA at a horizon of ``no`` samples."""
        if self.method == "srim":
            if self.fix_srim:
                A, _, C, _ = realize.srim(ucat, ycat, horizon=no, order=self.order, find="AC")
                B, D = _bd_zero_state(A, C, Ys, Us)
                return A, B, C, D
            return realize.srim(ucat, ycat, horizon=no, order=self.order)
        okid = okid_fixed() if self.fix_okid else markov_mod.okid
        m = max(2 * no + 2, int(round(self.markov / dt)))
        H = okid(ucat, ycat, m=m)
        return realize.era(H, horizon=no, order=self.order)

    def _predict(self, record) -> np.ndarray:
        check_compatible(self.reference_, record, min_samples=1)
        return self.modes_ @ modal_simulate(*self.model_, record.u)

    @property
    def diagnostics_(self) -> dict:
        """``n_modes`` and the identified model's ``order``, ``spectral_radius``, ``norm_B``,
        ``norm_D``."""
        return self._chosen_diagnostics()


def __getattr__(name: str):
    """Retired names of this module (:data:`podbench._compat.RETIRED`)."""
    return _compat.retired(__name__, name)
