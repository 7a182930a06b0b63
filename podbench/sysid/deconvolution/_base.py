"""The solver contract: :class:`Solver` (hyper-parameters in the constructor, ``solve(system)``)
and :class:`SolverResult` (the solution with its diagnostics).

A solver is a small object in the manner of opinf's ``lstsq`` solvers and scikit-learn's
estimators: the constructor stores keyword-only hyper-parameters unchanged, ``get_params`` /
``set_params`` read the constructor's signature (so ``sklearn.base.clone`` works), and
:meth:`Solver.solve` takes a validated :class:`~podbench.deconvolution.ConvolutionSystem` and
returns a :class:`SolverResult`. Instances hold plain attributes only, so they pickle and
travel to worker processes; nothing is registered in a global table.
"""

from __future__ import annotations

import inspect
import math
import numbers
import sys
from dataclasses import dataclass, field

import numpy as np

from podbench.core.userimport import import_module_or_file
from podbench.errors import DimensionError, IllConditionedError, InputError, InvalidParameterError
from podbench.sysid.deconvolution.determined import Determined, StoppingRule
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.params import ParamsMixin

__all__ = ["Solver", "SolverResult", "UnknownOptionError", "INFO_KEYS"]

INFO_KEYS = ("solver", "residual", "reg", "reg_rule", "iterations", "solves", "rank", "rcond",
             "condition", "growth", "shift")
"""Keys present in every :attr:`SolverResult.info` (``None`` where a solver has no such
quantity), in this order; a solver may add its own after them:

``solver``      the solver's :attr:`Solver.name`;
``residual``    relative residual ``‖A X − B‖_F / ‖B‖_F``, computed by :meth:`Solver.solve`
                for every solver (by FFT, ``A`` never formed);
``reg``         Tikhonov parameter used (relative, ``λ = reg·max_ω σ_max(Δt Ĝ(ω))``);
``reg_rule``    ``"gcv"`` (chosen from the data) or ``"fixed"``;
``iterations``  conjugate-gradient iterations, all trial solves of a GCV search included;
``solves``      number of (trial) solves behind ``iterations``;
``rank``        singular values kept (TLS) or effective rank of ``A`` (LS);
``rcond``       relative singular-value cut used;
``condition``   a condition estimate (see each solver);
``growth``      ``‖A‖‖X‖/‖B‖`` of block forward substitution;
``shift``       leading zero force samples shifted past.

An iterative solver adds ``determined``: the digits its stopping test determines, as text
(:meth:`Solver.determined`, :meth:`~podbench.sysid.deconvolution.determined.Determined.
as_info`)."""


class UnknownOptionError(InvalidParameterError, TypeError):
    """An option that the solver's constructor does not take (an
    :class:`~podbench.errors.InvalidParameterError` of ``solver_options``, and a
    ``TypeError`` as an unknown keyword argument is in Python)."""


@dataclass(frozen=True)
class SolverResult:
    """The solution of ``A X ≈ B`` and what the solver measured on the way.

    Attributes
    ----------
    X : (k·n,) or (k·n, r) ndarray
        ``C̄`` (Eq. 3.42), in/(lbf·s): row ``i·n + p`` holds the lag-``p`` kernel ``c_li[p]``
        for every column ``l``; a vector when ``B`` was one.
    info : dict
        Diagnostics, JSON scalars only (``None``, bool, int, float, str); the keys of
        :data:`INFO_KEYS` always, then any the solver adds.
    realization : tuple or None
        For a solver whose solution is a state-space model (``"realization"``,
        ``"subspace"``: poles and residues), that model ``(A, B, C, D)``, exact:
        ``X[0]ᵀ = D`` and ``X[p]ᵀ = C A^{p−1} B`` (``r × k``, in/(lbf·s)), and the memory
        beyond the ``n`` lags of ``X``. None for a solver that gives the kernel only.
    determined : Determined or None
        For an iterative solve, the significant digits its stopping tolerance determines of
        ``X``'s consequences and of its relative residual (:meth:`Solver.determined`); None
        for a direct solve (determined to round-off).
    """

    X: np.ndarray
    info: dict = field(default_factory=dict)
    realization: tuple | None = None
    determined: Determined | None = None

    def __repr__(self) -> str:
        return f"SolverResult(X=<array {self.X.shape}>, info={self.info!r})"


class Solver(ParamsMixin):
    """Base class of the deconvolution solvers.

    A solver of one's own: subclass, give the constructor keyword-only hyper-parameters that
    it stores unchanged under the same names, declare what each admits in
    ``_parameter_constraints`` (:mod:`podbench.sysid.params`; checked by
    :meth:`_validate_params`, which a solver extends for checks across parameters, raising
    :class:`InputError` naming the parameter) and implement :meth:`_solve`, which returns
    ``X`` (``(k·n,)`` or ``(k·n, r)`` like ``system.B``'s columns) or ``(X, info)``, or
    ``(X, info, realization)`` for a solution that is a state-space model
    (:attr:`SolverResult.realization`). :meth:`solve` validates, calls it, checks ``X``
    (shape, finite) and completes ``info`` (residual, standard keys). Example::

        class ScipyLstsq(Solver):
            name = "scipy-lstsq"
            _parameter_constraints = {"cond": [None, Interval("number", 0, 1)]}

            def __init__(self, *, cond=None):
                self.cond = cond

            def _solve(self, system):
                X = scipy.linalg.lstsq(system.dense(solver=self.name), system.B,
                                       cond=self.cond)[0]
                return X, {"rcond": self.cond}

    Attributes
    ----------
    name : str
        Short name shown in tables (a subclass that sets none gets its class name).
    structured : bool
        True if the solver never forms the dense matrix.
    stopping : StoppingRule or None
        For an iterative solver, what its stopping test leaves undetermined (measured);
        with ``stopping_tol``, the name of its tolerance parameter.
    """

    name = "solver"
    structured = False
    stopping: StoppingRule | None = None
    stopping_tol = "tol"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "name" not in cls.__dict__:
            cls.name = cls.__name__

    # ------------------------------------------------------------------ parameters
    @classmethod
    def _get_param_names(cls) -> list[str]:
        """Names of the constructor's parameters (the hyper-parameters), in order."""
        init = cls.__init__
        if init is not object.__init__:
            for p in inspect.signature(init).parameters.values():
                if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                    raise TypeError(
                        f"{cls.__name__}: a solver's constructor must name its "
                        f"hyper-parameters (no *{p.name} / **{p.name})"
                    )
        return super()._get_param_names()

    # ------------------------------------------------------------------ solving
    def solve(self, system: ConvolutionSystem) -> SolverResult:
        """Solve ``A X ≈ B`` for the system of Eq. 3.43 / 3.48.

        Parameters
        ----------
        system : ConvolutionSystem

        Returns
        -------
        SolverResult
            ``X`` (``(k·n,)`` or ``(k·n, r)``) and ``info`` (:data:`INFO_KEYS`).
        """
        if not isinstance(system, ConvolutionSystem):
            raise InputError(
                f"Parameter `system`: expected a ConvolutionSystem, got {type(system).__name__}"
            )
        self._validate_params()
        out = self._solve(system)
        X, info, real = (out + (None,) * (3 - len(out))) if isinstance(out, tuple) else (
            out, {}, None)
        return self._result(system, X, info, real)

    def solve_many(self, systems) -> list[SolverResult]:
        """:meth:`solve` on each of several systems (a solver may solve them together:
        :class:`~podbench.sysid.deconvolution.block.BlockSubstitution`)."""
        return [self.solve(system) for system in systems]

    def _solve(self, system: ConvolutionSystem):
        """Return ``X`` or ``(X, info)``; implemented by each solver."""
        raise NotImplementedError(f"{type(self).__name__} does not implement _solve(system)")

    def determined(self) -> Determined | None:
        """The digits this solver's answer is determined to at its own tolerance (its
        :attr:`stopping` rule), None for a direct solver."""
        if self.stopping is None:
            return None
        return self.stopping.determined(getattr(self, self.stopping_tol))

    def _result(self, system: ConvolutionSystem, X, info: dict | None,
                realization: tuple | None = None) -> SolverResult:
        expected = (system.k * system.n,) + (() if system.vector else (system.n_rhs,))
        X = checked_solution(self.name, X, expected)
        info = dict(info or {})
        det = Determined.from_info(info.get("determined")) or self.determined()
        if det is not None:
            info["determined"] = det.as_info()
        return SolverResult(X=X, info=full_info(self.name, info, system.residual(X)),
                            realization=realization, determined=det)

    # ------------------------------------------------------------------ pickling
    def __reduce_ex__(self, protocol):
        cls = type(self)
        path = getattr(sys.modules.get(cls.__module__), "__file__", None)
        # a class imported from a user's file (podbench.core.userimport) lives in a module that a
        # fresh process does not have: rebuild it from the file, as make_solver would
        if cls.__module__.startswith("podbench_user_") and path:
            return (_rebuild, (path, cls.__qualname__, dict(self.__dict__)))
        return super().__reduce_ex__(protocol)


def _rebuild(path: str, qualname: str, state: dict) -> Solver:
    """Unpickle a solver whose class lives in a user's file (see ``Solver.__reduce_ex__``)."""

    obj = import_module_or_file(path)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    solver = obj.__new__(obj)
    solver.__dict__.update(state)
    return solver


def checked_solution(name: str, X, expected: tuple) -> np.ndarray:
    """``X`` as a float array of shape ``expected`` with finite values, else an error."""
    X = np.asarray(X, dtype=float)
    if X.shape != expected:
        raise DimensionError(f"Solver {name!r} returned shape {X.shape}, expected {expected}")
    if not np.all(np.isfinite(X)):
        raise IllConditionedError(f"Solver {name!r} returned NaN or Inf")
    return X


def full_info(name: str, info: dict | None, residual: float) -> dict:
    """:data:`INFO_KEYS` (``None`` by default), then the solver's own keys, as JSON scalars."""
    full = dict.fromkeys(INFO_KEYS)
    for key, value in (info or {}).items():
        full[str(key)] = _json_scalar(value, name, key)
    full["solver"] = name
    full["residual"] = float(residual)
    return full


def relative_residual(num: float, den: float) -> float:
    """``num/den``; 0 if both are 0, ``inf`` if only ``den`` is."""
    if den > 0:
        return num / den
    return 0.0 if num == 0 else float("inf")


def _json_scalar(value, solver: str, key):
    """``value`` as a JSON scalar (NumPy scalars converted); TypeError naming the key if not."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        value = float(value)
        return value if not math.isnan(value) else None
    raise TypeError(
        f"Solver {solver!r}: info[{key!r}] must be a JSON scalar (None, bool, int, float, "
        f"str), got {type(value).__name__}"
    )
