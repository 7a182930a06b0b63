"""Hyperparameters declared once: constraints, checks, ``get_params`` and the docs' tables.

Every method (:class:`~podbench.methods.PODMethod`) and deconvolution solver
(:class:`~podbench.deconvolution.Solver`) states, beside its constructor, what each
hyperparameter may be, in scikit-learn's manner (``sklearn/utils/_param_validation.py``)::

    _parameter_constraints = {
        "n_modes": [None, Interval("integer", 1)],
        "energy": [Interval("number", 0, 1, closed="right")],
        "basis": [Options("first", "all")],
    }

The constructor's signature gives the names and defaults (so ``sklearn.base.clone`` works);
the constraints give type and range. From the two come :func:`validate_params` (a bad value
raises one :class:`~podbench.errors.InvalidParameterError` naming ``.param``, "Parameter
`n_modes`: expected an integer >= 1, got 0"), ``get_params`` / ``set_params``
(:class:`ParamsMixin`) and the parameter tables of docs/methods.md
(:func:`parameter_table`, a test compares). A class without a declaration (a user's class
written for the older contract) is not checked here: its own ``_validate_params`` runs.
"""

from __future__ import annotations

import inspect
import math
import numbers
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from podbench.core.hints import percent_hint
from podbench.errors import InvalidParameterError

__all__ = [
    "Interval",
    "Options",
    "InstanceOf",
    "Boolean",
    "ParamsMixin",
    "validate_params",
    "check_param",
    "check_names",
    "parameter_table",
    "parameters",
    "parameter_docs",
    "Parameter",
    "plain_text",
]


class Constraint:
    """One admissible kind of value: ``accepts(value)``, ``describe()`` for messages and
    tables, ``same_type(value)`` (a value of this kind that fails only its range)."""

    def same_type(self, value) -> bool:
        return False

    def accepts(self, value) -> bool:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError

    def coerce(self, value):
        """The value as the solver or method uses it (``int`` / ``float`` for numbers)."""
        return value


class _NoneConstraint(Constraint):
    def accepts(self, value) -> bool:
        return value is None

    def describe(self) -> str:
        return "None"


class Interval(Constraint):
    """An integer or a finite real number in a range.

    Parameters
    ----------
    kind : {"integer", "number"}
        ``"integer"``: an :class:`numbers.Integral` (not a bool); ``"number"``: a finite
        :class:`numbers.Real` (not a bool), integers included.
    lo, hi : float, optional
        Bounds (None: unbounded on that side).
    closed : {"left", "right", "both", "neither"}
        Which bounds belong to the range (default ``"left"``).
    """

    def __init__(self, kind: str, lo: float | None = None, hi: float | None = None, *,
                 closed: str = "left"):
        if kind not in ("integer", "number") or closed not in ("left", "right", "both",
                                                               "neither"):
            raise ValueError(f"Interval({kind!r}, closed={closed!r})")
        self.kind, self.lo, self.hi, self.closed = kind, lo, hi, closed

    def same_type(self, value) -> bool:
        if isinstance(value, (bool, np.bool_)):
            return False
        if self.kind == "integer":
            return isinstance(value, numbers.Integral)
        return isinstance(value, numbers.Real)

    def accepts(self, value) -> bool:
        if not self.same_type(value):
            return False
        if self.kind == "number" and not math.isfinite(float(value)):
            return False
        lo_in = self.closed in ("left", "both")
        hi_in = self.closed in ("right", "both")
        if self.lo is not None and not (value >= self.lo if lo_in else value > self.lo):
            return False
        return self.hi is None or bool(value <= self.hi if hi_in else value < self.hi)

    def coerce(self, value):
        return int(value) if self.kind == "integer" else float(value)

    def describe(self) -> str:
        noun = "an integer" if self.kind == "integer" else "a number"
        lo_in = self.closed in ("left", "both")
        hi_in = self.closed in ("right", "both")
        if self.lo is not None and self.hi is not None:
            return (f"{noun} in {'[' if lo_in else '('}{_num(self.lo)}, {_num(self.hi)}"
                    f"{']' if hi_in else ')'}")
        if self.lo is not None:
            return f"{noun} {'>=' if lo_in else '>'} {_num(self.lo)}"
        if self.hi is not None:
            return f"{noun} {'<=' if hi_in else '<'} {_num(self.hi)}"
        return noun


class Options(Constraint):
    """One of a few strings (or other hashable values)."""

    def __init__(self, *values):
        self.values = tuple(values)

    def same_type(self, value) -> bool:
        return isinstance(value, str)

    def accepts(self, value) -> bool:
        try:
            return value in self.values
        except TypeError:  # an unhashable value compared with the options
            return False

    def describe(self) -> str:
        return (repr(self.values[0]) if len(self.values) == 1
                else "one of " + ", ".join(map(repr, self.values)))


class InstanceOf(Constraint):
    """An instance of ``types`` (``text`` names it in messages: "a dict")."""

    def __init__(self, types, text: str):
        self.types, self.text = types, text

    def accepts(self, value) -> bool:
        return isinstance(value, self.types)

    def describe(self) -> str:
        return self.text


class Boolean(Constraint):
    """True or False (NumPy booleans included)."""

    def accepts(self, value) -> bool:
        return isinstance(value, (bool, np.bool_))

    def coerce(self, value):
        return bool(value)

    def describe(self) -> str:
        return "True or False"


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _as_constraint(c) -> Constraint:
    return _NoneConstraint() if c is None else c


def describe(constraints: Iterable) -> str:
    """``"None or an integer >= 1"``: what the constraints admit, in words."""
    words = [_as_constraint(c).describe() for c in constraints]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def check_param(value, name: str, constraints) -> Any:
    """``value`` (coerced by the constraint it meets) or :class:`InvalidParameterError`.

    The message names the parameter, what it admits and the value: "Parameter `n_modes`:
    expected an integer >= 1, got 0". When the value has the right type but not the range,
    only the constraints of that type are named.
    """
    cons = [_as_constraint(c) for c in constraints]
    for c in cons:
        if c.accepts(value):
            return c.coerce(value)
    near = [c for c in cons if c.same_type(value)]
    # a fraction given as a percentage (holdout = 25, coverage = 90): value/100 would do
    fraction = (isinstance(value, numbers.Real) and not isinstance(value, bool) and value > 1
                and any(isinstance(c, Interval) and c.hi is not None and c.hi <= 1
                        and c.accepts(value / 100) for c in near))
    raise InvalidParameterError(
        f"Parameter `{name}`: expected {describe(near or cons)}, got {value!r}"
        f"{percent_hint(value) if fraction else ''}", param=name)


def validate_params(obj) -> dict:
    """Check every declared hyperparameter of ``obj`` (its class's
    ``_parameter_constraints``); returns ``{name: value}`` as used (numbers as ``int`` /
    ``float``): the constructor's parameters (those without a declaration unchecked), then
    declared ones the object has from a base class's constructor (a subclass that passes
    some to ``super().__init__``)."""
    declared = getattr(type(obj), "_parameter_constraints", None) or {}
    names = dict.fromkeys([*type(obj)._get_param_names(), *declared])
    out = {}
    for name in names:
        if not hasattr(obj, name):
            continue
        value = getattr(obj, name)
        out[name] = check_param(value, name, declared[name]) if name in declared else value
    return out


def check_names(given: Iterable[str], valid: Iterable[str], *, where: str,
                kind: str = "parameter", of: str = "", error: type[Exception] = TypeError,
                **error_kw) -> None:
    """The one check of keyword names (``set_params``, a solver's options): raises
    ``error`` naming the first unknown name and listing the valid ones."""
    valid = list(valid)
    for key in given:
        if key not in valid:
            raise error(f"{where}: unknown {kind} {key!r}{of} (its {kind}s: "
                        f"{', '.join(valid) or 'none'})", **error_kw)


_PARAM_NAMES: dict = {}
"""Constructor → its keyword parameter names (:meth:`ParamsMixin._get_param_names`)."""


class ParamsMixin:
    """``get_params`` / ``set_params`` / ``repr`` / ``_validate_params`` from the constructor's
    signature and the class's ``_parameter_constraints`` (shared by methods and solvers)."""

    #: ``{name: [constraint, …]}`` (a constraint: None, :class:`Interval`,
    #: :class:`Options`, :class:`InstanceOf`, :class:`Boolean`); see the module docstring.
    _parameter_constraints: dict[str, list] = {}

    @classmethod
    def _get_param_names(cls) -> list[str]:
        """Names of the constructor's keyword parameters (the hyperparameters), in order."""
        init = cls.__init__
        if init is object.__init__:
            return []
        names = _PARAM_NAMES.get(init)
        if names is None:  # inspect.signature is slow: the bands' refits call this often
            sig = inspect.signature(init)
            names = tuple(p.name for p in sig.parameters.values() if p.name != "self"
                          and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD))
            _PARAM_NAMES[init] = names
        return list(names)

    def get_params(self, deep: bool = True) -> dict:
        """Hyperparameters as given to the constructor (``deep``: also ``name__param`` of
        a hyperparameter that has ``get_params`` itself, e.g. a solver object)."""
        out = {}
        for name in self._get_param_names():
            value = getattr(self, name)
            if deep and hasattr(value, "get_params") and not isinstance(value, type):
                out.update({f"{name}__{k}": v for k, v in value.get_params().items()})
            out[name] = value
        return out

    def set_params(self, **params):
        """Set hyperparameters (validated when used); returns ``self``. ``TypeError`` names an
        unknown one; ``name__param`` reaches a hyperparameter's own parameters."""
        nested: dict[str, dict] = {}
        heads = {name: name.partition("__") for name in params}
        check_names((h for h, _, _ in heads.values()), self._get_param_names(),
                    where=f"{type(self).__name__}.set_params")
        for name, value in params.items():
            head, sep, rest = heads[name]
            if sep:
                nested.setdefault(head, {})[rest] = value
            else:
                setattr(self, name, value)
        for head, sub in nested.items():
            inner = getattr(self, head)
            if not hasattr(inner, "set_params"):
                raise TypeError(f"{type(self).__name__}.set_params: parameter {head!r} "
                                f"({inner!r}) has no parameters of its own")
            inner.set_params(**sub)
        return self

    def _validate_params(self) -> None:
        """Check the declared hyperparameters without data (:class:`InvalidParameterError`
        naming the parameter); a class adds checks that relate several of them."""
        validate_params(self)

    def _params(self) -> dict:
        """The hyperparameters, checked, as used (numbers as ``int`` / ``float``)."""
        return validate_params(self)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params(deep=False).items())
        return f"{type(self).__name__}({args})"


@dataclass(frozen=True)
class Parameter:
    """One hyperparameter as declared: ``name``, what it ``admits`` (from the constraints),
    its ``default`` as shown (from the constructor's signature) and ``doc`` (its
    description in the class docstring's ``Parameters`` section, markup removed; "" if
    none)."""

    name: str
    admits: str
    default: str
    doc: str


def parameters(cls) -> list[Parameter]:
    """The hyperparameters of ``cls`` in the constructor's order, from its declaration:
    the one source of :func:`parameter_table` (docs/methods.md) and of
    ``podbench methods`` (the command line's help on a method or solver)."""
    sig = inspect.signature(cls.__init__)
    declared: Mapping = cls._parameter_constraints
    docs = parameter_docs(cls)
    out = []
    for name in cls._get_param_names():
        default = sig.parameters[name].default
        out.append(Parameter(
            name=name, admits=describe(declared[name]) if name in declared else "(not declared)",
            default=f"{default:g}" if isinstance(default, float) else repr(default),
            doc=docs.get(name, "")))
    return out


def parameter_table(cls) -> str:
    """The Markdown table of ``cls``'s hyperparameters (name, what it admits, default), as
    in docs/methods.md."""
    rows = ["| parameter | admits | default |", "| --- | --- | --- |"]
    rows += [f"| `{p.name}` | {p.admits} | `{p.default}` |" for p in parameters(cls)]
    return "\n".join(rows)


_HEADER = re.compile(r"^(\w+(?:\s*,\s*\w+)*)(?:\s+:\s+.*|\s*:)?\s*$")
"""A numpydoc parameter line, ``name : type`` or ``a, b : type`` or ``name``."""


def parameter_docs(cls) -> dict[str, str]:
    """Name → description of every parameter in the numpydoc ``Parameters`` section of
    ``cls``'s docstring (a parameter it leaves undescribed: its base classes'), one
    paragraph, reStructuredText roles and literals reduced to their text
    (``:class:`~a.B``` → ``B``)."""
    docs: dict[str, str] = {}
    for klass in cls.__mro__:
        for name, text in _section(inspect.cleandoc(klass.__dict__.get("__doc__") or "")):
            if text and name not in docs:
                docs[name] = text
    return docs


def _section(doc: str) -> list[tuple[str, str]]:
    """(name, description) of the ``Parameters`` section of one docstring."""
    lines = doc.splitlines()
    starts = [i for i in range(len(lines) - 1)
              if lines[i].strip() == "Parameters" and set(lines[i + 1].strip()) == {"-"}]
    if not starts:
        return []
    docs: dict[str, list[str]] = {}
    current: list[str] = []
    for i in range(starts[0] + 2, len(lines)):
        line = lines[i]
        if not line.strip():
            continue
        if line[0].isspace():
            current.append(line.strip())
            continue
        match = _HEADER.match(line)
        if match is None or (i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}):
            break  # prose after the section, or the next section
        current = []
        for name in match.group(1).split(","):
            docs[name.strip()] = current
    return [(name, plain_text(" ".join(text))) for name, text in docs.items()]


def plain_text(text: str) -> str:
    """reStructuredText reduced to plain text: ``:role:`~a.b.C``` → ``C``, ````x```` → ``x``."""
    text = re.sub(r":\w+:`~[\w.]*?(\w+)`", r"\1", text)
    text = re.sub(r":\w+:`([^`]+)`", r"\1", text)
    return re.sub(r"``([^`]+)``", r"\1", text)


# Constraints many hyperparameters share.
POSITIVE = Interval("number", 0, closed="neither")
"""A finite number > 0."""
NON_NEGATIVE = Interval("number", 0)
"""A finite number >= 0."""
FRACTION = Interval("number", 0, 1, closed="neither")
"""A number in (0, 1)."""
COUNT = Interval("integer", 1)
"""An integer >= 1."""
