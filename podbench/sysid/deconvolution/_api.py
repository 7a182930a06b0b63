"""Choosing a solver (:func:`make_solver`) and the one-call forms :func:`deconvolve`, :func:`solve`.

The built-in solvers are a fixed table; a user's solver is a :class:`Solver` subclass, passed
as an instance or named ``"module:Class"`` / ``"file.py:Class"`` (imported by
:func:`podbench.core.userimport.import_object`, the same way in every process). A former
name (:data:`RENAMED`) still names its solver and warns once with the new name.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path

from podbench.core.userimport import UserImportError, import_object
from podbench.errors import InputError, PodbenchWarning, UnknownNameError
from podbench.sysid.deconvolution._base import Solver, SolverResult, UnknownOptionError
from podbench.sysid.deconvolution.auto import Auto
from podbench.sysid.deconvolution.block import BlockSubstitution
from podbench.sysid.deconvolution.dense import (
    AppendixTLS,
    BalancedTLS,
    DenseSolver,
    LeastSquares,
    TruncatedTLS,
)
from podbench.sysid.deconvolution.kernel import KernelRegularized
from podbench.sysid.deconvolution.realization import Realization
from podbench.sysid.deconvolution.stls import STLS
from podbench.sysid.deconvolution.subspace import Subspace
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.deconvolution.tikhonov import CGLS, FFTTikhonov
from podbench.sysid.params import InstanceOf, check_names, check_param

__all__ = [
    "make_solver",
    "available_solvers",
    "structured_solvers",
    "get_solver",
    "solve",
    "deconvolve",
    "RENAMED",
    "current_name",
    "renamed_warned",
]

_BUILTIN: dict[str, type[Solver]] = {
    "ls": LeastSquares,
    "tls-dt": TruncatedTLS,
    "tls-appendix": AppendixTLS,
    "tls-balanced": BalancedTLS,
    "block": BlockSubstitution,
    "fft": FFTTikhonov,
    "cgls": CGLS,
    "kernel": KernelRegularized,
    "realization": Realization,
    "subspace": Subspace,
    "stls": STLS,
    "auto": Auto,
}


RENAMED: dict[str, tuple[str, str]] = {
    "tls": ("tls-dt", "podbench's truncated TLS of the Δt-scaled matrix, whose cut depends "
                      "on Δt and the units; the dissertation's TLS is 'tls-appendix', the "
                      "unit-free one 'tls-balanced'"),
}
"""Former solver names: ``old → (new, what the new name is)``. A former name still runs its
solver, with one :class:`~podbench.errors.PodbenchWarning` per process."""

_WARNED: set = set()

SOLVER_OPTIONS = [None, InstanceOf(Mapping, "a dict of keyword options")]
"""What a method's ``solver_options`` (and :func:`make_solver`'s ``options``) admits."""


def current_name(name, *, stacklevel: int = 3):
    """The solver name ``name`` stands for: itself, or for a former name of :data:`RENAMED`
    its new name, with one :class:`~podbench.errors.PodbenchWarning` per former name and
    process that gives the new name (every place that takes a solver name by the user —
    a scenario's ``options.solver``, ``sweep.solvers``, ``--solver``, ``--solvers``,
    :func:`make_solver` — passes through here). Letter case of a former name aside;
    anything else is returned as it is."""
    if not isinstance(name, str) or name.lower() not in RENAMED:
        return name
    old = name.lower()
    new, what = RENAMED[old]
    if old not in _WARNED:
        _WARNED.add(old)
        warnings.warn(f"solver {name!r} is now named {new!r} ({what}); {name!r} runs "
                      f"it as {new!r}", PodbenchWarning, stacklevel=stacklevel)
    return new


def renamed_warned() -> None:
    """Take every former name as already warned about in this process: for the worker
    processes of a run whose calling process read (and warned about) every file before
    handing out any task, so that a former name warns once per run, not once per worker."""
    _WARNED.update(RENAMED)


def available_solvers() -> tuple[str, ...]:
    """Names of the built-in deconvolution solvers (dense first, then structured)."""
    return tuple(_BUILTIN)


def structured_solvers() -> tuple[str, ...]:
    """Names of the built-in solvers that never form the dense matrix."""
    return tuple(name for name, cls in _BUILTIN.items() if cls.structured)


def get_solver(name: str) -> type[Solver]:
    """The built-in solver class named ``name`` (:class:`UnknownNameError` if none; a former
    name of :data:`RENAMED` warns once and gives its solver)."""
    name = current_name(name, stacklevel=4)
    try:
        return _BUILTIN[name]
    except (KeyError, TypeError):
        raise UnknownNameError(
            f"Parameter `solver`: unknown solver {name!r}; built-in: "
            f"{', '.join(map(repr, _BUILTIN))}, or a Solver subclass named "
            '"module:Class" / "file.py:Class"'
        ) from None


def make_solver(solver, options: Mapping | None = None, *,
                base_dir: Path | str | None = None) -> Solver:
    """A validated :class:`Solver` from a name, a class or an instance.

    Parameters
    ----------
    solver : str, Solver or Solver subclass
        A built-in name (:func:`available_solvers`), ``"module:Class"`` or
        ``"file.py:Class"`` naming a :class:`Solver` subclass (a relative file path is taken
        relative to ``base_dir``), a Solver subclass, or an instance (returned as it is,
        after checking its parameters). Objects that are not Solver subclasses are refused,
        even if they have a ``solve`` method: the contract (``get_params``, the diagnostics,
        pickling) comes from the base class.
    options : mapping, optional
        Keyword arguments of the solver's constructor. Not allowed with an instance.
    base_dir : path, optional
        Directory of the file that names the solver (default: the working directory).

    Raises
    ------
    UnknownNameError
        Unknown built-in name (the message lists them).
    UnknownOptionError
        An option the constructor does not take (an :class:`InputError`, and a TypeError).
    InputError
        Options with an instance, a bad option value (named), a class that is not a Solver,
        user code that cannot be imported.
    """
    options = dict(check_param(options, "solver_options", SOLVER_OPTIONS) or {})
    if isinstance(solver, Solver):
        if options:
            raise InputError(
                f"Parameter `solver_options`: options {sorted(options)} given with the solver "
                f"instance {solver!r}; set them on the instance (or pass its class or name)"
            )
        solver._validate_params()
        return solver
    if isinstance(solver, str):
        if ":" in solver:

            try:
                cls = import_object(solver, base_dir)
            except UserImportError as exc:
                raise UserImportError(f"Parameter `solver`: {exc}") from None
            label = solver
        else:
            cls = get_solver(solver)
            label = solver
    elif isinstance(solver, type):
        cls, label = solver, getattr(solver, "name", solver.__name__)
    else:
        raise InputError(
            f"Parameter `solver`: expected a solver name, a Solver subclass or instance, got "
            f"{type(solver).__name__}"
        )
    if not (isinstance(cls, type) and issubclass(cls, Solver)):
        raise InputError(
            f"Parameter `solver`: {label!r} is not a podbench.deconvolution.Solver subclass "
            f"(got {cls!r})"
        )
    check_names(options, cls._get_param_names(), where="Parameter `solver_options`",
                kind="option", of=f" for solver {label!r}", error=UnknownOptionError,
                param="solver_options")
    instance = cls(**options)
    instance._validate_params()
    return instance


def deconvolve(Q_list, B, dt: float, solver="ls", *, return_info: bool = False, **options):
    """Solve the (block) convolution system of Eq. 3.43 / 3.48 with the chosen solver.

    ``B ≈ block_convolution_matrix(Q_list, dt) @ X`` for the stacked kernel ``X = C̄``
    (Eq. 3.42). Dense solvers (``"ls"``, ``"tls-appendix"``, …) form the matrix (refused above
    ``max_dense_bytes``, default :data:`DENSE_MAX_BYTES`); structured solvers (``"block"``,
    ``"fft"``, ``"cgls"``) work on the modal forces directly and never form it.
    ``make_solver(solver, options).solve(ConvolutionSystem(Q_list, B, dt))``.

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case (lbf); for a scalar deconvolution (SL, MR) one
        ``(1, n)`` array.
    B : (n_cases·n,) or (n_cases·n, r) array_like
        Stacked scaled POC histories (in): rows ``j·n … j·n+n−1`` are load case ``j``.
    dt : float
        Sampling interval Δt (s).
    solver : str or Solver
        Name from :func:`available_solvers`, ``"module:Class"``, or a :class:`Solver`.
    return_info : bool
        Return the :class:`SolverResult` (solution and diagnostics) instead of ``X``.
    **options
        Constructor options of the solver (not with an instance).

    Returns
    -------
    (k·n,) or (k·n, r) ndarray, or SolverResult
        ``C̄``: row ``i·n + p`` holds the lag-``p`` kernel ``c_li[p]`` for every column ``l``
        (in/(lbf·s)).
    """
    instance = make_solver(solver, options)
    result = instance.solve(ConvolutionSystem(Q_list, B, dt))
    if not isinstance(result, SolverResult):
        raise InputError(
            f"Parameter `solver`: {instance!r}.solve returned {type(result).__name__}, "
            "expected a SolverResult (implement _solve, not solve)"
        )
    return result if return_info else result.X


def solve(A, B, solver="ls", *, return_info: bool = False, **options):
    """Solve ``A X ≈ B`` for a given matrix with a dense solver.

    Parameters
    ----------
    A : (N, M) array_like
    B : (N,) or (N, r) array_like
    solver : str or DenseSolver
        A dense solver (``"ls"``, ``"tls-dt"``, or a :class:`DenseSolver`). Structured solvers
        need the Toeplitz form, not a matrix: use :func:`deconvolve`.
    return_info : bool
        Return the :class:`SolverResult` instead of ``X``.
    **options
        Constructor options of the solver.

    Returns
    -------
    (M,) or (M, r) ndarray, or SolverResult
    """
    if isinstance(solver, str) and solver in _BUILTIN and _BUILTIN[solver].structured:
        raise UnknownNameError(
            f"Parameter `solver`: unknown solver {solver!r} for a dense matrix (it is a "
            f"structured solver: use deconvolve(Q_list, B, dt, solver={solver!r})); dense "
            f"solvers: {', '.join(repr(n) for n in _BUILTIN if n not in structured_solvers())}"
        )
    instance = make_solver(solver, options)
    if not isinstance(instance, DenseSolver):
        raise UnknownNameError(
            f"Parameter `solver`: {instance!r} does not solve a given matrix (it is not a "
            "DenseSolver); use deconvolve(Q_list, B, dt, solver=...)"
        )
    result = instance.solve_matrix(A, B)
    return result if return_info else result.X

