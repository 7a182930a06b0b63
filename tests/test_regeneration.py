"""Every committed result regenerates (issue 23): results/MANIFEST.toml names, for every
tracked file under results/, the command that writes it; the slow tests run each command in a
fresh clone, in an environment without this shell's variables (OpenBLAS then picks its own
kernel and thread count), and require `git status` to stay clean."""

import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "results" / "MANIFEST.toml"


def _manifest() -> dict:
    with MANIFEST.open("rb") as fh:
        return tomllib.load(fh)


def _tracked_results() -> list[str]:
    out = subprocess.run(["git", "ls-files", "results"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.split()
    return [p for p in out if p != "results/MANIFEST.toml"]


def _owner(path: str, manifest: dict) -> list[str]:
    return [name for name, entry in manifest.items()
            if any(path == p or path.startswith(p + "/") for p in entry["paths"])]


def test_every_committed_result_has_exactly_one_command():
    manifest = _manifest()
    tracked = _tracked_results()
    if not tracked:
        pytest.skip("not a git checkout")
    for path in tracked:
        assert len(_owner(path, manifest)) == 1, f"{path}: owners {_owner(path, manifest)}"
    for name, entry in manifest.items():
        assert entry["command"].split()[0] in ("podbench", "python"), name
        assert entry.get("regenerates", True) or entry.get("reason"), name
        for p in entry["paths"]:
            assert (ROOT / p).exists(), f"{name}: {p} is not committed"


def _regenerating() -> list[str]:
    return [name for name, e in _manifest().items() if e.get("regenerates", True)]


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    where = tmp_path_factory.mktemp("regen") / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(where)], check=True)
    return where


@pytest.mark.slow
@pytest.mark.parametrize("name", _regenerating())
def test_the_command_regenerates_its_results_byte_identically(name, clone):
    entry = _manifest()[name]
    argv = shlex.split(entry["command"])
    if argv[0] == "podbench":
        argv = [sys.executable, "-m", "podbench", *argv[1:], "-q"]
    # a new user's shell: no BLAS pinning, no PYTHONPATH but the clone's
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": os.environ.get("HOME", "/"),
           "PYTHONPATH": str(clone)}
    r = subprocess.run(argv, cwd=clone, env=env, capture_output=True, text=True,
                       timeout=max(1800, 300 * entry.get("minutes", 1)))
    assert r.returncode == 0, f"{entry['command']}: exit {r.returncode}\n{r.stderr[-3000:]}"
    status = subprocess.run(["git", "status", "--porcelain", "--", *entry["paths"]], cwd=clone,
                            capture_output=True, text=True, check=True).stdout
    diff = subprocess.run(["git", "diff", "--stat", "--", *entry["paths"]], cwd=clone,
                          capture_output=True, text=True, check=True).stdout
    assert status == "", f"{entry['command']} changed committed files:\n{status}{diff}"
