"""One BLAS thread per pytest-xdist worker.

The suite runs one xdist worker per core (``-n auto`` in pyproject.toml). OpenBLAS would
start one thread per core in every worker too, so two workers on two cores run four
threads, and OpenBLAS's threads busy-wait for the cores the other worker holds: a test's
least-squares solves then cost many times their single-thread CPU time (the F-16 modes test
of tests/measured_io/test_f16_gvt.py: 75 s of CPU with the default threads, 2 s with one,
docs/testing.md). A worker therefore limits NumPy's and SciPy's BLAS (and OpenMP) to one
thread, and the programs it starts inherit the limit through the environment (unless the
caller set one). The tests' numbers do not depend on the thread count: the harness computes
under :func:`podbench.core.threads.single_blas_thread` anyway, and
tests/harness/test_threads.py sets its own limits. A single process (``-n 0``, the slow
tier) keeps the library defaults.
"""

import os

if os.environ.get("PYTEST_XDIST_WORKER"):
    import numpy  # noqa: F401 - load NumPy's and SciPy's BLAS first (with their default
    import scipy.linalg  # noqa: F401 - pools, which a test may raise again), so that the
    from threadpoolctl import threadpool_limits  # limit reaches both copies

    _LIMITS = threadpool_limits(limits=1)  # kept for the worker's life (never restored)
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")  # the programs the tests start
