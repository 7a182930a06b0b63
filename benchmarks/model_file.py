"""The cost of keeping a model: fit + save + load + predict against fit + predict.

Target: a saved model predicts exactly what a fresh fit predicts (relative difference
≤ 1e-12), and fit + save + load + predict takes at most 1.5× the time of fit + predict.

The workload: ML on measured inputs (the lag length and TC prior chosen by
leave-one-record-out, ``podbench predict``'s default with three records) on the coupled
5-mass chain, a force at mass 3 (band-limited white noise) and the five displacements, three
training records and one target of ``--samples`` samples at ``dt`` = 0.002 s. Both paths are
timed in the same process, each the best of ``--repeat`` runs; the ratio is what the target
reads.

Saving writes the arrays and the JSON header; it does not realize the model
(:data:`podbench.sysid.models.NOT_REALIZED`): the realization and modes in ``model.json``
are those computed before saving (``podbench fit``, ``model.modes()``). Measured: ratio
1.07 (2.07 when the save realized; benchmarks/README.md).

Run: ``python benchmarks/model_file.py`` (prints one line; ``--samples``, ``--repeat``).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import podbench as pb
from podbench.core.records import Record
from podbench.dynamics import simulate
from podbench.sysid.methods import MultipleLoad


def records(n: int, dt: float = 0.002) -> list[Record]:
    chain = pb.load_structure("chain_coupled")
    out = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        F = np.zeros((5, n))
        F[2, 1:] = 10.0 * np.convolve(rng.normal(size=n), np.ones(5) / 5, mode="same")[1:]
        r = simulate(chain, n, dt, force=F)
        out.append(Record(u=F[[2]], y=r.W, dt=dt, input_units="lbf", output_units="in",
                          input_channels=("f3",), name=f"r{seed}"))
    return out


def _method():
    return MultipleLoad(inputs="measured", n_lags="auto", solver="ls", prior="tc")


def plain(train, target):
    return _method().fit(train).predict(target)


def kept(train, target, folder: Path):
    model = pb.fit("ML", train, inputs="measured", n_lags="auto", solver="ls", prior="tc")
    path = model.save(folder / "model.npz")
    return pb.load_model(path).predict(target)


def best(f, repeat: int) -> tuple[float, np.ndarray]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    recs = records(args.samples)
    train, target = recs[:3], recs[3]
    with tempfile.TemporaryDirectory() as tmp:
        t_plain, a = best(lambda: plain(train, target), args.repeat)
        t_kept, b = best(lambda: kept(train, target, Path(tmp)), args.repeat)
    diff = float(np.max(np.abs(a - b)) / np.max(np.abs(a)))
    print(f"model_file: fit+predict {t_plain:.3f} s, fit+save+load+predict {t_kept:.3f} s, "
          f"ratio {t_kept / t_plain:.3f} (target <= 1.5), saved vs fresh {diff:.1e} "
          "(target <= 1e-12)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
