"""Superposition of methods: the sum of their predictions, each part fed its own training
records and its own part of a target.

For a linear structure the response to an initial displacement, an initial velocity and a
load together is the sum of the three responses, so ``MDS(w0) + MDS(v0) + ML(F)`` fitted in
one basis is the coupled counterpart of the mixed-response method (MR's coupled twin,
:meth:`MixedResponse.coupled_twin`). Each part reads only the fields it needs from a
target record (an MDS for displacements reads ``w0``, ML reads ``F``), so the prediction
for a record is simply the sum of the parts' predictions.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from podbench.errors import InputError, InvalidParameterError
from podbench.sysid.methods.base import PODMethod
from podbench.sysid.params import InstanceOf

__all__ = ["Superposition"]

_PARTS: list = [InstanceOf((list, tuple), "a non-empty sequence of methods")]


class Superposition(PODMethod):
    """The sum of several methods' predictions, all fitted in one basis.

    Parameters
    ----------
    parts : sequence of estimators
        Unfitted methods (each following the :class:`PODMethod` contract).

    Attributes
    ----------
    parts_ : list of fitted estimators
        Fresh copies of ``parts`` (``type(p)(**p.get_params(deep=False))``), fitted.
    modes_ : (m, k) ndarray
        The basis every part predicts in: ``basis`` if given, else the first part's POMs
        (the other parts are then fitted in it).
    n_modes_ : int

    Examples
    --------
    >>> twin = Superposition(parts=(MDS(excitation="displacement"),          # doctest: +SKIP
    ...                             MDS(excitation="velocity"), MultipleLoad()))
    >>> twin.fit([[d1, d2, d3], [i1, i2, i3], [p1, p2, p3]], basis=U)      # doctest: +SKIP
    """

    abbreviation = "superposition"
    excitation_kind = "mixed"
    composite = True
    _parameter_constraints = {"parts": _PARTS}

    def __init__(self, *, parts=()):
        self.parts = parts

    @property
    def coupled(self) -> bool:  # type: ignore[override]
        """Coupled when every part is."""
        parts = self.parts if isinstance(self.parts, Sequence) else ()
        return bool(parts) and all(getattr(p, "coupled", False) for p in parts)

    def _validate_params(self) -> None:
        super()._validate_params()
        if not self.parts:
            raise InvalidParameterError(
                f"Parameter `parts`: expected {_PARTS[0].describe()}, got {self.parts!r}",
                param="parts")
        for j, p in enumerate(self.parts):
            if not (hasattr(p, "fit") and hasattr(p, "predict")):
                raise InvalidParameterError(
                    f"Parameter `parts[{j}]`: {p!r} is not a method (no fit/predict)",
                    param="parts")
            validate = getattr(p, "_validate_params", None)
            if validate is not None:
                validate()

    def required_fields(self) -> tuple[str, ...]:
        out: list[str] = []
        for p in self.parts:
            for f in getattr(p, "required_fields", lambda: ("W",))():
                if f not in out:
                    out.append(f)
        return tuple(out)

    def _training_records(self, records, name: str = "records") -> list:
        """One training set per part (``records[j]`` is what ``parts[j].fit`` takes)."""
        if not isinstance(records, Sequence) or len(records) != len(self.parts):
            got = len(records) if isinstance(records, Sequence) else type(records).__name__
            raise InputError(
                f"Parameter `{name}`: expected one training set per part "
                f"({len(self.parts)}), got {got}"
            )
        return list(records)

    def _fit(self, records, basis) -> None:
        """Every part on its own training records, all in one basis: ``basis``, default
        the first part's own POMs."""
        fitted = []
        for j, (p, recs) in enumerate(zip(self.parts, records, strict=True)):
            est = type(p)(**p.get_params(deep=False))
            est.fit(recs, basis=basis)
            if basis is None and j == 0:
                basis = np.asarray(est.modes_, dtype=float)
            fitted.append(est)
        self.parts_ = fitted
        self.modes_ = np.asarray(basis, dtype=float)
        self.n_modes_ = int(self.modes_.shape[1])

    def _predict(self, record) -> np.ndarray:
        """The sum of the parts' predictions for ``record`` (each reads its own fields)."""
        return np.asarray(sum(np.asarray(p.predict(record), dtype=float) for p in self.parts_))
