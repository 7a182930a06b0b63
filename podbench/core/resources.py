"""The data podbench ships with: structure files and the bundled studies.

In a checkout they are the top-level folders ``structures/`` and ``scenarios/<study>/`` (the
project's layout: ``pyproject.toml, podbench/, structures/, scenarios/, results/, tests/``).
The build backend (hatchling, ``[tool.hatch.build.targets.wheel.force-include]`` in
``pyproject.toml``) carries both into the wheel as ``podbench/_bundled/structures`` and
``podbench/_bundled/scenarios``, so an installed podbench (a wheel, not only this checkout)
finds them through :mod:`importlib.resources`: ``podbench run chapter4`` names a bundled
study from any folder, ``podbench run chapter4/beam_forced`` one of its scenarios. Files are
named the same way in both (``scenarios/chapter4/claims.toml``), so generated outputs do not
depend on how podbench was installed.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["bundled_root", "bundled_structures", "bundled_scenarios", "bundled_studies",
           "resolve_bundled", "display_path", "unique_paths", "DEFAULT_STUDY", "SWEEPS_STUDY",
           "DEFAULT_CACHE", "DEFAULT_RESULTS", "DEFAULT_BASELINE"]

DEFAULT_STUDY = "chapter4"
"""The study ``podbench run`` runs without a path."""
SWEEPS_STUDY = "sweeps"
"""The folder of scenarios with a ``[sweep]`` table that ``podbench sweep`` runs without a path."""
DEFAULT_CACHE = Path(".podbench_cache")
"""The truth cache's folder, in the current folder."""
DEFAULT_RESULTS = Path("results")
"""Where ``run`` writes without ``out``: ``results/<study>``."""
DEFAULT_BASELINE = DEFAULT_RESULTS / "baseline.csv"
"""The committed accuracy baseline ``regress`` compares with."""

_CHECKOUT = Path(__file__).resolve().parents[2]
"""The checkout's top folder when podbench runs from its sources (an editable install)."""


def bundled_root() -> Path:
    """The folder holding ``structures/`` and ``scenarios/``: ``podbench/_bundled`` of an
    installed wheel, else the checkout's top folder."""
    packaged = resources.files("podbench").joinpath("_bundled")
    if isinstance(packaged, Path) and packaged.is_dir():
        return packaged
    if (_CHECKOUT / "structures").is_dir() and (_CHECKOUT / "scenarios").is_dir():
        return _CHECKOUT
    raise RuntimeError(f"podbench's bundled data are not a folder on disk ({packaged}); "
                       "install podbench as files (pip install), not as a zip")


def bundled_structures() -> Path:
    """``structures/``: the structure files found by name."""
    return bundled_root() / "structures"


def bundled_scenarios() -> Path:
    """``scenarios/``: one sub-folder per bundled study."""
    return bundled_root() / "scenarios"


def bundled_studies() -> dict[str, Path]:
    """Bundled study name → its folder of scenario files, sorted by name."""
    return {p.name: p for p in sorted(bundled_scenarios().iterdir())
            if p.is_dir() and any(p.glob("*.toml"))}


def resolve_bundled(name: str) -> Path | None:
    """The bundled folder or file a name means (``chapter4``, ``chapter4/beam_forced`` or
    ``chapter4/beam_forced.toml``), or None."""
    parts = str(name).replace("\\", "/").strip("/").split("/")
    studies = bundled_studies()
    if len(parts) == 1 and parts[0] in studies:
        return studies[parts[0]]
    if len(parts) == 2 and parts[0] in studies:
        stem = parts[1][:-5] if parts[1].endswith(".toml") else parts[1]
        f = studies[parts[0]] / f"{stem}.toml"
        if f.is_file() and stem not in ("claims", "experiment"):  # not scenarios
            return f
    return None


def display_path(path) -> str:
    """How a file is named in generated outputs and messages: ``scenarios/...`` or
    ``structures/...`` for a bundled file (the same in a checkout and an installed package),
    otherwise relative to the current folder when below it, else absolute."""
    p = Path(path).resolve()
    root = bundled_root().resolve()
    for folder in ("structures", "scenarios"):
        try:
            return (Path(folder) / p.relative_to(root / folder)).as_posix()
        except ValueError:
            pass
    try:
        rel = os.path.relpath(p)
    except ValueError:  # pragma: no cover - another drive on Windows
        return str(p)
    return str(p) if rel.startswith("..") else rel


def unique_paths(paths) -> list[Path]:
    """``paths`` in their order without those naming a file or folder already named (the same
    after resolving links and ``..``); each kept as given."""
    seen: set[Path] = set()
    out = []
    for p in map(Path, paths):
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            out.append(p)
    return out
