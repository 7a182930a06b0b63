"""One BLAS thread while podbench computes, whatever the machine and the caller.

Multi-threaded BLAS (OpenBLAS, MKL) splits a matrix product into blocks whose partial sums
depend on the thread count, so the same SVD or least-squares solve can differ in the last
bits between a serial run (the caller's threads) and a worker process. The harness computes
every unit of a study and every point of a sweep inside :func:`single_blas_thread`, in every
execution mode (serial, local processes, Dask workers): tables are then byte-identical
whatever ``--jobs`` and the core count, and no environment variable is needed.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager

__all__ = ["single_blas_thread"]

_lock = threading.Lock()
_depth = 0
_restore = None


def _pin():
    """Set every BLAS/OpenMP library to one thread; returns the function that restores."""
    import numpy  # noqa: F401 - load both BLAS copies (NumPy's and SciPy's) first,
    import scipy.linalg  # noqa: F401 - so that the limit reaches both
    from threadpoolctl import ThreadpoolController

    ctl = ThreadpoolController()
    # OpenBLAS ignores openblas_set_num_threads called outside the main thread (a Dask
    # worker runs tasks in threads); openblas_set_num_threads_local (OpenBLAS >= 0.3.26)
    # sets the same global count from any thread.
    local = []
    for c in ctl.lib_controllers:
        fn = getattr(c.dynlib, "openblas_set_num_threads_local", None)
        if c.internal_api == "openblas" and fn is not None:
            local.append((fn, int(c.get_num_threads())))
    limiter = ctl.limit(limits=1)
    for fn, _ in local:
        fn(1)

    def restore():
        limiter.restore_original_limits()
        for fn, n in local:
            fn(n)

    return restore


@contextmanager
def single_blas_thread():
    """Limit every loaded BLAS and OpenMP library to one thread inside the block.

    The caller's limits are restored on exit (also on an exception). Re-entrant and safe
    for threads of one process (a Dask worker runs its tasks in threads): thread-pool limits
    are global to the process, so the first block to enter sets them and the last to leave
    restores them.
    """
    global _depth, _restore
    with _lock:
        if _depth == 0:
            _restore = _pin()
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _restore()
                _restore = None
