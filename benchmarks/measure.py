"""Measurement helpers of the benchmarks: one call in a fresh process, its wall time and peak
memory, and ratios against a baseline measured in the same run.

Every measurement runs in a fresh process (``multiprocessing`` spawn) with one BLAS thread
(:func:`podbench.core.threads.single_blas_thread`): wall time of the call, and peak memory as the
growth of the resident set size over the process's size just before the call (Linux
``VmHWM`` after resetting it through ``/proc/self/clear_refs``; this counts LAPACK and
SuperLU allocations that tracemalloc misses). Timings are the best of up to three repeats
when a call takes under a second. A speed-up is a ratio of two such times of one run on one
machine, never an absolute number to assert.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import platform
import time
import traceback

__all__ = ["best_of", "measure", "run_isolated", "speedup", "rel_diff", "mb", "available_bytes",
           "machine"]


def _status() -> dict[str, int]:
    out = {}
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(("VmHWM:", "VmRSS:")):
                key, val = line.split(":")
                out[key] = int(val.split()[0]) * 1024
    return out


def _reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def best_of(fn, repeat: int = 3) -> float:
    """The least wall time (s) of ``repeat`` calls of ``fn`` in this process (the ratios of
    ``benchmarks/bands.py`` and ``benchmarks/era_order.py`` time both sides this way)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(fn, repeat_below: float = 1.0, max_repeat: int = 3):
    """Run ``fn`` and return ``(result, best_time_s, peak_bytes)`` (peak NaN where
    ``/proc/self/clear_refs`` is not available)."""
    exact = _reset_peak()
    rss0 = _status().get("VmRSS", 0)
    t0 = time.perf_counter()
    result = fn()
    best = time.perf_counter() - t0
    peak = _status().get("VmHWM", 0) - rss0 if exact else float("nan")
    for _ in range(max_repeat - 1):
        if best >= repeat_below:
            break
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return result, best, peak


def _child(func, args: tuple, queue) -> None:
    try:
        from podbench.core.threads import single_blas_thread

        with single_blas_thread():
            queue.put(("ok", func(*args)))
    except BaseException as exc:  # report every failure to the parent as a row
        queue.put(("error", f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
                   + "\n" + traceback.format_exc(limit=3)))


def run_isolated(func, args: tuple, timeout: float):
    """``("ok", func(*args))`` computed in a fresh spawned process, or ``("error", message)``
    / ``("timeout", message)``. ``func`` must be a module-level function."""
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(func, args, queue))
    proc.start()
    try:
        status, payload = queue.get(timeout=timeout)
    except Exception:  # queue.Empty: the child ran out of time
        proc.terminate()
        proc.join()
        return "timeout", f"over {timeout:.0f} s"
    proc.join()
    return status, payload


def speedup(baseline_s: float, time_s: float) -> float:
    """``baseline_s / time_s``: how many times faster than the baseline of the same run."""
    return baseline_s / time_s


def rel_diff(a, b) -> float:
    import numpy as np

    nb = float(np.linalg.norm(b))
    return float(np.linalg.norm(a - b) / nb) if nb > 0 else float(np.linalg.norm(a))


def mb(x) -> float:
    return round(x / 2**20, 1) if x == x else float("nan")


def available_bytes():
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def machine() -> str:
    import numpy
    import scipy

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as fh:
            mem = f", {int(fh.readline().split()[1]) / 2**20:.0f} GiB RAM"
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}, NumPy {numpy.__version__}, "
            f"SciPy {scipy.__version__}; one BLAS thread (threadpoolctl)")


