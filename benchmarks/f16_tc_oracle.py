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

    python benchmarks/f16_tc_oracle.py --rules    # also the rules that see the training only

``--rules`` adds three rules that choose the TC kernel's lags, τ and γ over the same grid
from the **training levels alone**, each a named variant (none is tuned on the validation):

* ``lolo``: leave-one-level-out (each level is one record: the study's rule, here without
  its lengthening beyond the grid; needs two training levels);
* ``evidence``: the marginal likelihood (empirical Bayes: Pillonetto, Chiuso & De Nicolao
  2011; Chen, Ohlsson & Ljung 2012), ``y = Φθ + e``, ``e ~ N(0, σ²I)`` per output,
  ``θ = Rφ``, ``φ ~ N(0, (σ²/ρ) I)``, ``ρ = γ·trace(RᵀAR)/rows``:
  ``−2 log p(y) = n log σ̂² + log det(I + RᵀAR/ρ) + n`` per output with
  ``σ̂² = (c − Nᵀ(RᵀAR + ρI)⁻¹N)/n`` (``N = RᵀB``, ``n`` the samples), summed over the
  outputs (one τ, γ for all, as the method);
* ``gcv``: generalized cross-validation, ``n·RSS/(n − df)²`` with
  ``df = trace(RᵀAR (RᵀAR + ρI)⁻¹)``, RSS over the outputs.

Both ``evidence`` and ``gcv`` choose from one training level too (the study's rule cannot).

    python benchmarks/f16_tc_oracle.py --no-oracle --measured   # rules from the records' noise

``--measured`` adds three rules of the same marginal likelihood whose nuisance parameter is
not estimated but read from what the training records show of themselves (each a named
variant; none sees the validation level):

* ``evidence-noise``: the noise variance per output fixed at the period-to-period variance
  of the training levels' steady state (the BLA's noise variance: the spread of the
  periods about their mean, ``P/(P − 1)`` corrected), ``−2 log p(y) = Σ_outputs
  [log det(I + RᵀAR/ρ) + (c − Nᵀ(RᵀAR + ρI)⁻¹N)/σ²]`` (+ a constant), ``ρ = γ·trace/rows``
  as above (the prior's scale ``σ²/ρ``);
* ``evidence-total``: the same with ``σ²`` the training levels' own BLA residual (noise on
  every line and the nonlinear distortion on the non-excited lines: what one multisine
  realization separates of the total variance);
* ``evidence-damping``: TC's decay time fixed by the pooled training BLA's slowest mode,
  ``τ = 1/(2 min ζω)`` (the prior's variance ``λ^k`` decays as the square of the kernel's
  envelope ``exp(−ζωt)``; the stable physical modes of the 24-pole rational fit, as
  modes.csv, or its physical modes when none is stable), lags and γ by ``evidence``.
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
from podbench.sysid.methods.periodic import BestLinearApproximation  # noqa: E402
from podbench.sysid.modal import (  # noqa: E402
    RESPONSE_POLES,
    physical_mask,
    response_fit,
    response_modes,
)
from podbench.sysid.periodic import steady_periods  # noqa: E402

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


RULES = ("lolo", "evidence", "gcv")


def _eig_solutions(M, N, c, n: int, rows: int):
    """Per γ of :data:`GAMMAS`: ``(φ, evidence, gcv)`` of the ridge ``(M + ρI)⁻¹N``,
    ``ρ = γ·trace(M)/rows``, from one eigen-decomposition of ``M`` (``c``: the outputs'
    ``y yᵀ``, ``n`` samples per output)."""
    mu, V = np.linalg.eigh(M)
    mu = np.clip(mu, 0.0, None)
    VN = V.T @ N  # (rows, k)
    cc = np.diag(c)
    out = {}
    for g in GAMMAS:
        rho = g * float(np.trace(M)) / rows
        phi = V @ (VN / (mu + rho)[:, None])
        fitted = np.sum(VN * VN / (mu + rho)[:, None], axis=0)  # Nᵀ(M + ρI)⁻¹N per output
        s2 = np.maximum(cc - fitted, 1e-300) / n
        evidence = float(n * np.sum(np.log(s2)) + N.shape[1] * np.sum(np.log1p(mu / rho)))
        rss = float(np.sum(cc) - 2 * np.sum(phi * N) + np.sum(phi * (M @ phi)))
        df = float(np.sum(mu / (mu + rho)))
        out[g] = (phi, evidence, n * N.shape[1] * rss / (n * N.shape[1] - df) ** 2)
    return out


def _lolo(white, rows: int, g: float) -> float:
    """Mean leave-one-level-out relative error of the TC kernel (whitened Grams)."""
    M = sum(w[0] for w in white)
    N = sum(w[1] for w in white)
    errs = []
    for Mj, Nj, cj in white:
        Mk = M - Mj
        phi = solve_ls(Mk + g * float(np.trace(Mk)) / rows * np.eye(rows), N - Nj)
        e2 = float(np.sum(np.diag(cj)) - 2 * np.sum(phi * Nj) + np.sum(phi * (Mj @ phi)))
        errs.append(np.sqrt(max(e2, 0.0) / float(np.sum(np.diag(cj)))))
    return float(np.mean(errs))


def rules(train, targets, dt: float) -> dict:
    """The choice of each rule of :data:`RULES` over the oracle's grid, from the training
    records alone, and its errors on ``targets``: ``{rule: ((lags_s, tau, gamma),
    [errors])}`` (``lolo`` absent for one training record)."""
    Lmax = int(round(max(LAGS_S) / dt))
    tr = [_channel_grams(r, Lmax, 0) for r in train]
    va = [_channel_grams(r, Lmax, 0) for r in targets]
    n = sum(r.n_samples for r in train)
    scores: dict = {r: {} for r in RULES}
    thetas = {}
    for s in LAGS_S:
        L = int(round(s / dt))
        grams = [(g[0][:L, :L], g[1][:L], g[2]) for g in tr]
        for tau in TAUS:
            white = _whiten(grams, _tc_weights(L, dt, tau), 1)
            M = sum(w[0] for w in white)
            N = sum(w[1] for w in white)
            R = _tc_factor(L, 1, dt, tau)
            c = sum(w[2] for w in white)
            for g, (phi, ev, gcv) in _eig_solutions(M, N, c, n, L).items():
                key = (s, tau, g)
                thetas[key] = R @ phi
                scores["evidence"][key], scores["gcv"][key] = ev, gcv
                if len(train) > 1:
                    scores["lolo"][key] = _lolo(white, L, g)
    out = {}
    for rule, sc in scores.items():
        if not sc:
            continue
        key = min(sc, key=sc.get)
        L = int(round(key[0] / dt))
        out[rule] = (key, [_error(thetas[key], v[0][:L, :L], v[1][:L], v[2]) for v in va])
    return out


MEASURED = ("evidence-noise", "evidence-total", "evidence-damping")


def noise_variance(recs, plan) -> np.ndarray:
    """Per output channel, the variance of the training records' steady-state periods about
    their mean ((m/s²)², ``P/(P − 1)`` corrected; the BLA's noise variance in time)."""
    out = []
    for r in recs:
        y = steady_periods(r.y, plan.period, plan.transient_periods, r.name)
        out.append(np.sum((y - y.mean(axis=0)) ** 2, axis=(0, 2))
                   / ((y.shape[0] - 1) * y.shape[2]))
    return np.mean(out, axis=0)


def _bla(recs, plan):
    return BestLinearApproximation(period=plan.period,
                                   transient_periods=plan.transient_periods).fit(recs)


def total_variance(recs, plan) -> np.ndarray:
    """Per output channel, the mean square of each training record's own BLA residual over
    its steady-state periods ((m/s²)²: noise and the distortion on the non-excited lines)."""
    out = []
    for r in recs:
        y = steady_periods(r.y, plan.period, plan.transient_periods, r.name)
        out.append(np.mean((y - _bla([r], plan).predict_periodic(r)[None]) ** 2, axis=(0, 2)))
    return np.mean(out, axis=0)


def damping_tau(recs, plan) -> tuple[float, float, float]:
    """``(τ, f, ζ)``: TC's decay time ``1/(2ζω)`` of the pooled training BLA's slowest
    stable physical mode (24-pole rational fit, as modes.csv), its frequency (Hz) and
    damping ratio."""
    bla = _bla(recs, plan)
    G = bla.frequency_response()[:, 0]
    channels = recs[0].output_channels or tuple(str(i) for i in range(G.shape[0]))
    modes, _, _ = response_modes(G, bla.frequencies_, recs[0].dt, channels)
    if not len(modes.frequency_hz):  # none stable: the physical poles of the 24-pole fit
        modes = response_fit(G, bla.frequencies_, RESPONSE_POLES, channels)[0]
        modes = modes.subset(physical_mask(modes, recs[0].dt))
    decay = 2 * np.pi * np.asarray(modes.frequency_hz) * np.asarray(modes.damping_ratio)
    j = int(np.argmin(decay))
    return (float(1.0 / (2.0 * decay[j])), float(modes.frequency_hz[j]),
            float(modes.damping_ratio[j]))


def measured_rules(train, targets, dt: float, plan) -> dict:
    """The choices of :data:`MEASURED` from the training records alone and their errors on
    ``targets``: ``{rule: ((lags_s, tau, gamma), [errors], note)}``."""
    Lmax = int(round(max(LAGS_S) / dt))
    tr = [_channel_grams(r, Lmax, 0) for r in train]
    va = [_channel_grams(r, Lmax, 0) for r in targets]
    n = sum(r.n_samples for r in train)
    fixed = {"evidence-noise": noise_variance(train, plan),
             "evidence-total": total_variance(train, plan)}
    tau_d, f_d, z_d = damping_tau(train, plan)
    scores: dict = {r: {} for r in MEASURED}
    thetas = {}
    for s in LAGS_S:
        L = int(round(s / dt))
        grams = [(g[0][:L, :L], g[1][:L], g[2]) for g in tr]
        for tau in (*TAUS, tau_d):
            white = _whiten(grams, _tc_weights(L, dt, tau), 1)
            M = sum(w[0] for w in white)
            N = sum(w[1] for w in white)
            c = np.diag(sum(w[2] for w in white))
            mu, V = np.linalg.eigh(M)
            mu = np.clip(mu, 0.0, None)
            VN = V.T @ N
            R = _tc_factor(L, 1, dt, tau)
            for g in GAMMAS:
                rho = g * float(np.trace(M)) / L
                key = (s, tau, g)
                thetas[key] = R @ (V @ (VN / (mu + rho)[:, None]))
                fitted = np.sum(VN * VN / (mu + rho)[:, None], axis=0)
                logdet = float(np.sum(np.log1p(mu / rho)))
                if tau != tau_d:
                    for rule, s2 in fixed.items():
                        scores[rule][key] = float(np.sum(logdet + (c - fitted) / s2))
                else:
                    s2 = np.maximum(c - fitted, 1e-300) / n
                    scores["evidence-damping"][key] = float(n * np.sum(np.log(s2))
                                                            + c.size * logdet)
    notes = {r: "sigma " + "/".join(f"{v:.2e}" for v in np.sqrt(fixed[r])) + " m/s2"
             for r in fixed}
    notes["evidence-damping"] = f"slowest mode {f_d:.3f} Hz, zeta {z_d:.4f}"
    out = {}
    for rule, sc in scores.items():
        key = min(sc, key=sc.get)
        L = int(round(key[0] / dt))
        out[rule] = (key, [_error(thetas[key], v[0][:L, :L], v[1][:L], v[2]) for v in va],
                     notes[rule])
    return out


def _print_measured(sets, levels, dt, plan) -> None:
    print("\ntrain,target,rule,lags_s,tau_s,gamma,rel_whole,note")
    for train, targets in sets.items():
        targets = sorted(targets)
        res = measured_rules([levels[t] for t in train], [levels[n] for n in targets], dt,
                             plan)
        for j, n in enumerate(targets):
            for rule in MEASURED:
                (s, tau, g), errs, note = res[rule]
                print(f"{'+'.join(map(str, train))},{n},{rule},{s},{tau:.3g},{g:g},"
                      f"{errs[j]:.4f},{note}", flush=True)


def _print_rules(sets, levels, dt) -> None:
    print("\ntrain,target,rule,lags_s,tau_s,gamma,rel_whole")
    for train, targets in sets.items():
        targets = sorted(targets)
        res = rules([levels[t] for t in train], [levels[n] for n in targets], dt)
        for j, n in enumerate(targets):
            for rule in RULES:
                if rule in res:
                    (s, tau, g), errs = res[rule]
                    print(f"{'+'.join(map(str, train))},{n},{rule},{s},{tau},{g:g},"
                          f"{errs[j]:.4f}", flush=True)


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    with_rules, with_measured = "--rules" in args, "--measured" in args
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
        for train, targets in ({} if "--no-oracle" in args else sets).items():
            targets = sorted(targets)
            res = oracle([levels[t] for t in train], [levels[n] for n in targets], dt)
            for j, n in enumerate(targets):
                ls = min(res["ls"], key=lambda k: res["ls"][k][j])
                tc = min(res["tc"], key=lambda k: res["tc"][k][j])
                print(f"{'+'.join(map(str, train))},{n},{ls},{res['ls'][ls][j]:.4f},"
                      f"{tc[0]};{tc[1]};{tc[2]:g},{res['tc'][tc][j]:.4f}", flush=True)
        if with_rules:
            _print_rules(sets, levels, dt)
        if with_measured:
            _print_measured(sets, levels, dt, plan)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
