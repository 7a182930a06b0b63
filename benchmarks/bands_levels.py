"""The error estimate of a measured-input prediction at force levels outside the training
levels: the F-16 ground-vibration test (J.P. Noël and M. Schoukens, "F-16 aircraft benchmark
based on ground vibration test data", Workshop on Nonlinear System Identification
Benchmarks, Brussels, 2017; measured shaker force in N -> three accelerations in m/s²,
multisine 2-15 Hz at several force levels, one ``.npz`` per level).

ML on input/output records (measured-input ML, a fixed FIR length) is fitted on two
records of the lowest level (12.4 N RMS: periods 2 and 4 of its multisine, 8192 samples
each at 400 Hz) and asked for the other levels (a third period of level 1, and periods 2-3
of 24.6, 61.4 and 97.7 N) with ``predict(target, coverage=0.9)``; each prediction is scored
against the measured outputs: realized total error ``‖Ŷ − Y‖_F/‖Y‖_F``, the estimate, their
ratio, the band's coverage of the measured samples, and the target's level excursion
(docs/bands.md, *The estimate*). Nothing is asserted: the numbers go in docs/bands.md.

    python benchmarks/bands_levels.py --data DIR [--lags 1600]   # minutes on 1 core
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

FILES = {12: "f16_fullmsine_level1_12N.npz", 25: "f16_fullmsine_level2_25N_validation.npz",
         61: "f16_fullmsine_level4_61N_validation.npz", 98: "f16_fullmsine_level7_98N.npz"}
"""The levels used (nominal force RMS, N) and their files."""
PERIOD = 8192
"""Samples per multisine period (the first period is the start-up transient)."""


def record(data: Path, level: int, first: int, last: int, *, outputs: bool = True):
    """Periods ``first … last − 1`` (0-based) of one level as a Record."""
    from podbench.core.records import Record

    z = np.load(data / FILES[level])
    sl = slice(PERIOD * first, PERIOD * last)
    return Record(u=np.asarray(z["inputs"], float)[:, sl],
                  y=np.asarray(z["outputs"], float)[:, sl] if outputs else None,
                  dt=float(z["dt"]), input_units="N", output_units="m/s^2",
                  name=f"{level} N, periods {first + 1}-{last}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=Path,
                    help="folder holding the F-16 benchmark's .npz files")
    ap.add_argument("--lags", type=int, default=1600, help="FIR length, samples")
    args = ap.parse_args(argv)
    missing = [f for f in FILES.values() if not (args.data / f).is_file()]
    if missing:
        print(f"error: --data {args.data}: missing {', '.join(missing)}", file=sys.stderr)
        return 2
    from podbench.sysid.methods import MultipleLoad

    train = [record(args.data, 12, 1, 2), record(args.data, 12, 3, 4)]
    model = MultipleLoad(inputs="measured", solver="ls", n_lags=args.lags).fit(train)
    targets = [record(args.data, 12, 5, 6)] + [record(args.data, lv, 1, 3)
                                               for lv in (25, 61, 98)]
    print("| target | input RMS, N | excursion | estimate | realized | ratio | coverage |")
    print("|---|---|---|---|---|---|---|")
    for t in targets:
        blind = record(args.data, int(t.name.split()[0]), *_periods(t.name), outputs=False)
        p = model.predict(blind, coverage=0.9)
        real = float(np.linalg.norm(p.mean - t.y) / np.linalg.norm(t.y))
        print(f"| {t.name} | {np.sqrt(np.mean(t.u ** 2)):.1f} | "
              f"{p.details['level_excursion']:.2f} | {p.error_estimate:.3f} | {real:.3f} | "
              f"{p.error_estimate / real:.2f} | {p.covers(t.y):.3f} |")
    cal = model.band_calibration_
    print(f"\nfolds: realized {np.round(cal.fold_errors, 3).tolist()}, estimated "
          f"{np.round(cal.fold_estimates, 3).tolist()}; β = {cal.level_power}")
    return 0


def _periods(name: str) -> tuple[int, int]:
    first, last = name.split("periods ")[1].split("-")
    return int(first) - 1, int(last)


if __name__ == "__main__":
    raise SystemExit(main())
