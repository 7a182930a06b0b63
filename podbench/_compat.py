"""Old module names, kept importable after the re-layout into layers.

podbench was re-laid out into ``core → structures → dynamics → sysid → study → harness →
report → api/cli`` (docs/ARCHITECTURE.md). What users imported before —
``podbench.methods.forced``, ``podbench.deconvolution.kernel``, ``podbench.excitations``,
``podbench.fem``, ``podbench.records``, ``podbench.data`` … — still imports: an import of an
old name returns the module at its new place (the same module object, so classes,
``isinstance`` and monkeypatching agree whichever name was used).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

__all__ = ["ALIASES", "install"]

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
    "podbench.measured": "podbench.sysid.measured",
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
