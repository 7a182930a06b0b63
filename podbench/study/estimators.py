"""From a scenario's ``[[methods]]`` entries to estimators, and from cases to training records.

Every method — built-in, peer or a user's class — is driven the same way: the entry's class
is constructed with the entry's ``options`` (and ``n_modes``), then ``fit(records,
basis=None)`` receives the training cases' responses in the entry's order (a
:class:`~podbench.data.Response` is a record: ``W, F, w0, v0, dt``) and ``predict(target)``
the target's response; ``modes_`` is the basis it predicts in. What each method reads from
a record it declares itself (``required_fields()``), so this module has no per-method
branch. A composite entry (``superposition``) becomes a :class:`~podbench.methods.Superposition` of
its parts' estimators, each fitted on its own training cases. Names are the registry's
(:mod:`podbench.sysid.registry`).

A method of your own is named ``"module:Class"`` (an importable module) or
``"file.py:Class"`` (relative to the scenario file); a deconvolution solver of your own,
likewise, as ``options.solver``. Both are imported where the scenario is read — in every
worker process too — so nothing depends on a registry in the user's process.

Options are bound to the constructor's signature when the scenario file is read
(:func:`check_method_entry`): an unknown option, a bad value (the class's
``_validate_params``), a missing file or class is a
:class:`~podbench.errors.ScenarioFileError` naming the file and the dotted field, raised
before any simulation.
"""

from __future__ import annotations

import inspect
import re

from podbench.core.hints import did_you_mean
from podbench.core.userimport import UserImportError
from podbench.errors import InputError, PodbenchError
from podbench.sysid import registry
from podbench.sysid.deconvolution import available_solvers, get_solver, make_solver
from podbench.sysid.registry import is_user_method

__all__ = ["method_entry", "method_class", "build_estimator", "check_method_entry",
           "training_records", "all_cases", "is_user_method", "option_names"]


def method_entry(method: str, base_dir=None) -> registry.Entry:
    """The registry entry of a ``method`` entry: a registered name (a class or a
    configuration) or a user's ``module:Class`` (:func:`podbench.sysid.registry.resolve`).

    Raises
    ------
    InputError
        Unknown name, a module or file that does not import, no such class, or a class that
        lacks ``fit`` or ``predict``.
    """
    return registry.resolve(method, base_dir)


def method_class(method: str, base_dir=None) -> type:
    """The class of a ``method`` entry (:func:`method_entry`)."""
    return method_entry(method, base_dir).cls


def option_names(cls) -> tuple[list[str], bool]:
    """The keyword names the constructor of ``cls`` accepts, and whether it takes ``**kw``."""
    sig = inspect.signature(cls)
    names = [p.name for p in sig.parameters.values()
             if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return names, any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())


def _resolve_user_solver(options: dict, base_dir) -> dict:
    """Replace a ``module:Class`` / ``file.py:Class`` solver name by the solver object."""
    solver = options.get("solver")
    if not (isinstance(solver, str) and ":" in solver):
        return options

    out = dict(options)
    out["solver"] = make_solver(solver, out.pop("solver_options", None), base_dir=base_dir)
    return out


def solver_hint(name) -> str:
    """``; did you mean 'ls'?`` for a misspelt built-in solver name, else ""."""
    if not isinstance(name, str) or ":" in name or name in available_solvers():
        return ""
    return did_you_mean(name, available_solvers())


def solver_options_hint(solver, options) -> str:
    """``; did you mean 'max_iter'?`` for the first key of ``options`` that is not an option
    of the built-in solver ``solver``, else ""."""
    if not (isinstance(solver, str) and solver in available_solvers()
            and isinstance(options, dict)):
        return ""
    names = get_solver(solver)._get_param_names()
    unknown = [k for k in options if k not in names]
    return did_you_mean(unknown[0], names) if unknown else ""


def build_estimator(spec, method_of, base_dir=None):
    """A fresh, unfitted estimator for a method entry.

    Parameters
    ----------
    spec : MethodSpec
        The ``[[methods]]`` entry.
    method_of : callable
        ``label -> MethodSpec`` (the parts of a superposition are other entries).
    base_dir : path, optional
        Folder of the scenario file (relative ``file.py:Class`` names).
    """
    entry = method_entry(spec.method, base_dir)
    if spec.composite:
        return entry.build(parts=tuple(build_estimator(method_of(p), method_of, base_dir)
                                       for p in spec.parts))
    cls = entry.cls
    options = dict(spec.options)
    if spec.n_modes is not None:
        options["n_modes"] = spec.n_modes
    names, var_kw = option_names(cls)
    if not var_kw:
        for key in options:
            if key not in names:
                raise InputError(
                    f"Parameter `{key}`: not an option of {cls.__name__}"
                    f"{did_you_mean(key, names)} (its options: "
                    f"{', '.join(names) or 'none'})"
                )
    options = _resolve_user_solver(options, base_dir)
    try:
        return entry.build(**options)
    except PodbenchError:
        raise
    except Exception as exc:  # a user's constructor may raise anything
        raise InputError(f"{cls.__name__}(...) raised {type(exc).__name__}: {exc}") from None


_PARAM = re.compile(r"Parameter `([A-Za-z_][A-Za-z0-9_]*)")


def check_method_entry(spec, method_of, base_dir=None) -> tuple[str, str] | None:
    """Build the estimator of an entry and validate its options without data.

    Returns None when the entry is usable, else ``(field, message)`` for the first problem:
    ``field`` is the entry's dotted sub-field (``"method"``, ``"n_modes"``,
    ``"options.energy"``, …) and ``message`` the reason.
    """
    try:
        est = build_estimator(spec, method_of, base_dir)
        validate = getattr(est, "_validate_params", None)
        if validate is not None:
            validate()
    except UserImportError as exc:
        return "method", str(exc)
    except InputError as exc:
        msg = " ".join(str(exc).split())
        if msg.startswith("unknown method") or "a method needs fit" in msg:
            return "method", msg
        m = _PARAM.match(msg)
        name = m.group(1) if m else None
        solver_options = spec.options.get("solver_options")
        if name == "n_modes" and spec.n_modes is not None and "n_modes" not in spec.options:
            return "n_modes", msg
        if name is not None and name in spec.options:
            if name == "solver":
                msg += solver_hint(spec.options["solver"])
            elif name == "solver_options":
                msg += solver_options_hint(spec.options.get("solver"), solver_options)
            return f"options.{name}", msg
        if isinstance(solver_options, dict) and name in solver_options:
            return f"options.solver_options.{name}", msg
        return "options", msg
    return None


def training_records(spec, method_of, get):
    """The training records of an entry: ``[get(case) …]`` in the entry's order, or for a
    superposition one such list per part."""
    if spec.composite:
        return [training_records(method_of(p), method_of, get) for p in spec.parts]
    return [get(c) for c in spec.train]


def all_cases(spec, method_of) -> set[str]:
    """Every case an entry (or a superposition's parts) trains on."""
    if spec.composite:
        return set().union(*(all_cases(method_of(p), method_of) for p in spec.parts))
    return set(spec.train)
