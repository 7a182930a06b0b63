"""Atomic writes: an interrupted write keeps the old content and leaves no temporary file."""

import os

import pytest

from podbench import api
from podbench.core.atomic import atomic_write_bytes, atomic_write_text, replace_dir


class HalfWriter:
    """A file that writes half of the data, then is interrupted (as by Ctrl-C)."""

    def __init__(self, fh):
        self.fh = fh

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.fh.close()

    def write(self, data):
        self.fh.write(data[: len(data) // 2])
        self.fh.flush()
        raise KeyboardInterrupt


def test_new_content_replaces_the_old_and_parents_are_made(tmp_path):
    p = tmp_path / "a" / "b" / "x.txt"
    atomic_write_text(p, "first\nline é\n")
    assert p.read_bytes() == "first\nline é\n".encode()
    atomic_write_bytes(p, b"\x00\x01")
    assert p.read_bytes() == b"\x00\x01"
    assert sorted(f.name for f in p.parent.iterdir()) == ["x.txt"]
    assert api.atomic_write_text is atomic_write_text  # the name the regress baseline uses


@pytest.mark.parametrize("exc", [KeyboardInterrupt, OSError])
def test_an_exception_mid_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch, exc):
    p = tmp_path / "summary.csv"
    p.write_text("old\n")

    def fail_in_rename(src, dst):
        assert open(src, "rb").read() == b"new\n"  # the temporary file was complete
        raise exc("interrupted")

    monkeypatch.setattr("podbench.core.atomic.os.replace", fail_in_rename)
    with pytest.raises(exc):
        atomic_write_text(p, "new\n")
    monkeypatch.undo()
    fdopen = os.fdopen
    monkeypatch.setattr("podbench.core.atomic.os.fdopen", lambda *a: HalfWriter(fdopen(*a)))
    with pytest.raises(KeyboardInterrupt):
        atomic_write_bytes(p, b"new content\n")
    assert p.read_text() == "old\n"
    assert [f.name for f in tmp_path.iterdir()] == ["summary.csv"]


def test_replace_dir_swaps_a_folder_whole_or_not_at_all(tmp_path):
    out = tmp_path / "study"
    with replace_dir(out) as tmp:
        (tmp / "a.csv").write_text("1")
    assert [f.name for f in out.iterdir()] == ["a.csv"]
    with pytest.raises(KeyboardInterrupt), replace_dir(out) as tmp:
        (tmp / "b.csv").write_text("2")
        raise KeyboardInterrupt
    assert [f.name for f in out.iterdir()] == ["a.csv"]
    with replace_dir(out) as tmp:
        (tmp / "b.csv").write_text("2")
    assert [f.name for f in out.iterdir()] == ["b.csv"]
    assert [f.name for f in tmp_path.iterdir()] == ["study"]  # no temporary or old folder
