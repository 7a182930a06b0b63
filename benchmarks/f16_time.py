"""Where the F-16 study's CPU goes: seconds of CPU per method and per part, one process.

    python benchmarks/f16_time.py                     # every method and every part
    python benchmarks/f16_time.py --methods ERA       # the ERA tasks only
    python benchmarks/f16_time.py --methods "modes and pole sweep" --parts methods

Runs the tasks of ``podbench run f16_gvt`` (:func:`podbench.harness.f16_gvt._tasks`: each
method on each training set, fit, predictions and bands; each level's modes and pole
sweep) and the parts the study computes after them in the calling process (the own-level
BLAs, the decomposition, the levels' table, the BLA table), each timed by
``time.process_time`` with one BLAS thread: CPU seconds, which a loaded machine inflates
much less than the wall time. Prints one line per method (summed over its training sets)
and per part, the time the executor's schedule of these tasks takes on two idle cores
(:func:`makespan`, what ``--jobs 2`` reaches at best), then the
total, each also in units of the CPU time of ``benchmarks/study_time.py``'s reference
workload (:func:`reference_cpu`), measured in the same run. No table is written.

    python benchmarks/f16_time.py --srim-horizons 0.125,0.25,0.5,0.75

times mdof's SRIM fit alone (the peer as the study configures it, order 20) on each of the
study's training sets that it runs (a validation level present) at each prediction
horizon (s; the study's 0.5 s is 200 samples at 400 Hz, mdof's documented default
``min(300, nt)`` samples is 0.75 s), and prints its CPU seconds and the identified ``A``'s
spectral radius: what the peer's cost depends on.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

from benchmarks.study_time import REFERENCE, _env  # noqa: E402
from podbench.core.threads import single_blas_thread  # noqa: E402
from podbench.harness import f16_gvt as h  # noqa: E402
from podbench.study.f16_gvt import load_f16_gvt  # noqa: E402


def reference_cpu() -> float:
    """CPU seconds of ``benchmarks/study_time.py``'s reference workload (best of three, one
    BLAS thread, a fresh process): its wall time on an idle machine, and steadier than its
    wall time on a loaded one."""
    code = REFERENCE.replace("time.perf_counter()", "time.process_time()")
    return float(subprocess.run([sys.executable, "-c", code], check=True,
                                capture_output=True, text=True, env=_env()).stdout)


PARTS = ("methods", "own", "decomposition", "levels", "bla")


def _timed(fn, *args):
    t = time.process_time()
    out = fn(*args)
    return out, time.process_time() - t


def _tail(plan, levels, parts, cpu) -> None:
    """The parts :func:`podbench.harness.f16_gvt.run_study` computes after the tasks."""
    own, cpu["own levels' BLA"] = _timed(h._own_models, levels, plan)
    if "decomposition" in parts:
        pairs = {(s.train, n) for s in plan.sets for n in s.targets
                 if n in levels and all(t in levels for t in s.train)}
        _, cpu["decomposition"] = _timed(lambda: [
            h._decomposition([(t, levels[t]) for t in tr], n, levels[n], own, plan)
            for tr, n in pairs])
    if "levels" in parts:
        _, cpu["levels"] = _timed(lambda: [h._level_row(n, levels[n], own, plan)
                                           for n in sorted(levels)])
    if "bla" in parts:
        _, cpu["BLA table"] = _timed(h._bla_table, levels, own, plan)


def makespan(seconds, jobs: int) -> float:
    """The time the executor's schedule takes on ``jobs`` idle cores: tasks handed out in
    the given order (the executor's: largest expected cost first), each to the process
    that frees first (:func:`podbench.harness.executor.execute`)."""
    free = [0.0] * jobs
    for s in seconds:
        i = free.index(min(free))
        free[i] += s
    return max(free)


def _time_tasks(plan, levels, wanted, cpu) -> list[float]:
    """Time every task of the study (methods' and levels' modes) one by one; returns their
    CPU seconds in the executor's hand-out order (expected cost, largest first)."""
    tasks, costs, _ = h._tasks(plan, levels)
    lines = h._common_lines(levels, plan)
    items = [(("method", t), c, t[1].label) for t, c in zip(tasks, costs, strict=True)]
    items += [(("modes", (plan, n, levels[n], lines)), h.MODES_COST, "modes and pole sweep")
              for n in sorted(levels)]
    timed = []
    for task, cost, label in items:
        if wanted is None or label in wanted:
            _, s = _timed(h._task, task)
            cpu[label] += s
            timed.append((cost, s))
    return [s for _, s in sorted(timed, key=lambda cs: -cs[0])]


def srim_horizons(plan, levels, horizons) -> None:
    """CPU seconds of the mdof-SRIM fit on each training set at each horizon (s)."""
    import numpy as np

    from podbench.sysid.methods.mdof_peer import Mdof

    trains = sorted({s.train for s in plan.sets if all(n in levels for n in s.train)
                     and any(n in levels for n in s.targets)
                     and (s.methods is None or "mdof-SRIM" in s.methods)}, key=len)
    print("train,samples,horizon_s,horizon_samples,cpu_s,spectral_radius")
    for train in trains:
        recs = [levels[n] for n in train]
        for hz in horizons:
            est = Mdof(method="srim", horizon=hz)
            t = time.process_time()
            try:
                est.fit(recs)
                radius = f"{est.info_['spectral_radius']:.5f}"
            except (np.linalg.LinAlgError, ValueError) as exc:  # the peer fails: say so
                radius = f"failed ({type(exc).__name__}: {exc})"
            s = time.process_time() - t
            print(f"{'+'.join(map(str, train))},{sum(r.n_samples for r in recs)},{hz:g},"
                  f"{int(round(hz / recs[0].dt))},{s:.2f},{radius}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", default=None,
                    help="labels of the methods to time, separated by commas (default: all; "
                         "'modes and pole sweep' for the levels' modes)")
    ap.add_argument("--parts", default=",".join(PARTS),
                    help=f"parts to time, separated by commas ({', '.join(PARTS)})")
    ap.add_argument("--srim-horizons", default=None,
                    help="time mdof's SRIM fit alone at these horizons (s, separated by "
                         "commas) on every training set, instead of the study")
    args = ap.parse_args(argv)
    parts = set(args.parts.split(","))
    unknown = parts - set(PARTS)
    if unknown:
        ap.error(f"unknown parts: {sorted(unknown)} (expected {', '.join(PARTS)})")
    plan = load_f16_gvt(ROOT / "scenarios" / "f16_gvt" / "f16_gvt.toml")
    levels = h.load_levels(plan)
    if args.srim_horizons:
        with single_blas_thread():
            srim_horizons(plan, levels, [float(x) for x in args.srim_horizons.split(",")])
        print(f"reference workload CPU {reference_cpu():.2f} s")
        return 0
    cpu: dict = defaultdict(float)
    order: list[float] = []
    with single_blas_thread():
        if "methods" in parts:
            wanted = None if args.methods is None else set(args.methods.split(","))
            order = _time_tasks(plan, levels, wanted, cpu)
        tail = dict(cpu)
        if parts - {"methods"}:
            _tail(plan, levels, parts, cpu)
        serial = sum(cpu.values()) - sum(tail.values())
    ref = reference_cpu()
    for name, s in cpu.items():
        print(f"{name:40s} {s:7.1f} s of CPU = {s / ref:5.1f} units")
    total = sum(cpu.values())
    print(f"{'total':40s} {total:7.1f} s of CPU = {total / ref:5.1f} units of the reference "
          f"workload's CPU ({ref:.2f} s, benchmarks/study_time.py's workload timed by "
          "process_time)")
    if order:
        two = makespan(order, 2) + serial
        print(f"{'--jobs 2 on two idle cores, at best':40s} {two:7.1f} s = {two / ref:5.1f} "
              "units (the tasks as timed here, scheduled as the executor does, plus the "
              "serial parts; without the workers' imports)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
