"""Write files and folders atomically: a reader (or the next run) sees the old content or the
new, never half of it, and an interrupted write (an exception, Ctrl-C) leaves no temporary
file behind.

A file is written to a temporary file in the same folder (same file system, so the rename
is atomic) and moved into place with :func:`os.replace`; a folder is built beside its
destination and swapped in (:func:`replace_dir`).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_write_text", "atomic_write_bytes", "replace_dir", "Keep"]

#: ``keep(old bytes, new bytes) -> bool``: whether a file being rewritten may stay as it is.
Keep = Callable[[bytes, bytes], bool]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write(path, data: bytes) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path, data: bytes, keep: Keep | None = None) -> None:
    """Write ``data`` to ``path`` (parents created) through a temporary file and a rename.

    ``keep(old, new)``, if given, is asked first when ``path`` exists: when it returns True
    the file is left as it is (a regenerated table whose numbers moved only within their
    last digit, :func:`podbench.harness.rewrite.unmoved`)."""
    path = Path(path)
    if keep is not None and path.is_file() and keep(path.read_bytes(), bytes(data)):
        return
    _write(path, bytes(data))


def atomic_write_text(path, text: str, keep: Keep | None = None) -> None:
    """Write ``text`` to ``path`` as UTF-8 with ``\\n`` line ends, atomically
    (:func:`atomic_write_bytes`, ``keep`` as there)."""
    atomic_write_bytes(path, text.encode("utf-8"), keep)


def _keep_unmoved(path: Path, tmp: Path, keep: Keep) -> None:
    """Put back, in the new folder ``tmp``, every file of ``path`` that ``keep`` says the
    new one may leave as it is."""
    for new in sorted(p for p in tmp.rglob("*") if p.is_file()):
        old = path / new.relative_to(tmp)
        if old.is_file():
            before = old.read_bytes()
            if keep(before, new.read_bytes()):
                new.write_bytes(before)


@contextmanager
def replace_dir(path, keep: Keep | None = None) -> Iterator[Path]:
    """Build a folder and swap it in for ``path`` as a whole.

    Yields an empty temporary folder beside ``path``; when the block ends without an
    exception, the previous ``path`` (if any) is moved aside, the new folder renamed to
    ``path`` and the old one removed. On any exception (Ctrl-C included) the temporary
    folder is removed and ``path`` is left as it was. ``keep(old, new)``, if given, is asked
    for every new file that ``path`` already holds; where it returns True the old bytes are
    kept (:func:`podbench.harness.rewrite.unmoved`).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
    try:
        yield tmp
        if keep is not None and path.is_dir():
            _keep_unmoved(path, tmp, keep)
        old = None
        if path.exists():
            old = path.with_name(f".{path.name}.old")
            if old.exists():
                shutil.rmtree(old)
            os.replace(path, old)
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
