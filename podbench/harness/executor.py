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

With ``jobs`` > 1 the calling process computes tasks itself from the start and, once it has
computed for :data:`POOL_AFTER` seconds with tasks still waiting, starts ``jobs - 1`` worker
processes that take the next tasks from the same queue: a run whose tasks all end sooner (a
warm truth cache, a test's tiny study) spawns no process, since a spawned worker spends
seconds on its imports before its first task. ``jobs = "auto"`` is the number of cores this
process may run on (:func:`resolve_jobs`). Tasks are handed out in task order, or largest
first when the caller gives their expected ``costs`` (so that no long task starts last while
the other cores idle); results always come back in task order.

Local processes are spawned (not forked: no inherited locks or BLAS thread pools); ``func``
and the tasks must be picklable, ``func`` a module-level function. A spawned process first
runs the main script again; when the call comes from that script's top-level code outside an
``if __name__ == "__main__":`` block, a worker would repeat the call while it starts, which
multiprocessing refuses, so the tasks then run in the calling process alone, with a
:class:`~podbench.errors.PodbenchWarning` saying why (:func:`unguarded_main_script`). A Dask
worker imports ``func``'s module itself, so it needs podbench (and the data the tasks name)
at the same paths as the client.
"""

from __future__ import annotations

import ast
import os
import socket
import sys
import threading
import time
import traceback
import warnings
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context

from podbench.core.threads import single_blas_thread
from podbench.core.warnfmt import one_line_warnings
from podbench.errors import InputError, PodbenchError, PodbenchWarning
from podbench.sysid.deconvolution import renamed_warned

__all__ = ["MAX_AUTO_JOBS", "POOL_AFTER", "execute", "resolve_jobs", "unguarded_main_script"]

POOL_AFTER = 2.0
"""Seconds the calling process computes alone before it starts worker processes (``jobs`` >
1): about what spawning one costs (importing NumPy, SciPy, pandas and podbench under load)."""

MAX_AUTO_JOBS = 8
"""The most processes ``jobs = "auto"`` starts (each holds its own copies of the dense
systems, up to a few hundred MB for Chapter 5's 2048-sample ones)."""


def resolve_jobs(jobs, what: str = "jobs") -> int:
    """``jobs`` as a number of processes: a positive integer as given, or ``"auto"``: the
    cores this process may run on (its CPU affinity), at most :data:`MAX_AUTO_JOBS`.
    InputError naming ``what`` for anything else."""
    if jobs == "auto":
        try:
            cores = len(os.sched_getaffinity(0))
        except AttributeError:  # no affinity call (macOS, Windows)
            cores = os.cpu_count() or 1
        return max(1, min(cores, MAX_AUTO_JOBS))
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"{what}: expected a positive integer or 'auto', got {jobs!r}")
    return jobs


def _is_main_guard(node: ast.stmt) -> bool:
    """``node`` is ``if __name__ == "__main__":`` (either operand order)."""
    if not (isinstance(node, ast.If) and isinstance(node.test, ast.Compare)
            and len(node.test.ops) == 1 and isinstance(node.test.ops[0], ast.Eq)):
        return False
    sides = [node.test.left, *node.test.comparators]
    return ({type(s) for s in sides} == {ast.Name, ast.Constant}
            and any(isinstance(s, ast.Name) and s.id == "__name__" for s in sides)
            and any(isinstance(s, ast.Constant) and s.value == "__main__" for s in sides))


def guarded_line(source: str, lineno: int) -> bool:
    """Line ``lineno`` of the module ``source`` lies in the body of a top-level ``if __name__
    == "__main__":`` block (code a spawned process does not run again). False when the source
    does not parse."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return False
    return any(_is_main_guard(node) and node.body[0].lineno <= lineno <= node.body[-1].end_lineno
               for node in tree.body)


def unguarded_main_script() -> str | None:
    """The main script's path when this call runs in its top-level code outside an ``if
    __name__ == "__main__":`` block, else None.

    A spawned process runs the main script again (as ``__mp_main__``) before it takes a
    task; code outside the guard would call podbench again there and try to start processes
    of its own during that start-up, which multiprocessing refuses (``RuntimeError: An
    attempt has been made to start a new process before the current process has finished
    its bootstrapping phase``, the pool broken). An interactive session, ``python -c`` and a
    notebook have no main script to run again; ``podbench`` itself and pytest call under the
    guard."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or not path:
        return None
    frame, line = sys._getframe(1), None
    while frame is not None:  # the outermost frame of the main module's top-level code
        if frame.f_globals is vars(main) and frame.f_code.co_name == "<module>":
            line = frame.f_lineno
        frame = frame.f_back
    if line is None:
        return None
    try:
        with open(path, "rb") as fh:
            source = fh.read().decode("utf-8", errors="replace")
    except OSError:
        return None
    return None if guarded_line(source, line) else path


_WARNED: set[str] = set()
"""The unguarded main scripts already warned about (one warning per script and process)."""


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
        raise InputError("Parameter `scheduler`: needs Dask distributed: pip install "
                         "'podbench[dask]' "
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


def execute(func: Callable, tasks: Sequence, *, jobs: int | str = 1,
            scheduler: str | None = None, progress: Callable | None = None,
            connect_timeout: float = 10.0, costs: Sequence[float] | None = None) -> list:
    """``[func(task) for task in tasks]``, serially, in processes or on a Dask cluster.

    Parameters
    ----------
    func : callable
        A module-level function of one argument (picklable by reference).
    tasks : sequence
        The arguments, picklable.
    jobs : int or "auto"
        Processes, the calling one included (the others spawned after :data:`POOL_AFTER`
        seconds); 1, or a single task, runs in the calling process alone; ``"auto"``: the
        cores available (:func:`resolve_jobs`). Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:8786``): every task runs on
        its workers.
    progress : callable, optional
        ``progress(done, total, elapsed, result)`` in the calling process after each
        finished task (``elapsed`` in seconds since the call; tasks finish in any order).
    connect_timeout : float
        Seconds to wait for the scheduler.
    costs : sequence of float, optional
        Each task's expected cost (any unit): local processes take the costliest waiting
        task first (ties in task order). Only the schedule depends on it, never a result.

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
    jobs = resolve_jobs(jobs)
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
        order = range(total) if costs is None else sorted(range(total), key=lambda i: -costs[i])
        _in_processes(func, tasks, finished, jobs, order, unguarded_main_script())
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


class _Queue:
    """The tasks waiting, shared by the calling process and the threads that feed the
    worker processes; ``finished`` is called under the lock (one thread at a time). The
    first error a result or ``finished`` raises is kept in ``failure`` and stops the hand-out
    (the running tasks finish, their results are dropped)."""

    def __init__(self, order, finished: Callable):
        self.waiting = deque(order)
        self.finished = finished
        self.lock = threading.Lock()
        self.caller_done = threading.Event()
        self.stopped = False
        self.failure: BaseException | None = None
        self.pool: ProcessPoolExecutor | None = None

    def take(self) -> int | None:
        with self.lock:
            return None if self.stopped or not self.waiting else self.waiting.popleft()

    def stop(self) -> None:
        with self.lock:
            self.stopped = True

    def report(self, i: int, out) -> None:
        with self.lock:
            if self.stopped:
                return
            try:
                self.finished(i, out)
            except BaseException as exc:  # noqa: BLE001 - raised by the caller afterwards
                self.failure, self.stopped = exc, True


def _feed(queue: _Queue, func: Callable, tasks: list) -> None:
    """One worker process's lane: the next waiting task to the pool, its result reported,
    until none waits."""
    while (i := queue.take()) is not None:
        try:
            out = queue.pool.submit(_call, func, tasks[i]).result()  # type: ignore[union-attr]
        except BaseException as exc:  # noqa: BLE001 - a broken pool, a worker's Ctrl-C
            out = _Failure(exc)
        queue.report(i, out)


def _worker_start() -> None:
    """A spawned worker's set-up: warnings on one line; the former solver names taken as
    warned about (the calling process read every file, and warned, before any task)."""
    one_line_warnings()
    renamed_warned()


def _start_workers(queue: _Queue, func: Callable, tasks: list, workers: int,
                   script: str | None) -> None:
    """After :data:`POOL_AFTER` seconds, unless the caller is done: up to ``workers``
    spawned processes (no more than tasks wait), each fed by its own thread; none, with a
    warning, when they would run the unguarded main ``script`` again."""
    if queue.caller_done.wait(POOL_AFTER):
        return
    with queue.lock:
        n = min(workers, len(queue.waiting))
        if queue.stopped or n < 1:
            return
        if script is not None:
            if script in _WARNED:
                return
            _WARNED.add(script)
            warnings.warn(
                f"computing in this process alone, not {workers + 1} processes: a worker "
                f"process starts by running {os.path.basename(script)} again, which calls "
                f"podbench outside an `if __name__ == \"__main__\":` block; put the call "
                f"under one to use more processes", PodbenchWarning, stacklevel=1)
            return
        queue.pool = ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn"),
                                         initializer=_worker_start)
    lanes = [threading.Thread(target=_feed, args=(queue, func, tasks), daemon=True)
             for _ in range(n - 1)]
    for t in lanes:
        t.start()
    _feed(queue, func, tasks)
    for t in lanes:
        t.join()


def _in_processes(func: Callable, tasks: list, finished: Callable, jobs: int, order,
                  script: str | None = None) -> None:
    """Every task, in ``order``, by the calling process and up to ``jobs - 1`` spawned ones
    (started after :data:`POOL_AFTER` seconds if tasks still wait, never when ``script``,
    the unguarded main script, would run again in them); ``finished(i, out)`` as each ends.
    Every task goes through :func:`_call` wherever it runs, so an error reads the same
    whichever process met it."""
    queue = _Queue(order, finished)
    starter = threading.Thread(target=_start_workers,
                               args=(queue, func, tasks, jobs - 1, script), daemon=True)
    starter.start()
    try:
        while (i := queue.take()) is not None:
            queue.report(i, _call(func, tasks[i]))
    except BaseException:  # Ctrl-C in the caller: hand out nothing more
        queue.stop()
        raise
    finally:
        # wait for the tasks running in workers; on an error drop the queued ones
        queue.caller_done.set()
        starter.join()
        if queue.pool is not None:
            queue.pool.shutdown(wait=True, cancel_futures=True)
    if queue.failure is not None:
        raise queue.failure
