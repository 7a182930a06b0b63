"""``solver="auto"``'s noise test: clean or noisy, judged from the records only (issue 23).

    python benchmarks/auto_test.py                      # every case below, seed 0
    python benchmarks/auto_test.py --cases truss,frame40 --loads rect5 --on W

Each case is a structure, a sampling step, a record length and ``k`` load cases (one point
load per case, at ``k`` sensors spread from the last one inwards; the same load shape in
every case): ``rect5`` a 10-lbf rectangular pulse of 5 samples, ``halfsine`` a half-sine of 8
samples, ``tri`` a triangle of 11, ``burst`` a standard-normal random force over the first
quarter of the record (all from sample 1). The records get per-channel noise
(:func:`podbench.noise.noisy`, ``level`` × each channel's RMS; on the responses only, ``W``,
or on responses and the loaded force channel, ``WF``). ML (``k`` load cases, ``k`` POMs) and
SL (the first load case, ``k`` POMs, one scalar deconvolution per mode: noisy if any
is) are fitted with :class:`podbench.deconvolution.Auto`;
the data are *judged clean* when it returns the exact solution (``block`` or ``ls``).
Printed: one line per fit (choice, which test decided, its statistic) and the confusion
table (clean = level 0; noisy = level ≥ 0.3 %; records rounded to single precision
(level -1), 0.01 % and 0.1 % shown apart).
Cases ``frame150`` and ``lti_beam`` are the ones the kernel test was designed on; the
others were measured after. Nothing is asserted; the numbers are for docs/noise.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

LEVELS = (0.0, -1.0, 1e-4, 1e-3, 3e-3, 1e-2, 5e-2)
"""Noise levels (fraction of each channel's RMS); -1: no noise, records rounded to float32."""


def _structure(name):
    import podbench as pb
    from podbench.structures.chain import chain

    if name == "frame150":  # the 150-storey shear frame of benchmarks/defaults.py
        return chain(150, masses=0.5, springs=2.0e5, rayleigh=(0.1, 1e-4),
                     sensors=list(range(9, 150, 10)), name="frame150")
    if name == "frame40":
        return chain(40, masses=1.0, springs=5e4, rayleigh=(0.05, 2e-4), name="frame40")
    return pb.load_structure(name)


# case: (structure, dt in s, n samples, k)
CASES = {
    "frame150": ("frame150", 1e-3, 1000, 4),
    "lti_beam": ("lti_beam", 1e-4, 1000, 4),
    "lti_beam_1kHz": ("lti_beam", 1e-3, 500, 4),
    "truss": ("satellite_truss_stiffness_only", 0.05, 400, 3),
    "chain_ideal": ("chain_ideal", 0.01, 500, 3),
    "chain_coupled": ("chain_coupled", 1e-3, 600, 3),
    "aluminium_beam": ("aluminium_beam", 1e-4, 1024, 3),
    "frame40": ("frame40", 1e-3, 800, 3),
}


def _forces(m: int, n: int, kind: str, rows, rng):
    out = []
    for row in rows:
        F = np.zeros((m, n))
        if kind == "rect5":
            F[row, 1:6] = 10.0
        elif kind == "halfsine":
            F[row, 1:9] = 10.0 * np.sin(np.pi * np.arange(1, 9) / 9)
        elif kind == "tri":
            F[row, 1:12] = 10.0 * (1 - np.abs(np.linspace(-1, 1, 13)[1:12]))
        else:  # burst
            F[row, 1:n // 4] = rng.standard_normal(n // 4 - 1)
        out.append(F)
    return out


def run_case(case: str, kind: str, on: str, levels, seed: int = 0):
    import podbench as pb
    from podbench.sysid.deconvolution import Auto
    from podbench.sysid.methods import MultipleLoad, SingleLoad
    from podbench.sysid.noise import NoiseSpec, noisy

    sname, dt, n, k = CASES[case]
    s = _structure(sname)
    m = s.n_sensors
    rows = [m - 1 - int(round(j * (m - 1) / (2 * k))) for j in range(k)]
    recs = [pb.simulate(s, n_samples=n, dt=dt, force=F)
            for F in _forces(m, n, kind, rows, np.random.default_rng(1))]
    out = []
    for level in levels:
        if level < 0:  # exact records rounded to single precision (as a float32 file holds them)
            rr = [SimpleNamespace(W=r.W.astype(np.float32).astype(float),
                                  F=r.F.astype(np.float32).astype(float)) for r in recs]
        else:
            rr = [noisy(r, NoiseSpec(level=level, seed=seed, on=tuple(on)), "auto_test", case,
                        str(j)) for j, r in enumerate(recs)]
        for method in ("ML", "SL"):
            try:
                if method == "ML":
                    est = MultipleLoad(n_modes=k, solver=Auto()).fit(
                        [r.W for r in rr], [r.F for r in rr], dt=dt)
                else:
                    est = SingleLoad(n_modes=k, solver=Auto()).fit(rr[0].W, rr[0].F, dt=dt)
                infos = est.solver_info_  # SL: one per mode; judged noisy if any mode is
                infos = infos if isinstance(infos, list) else [infos]
                info = next((i for i in infos if i["choice"] not in ("block", "ls")), infos[0])
                choice, test = info["choice"], info["noise_test"]
                stat = max(i["noise_floor"] for i in infos)
            except Exception as exc:  # a failed fit is a row of the table
                choice, test, stat = f"error {type(exc).__name__}", "-", float("nan")
            out.append((case, kind, on, method, level, choice, test, stat))
            print(f"{case:15s} {kind:8s} {on:2s} {method} level={level:<7g} choice={choice:9s} "
                  f"test={test:8s} statistic={stat:.2e}", flush=True)
    return out


def confusion(rows) -> str:
    cnt = Counter()
    for *_, level, choice, _test, _stat in rows:
        judged = "clean" if choice in ("block", "ls") else (
            "error" if choice.startswith("error") else "noisy")
        truth = ("clean" if level == 0 else "single precision" if level < 0
                 else "noisy ≥ 0.3 %" if level >= 3e-3 else f"noisy {level * 100:g} %")
        cnt[truth, judged] += 1
    lines = ["| records | judged clean | judged noisy | fit failed |", "| --- | --- | --- | --- |"]
    for truth in ("clean", "single precision", "noisy 0.01 %", "noisy 0.1 %", "noisy ≥ 0.3 %"):
        if any(t == truth for t, _ in cnt):
            lines.append(f"| {truth} | {cnt[truth, 'clean']} | {cnt[truth, 'noisy']} | "
                         f"{cnt[truth, 'error']} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--loads", default="rect5,halfsine,tri,burst")
    ap.add_argument("--on", default="W,WF", help="noisy quantities: W, WF or both")
    ap.add_argument("--levels", default=",".join(f"{v:g}" for v in LEVELS))
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    levels = [float(v) for v in args.levels.split(",")]
    rows = []
    for case in args.cases.split(","):
        for kind in args.loads.split(","):
            for on in args.on.split(","):
                rows += run_case(case, kind, on, levels, args.seed)
    for on in sorted({r[2] for r in rows}):
        print(f"\nnoise on {on}:\n" + confusion([r for r in rows if r[2] == on]))
    print("\nall:\n" + confusion(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
