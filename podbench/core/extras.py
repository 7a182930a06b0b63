"""The optional extras a study needs, and the one-line refusal when one is not installed.

A study file names the extras of ``pyproject.toml`` its committed tables need
(``requires = ["mdof"]`` in its ``[study]`` or ``[scenario]`` table). Without them the
study would write other numbers (a peer's rows ``refused``) over the committed ones, so
loading it refuses before any work, naming the extra and the command that installs it.
Which packages an extra brings is read from podbench's installed metadata, the same list
``pip`` installs.
"""

from __future__ import annotations

import re
from importlib import metadata

from podbench.core.resources import bundled_root

__all__ = ["known_extras", "missing_packages", "install_command", "unmet_extras_message"]

_EXTRA = re.compile(r"""extra\s*==\s*["']([^"']+)["']""")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


def known_extras() -> dict[str, list[str]]:
    """``extra -> [distribution names]`` of podbench's optional dependencies (empty when
    podbench runs from sources without being installed: nothing can then be checked)."""
    try:
        reqs = metadata.requires("podbench") or []
    except metadata.PackageNotFoundError:
        return {}
    out: dict[str, list[str]] = {}
    for req in reqs:
        spec, _, marker = req.partition(";")
        extra = _EXTRA.search(marker)
        name = _NAME.match(spec.strip())
        if extra and name:
            out.setdefault(extra.group(1), []).append(name.group(0))
    return out


def _installed(distribution: str) -> bool:
    try:
        metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return False
    return True


def missing_packages(extra: str) -> list[str]:
    """The distributions of ``extra`` that are not installed (all known extras only)."""
    return [d for d in known_extras().get(extra, []) if not _installed(d)]


def install_command(extras) -> str:
    """The command that installs ``extras``: ``pip install -e ".[a,b]"`` in a checkout,
    ``pip install 'podbench[a,b]'`` for an installed podbench."""
    names = ",".join(extras)
    if (bundled_root() / "pyproject.toml").is_file():
        return f'pip install -e ".[{names}]"'
    return f"pip install 'podbench[{names}]'"


def unmet_extras_message(extras) -> str | None:
    """``None`` when every extra of ``extras`` is installed, else the refusal's text:
    which extras are missing, their packages, and the install command."""
    unmet = {e: missing_packages(e) for e in extras}
    unmet = {e: pkgs for e, pkgs in unmet.items() if pkgs}
    if not unmet:
        return None
    what = "; ".join(f'"{e}" ({", ".join(p)} not installed)' for e, p in unmet.items())
    return (f"this study's tables need the extra {what}: install it with "
            f"{install_command(unmet)} (nothing was run or written)")
