"""Run independent tasks serially, in local processes or on a Dask cluster: one executor for
the study's units (:func:`podbench.harness.runner.run_study`), the sweep's points
(:func:`podbench.harness.sweep.run_sweep`) and the figures
(:func:`podbench.report.study.write_study`).

Whatever the mode, :func:`execute` returns the results in task order, computes each task
with one BLAS thread (:func:`podbench.core.threads.single_blas_thread`, so a result does not
depend on the mode, ``jobs`` or the machine's cores), reports every finished task to a
progress callback, and on the first error or a KeyboardInterrupt cancels the pending tasks
and raises in the caller: a :class:`~podbench.errors.PodbenchError` as itself (one line for
the command line), any other exception of a worker as a ``RuntimeError`` carrying the
worker's traceback text.

Local processes are spawned (not forked: no inherited locks or BLAS thread pools); ``func``
and the tasks must be picklable, ``func`` a module-level function. A Dask worker imports
``func``'s module itself, so it needs podbench (and the data the tasks name) at the same
paths as the client.
"""

from __future__ import annotations

import socket
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context

from podbench.core.threads import single_blas_thread
from podbench.core.warnfmt import one_line_warnings
from podbench.errors import InputError, PodbenchError

__all__ = ["execute"]


@dataclass
class _Failure:
    """What a worker returns instead of raising: the error to raise in the caller."""

    error: BaseException


def _call(func, task):
    """``func(task)`` with one BLAS thread, in a worker: errors come back as values, so
    the caller re-raises them without the executor's wrapping."""
    try:
        with single_blas_thread():
            return func(task)
    except PodbenchError as exc:
        return _Failure(exc)
    except Exception as exc:  # noqa: BLE001 - keep the worker's traceback readable
        return _Failure(RuntimeError("".join(traceback.format_exception(exc)).rstrip()))


def _raise(failure: _Failure):
    raise failure.error from None


def _dask_client(address: str, timeout: float):
    """A Client of the Dask scheduler at ``address``; InputError if it cannot be reached."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler needs Dask distributed: pip install 'podbench[dask]' "
                         "(or pip install 'dask[distributed]')") from None
    from distributed.comm import parse_address, parse_host_port
    from distributed.comm.registry import backends

    # Check the address and reach the port first: a Client that fails to connect blocks in
    # its destructor and prints a traceback at exit.
    try:
        scheme, loc = parse_address(address)
        if scheme not in backends:
            raise ValueError(f"unknown address scheme {scheme!r} (known: "
                             f"{', '.join(sorted(backends))})")
        if scheme == "tcp":
            host, port = parse_host_port(loc)
            socket.create_connection((host, port), timeout=timeout).close()
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"cannot connect to the Dask scheduler {address!r}: "
                         f"{type(exc).__name__}: {exc}") from None
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise InputError(f"cannot connect to the Dask scheduler {address!r}: "
                         f"{type(exc).__name__}: {exc}") from None


def execute(func: Callable, tasks: Sequence, *, jobs: int = 1, scheduler: str | None = None,
            progress: Callable | None = None, connect_timeout: float = 10.0) -> list:
    """``[func(task) for task in tasks]``, serially, in processes or on a Dask cluster.

    Parameters
    ----------
    func : callable
        A module-level function of one argument (picklable by reference).
    tasks : sequence
        The arguments, picklable.
    jobs : int
        Local processes (spawned); 1, or a single task, runs in the calling process.
        Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:8786``): every task runs on
        its workers.
    progress : callable, optional
        ``progress(done, total, elapsed, result)`` in the calling process after each
        finished task (``elapsed`` in seconds since the call; tasks finish in any order).
    connect_timeout : float
        Seconds to wait for the scheduler.

    Returns
    -------
    list
        The results in task order.

    Raises
    ------
    InputError
        ``jobs`` < 1, or the scheduler cannot be reached.
    PodbenchError
        The first one a task raised (pending tasks are cancelled).
    RuntimeError
        Another exception of a worker process, with its traceback text.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"jobs: expected a positive integer, got {jobs!r}")
    tasks = list(tasks)
    total = len(tasks)
    results: list = [None] * total
    t0 = time.perf_counter()
    done = 0

    def finished(i, out):
        nonlocal done
        if isinstance(out, _Failure):
            _raise(out)
        results[i] = out
        done += 1
        if progress is not None:
            progress(done, total, time.perf_counter() - t0, out)

    if scheduler is not None:
        _on_dask(func, tasks, finished, scheduler, connect_timeout)
    elif jobs == 1 or total <= 1:
        _serially(func, tasks, finished)
    else:
        _in_processes(func, tasks, finished, jobs)
    return results


def _on_dask(func: Callable, tasks: list, finished: Callable, scheduler: str,
             timeout: float) -> None:
    """Every task on the workers of the Dask scheduler ``scheduler``; ``finished(i, out)``
    as each ends (the pending ones are cancelled when it raises)."""
    client = _dask_client(scheduler, timeout)
    try:
        from distributed import as_completed as dask_completed

        futs = client.map(_call, [func] * len(tasks), tasks, pure=False)
        index = {f.key: i for i, f in enumerate(futs)}
        try:
            for fut in dask_completed(futs, loop=client.loop):
                finished(index[fut.key], fut.result())
        except BaseException:
            client.cancel(futs)
            raise
    finally:
        client.close()


def _serially(func: Callable, tasks: list, finished: Callable) -> None:
    """Every task in the calling process, one BLAS thread (a task's exception propagates
    as it was raised, traceback and all)."""
    for i, task in enumerate(tasks):
        with single_blas_thread():
            out = func(task)  # the original exception, traceback and all
        finished(i, out)


def _in_processes(func: Callable, tasks: list, finished: Callable, jobs: int) -> None:
    """Every task in at most ``jobs`` spawned processes; ``finished(i, out)`` as each ends."""
    ex = ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=get_context("spawn"),
                             initializer=one_line_warnings)
    try:
        pending = {ex.submit(_call, func, task): i for i, task in enumerate(tasks)}
        while pending:
            ready, _ = wait(pending, return_when=FIRST_COMPLETED)
            for f in ready:
                finished(pending.pop(f), f.result())
    finally:
        # on an error or Ctrl-C: drop the queued tasks, wait for the running ones
        ex.shutdown(wait=True, cancel_futures=True)
