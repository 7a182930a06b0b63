"""Input checks shared by the whole package (one place, one wording)."""

from __future__ import annotations

import numbers
from collections.abc import Collection
from typing import Literal, TypeVar, overload

import numpy as np

from podbench.core.hints import did_you_mean
from podbench.errors import DimensionError, InputError


def as_finite_array(x, name: str, *, ndim: int | None = None, dtype=float) -> np.ndarray:
    """Return ``x`` as a float ndarray, rejecting NaN/Inf and a wrong number of dimensions.

    Parameters
    ----------
    x : array_like
        The data.
    name : str
        Name of the parameter, used in the error message.
    ndim : int, optional
        Required number of dimensions.
    """
    try:
        arr = np.asarray(x, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"Parameter `{name}`: cannot be converted to a numeric array ({exc})"
        ) from None
    if ndim is not None and arr.ndim != ndim:
        raise DimensionError(
            f"Parameter `{name}`: expected a {ndim}-D array, got shape {arr.shape}"
        )
    if arr.size and not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise InputError(f"Parameter `{name}`: contains {bad} NaN or Inf value(s)")
    return arr


_T = TypeVar("_T")


@overload
def check_positive(x, name: str, *, integer: Literal[True], allow_zero: bool = False) -> int: ...


@overload
def check_positive(x, name: str, *, integer: Literal[False] = False,
                   allow_zero: bool = False) -> float: ...


def check_positive(x, name: str, *, integer: bool = False,
                   allow_zero: bool = False) -> int | float:
    """Return ``x`` after checking it is a positive (or non-negative) finite number."""
    if integer:
        if isinstance(x, bool) or not isinstance(x, numbers.Integral):
            raise InputError(f"Parameter `{name}`: expected an integer, got {x!r}")
        x = int(x)
    else:
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            raise InputError(f"Parameter `{name}`: expected a number, got {x!r}")
        x = float(x)
        if not np.isfinite(x):
            raise InputError(f"Parameter `{name}`: must be finite, got {x!r}")
    if x < 0 or (x == 0 and not allow_zero):
        word = "non-negative" if allow_zero else "positive"
        raise InputError(f"Parameter `{name}`: must be {word}, got {x!r}")
    return x


def check_choice(value: _T, name: str, choices: Collection) -> _T:
    """Return ``value`` if it is one of ``choices``, else raise an InputError naming them
    (and the closest, letter case aside: ``'halfsine'`` finds ``'half_sine'``)."""
    if value not in choices:
        raise InputError(
            f"Parameter `{name}`: {value!r} is not one of {', '.join(map(repr, choices))}"
            f"{did_you_mean(value, choices)}"
        )
    return value


def condition_number(singular_values) -> float:
    """The 2-norm condition number ``σ_max / σ_min`` from singular values in descending
    order (as ``numpy.linalg.svd`` returns them); ``inf`` when the smallest is 0 or there
    are none."""
    s = np.asarray(singular_values)
    return float(s[0] / s[-1]) if s.size and s[-1] > 0 else float("inf")
