"""The one alias table: old module names and retired names, kept importable.

Modules (:data:`ALIASES`): podbench was laid out into ``core → structures → dynamics →
sysid → study → harness → report → api/cli`` (docs/ARCHITECTURE.md). What users imported
before — ``podbench.methods.forced``, ``podbench.deconvolution.kernel``,
``podbench.excitations``, ``podbench.fem``, ``podbench.records``, ``podbench.data`` … — still
imports: an import of an old name returns the module at its new place (the same module
object, so classes, ``isinstance`` and monkeypatching agree whichever name was used).

Names (:data:`RETIRED`): a class or function that was merged into another (``IORecord`` into
:class:`~podbench.core.records.Record`, ``MultipleLoadIO`` into
:class:`~podbench.sysid.methods.MultipleLoad`, …) still imports from its old module; the
first use warns once (``FutureWarning``) naming the new name. Where the old name stood for a
configuration of the new class (other defaults), it builds the new class with them.
"""

from __future__ import annotations

import functools
import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from dataclasses import dataclass, field

__all__ = ["ALIASES", "RETIRED", "Retired", "install", "retired"]

ALIASES: dict[str, str] = {
    "podbench.fem": "podbench.structures",
    "podbench.records": "podbench.core.records",
    "podbench.data": "podbench.core.response",
    "podbench.excitations": "podbench.dynamics.excitations",
    "podbench.pod": "podbench.sysid.pod",
    "podbench.deconvolution": "podbench.sysid.deconvolution",
    "podbench.methods": "podbench.sysid.methods",
    "podbench.noise": "podbench.sysid.noise",
    "podbench.conditioning": "podbench.sysid.conditioning",
    "podbench.measured": "podbench.core.recordfiles",
    "podbench.sysid.measured": "podbench.core.recordfiles",
    "podbench.core.iorecords": "podbench.core.records",
    "podbench.sysid.methods.peers_io": "podbench.sysid.methods.peers",
    "podbench.study.hints": "podbench.core.hints",
    "podbench.scenarios": "podbench.study.scenarios",
    "podbench.experiments": "podbench.study.experiments",
}
"""Old module name (and every submodule under it) → the module's name now."""


def _target(fullname: str) -> str | None:
    for old in sorted(ALIASES, key=len, reverse=True):
        if fullname == old or fullname.startswith(old + "."):
            return ALIASES[old] + fullname[len(old):]
    return None


class _AliasFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old name and loads it as the module at the new name."""

    def find_spec(self, fullname, path=None, target=None):
        new = _target(fullname)
        if new is None or importlib.util.find_spec(new) is None:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        return importlib.import_module(_target(spec.name))

    def exec_module(self, module):  # the module at its new name is already executed
        pass


def install() -> None:
    """Put the alias finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _AliasFinder())


@dataclass(frozen=True)
class Retired:
    """A retired name: ``new`` (``"module:name"``), the keyword arguments the old name fixed
    (``fixed``: a configuration of the new class) and old keywords renamed (``renamed``)."""

    new: str
    fixed: dict = field(default_factory=dict)
    renamed: dict = field(default_factory=dict)  # old keyword → new one (None: dropped)
    warn: bool = True  # False: the name moved, it is not retired
    positional: tuple = ()  # the old name's positional parameters, passed as keywords


RETIRED: dict[tuple[str, str], Retired] = {
    ("podbench.core.records", "IORecord"): Retired("podbench.core.records:Record"),
    ("podbench.sysid.methods", "BUILTIN_METHODS"):
        Retired("podbench.sysid.registry:BUILTIN_METHODS", warn=False),
    ("podbench.core.records", "from_record"): Retired("podbench.core.records:as_record"),
    ("podbench.core.records", "read_io_record"):
        Retired("podbench.core.recordfiles:read_record"),
    ("podbench.core.records", "write_io_record"):
        Retired("podbench.core.recordfiles:write_record", fixed={"layout": "io"}),
    ("podbench.core.recordfiles", "MeasuredRecord"):
        Retired("podbench.core.records:Record", positional=("W", "F", "dt"),
                renamed={"sensors": "output_channels", "path": "name"}),
    **{(module, name): spec for module in ("podbench.sysid.methods",
                                           "podbench.sysid.methods.inputs")
       for name, spec in {
           "MultipleLoadIO": Retired("podbench.sysid.methods:MultipleLoad", fixed={
               "inputs": "measured", "n_lags": "auto", "solver": "ls"}),
           "SingleLoadIO": Retired("podbench.sysid.methods:SingleLoad"),
       }.items()},
    ("podbench.sysid.methods.inputs", "FIRLeastSquares"):
        Retired("podbench.sysid.methods.fir:FIRLeastSquares"),
    ("podbench.sysid.methods.inputs", "mixed_response_io"):
        Retired("podbench.sysid.methods.mixed:check_measured_inputs"),
    ("podbench.sysid.methods.inputs", "io_records"): Retired("podbench.core.records:as_records"),
    **{(module, name): Retired(f"podbench.sysid.methods:{new}", fixed={
        "inputs": "measured", **extra}, renamed={"feedthrough": None})
       for module in ("podbench.sysid.methods", "podbench.sysid.methods.peers")
       for name, new, extra in (("ERAIO", "ERA", {"blocks": 1.0}), ("DMDcIO", "DMDc", {}),
                                ("OpInfIO", "OpInf", {}))},
    **{(module, "MdofIO"): Retired("podbench.sysid.methods.mdof_peer:Mdof")
       for module in ("podbench.sysid.methods", "podbench.sysid.methods.mdof_peer")},
}
"""(module where the name is looked up, old name) → :class:`Retired`."""

_WARNED: set = set()


def _load(dotted: str):
    module, _, name = dotted.partition(":")
    return getattr(importlib.import_module(module), name)


def _configured(obj, spec: Retired):
    """``obj`` called with the old name's fixed and renamed keywords."""

    @functools.wraps(obj)
    def build(*args, **kwargs):
        if spec.positional:
            kwargs.update(zip(spec.positional, args, strict=False))
            args = args[len(spec.positional):]
        for old, new in spec.renamed.items():
            if old in kwargs:
                value = kwargs.pop(old)
                if new is not None:
                    kwargs[new] = value
        return obj(*args, **{**spec.fixed, **kwargs})

    return build


def retired(module: str, name: str):
    """The object a retired ``name`` of ``module`` stands for (warning once, naming the new
    name); AttributeError for a name that is neither there nor retired (a module's
    ``__getattr__`` calls this)."""
    spec = RETIRED.get((module, name))
    if spec is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    if spec.warn and (module, name) not in _WARNED:
        _WARNED.add((module, name))
        how = ""
        if spec.fixed:
            how = " with " + ", ".join(f"{k}={v!r}" for k, v in spec.fixed.items())
        warnings.warn(f"{name} is retired: use {spec.new.replace(':', '.')}{how}",
                      FutureWarning, stacklevel=3)
    obj = _load(spec.new)
    return _configured(obj, spec) if spec.fixed or spec.renamed or spec.positional else obj
