"""Cost of a 90 % band on the path the acceptance check runs: ``podbench predict --method
ML|MDS --train … --target … --coverage 0.9`` on files (issue target: band ≤ 5× the plain
fit + predict).

The cases are built like the held-out designs (:mod:`benchmarks.bands_heldout`, its ``dev``
seeds, one design per class × method unless ``--per-cell``): per class (LTI, LTV, NL beam;
the satellite truss) ML on 3–6 displacement/force records and MDS on 3–6 free responses
(``W``, ``dt``, ``w0``), clean and with 1 % and 5 % per-channel noise, each design with its
five targets. The records are written to ``.npz`` files (``W`` in in, ``F`` in lbf, ``dt`` in
s; ``w0`` in in) and every case is timed three ways, best of ``--repeat``:

* ``in-process``: the estimator ``podbench predict`` builds
  (:func:`~podbench.harness.predict.command_line_estimator` on the files' records: ML with
  the ``auto`` solver, MDS in the design's modes), ``fit`` + ``predict`` of every target,
  against the same with ``coverage=0.9`` — CPU time of this process
  (``time.process_time``), one BLAS thread, every call from empty solver caches
  (:func:`clear_caches`: a repeat would otherwise reuse the least-squares SVD of the last
  call, which a ``podbench predict`` process never has; ``--warm`` keeps them); ``floor`` =
  (plain + the calibration's refits) / plain (the time in ``bands._residuals`` and
  ``bands._noise_refits``, as :func:`benchmarks.bands.refit_time`): what a band built on
  leave-one-record-out refits cannot go below;
* ``CLI``: the command itself in a child process, ``podbench predict … --out D`` with and
  without ``--coverage 0.9``, its wall time and its CPU time (user + system of the child,
  ``os.wait4``); the child's start (imports, reading and checking the files, writing
  ``D``) is in both. The child runs with one BLAS thread (as ``podbench predict`` fits
  anyway) and its bytecode cached (``PYTHONDONTWRITEBYTECODE`` unset; one warm-up run
  first): a process that compiles every module from source spends about 0.8 s more.

::

    python benchmarks/bands_cli.py                          # 8 designs × 3 noise levels
    python benchmarks/bands_cli.py --noise 0.01 --repeat 3  # the reduced set
    python benchmarks/bands_cli.py --no-cli                 # in-process only

Speed is measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from benchmarks import bands_heldout as held  # noqa: E402

PODBENCH = Path(sys.executable).with_name("podbench")
"""The command line of this environment (``.venv/bin/podbench``)."""


def write_case(d, level: float, sims, folder: Path) -> tuple[list[str], list[str]]:
    """The training and target records of design ``d`` at noise ``level`` as ``.npz``
    files in ``folder`` (the records :func:`benchmarks.bands_heldout.run_design` fits and
    predicts); ``(train, targets)`` paths."""
    train, targets = sims
    folder.mkdir(parents=True, exist_ok=True)

    def save(rec, name):
        path = folder / f"{name}.npz"
        arrays = {"W": rec.W, "dt": rec.dt}
        arrays.update({"F": rec.F} if d.method == "ML" else {"w0": rec.w0})
        np.savez(path, **arrays)
        return str(path)

    return ([save(held.noisy_record(r, level, d, f"train{j}"), f"train{j}")
             for j, r in enumerate(train)],
            [save(held.noisy_record(t, level, d, f"target{j}"), f"target{j}")
             for j, t in enumerate(targets)])


def _estimator(d, train_files):
    """The estimator and the records ``podbench predict`` fits (the same reading and
    construction as :func:`~podbench.harness.predict.predict_files`)."""
    from podbench.harness.predict import command_line_estimator, method_entry, read_any

    tr = [read_any(p, require_outputs=True) for p in train_files]
    entry = method_entry(d.method)
    return (lambda: command_line_estimator(entry, tr, solver="auto", n_modes=d.n_modes,
                                           period=None)), tr


WARM = False
"""``--warm``: keep the per-process decomposition caches between the timed calls (by
default each call starts from empty caches, as each ``podbench predict`` process does)."""


def clear_caches() -> None:
    """Empty the per-process caches of the deconvolution solvers (the least-squares SVD of
    a convolution matrix, the bordered eigendecompositions, the dense memo, the kernel's
    decompositions), so that an in-process repeat costs what a fresh process pays."""
    from podbench.sysid.deconvolution import bordered, dense, kernel

    for cache in (bordered._CACHE, bordered._SVD_CACHE, dense._MEMO, kernel._DECOMPOSED):
        cache.clear()


def in_process(d, train_files, target_files, repeat: int) -> dict:
    """Plain and band CPU times (s) of fit + predict of every target, and the floor (the
    band's refits, :func:`benchmarks.bands.refit_time`'s, timed in the same calls)."""
    from benchmarks.bands import refits_timed
    from podbench.harness.predict import read_any

    make, tr = _estimator(d, train_files)
    tg = [read_any(p, default_output_units=tr[0].output_units) for p in target_files]
    clock = time.process_time

    def run(coverage, spent):
        if not WARM:
            clear_caches()
        spent[0] = 0.0
        t0 = clock()
        est = make().fit(tr)
        preds = [est.predict(t, coverage=coverage) for t in tg]
        return clock() - t0, spent[0], preds

    t_plain = min(run(None, [0.0])[0] for _ in range(repeat))
    with refits_timed(clock) as spent:
        runs = [run(0.9, spent) for _ in range(repeat)]
    t_band, t_refits, preds = min(runs, key=lambda r: r[0])
    return dict(plain=t_plain, band=t_band, floor=1.0 + t_refits / t_plain,
                estimates=[p.error_estimate for p in preds])


def _run_cli(args: list[str]) -> tuple[float, float]:
    """Wall and CPU time (s) of one child ``podbench`` process (error if it fails)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode cached
    t0 = time.perf_counter()
    proc = subprocess.Popen([str(PODBENCH), *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    if proc.returncode != 0:
        raise RuntimeError(f"podbench {' '.join(args[:3])} …: exit {proc.returncode}: "
                           f"{err.strip()[-300:]}")
    return wall, usage.ru_utime + usage.ru_stime


def cli(d, train_files, target_files, folder: Path, repeat: int) -> dict:
    """Best-of-``repeat`` wall and CPU times (s) of ``podbench predict`` with and without
    ``--coverage 0.9`` (alternating, a fresh ``--out`` each run)."""
    base = ["predict", "--method", d.method, "--train", *train_files,
            "--target", *target_files]
    if d.n_modes is not None:
        base += ["--n-modes", str(d.n_modes)]
    _run_cli(base + ["--out", str(folder / "out_warm")])  # bytecode and file caches warm
    best = {k: [np.inf, np.inf] for k in ("plain", "band")}
    for i in range(repeat):
        for kind in ("plain", "band"):
            extra = ["--coverage", "0.9"] if kind == "band" else []
            wall, cpu = _run_cli(base + ["--out", str(folder / f"out_{kind}{i}")] + extra)
            best[kind] = [min(best[kind][0], wall), min(best[kind][1], cpu)]
    return {f"{k}_{w}": best[k][n] for k in best for n, w in enumerate(("wall", "cpu"))}


def measure(designs, levels, repeat: int, with_cli: bool = True):
    """One row per design × noise level: the times of :func:`in_process` and :func:`cli`."""
    with tempfile.TemporaryDirectory(prefix="bands_cli_") as tmp:
        for d in designs:
            sims = held.simulate_design(d)
            for level in levels:
                folder = Path(tmp) / f"{d.cls}_{d.method}_{d.seed}_{level:g}"
                train, targets = write_case(d, level, sims, folder)
                row = dict(cls=d.cls, method=d.method, seed=d.seed, noise=level,
                           n_train=len(train), n_targets=len(targets),
                           n_samples=d.n_samples)
                try:
                    row.update(in_process(d, train, targets, repeat))
                    if with_cli:
                        row.update(cli(d, train, targets, folder, repeat))
                except Exception as exc:  # a refused fit is a row saying so
                    row["status"] = f"{type(exc).__name__}: {exc}"[:100]
                yield row


def _fmt(row) -> str:
    head = (f"| {row['cls']} | {row['method']} | {100 * row['noise']:g} % | "
            f"{row['n_train']} / {row['n_samples']} | ")
    if "status" in row:
        return head + f"{row['status']} | | | | |"
    text = (f"{1e3 * row['plain']:.0f} → {1e3 * row['band']:.0f} ms | "
            f"{row['band'] / row['plain']:.2f}× | {row['floor']:.2f}× | ")
    if "plain_wall" in row:
        text += (f"{row['plain_wall']:.2f} → {row['band_wall']:.2f} s: "
                 f"{row['band_wall'] / row['plain_wall']:.2f}× | "
                 f"{row['plain_cpu']:.2f} → {row['band_cpu']:.2f} s: "
                 f"{row['band_cpu'] / row['plain_cpu']:.2f}× |")
    else:
        text += "| |"
    return head + text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=tuple(held.SETS), default="dev")
    ap.add_argument("--classes", nargs="*", default=list(held.CLASSES))
    ap.add_argument("--methods", nargs="*", default=list(held.METHODS))
    ap.add_argument("--per-cell", type=int, default=1)
    ap.add_argument("--noise", nargs="*", type=float, default=list(held.NOISE))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-cli", action="store_true", help="in-process times only")
    ap.add_argument("--rows", default=None, help="also write every row to this CSV")
    ap.add_argument("--warm", action="store_true",
                    help="keep the solvers' per-process caches between in-process repeats")
    args = ap.parse_args(argv)
    global WARM
    WARM = args.warm
    ds = held.designs(args.set, tuple(args.classes), tuple(args.methods), args.per_cell)
    print("| class | method | noise | records / samples | in-process CPU, plain → band | "
          "band / plain | floor | CLI wall | CLI CPU |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for row in measure(ds, args.noise, args.repeat, not args.no_cli):
        print(_fmt(row), flush=True)
        rows.append(row)
    if args.rows:
        import pandas as pd

        pd.DataFrame(rows).to_csv(args.rows, index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
