"""TLS vs LS deconvolution with noisy force *and* displacement data (§3.5).

Run ``python -m tests.methods.noise_study`` from the repository root; it prints the Markdown
table reproduced in docs/methods.md. ``test_noise_study.py`` runs it (marked slow) and
checks the claims made in the docs.

Set-up (everything seeded, nothing tuned):

* truth from the independent Newmark integrator of ``_truth`` (chains of 5 DOFs);
* the *training* snapshot and force matrices get independent Gaussian noise of standard
  deviation ``level × RMS`` of the respective matrix (a relative noise level);
* the new load is known exactly and the prediction is compared with the noise-free truth:
  the error is the identification (deconvolution) error plus, for SL, the diagonalization
  error of the clean data (the ``level = 0`` row);
* solvers: ``ls`` (minimum-norm least squares, Eq. 3.76); ``tls`` (truncated TLS, default
  ``rcond = 1e-3``, the MATLAB's limit); ``tls rcond=1e-2``; ``tls noise`` (the noise-edge
  rule with ``noise_level`` = the larger of the two noise standard deviations in
  ``[A | B]``: ``Δt·level·RMS(F)`` in the convolution matrix, ``level·RMS(W)`` in the POC
  histories).
"""

from __future__ import annotations

import numpy as np

from podbench.sysid.methods import MultipleLoad, SingleLoad

from ._cases import D, forced_case
from ._truth import rel_err

LEVELS = (0.0, 1e-4, 1e-3, 1e-2, 3e-2, 5e-2)
SEEDS = (0, 1, 2, 3, 4)
SOLVERS = ("ls", "tls-dt", "tls-dt rcond=1e-2", "tls-dt noise")
CASES = (
    ("SL, ideal chain, k = 2", "ideal", "SL", 2),
    ("SL, ideal chain, k = 5", "ideal", "SL", 5),
    ("ML, coupled chain, k = 5", "coupled", "ML", 5),
)


def _rms(X):
    return float(np.sqrt(np.mean(X**2)))


def _noisy(X, level, rng):
    return X + level * _rms(X) * rng.standard_normal(X.shape)


def _solver(label, level, dt, W, F):
    if label == "ls":
        return "ls", {}
    if label == "tls-dt":
        return "tls-dt", {}
    if label == "tls-dt rcond=1e-2":
        return "tls-dt", {"rcond": 1e-2}
    sd = max(dt * level * _rms(F), level * _rms(W))
    return ("tls-dt", {"noise_level": sd}) if sd > 0 else ("tls-dt", {})


def error(case: str, method: str, k: int, level: float, seed: int, solver: str) -> float:
    """Relative Frobenius error of the prediction of the new load's response."""
    fc = forced_case(case)
    rng = np.random.default_rng(seed)
    W = [_noisy(Wj, level, rng) for Wj in fc.W]
    F = [_noisy(Fj, level, rng) for Fj in fc.F]
    name, opts = _solver(solver, level, fc.dt, fc.W[0], fc.F[0])
    if method == "SL":
        model = SingleLoad(n_modes=k, solver=name, solver_options=opts)
        model.fit(W[0], F[0], dt=fc.dt)
    else:
        model = MultipleLoad(n_modes=k, solver=name, solver_options=opts)
        model.fit(W[:k], F[:k], dt=fc.dt)
    return rel_err(model.predict(fc.F_new), fc.W_new)


def run(levels=LEVELS, seeds=SEEDS, solvers=SOLVERS, cases=CASES):
    """Rows ``(case label, level, solver, median error, max error)``."""
    rows = []
    for label, case, method, k in cases:
        for level in levels:
            for solver in solvers:
                errs = [error(case, method, k, level, s, solver) for s in seeds]
                rows.append((label, level, solver, float(np.median(errs)), float(np.max(errs))))
    return rows


def table(rows) -> str:
    """Markdown table: one row per (case, level), median (max) error per solver."""
    solvers = list(dict.fromkeys(r[2] for r in rows))
    out = ["| case | noise level | " + " | ".join(solvers) + " |",
           "|---|---|" + "---|" * len(solvers)]
    keys = list(dict.fromkeys((r[0], r[1]) for r in rows))
    for case, level in keys:
        cells = []
        for s in solvers:
            (med, mx), = [(r[3], r[4]) for r in rows if (r[0], r[1], r[2]) == (case, level, s)]
            cells.append(f"{med:.3g} ({mx:.3g})")
        out.append(f"| {case} | {level:g} | " + " | ".join(cells) + " |")
    return "\n".join(out)


if __name__ == "__main__":  # pragma: no cover
    print(f"relative error ‖Ŵ − W‖_F/‖W‖_F, median (max) over seeds {SEEDS}; m = {D}\n")
    print(table(run()))
