"""Cache of simulated truth data, keyed by content.

A key is the SHA-256 of: the structure's content (its M, K, C, sensor map, events with
their mass changes and removed DOFs, the tip-mass
law sampled at fixed times, the nonlinear elements; and the same for every structure an
excitation names as ``reference``), the case's excitation tables, ``n_samples``, ``dt``, the
engine, whether the linear twin is simulated, and :data:`TRUTH_VERSION`. A changed structure
file or scenario entry therefore misses the cache and is re-simulated.

Entries are ``.npz`` files (``W, F, w0, v0, t``) read with ``allow_pickle=False`` and written
to a temporary file first, then renamed (an interrupted write leaves no entry). An entry that
cannot be read or has the wrong shape is reported and re-simulated.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from podbench.core.atomic import atomic_write_bytes
from podbench.errors import PodbenchWarning
from podbench.study.scenarios import canonical_json

__all__ = ["TruthCache", "structure_fingerprint", "TRUTH_VERSION"]

TRUTH_VERSION = "1"
"""Bump when the integrator or the excitation builders change what they compute."""

_ADDR = re.compile(r" at 0x[0-9a-fA-F]+")


def _hash_array(h, a) -> None:
    if a is None:
        h.update(b"none")
        return
    if sp.issparse(a):
        a = sp.csr_matrix(a)
        a.sort_indices()
        for part in (a.data, a.indices, a.indptr, np.asarray(a.shape)):
            _hash_array(h, part)
        return
    a = np.ascontiguousarray(a)
    h.update(str((a.dtype.str, a.shape)).encode())
    h.update(a.tobytes())


def structure_fingerprint(s) -> str:
    """SHA-256 of what a simulation of ``s`` depends on."""
    h = hashlib.sha256()
    for a in (s.M, s.K, s.C, s.sensor_dofs):
        _hash_array(h, a)
    if s.variable_mass is not None:
        vm = s.variable_mass
        h.update(f"vm:{vm.dof}".encode())
        _hash_array(h, np.asarray(vm.law(np.linspace(0.0, 1.0, 101)), dtype=float))
    for ev in s.events:
        h.update(f"ev:{ev.time!r}".encode())
        _hash_array(h, getattr(ev, "delta_K", None))
        if getattr(ev, "delta_M", None) is not None or getattr(ev, "removed_dofs", ()):
            _hash_array(h, ev.delta_M)
            _hash_array(h, np.asarray(ev.removed_dofs, dtype=np.int64))
    for el in s.nonlinear:
        h.update(_ADDR.sub("", repr(el)).encode())
    return h.hexdigest()


class TruthCache:
    """A folder of ``.npz`` truth entries (``None`` folder: no caching)."""

    def __init__(self, folder: str | os.PathLike | None):
        self.folder = Path(folder) if folder is not None else None
        self.hits = 0
        self.misses = 0

    @staticmethod
    def key(**parts) -> str:
        return hashlib.sha256(canonical_json({"v": TRUTH_VERSION, **parts}).encode()).hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.npz"

    def load(self, key: str, shape: tuple[int, int]) -> dict | None:
        """The arrays of an entry, or None (missing, unreadable or wrongly shaped)."""
        if self.folder is None:
            return None
        path = self._path(key)
        if not path.is_file():
            self.misses += 1
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                out = {k: np.array(z[k]) for k in ("W", "F", "w0", "v0", "t")}
            ok = (out["W"].shape == shape and out["F"].shape == shape
                  and out["t"].shape == (shape[1],) and all(np.isfinite(out["W"]).ravel()))
            if not ok:
                raise ValueError("arrays of the wrong shape or non-finite values")
        except Exception as exc:  # noqa: BLE001 - any unreadable entry is re-simulated
            warnings.warn(f"truth cache: entry {path} is unusable ({type(exc).__name__}: "
                          f"{exc}); re-simulating", PodbenchWarning, stacklevel=2)
            self.misses += 1
            return None
        self.hits += 1
        return out

    def store(self, key: str, arrays: dict) -> None:
        if self.folder is None:
            return
        buf = io.BytesIO()
        np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
        atomic_write_bytes(self._path(key), buf.getvalue())
