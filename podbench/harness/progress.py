"""Progress of a run on stderr: a tqdm bar (counts, rate, time left) on a terminal, plain
lines when stderr is not one (CI logs), nothing with ``--quiet``.

A run has stages (simulating and fitting the units, drawing the figures, the points of a
sweep); each stage is a :class:`Stage` that is told when one of its ``total`` items is done.
Progress never goes to stdout, so what a command prints on stdout stays deterministic.
"""

from __future__ import annotations

import os
import sys
import time

__all__ = ["Progress", "Stage", "as_stage"]


class Stage:
    """One stage of ``total`` items. ``advance(message)`` after each finished item;
    ``close()`` at the end (also as a context manager)."""

    def __init__(self, desc: str, total: int, unit: str, *, stream=None, bar: bool = False,
                 lines: bool = True, every: int = 1):
        self.desc, self.total, self.unit = desc, int(total), unit
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self.every = max(1, int(every))
        self._lines = lines
        self._t0 = time.perf_counter()
        self._bar = None
        if lines and not bar and self.total > 0:  # a log shows what is coming, and how much
            print(f"{desc}: 0/{self.total} {unit}s", file=self.stream, flush=True)
        if bar and self.total > 0:
            from tqdm import tqdm

            try:  # a pseudo-terminal may report 0 columns: then a fixed width
                cols = os.get_terminal_size(self.stream.fileno()).columns
            except (AttributeError, ValueError, OSError):
                cols = 0
            self._bar = tqdm(total=self.total, desc=desc, unit=f" {unit}", file=self.stream,
                             dynamic_ncols=cols > 0, ncols=None if cols > 0 else 100,
                             nrows=None if cols > 0 else 20,
                             leave=True, mininterval=0.2)

    def advance(self, message: str = "", detail: str = "") -> None:
        """One more item done: ``message`` names it (on the bar and the lines), ``detail``
        adds to the plain lines only (a bar keeps its width for the counts)."""
        self.done += 1
        if detail:
            message = f"{message}: {detail}" if self._bar is None else message
        if self._bar is not None:
            if message:
                self._bar.set_postfix_str(message, refresh=False)
            self._bar.update(1)
        elif self._lines and (self.done % self.every == 0 or self.done == self.total):
            elapsed = time.perf_counter() - self._t0
            left = ""
            if 0 < self.done < self.total:
                left = f", about {elapsed / self.done * (self.total - self.done):.0f} s left"
            text = f"{self.desc}: {self.done}/{self.total}"
            if message:
                text += f"  {message}"
            print(f"{text} (elapsed {elapsed:.1f} s{left})", file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class Progress:
    """Where a run's progress goes.

    Parameters
    ----------
    quiet : bool
        Nothing at all.
    bar : bool, optional
        A tqdm bar per stage; default: when ``stream`` is a terminal. Otherwise plain lines
        (every item of a stage of units, about every tenth of a stage of figures).
    stream : file, optional
        Default ``sys.stderr``.
    """

    def __init__(self, *, quiet: bool = False, bar: bool | None = None, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.quiet = quiet
        if bar is None:
            isatty = getattr(self.stream, "isatty", None)
            bar = bool(isatty and isatty())
        self.bar = bar and not quiet

    def note(self, text: str) -> None:
        """One line of what the run is about to do (nothing when ``quiet``)."""
        if not self.quiet:
            print(text, file=self.stream, flush=True)

    def stage(self, desc: str, total: int, unit: str, *, every: int = 1) -> Stage:
        """A new stage; ``every``: plain lines only after every ``every``-th item."""
        return Stage(desc, total, unit, stream=self.stream, bar=self.bar,
                     lines=not self.quiet, every=every)


def as_stage(progress, desc: str, total: int, unit: str, *, every: int = 1) -> Stage:
    """The stage of a ``progress`` argument: a :class:`Progress`, a callable given one line
    per item (the older interface of :func:`podbench.harness.runner.run_study`), or None."""
    if isinstance(progress, Progress):
        return progress.stage(desc, total, unit, every=every)
    if progress is None:
        return Stage(desc, total, unit, lines=False)
    return _CallableStage(progress, desc, total, unit, every)


class _CallableStage(Stage):
    def __init__(self, say, desc, total, unit, every):
        super().__init__(desc, total, unit, lines=False, every=every)
        self._say = say

    def advance(self, message: str = "", detail: str = "") -> None:
        self.done += 1
        message = f"{message}: {detail}" if detail else message
        if self.done % self.every == 0 or self.done == self.total:
            elapsed = time.perf_counter() - self._t0
            n = 20 * self.done // max(self.total, 1)
            text = f"[{'#' * n}{'-' * (20 - n)}] {self.done}/{self.total}"
            self._say(f"{text}  {message} (elapsed {elapsed:.1f} s)" if message
                      else f"{text} (elapsed {elapsed:.1f} s)")
