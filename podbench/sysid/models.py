"""Identified models you keep: a fitted method saved to ``model.npz``, loaded, and read.

A model file is a NumPy ``.npz`` archive of arrays, one of which, ``__header__``, is a JSON
string:

* ``format`` (``"podbench-model"``) and ``format_version`` (:data:`FORMAT_VERSION`);
* ``method`` (the abbreviation), ``class`` (``"module:Class"``, a podbench class);
* ``parameters``: the hyperparameters (``get_params(deep=False)``; a solver object as its
  class and its own parameters);
* ``state``: the fitted attributes (names ending in ``_``): arrays are stored as members of
  the archive and named in the header, scalars, strings, lists, tuples and dicts as JSON,
  records (the training records, which a prediction band refits on) by their fields, and
  nested podbench objects (a solver, a band calibration and its refitted models) in the same
  way, recursively;
* ``provenance``: the training files with their SHA-256, ``dt``, the channels and units,
  the podbench version. The hashes are provenance, not a condition for loading.

Written generically over the estimator contract (hyperparameters from the constructor,
fitted state in ``_`` attributes), so any podbench method saves. An attribute of a type the
format cannot hold (a third-party object) is refused when saving, in one line naming it.

``model.json`` beside the archive is the readable summary: the header with the arrays
described by dtype and shape instead of their values, and the model's state-space
realization and modes where it has one (:mod:`podbench.sysid.realize`) *when they were
made before saving* (``podbench fit`` makes them for ``modes.csv``; ``Model.modes()`` or
``Model.to_statespace()`` before ``save``); otherwise ``realization`` is null and
``realization_note`` says it was not computed: saving writes the arrays only, the
realization (about as long as the fit: every order of the lag rule) is made on demand.

Loading reads the archive with ``np.load(allow_pickle=False)``; a file that is not a
podbench model, has an unknown ``format_version``, or holds pickled objects is refused in
one line naming the file, before anything is built; only podbench classes are built. The
header records each array's shape and dtype and, in the member ``__parameters__``, the
parameters the state was fitted with: a truncated array, or a header whose ``parameters``
were edited by hand (another ``solver`` or ``n_modes``: the fitted arrays would predict
regardless), is refused in one line naming the file and the field. A
loaded model predicts exactly as the one saved (the same arrays and parameters).
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import inspect
import io
import json
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from podbench.core.atomic import atomic_write_bytes, atomic_write_text
from podbench.core.records import Record
from podbench.core.version import __version__
from podbench.errors import InputError
from podbench.sysid.realize import to_statespace

__all__ = ["Model", "save_model", "load_model", "read_header", "file_sha256", "FORMAT",
           "FORMAT_VERSION", "NOT_REALIZED", "realization_summary"]

FORMAT = "podbench-model"
"""The header's ``format``: what marks an archive as a podbench model."""
FORMAT_VERSION = 1
"""The model file layout this podbench writes and reads."""

_HEADER = "__header__"
_FITTED = "__parameters__"
"""The archive member holding the parameters the state was fitted with, as the header wrote
them: a header edited by hand (another ``solver`` or ``n_modes``) disagrees with it and is
refused, instead of predicting with the fitted state under parameters it was not fitted with."""
_TAG = "__pb__"  # the key of a tagged (non-JSON) value


class _Encoder:
    """Values → JSON with arrays set aside (module docstring)."""

    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}

    def array(self, a: np.ndarray, where: str) -> dict:
        if a.dtype.hasobject:
            raise InputError(f"save_model: attribute `{where}`: an object array cannot be "
                             "stored without pickles")
        key = f"a{len(self.arrays)}"
        self.arrays[key] = a
        return {_TAG: "array", "key": key, "shape": list(a.shape), "dtype": a.dtype.str}

    def value(self, v: Any, where: str):
        if v is None or isinstance(v, (bool, str)):
            return v
        if isinstance(v, int) and not isinstance(v, bool):
            return v
        if isinstance(v, float):
            return v if np.isfinite(v) else {_TAG: "float", "value": repr(v)}
        if isinstance(v, complex):
            return {_TAG: "complex", "value": [self.value(v.real, where),
                                               self.value(v.imag, where)]}
        if isinstance(v, np.generic):
            return {_TAG: "scalar", "dtype": v.dtype.str,
                    "value": self.value(v.item(), where)}
        if isinstance(v, np.ndarray):
            return self.array(v, where)
        if isinstance(v, (list, tuple)):
            items = [self.value(x, f"{where}[{i}]") for i, x in enumerate(v)]
            return items if isinstance(v, list) else {_TAG: "tuple", "items": items}
        if isinstance(v, dict):
            return {_TAG: "dict", "items": [[self.value(k, f"{where} key"),
                                             self.value(x, f"{where}[{k!r}]")]
                                            for k, x in v.items()]}
        if isinstance(v, Record):  # a Record, a Response: what methods read
            return {_TAG: "record", "fields": {f.name: self.value(getattr(v, f.name),
                                                                  f"{where}.{f.name}")
                                               for f in dataclasses.fields(Record)}}
        if hasattr(v, "get_params") and not isinstance(v, type):
            return self.estimator(v, where)
        if dataclasses.is_dataclass(v) and not isinstance(v, type):
            return {_TAG: "dataclass", "class": _class_path(v, where),
                    "fields": {f.name: self.value(getattr(v, f.name), f"{where}.{f.name}")
                               for f in dataclasses.fields(v)}}
        raise InputError(f"save_model: attribute `{where}`: a {type(v).__name__} cannot be "
                         "stored in a model file")

    def estimator(self, obj, where: str) -> dict:
        """A podbench object with hyperparameters (a method, a solver): its class, its
        parameters and its fitted attributes."""
        params = obj.get_params(deep=False)
        state = {k: v for k, v in vars(obj).items()
                 if k.endswith("_") and not k.startswith("_") and k not in params}
        return {_TAG: "object", "class": _class_path(obj, where),
                "parameters": {k: self.value(v, f"{where}.{k}") for k, v in params.items()},
                "state": {k: self.value(v, f"{where}.{k}") for k, v in state.items()}}


def _class_path(obj, where: str) -> str:
    cls = type(obj)
    if not cls.__module__.startswith("podbench."):
        raise InputError(f"save_model: attribute `{where}`: class {cls.__module__}."
                         f"{cls.__qualname__} is not podbench's; only podbench classes are "
                         "stored (and built when loading)")
    return f"{cls.__module__}:{cls.__qualname__}"


class _Decoder:
    """JSON with array references → values (the inverse of :class:`_Encoder`)."""

    def __init__(self, arrays, name: str):
        self.arrays = arrays
        self.name = name

    def array(self, v: dict, where: str) -> np.ndarray:
        """The archive member ``v["key"]``, checked against the shape and dtype the header
        recorded for it (files written before they were recorded: not checked)."""
        key = v.get("key")
        if key not in self.arrays:
            raise InputError(f"{self.name}: array {key!r}: missing (the header refers to it "
                             f"for `{where}`: an incomplete or edited model file)")
        a = np.array(self.arrays[key])
        shape, dtype = v.get("shape"), v.get("dtype")
        if shape is not None and list(a.shape) != list(shape) or (
                dtype is not None and a.dtype.str != dtype):
            raise InputError(f"{self.name}: array {key!r}: {a.dtype.str} {list(a.shape)}, "
                             f"but the header recorded {dtype} {shape} for `{where}` (a "
                             "truncated or edited model file)")
        return a

    def value(self, v, where: str = "model"):
        if isinstance(v, list):
            return [self.value(x, f"{where}[{i}]") for i, x in enumerate(v)]
        if not isinstance(v, dict):
            return v
        tag = v.get(_TAG)
        if tag == "array":
            return self.array(v, where)
        if tag == "float":
            return float(v["value"])
        if tag == "complex":
            return complex(self.value(v["value"][0], where), self.value(v["value"][1], where))
        if tag == "scalar":
            return np.dtype(v["dtype"]).type(self.value(v["value"], where))
        if tag == "tuple":
            return tuple(self.value(x, f"{where}[{i}]") for i, x in enumerate(v["items"]))
        if tag == "dict":
            return {_hashable(self.value(k, where)): self.value(x, f"{where}[{k!r}]")
                    for k, x in v["items"]}
        if tag in ("record", "iorecord"):  # "iorecord": files of before the one record type
            return Record.from_fields(**{k: self.value(x, f"{where}.{k}")
                                         for k, x in v["fields"].items()})
        if tag == "object":
            cls = self.cls(v["class"])
            params = {k: self.value(x, f"{where}.{k}") for k, x in v["parameters"].items()}
            accepted = inspect.signature(cls).parameters
            unknown = sorted(set(params) - set(accepted))  # an edited header: one line
            if unknown and not any(p.kind is p.VAR_KEYWORD for p in accepted.values()):
                raise InputError(f"{self.name}: field `parameters.{unknown[0]}`: not a "
                                 f"parameter of {cls.__name__}")
            obj = cls(**params)
            for k, x in v["state"].items():
                setattr(obj, k, self.value(x, f"{where}.{k}"))
            return obj
        if tag == "dataclass":
            return self.cls(v["class"])(**{k: self.value(x, f"{where}.{k}")
                                           for k, x in v["fields"].items()})
        raise InputError(f"{self.name}: not a podbench model (unknown entry {tag!r})")

    def cls(self, path: str):
        module, _, qual = str(path).partition(":")
        if not module.startswith("podbench.") or not qual:
            raise InputError(f"{self.name}: class {path!r} is not podbench's; refused")
        try:
            obj: Any = importlib.import_module(module)
            for part in qual.split("."):
                obj = getattr(obj, part)
        except (ImportError, AttributeError):
            raise InputError(f"{self.name}: class {path!r} does not exist in this podbench "
                             f"({__version__})") from None
        if not isinstance(obj, type):
            raise InputError(f"{self.name}: {path!r} is not a class; refused")
        return obj


def _hashable(k):
    return tuple(_hashable(x) for x in k) if isinstance(k, list) else k


def file_sha256(path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _provenance(method, training_files: Sequence) -> dict:
    ref = getattr(method, "reference_", None)
    out: dict = {"podbench_version": __version__,
                 "training_files": [{"name": Path(p).name, "sha256": file_sha256(p)}
                                    for p in training_files]}
    dt = getattr(method, "dt_", None)
    recs = getattr(method, "training_records_", None) or []
    if dt is None and recs:
        dt = getattr(recs[0], "dt", None)
    out["dt"] = None if dt is None else float(dt)
    if ref is not None and hasattr(ref, "input_channels"):
        out.update(input_channels=list(ref.input_channels),
                   output_channels=list(ref.output_channels),
                   input_units=ref.input_units, output_units=ref.output_units,
                   input_quantity=ref.input_quantity, output_quantity=ref.output_quantity)
    else:
        m = int(np.shape(method.modes_)[0])
        chans = [str(i) for i in range(m)]
        out.update(input_channels=chans, output_channels=chans, output_units="in",
                   output_quantity="displacement")
    return out


def _readable(v):
    """A header value with arrays described instead of referenced (for ``model.json``)."""
    if isinstance(v, list):
        return [_readable(x) for x in v]
    if not isinstance(v, dict):
        return v
    if v.get(_TAG) == "array":
        return f"<array {v['key']}>"
    return {k: _readable(x) for k, x in v.items()}


def realization_summary(method, ss=None):
    """``(summary, table)``: the state-space realization and modes of ``method`` (or of its
    realization ``ss`` already made) for ``model.json`` and the modes table; ``table`` None
    (and the summary's ``reason``) where the method has no state-space form."""
    try:
        ss = to_statespace(method) if ss is None else ss
        modes = ss.modes()
    except InputError as exc:
        return {"realization": None, "reason": str(exc)}, None
    table = modes.table()
    return {"realization": ss.realization, "order": ss.order,
            "form": "free (A, C, x0_map)" if ss.is_free else "forced (A, B, C, D)",
            "modes_rule": list(modes.notes), "modes": table.to_dict(orient="records")}, table


NOT_REALIZED = ("not computed when saving (a realization tries every order of the lag rule, "
                "as long as the fit itself): Model.modes() and Model.to_statespace() compute "
                "it from the saved model, and podbench fit writes it here with modes.csv")
"""``model.json``'s ``realization_note`` when the realization was not made before saving."""


def save_model(method, path, *, training_files: Sequence = (), include_records: bool = True,
               summary: bool = True, extra: dict | None = None,
               realize: bool = False) -> Path:
    """Save a fitted method to ``path`` (``.npz``) and its summary beside it (``.json``).

    Parameters
    ----------
    method : fitted estimator
        A podbench method after ``fit``.
    path : path-like
        The archive (written atomically; the suffix ``.npz`` is required).
    training_files : sequence of path-like
        The files the method was trained on (their names and SHA-256 go to the provenance).
    include_records : bool
        Keep the training records (what a prediction band refits on; default True).
    summary : bool
        Write ``<stem>.json`` beside the archive (default True).
    extra : dict, optional
        More entries for the summary (JSON values: e.g. what the fit chose); with a
        ``realization`` entry, the realization summary the caller made (not made again).
    realize : bool
        Without a ``realization`` entry in ``extra``: realize the model now for the summary
        (default False: the summary says it was not computed, :data:`NOT_REALIZED`; the
        realization costs about as much as the fit, the archive alone is cheap).

    Returns
    -------
    Path
        The archive written.
    """
    path = Path(path)
    if path.suffix != ".npz":
        raise InputError(f"{path}: a model file ends in .npz")
    if not hasattr(method, "modes_"):
        raise InputError(f"{type(method).__name__}: not fitted; fit before save_model")
    enc = _Encoder()
    body = enc.estimator(method, "model")
    if not include_records:
        body["state"].pop("training_records_", None)
        body["state"].pop("band_calibration_", None)
    header = {"format": FORMAT, "format_version": FORMAT_VERSION,
              "method": str(getattr(method, "abbreviation", "") or type(method).__name__),
              "class": body["class"], "parameters": body["parameters"],
              "state": body["state"], "provenance": _provenance(method, training_files)}
    text = json.dumps(header, allow_nan=False, ensure_ascii=False)
    buf = io.BytesIO()
    fitted = json.dumps(header["parameters"], allow_nan=False, ensure_ascii=False)
    members: dict[str, Any] = {_HEADER: np.array(text), _FITTED: np.array(fitted),
                               **enc.arrays}
    np.savez_compressed(buf, **members)
    atomic_write_bytes(path, buf.getvalue())
    if summary:
        readable = _readable(header)
        readable["arrays"] = {k: f"{a.dtype} {list(a.shape)}" for k, a in enc.arrays.items()}
        extra = dict(extra or {})
        if "realization" not in extra:  # a caller that realized already passes its summary
            readable.update(realization_summary(method)[0] if realize else
                            {"realization": None, "realization_note": NOT_REALIZED})
        readable.update(extra)
        atomic_write_text(path.with_suffix(".json"),
                          json.dumps(readable, indent=1, ensure_ascii=False, default=str) + "\n")
    return path


def _open(path: Path) -> dict:
    name = str(path)
    if path.is_dir():
        inside = path / "model.npz"
        hint = (f"; the model podbench fit wrote there is {inside}" if inside.is_file()
                else "; give the model.npz that podbench fit wrote")
        raise InputError(f"{path}: a folder, not a model file{hint}")
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    with open(path, "rb") as fh:
        magic = fh.read(6)
    if magic[:1] == b"\x80":  # a pickle's protocol opcode
        raise InputError(f"{name}: refused: it is a pickle, which podbench never loads")
    if not magic.startswith(b"PK"):
        raise InputError(f"{name}: not a podbench model (not an .npz archive)")
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except ValueError as exc:
        if "pickle" in str(exc):
            raise InputError(f"{name}: refused: it holds pickled objects, which podbench "
                             "never loads") from None
        raise InputError(f"{name}: not a podbench model ({exc})") from None
    except (OSError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"{name}: not a podbench model (not an .npz archive: {exc})") from None


def read_header(path) -> tuple[dict, dict]:
    """``(header, arrays)`` of a model file, checked (module docstring's refusals)."""
    path = Path(path)
    name = str(path)
    arrays = _open(path)
    raw = arrays.pop(_HEADER, None)
    if raw is None or raw.ndim != 0 or raw.dtype.kind != "U":
        raise InputError(f"{name}: not a podbench model (no `{_HEADER}` entry)")
    try:
        header = json.loads(str(raw))
    except json.JSONDecodeError:
        raise InputError(f"{name}: not a podbench model (its header is not JSON)") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise InputError(f"{name}: not a podbench model (format is not {FORMAT!r})")
    version = header.get("format_version")
    if version != FORMAT_VERSION:
        raise InputError(f"{name}: field `format_version`: {version!r} is unknown; this podbench "
                         f"({__version__}) reads version {FORMAT_VERSION}")
    for key in ("class", "parameters", "state"):
        if key not in header:
            raise InputError(f"{name}: field `{key}`: missing (not a complete podbench model)")
    return header, arrays


def load_model(path):
    """The fitted method saved in ``path`` by :func:`save_model`.

    Raises
    ------
    InputError
        One line naming the file: not a podbench model, an unknown ``format_version``,
        pickled content, a class that is not podbench's, an array whose shape or dtype is not
        the one the header recorded, a header ``parameters.<name>`` other than the one the
        state was fitted with.
    """
    path = Path(path)
    header, arrays = read_header(path)
    dec = _Decoder(arrays, str(path))
    obj = dec.value({_TAG: "object", "class": header["class"],
                     "parameters": header["parameters"], "state": header["state"]})
    _check_fitted_parameters(header, arrays, str(path))
    if not hasattr(obj, "modes_"):
        raise InputError(f"{path}: the model holds no fitted state (`modes_` missing)")
    obj.provenance_ = header.get("provenance", {})
    return obj


def _check_fitted_parameters(header: dict, arrays: dict, name: str) -> None:
    """Refuse a header whose ``parameters`` differ from those the state was fitted with
    (member :data:`_FITTED`; files written before it existed are not checked)."""
    raw = arrays.get(_FITTED)
    if raw is None:
        return
    try:
        fitted = json.loads(str(raw))
    except json.JSONDecodeError:
        raise InputError(f"{name}: member `{_FITTED}` is not JSON (an edited model "
                         "file)") from None
    params = header["parameters"]
    for key in sorted(set(params) | set(fitted), key=str):
        if params.get(key) != fitted.get(key):
            def shown(v):
                text = json.dumps(v, ensure_ascii=False)
                return text if len(text) <= 60 else text[:57] + "..."
            raise InputError(
                f"{name}: field `parameters.{key}`: {shown(params.get(key))} in the header, "
                f"but the arrays were fitted with {shown(fitted.get(key))} (an edited model "
                "file; refit with podbench fit to change a parameter)")


class Model:
    """A fitted method as a model you keep: predict with it, read its modes, export its
    state-space form, save it (``pb.fit`` returns one; ``pb.load_model`` reads one back).

    Every other attribute is the fitted method's own (``model.kernel_``, ``model.n_lags_``).

    Parameters
    ----------
    method : fitted estimator
        A podbench method after ``fit``.
    training_files : sequence of path-like
        The files it was trained on (their SHA-256 go to the saved provenance).
    """

    def __init__(self, method, *, training_files: Sequence = ()):
        if not hasattr(method, "modes_"):
            raise InputError(f"{type(method).__name__}: not fitted; fit before making a Model")
        self.method = method
        self.training_files = tuple(str(p) for p in training_files)
        self._statespace = None  # the default realization, made once (to_statespace)

    def __getattr__(self, name: str):
        if name in ("method", "_statespace"):  # not set yet (unpickling, copying)
            raise AttributeError(name)
        return getattr(self.method, name)

    def __repr__(self) -> str:
        return f"Model({self.method!r})"

    @property
    def provenance(self) -> dict:
        """Where the model came from: read from the file for a loaded model, else the
        training files, ``dt``, channels and units of this fit."""
        saved = getattr(self.method, "provenance_", None)
        return dict(saved) if saved else _provenance(self.method, self.training_files)

    def predict(self, record=None, *, coverage=None, **fields):
        """The method's prediction (:meth:`podbench.sysid.methods.PODMethod.predict`)."""
        return self.method.predict(record, coverage=coverage, **fields)

    def to_statespace(self, *, order: int | None = None, dt: float | None = None):
        """The discrete state-space model (:func:`podbench.sysid.realize.to_statespace`):
        ``A, B, C, D, dt``; ``.to_dlti()``, ``.to_control()`` export it. The default
        realization (no ``order``, ``dt``) is made once and kept."""
        if order is not None or dt is not None:
            return to_statespace(self.method, order=order, dt=dt)
        if self._statespace is None:
            self._statespace = to_statespace(self.method)
        return self._statespace

    def modes(self, criteria: dict | None = None):
        """The identified physical modes as a DataFrame: ``mode, frequency_hz,
        damping_ratio, shape:<output channel>…`` sorted by frequency
        (:meth:`podbench.sysid.realize.StateSpaceModel.modes`: the hard criteria and the
        stabilization rule of :func:`podbench.sysid.modal.physical_modes`)."""
        return self.to_statespace().modes(criteria).table()

    def to_dlti(self):
        """The model as :class:`scipy.signal.dlti` (forced models)."""
        return self.to_statespace().to_dlti()

    def to_control(self):
        """The model as python-control's ``StateSpace`` (forced models; the ``control``
        package)."""
        return self.to_statespace().to_control()

    def save(self, path, *, include_records: bool = True, extra: dict | None = None) -> Path:
        """Write the model file ``path`` (``.npz``) and its summary ``<stem>.json``
        (:func:`save_model`). The summary holds the realization and modes when they were
        made before saving (``modes()``, ``to_statespace()``), else says that they were not
        computed (:data:`NOT_REALIZED`): saving does not realize."""
        extra = dict(extra or {})
        if self._statespace is not None and "realization" not in extra:
            extra.update(realization_summary(self.method, self._statespace)[0])
        return save_model(self.method, path, training_files=self.training_files,
                          include_records=include_records, extra=extra)

    @classmethod
    def load(cls, path) -> Model:
        """The model saved in ``path`` (:func:`load_model`'s refusals)."""
        return cls(load_model(path))
