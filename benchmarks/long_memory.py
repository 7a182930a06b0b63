"""Long memories: ML on measured inputs against ERA on lightly damped structures.

Target: ML's prediction error on a lightly damped structure at or below ERA's on the same
records (the issue's case: a 5-mass chain, force input, acceleration outputs, 40-s records at
200 Hz, 1 % noise: ML 0.042 against ERA 0.022 with ML's lags stopping at 2 s).

The workload, one rule for every structure: a band-limited random force (4th-order
Butterworth below 0.4 × Nyquist, zero-order hold) at ``--sensor``, the accelerations at every
sensor (in/s²) by the exact zero-order-hold model (:func:`benchmarks.modal.zoh_model`),
``--seconds`` at ``--rate``; four training records and one new record (seeds 0–4), 1 %
noise (``--noise``) per input and output channel on the training records, the new record
clean. Methods with their defaults as ``podbench predict`` runs them: ``ML-poles`` (ML on
measured inputs with ``kernel="poles"``: the kernel in a basis of decaying modes whose poles
start from ML-TC's FIR kernel and are refined by the records' output error; that FIR kernel,
its *pilot*, is ``ML-TC``'s own fit — lags
and TC prior by leave-one-record-out, ``n_lags="auto"``, ``prior="tc"`` — and its error is
printed from the same fit) and ``ERA`` (ERA/OKID on measured inputs, ``ERA-measured``: order
by its hold-out rule); ``--methods`` names others. Error: ``‖ŷ − y‖_F / ‖y‖_F`` on the new
record; the time of each fit + predict. ``--oracle``: the true kernel (the exact ZOH
model's Markov parameters) truncated at 2, 6.75, 12 s and half the record — the best any
FIR kernel of that length predicts — and the pole basis with the true poles, its residues
fitted on the same noisy records (the bound of ``ML-poles`` with exact poles).

Run: ``python benchmarks/long_memory.py --structure chain_coupled --oracle`` (prints the
table). Structures: ``benchmarks/structures/chain_issue.toml`` (the issue's chain),
``chain_ideal``, ``chain_coupled``, two written down before the pilot-pole basis was run:
``benchmarks/structures/chain_six_light.toml``, ``chain_four_dashpot.toml``, and two before
the pole refinement was built: ``chain_three_stiff.toml``, ``chain_eight_links.toml``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from benchmarks.modal import forced_records, zoh_model  # noqa: E402


def make_records(structure, sensor: int, dt: float, n: int, noise: float):
    """Four noisy training records and one clean new record (module docstring)."""
    recs = forced_records(structure, sensor, dt, n, noise, range(5), cutoff=0.4, gain=10.0,
                          prefix="long", streams=("f", "nu", "ny"), spread=np.std,
                          clean=(4,))
    return recs[:4], recs[4]


def oracle(structure, sensor: int, dt: float, target, lags) -> dict:
    """The FIR bound: the relative error of the true kernel (the exact ZOH model's Markov
    parameters) truncated at each of ``lags`` on the new record — what a FIR kernel of that
    length predicts at best, with no noise and no estimation error."""
    from podbench.sysid.deconvolution.lagged import lag_response
    from podbench.sysid.realize import markov_parameters

    Ad, Bd, Cy, Dy = zoh_model(structure, sensor, dt)
    out = {}
    for L in lags:
        h = markov_parameters(Ad, Bd, Cy, Dy, L)  # (L, n_out, 1): lag-major θ
        yh = lag_response(h.transpose(0, 2, 1).reshape(L, -1), target.u, 1, 0)
        out[L] = float(np.linalg.norm(yh - target.y) / np.linalg.norm(target.y))
    return out


def oracle_poles(structure, sensor: int, dt: float, train, target) -> float:
    """The pole basis with the true poles (the exact ZOH model's eigenvalues) in place of the
    pilot's, its residues fitted on the same noisy training records: the bound of
    ``ML-poles`` when its poles are exact."""
    from podbench.sysid.deconvolution.lagged import solve_ls
    from podbench.sysid.methods.inputs import measured_basis
    from podbench.sysid.methods.pole_basis import pole_states

    lam = np.linalg.eigvals(zoh_model(structure, sensor, dt)[0])
    lam = lam[lam.imag > 0]
    N = 2 * lam.size
    A, B = np.zeros((N, N)), np.zeros((N, 1))
    for i, x in enumerate(lam):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[x.real, -x.imag], [x.imag, x.real]]
        B[2 * i] = 1.0
    U, _ = measured_basis(train, None)
    F = [pole_states(A, B, r.u, 0) for r in train]
    th = solve_ls(sum(f @ f.T for f in F),
                  sum(f @ (U.T @ r.y).T for f, r in zip(F, train, strict=True)))
    yh = U @ th.T @ pole_states(A, B, target.u, 0)
    return float(np.linalg.norm(yh - target.y) / np.linalg.norm(target.y))


def main(argv=None) -> int:
    import podbench as pb
    from podbench.dynamics.modes import fe_modes
    from podbench.sysid import registry
    from podbench.sysid.deconvolution.lagged import lag_response

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--structure", default="chain_coupled")
    ap.add_argument("--sensor", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=40.0)
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--methods", default="ML-poles,ERA-measured")
    ap.add_argument("--oracle", action="store_true",
                    help="also the FIR bound: the true kernel truncated at 2, 6.75, 12 s "
                         "and half the record")
    args = ap.parse_args(argv)
    s = pb.load_structure(args.structure)
    m = fe_modes(s)
    decay = float(np.max(1.0 / (m.damping_ratio * 2 * np.pi * m.frequency_hz)))
    print(f"{s.name}: modes {', '.join(f'{f:.3g}' for f in m.frequency_hz)} Hz, ζ "
          f"{', '.join(f'{100 * z:.2g}' for z in m.damping_ratio)} %, slowest decay time "
          f"1/(ζω) = {decay:.3g} s")
    dt = 1.0 / args.rate
    train, target = make_records(s, args.sensor, dt, int(round(args.seconds * args.rate)),
                                 args.noise)
    for name in filter(None, args.methods.split(",")):
        t0 = time.perf_counter()
        est = registry.lookup(name).build().fit(train)
        yh = est.predict(target)
        secs = time.perf_counter() - t0
        err = float(np.linalg.norm(yh - target.y) / np.linalg.norm(target.y))
        info = getattr(est, "info_", {}) or {}
        chosen = {k: info[k] for k in ("n_lags", "tc_tau", "tc_gamma", "pole_order",
                                        "order") if k in info}
        print(f"{name:14s} error {err:.4f}  {secs:6.1f} s  {chosen}", flush=True)
        if info.get("kernel") == "poles":  # its pilot: the lag rule's FIR kernel (ML-TC's)
            yp = est.modes_ @ lag_response(est.theta_, target.u, 1, est.first_lag_)
            print(f"{'  its pilot':14s} error "
                  f"{np.linalg.norm(yp - target.y) / np.linalg.norm(target.y):.4f}  "
                  f"(ML-TC's FIR kernel, {est.info_['n_lags']} lags)", flush=True)
    if args.oracle:
        half = int(round(args.seconds * args.rate)) // 2
        lags = sorted({int(round(x * args.rate)) for x in (2.0, 6.75, 12.0)} | {half})
        for L, e in oracle(s, args.sensor, dt, target, lags).items():
            print(f"true kernel, {L} lags ({L * dt:g} s): error {e:.4f}")
        print(f"pole basis with the true poles: error "
              f"{oracle_poles(s, args.sensor, dt, train, target):.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
