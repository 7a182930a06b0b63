"""How far the truncated kernels' hyperparameters limit them on the F-16 records: an oracle.

    python benchmarks/f16_tc_oracle.py            # prints one row per training set and target

For each training set of the F-16 study that runs the truncated kernels (ML-FIR-TC,
FIR-LS) and each of its validation levels: the relative error over the whole record of
the kernel fitted on the training levels (output channels; with k = n_out POMs ML is a
rotation of them and the TC prior is the same in any orthonormal basis), for

* FIR-LS at every lag length of the grid and its first lengthening (0.25-3 s), one
  training level included (least squares needs no fold);
* the TC prior at every lag length, decay time tau in 0.05-1.6 s and weight gamma in
  1e-5-1 (relative to trace(RᵀAR)/rows), a wider grid than the method's own;

and the best of each chosen on the validation record itself (the oracle: no rule that
sees only the training levels can do better within these families). The errors come from
the Gram matrices of the validation record (the prediction from rest, ‖y − ŷ‖/‖y‖ over the
whole record, as summary.csv's rel_whole). This bounds what the prior's hyperparameters
can do; it does not choose them (the study keeps its leave-one-record-out rule).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

from podbench.core.threads import single_blas_thread  # noqa: E402
from podbench.harness.f16_gvt import load_levels  # noqa: E402
from podbench.study.f16_gvt import load_f16_gvt  # noqa: E402
from podbench.sysid.deconvolution.lagged import solve_ls  # noqa: E402
from podbench.sysid.methods.inputs import (  # noqa: E402
    _channel_grams,
    _tc_factor,
    _tc_weights,
    _whiten,
)

LAGS_S = (0.25, 0.5, 1.0, 1.5, 2.0, 3.0)
TAUS = (0.05, 0.1, 0.2, 0.4, 0.8, 1.6)
GAMMAS = (1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0)


def _error(theta, A, B, c) -> float:
    """‖y − ŷ‖/‖y‖ from the target's Grams (``c``: ``y yᵀ``, its trace is ‖y‖²)."""
    c = np.diag(c)
    e2 = float(np.sum(c) - 2 * np.sum(theta * B) + np.sum(theta * (A @ theta)))
    return float(np.sqrt(max(e2, 0.0) / np.sum(c)))


def oracle(train, targets, dt: float) -> dict:
    """Errors on each of ``targets`` (records) of the FIR-LS and TC kernels fitted on
    ``train``: ``{"ls": {lags_s: [errors]}, "tc": {(lags_s, tau, gamma): [errors]}}``."""
    Lmax = int(round(max(LAGS_S) / dt))
    tr = [_channel_grams(r, Lmax, 0) for r in train]
    va = [_channel_grams(r, Lmax, 0) for r in targets]
    out: dict = {"ls": {}, "tc": {}}

    def errs(theta, L):
        return [_error(theta, v[0][:L, :L], v[1][:L], v[2]) for v in va]

    for s in LAGS_S:
        L = int(round(s / dt))
        A = sum(g[0][:L, :L] for g in tr)
        B = sum(g[1][:L] for g in tr)
        out["ls"][s] = errs(solve_ls(A, B), L)
        for tau in TAUS:
            M, N, _ = _whiten([(A, B, None)], _tc_weights(L, dt, tau), 1)[0]
            R = _tc_factor(L, 1, dt, tau)
            for g in GAMMAS:
                phi = solve_ls(M + g * float(np.trace(M)) / L * np.eye(L), N)
                out["tc"][(s, tau, g)] = errs(R @ phi, L)
    return out


def main() -> int:
    plan = load_f16_gvt(ROOT / "scenarios" / "f16_gvt" / "f16_gvt.toml")
    levels = load_levels(plan)
    dt = levels[1].dt
    print("train,target,ls_best_s,ls_oracle,tc_best(lags_s;tau_s;gamma),tc_oracle")
    sets: dict = {}
    for s in plan.sets:
        if s.methods is not None and "FIR-LS" not in s.methods:
            continue
        if any(n not in levels for n in s.train):
            continue
        sets.setdefault(s.train, set()).update(n for n in s.targets if n in levels)
    with single_blas_thread():
        for train, targets in sets.items():
            targets = sorted(targets)
            res = oracle([levels[t] for t in train], [levels[n] for n in targets], dt)
            for j, n in enumerate(targets):
                ls = min(res["ls"], key=lambda k: res["ls"][k][j])
                tc = min(res["tc"], key=lambda k: res["tc"][k][j])
                print(f"{'+'.join(map(str, train))},{n},{ls},{res['ls'][ls][j]:.4f},"
                      f"{tc[0]};{tc[1]};{tc[2]:g},{res['tc'][tc][j]:.4f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
