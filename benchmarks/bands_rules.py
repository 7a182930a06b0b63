"""Score the error-estimate rules of :data:`podbench.sysid.methods.bands.ESTIMATE_RULE`
offline, on the rows ``benchmarks/bands_heldout.py --features`` stores (each prediction's
terms and its model's folds), without refitting anything.

Every rule is applied through the band code itself (:func:`bands._rule_constants` on the
stored folds, the target's estimate as :func:`bands._cross_validated` computes it), so a
rule scored here is the rule ``predict(target, coverage=0.9)`` would apply. Rows written by
a run with the grid features (``fold_cdf``, ``target_cdf``, …) also give each rule's
coverage cells and interval score (the pooled conformal quantile of the folds' scores at the
rule's fold estimates; ``bands_heldout._grid_features``).

    python benchmarks/bands_heldout.py --set dev --features --rows dev.csv
    python benchmarks/bands_rules.py dev.csv
    python benchmarks/bands_rules.py dev.csv --rules folds-leverage --leverage-powers 0.25 0.5 1
    python benchmarks/bands_rules.py dev.csv --rules folds-gains --growth
    python benchmarks/bands_rules.py dev.csv --rules gains --mondrian none leverage level
    python benchmarks/bands_rules.py dev.csv --rules gains --recenter
    python benchmarks/bands_rules.py dev.csv --rules gains --leverage-exponents 1 0.75 0.5
    python benchmarks/bands_rules.py dev.csv --rules gains J hypot geomean gain [--jack-full]
    python benchmarks/bands_rules.py dev.csv --jack-diagnostics

The jackknife rules (:data:`JACK_RULES`, measured in docs/bands.md, *A jackknife term on
the target*) need rows with the ``jack`` columns (``bands_heldout.py --features``).

``--leverage-exponents`` (a variant, measured in docs/bands.md): the gains' leverage term
``κ_Λ²(Λ² + 1)^γ`` with γ chosen per model from the values given by the fit's log loss on
its folds (:data:`podbench.sysid.methods.bands.GAINS_LEVERAGE_EXPONENTS`).

``--recenter`` (a variant, measured in docs/bands.md): every estimate of a model divided by
the median over its folds of the fold's estimate over its realized error (the folds'
own bias of the fitted rule, known without the truth). ``--l1`` (a variant): the gains
fitted by least absolute log residuals (for each κ_Δ² on the grid, κ_Λ² the median instead
of the geometric mean; :func:`fit_l1`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

RULES = ("gains", "folds", "folds-leverage", "choose", "folds-gains")
SCALE_GRID = np.logspace(-4, 4, 321)
COVERAGE_GRID = np.concatenate([np.linspace(0.0, 0.9, 91)[:-1], np.linspace(0.9, 1.0, 101)])


def _floats(s) -> np.ndarray:
    return np.array([float(x) for x in str(s).split(";")])


def _model_estimates(rows, rule: str):
    """``(estimates of the rows, the folds' own estimates, rule applied)`` of one model."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    r0 = rows.iloc[0]
    errors = _floats(r0.fold_errors)
    terms = [TargetTerms(a, b, c if c > 0 else None) for a, b, c in
             zip(_floats(r0.fold_lev2), _floats(r0.fold_blind2), _floats(r0.fold_rho),
                 strict=True)]
    beta = float(r0.level_power)
    if "fold_excursions" in rows.columns and isinstance(r0.fold_excursions, str):
        excursions = _floats(r0.fold_excursions)
    elif beta > 0:  # rows stored before the excursions were: a = d^(1/β)
        excursions = _floats(r0.fold_factors) ** (1.0 / beta)
    else:
        raise SystemExit("bands_rules: rows without fold_excursions need a level power above "
                         "0 to recover them from the folds' factors d = a^β")
    cal = bands.BandCalibration("cross-validation", np.zeros(0), 0.0,
                                np.ones(bands.N_TIME_BINS), None, len(errors), 0)
    old = bands.ESTIMATE_RULE
    bands.ESTIMATE_RULE = rule
    try:
        bands._rule_constants(cal, errors, terms, excursions)
    finally:
        bands.ESTIMATE_RULE = old
    est = []
    for _, r in rows.iterrows():
        rho = r.projection_share if np.isfinite(r.projection_share) else None
        t = TargetTerms(r.leverage ** 2, r.blind_spot ** 2, rho)
        est.append(bands.rule_estimate(cal, t, r.level_excursion))
    EXPONENTS_CHOSEN.append(cal.leverage_exponent)
    return np.array(est), np.asarray(cal.fold_estimates, float), cal.rule


EXPONENTS_CHOSEN: list = []
"""The gains' leverage exponent γ each scored model applied (``--leverage-exponents``)."""


MONDRIAN = ("none", "leverage", "level")
"""Categories of a per-category (Mondrian) conformal quantile within one fitted model, read
from what the records show: ``"leverage"`` a fold (target) whose ``Λ² + 1`` exceeds every
other fold's (every fold's) against the rest; ``"level"`` a fold (target) whose level
excursion exceeds 1 (a prediction beyond the others' range) against the rest; ``"none"``
the pooled quantile (the band code's)."""


def _log_quantile(n, c, cdfs, coverage: float) -> float:
    """The log of the conformal quantile of the scores ``r_j/c_j`` pooled over the folds
    given (bisection in log q on their stored coverage curves)."""
    lk = np.log(SCALE_GRID)
    rank = math.ceil(coverage * (n.sum() + 1)) / n.sum()
    lo, hi = -40.0, 40.0
    for _ in range(90):
        mid = 0.5 * (lo + hi)
        share = sum(nj * np.interp(mid + math.log(cj), lk, f)
                    for nj, cj, f in zip(n, c, cdfs, strict=True)) / n.sum()
        lo, hi = (lo, mid) if share >= rank else (mid, hi)
    return hi


def _categories(rows, mondrian: str):
    """``(fold categories, row categories)`` (booleans: beyond the rest) of one model."""
    r0 = rows.iloc[0]
    if mondrian == "leverage":
        L = _floats(r0.fold_lev2) + 1.0
        folds = np.array([L[j] > np.delete(L, j).max() if L.size > 1 else False
                          for j in range(L.size)])
        tgt = (rows["leverage"].to_numpy(float) ** 2 + 1.0) > L.max()
        return folds, tgt
    if mondrian == "level":
        a = _floats(r0.fold_excursions) if "fold_excursions" in rows.columns else \
            _floats(r0.fold_factors)
        return a > 1.0, rows["level_excursion"].to_numpy(float) > 1.0
    return None, None


def _band(rows, est, own, coverage=0.9, mondrian: str = "none"):
    """Each row's coverage, interval score and best constant band's interval score under a
    rule's estimates (NaN without the grid features); ``mondrian``: the quantile of the
    folds of the target's category (:data:`MONDRIAN`; pooled where it has no fold)."""
    nan = np.full(len(rows), np.nan)
    r0 = rows.iloc[0]
    if "fold_cdf" not in rows.columns or not isinstance(r0.fold_cdf, str):
        return nan, nan, nan
    lk = np.log(SCALE_GRID)
    cdfs = [_floats(s) for s in r0.fold_cdf.split("|")]
    n = _floats(r0.fold_sizes)
    c = own / np.sqrt(1.0 + own ** 2)
    pooled = _log_quantile(n, c, cdfs, coverage)
    fcat, tcat = _categories(rows, mondrian)
    per_cat = {}
    if fcat is not None:
        for cat in (False, True):
            sel = np.flatnonzero(fcat == cat)
            per_cat[cat] = _log_quantile(n[sel], c[sel], [cdfs[j] for j in sel], coverage) \
                if sel.size else pooled
    cov, isc, csc = nan.copy(), nan.copy(), nan.copy()
    for i, (_, r) in enumerate(rows.iterrows()):
        hi = pooled if tcat is None else per_cat[bool(tcat[i])]
        k = math.log(math.exp(hi) * est[i] / math.sqrt(1.0 + est[i] ** 2))
        cov[i] = np.interp(k, lk, _floats(r.target_cdf))
        isc[i] = math.exp(np.interp(k, lk, np.log(_floats(r.target_is))))
        csc[i] = np.interp(cov[i], COVERAGE_GRID, _floats(r.constant_is))
    return cov, isc, csc


def fit_l1(errors, terms, factors):
    """``(loss, κ_Λ², κ_Δ²)`` as :func:`podbench.sysid.methods.bands._fit`, with the sum of
    absolute log residuals for the sum of squares (the median for the geometric mean)."""
    from podbench.sysid.methods import bands

    data = bands.fit_data(errors, terms, factors)
    if data is None:
        return math.inf, 0.0, 0.0
    y, L, D, cands = data
    best = None
    for b in cands:
        a = float(np.exp(np.median(np.log(np.maximum(y - b * D, 1e-12 * y) / L))))
        loss = float(np.sum(np.abs(np.log(y) - np.log(a * L + b * D))))
        if best is None or loss < best[0] - 1e-12 * max(1.0, best[0]):
            best = (loss, a, b)
    return best


def _oracle_and_bias(ok) -> dict:
    """Within ×2 of the per-model-constant oracle (each model's estimates times the
    constant, chosen on the truth, that puts most of them within ×2) and the median
    log₂(estimate/realized) per method."""
    out = {}
    hits = 0
    for _, g in ok.groupby(["cls", "method", "seed", "noise"]):
        lr = np.log2(g["error_estimate"].to_numpy(float) / g["total_error"].to_numpy(float))
        lr = lr[np.isfinite(lr)]
        # the best window [c, c + 2] in log₂ starts at one of the ratios
        hits += max((int(np.sum((lr >= c) & (lr <= c + 2.0 + 1e-12))) for c in lr), default=0)
    out["oracle_per_model_constant"] = hits / max(len(ok), 1)
    for m in ("MDS", "ML"):
        g = ok[ok["method"] == m]
        out[f"median_log2_ratio_{m}"] = float(np.nanmedian(np.log2(
            g["error_estimate"].to_numpy(float) / g["total_error"].to_numpy(float))))
    return out


RECENTER = False
"""``--recenter``: divide a model's estimates (and its folds') by the folds' median ratio
of estimate to realized error."""


JACK_RULES = ("J", "hypot", "geomean", "gain")
"""Rules on the target's jackknife spread ``J`` over the band's fold models (the rows'
``jack``; ``bands_heldout._jack_features``), each with its folds' own estimates (for the
band's pooled quantile) from each fold's leave-two-out ``J_j`` (``fold_jack``), ``e``
being today's estimate (the rows' ``error_estimate``, the folds' ``fold_estimates``):

* ``"J"``: ``J`` alone;
* ``"hypot"``: ``sqrt(e² + J²)``;
* ``"geomean"``: ``sqrt(e·J)``;
* ``"gain"``: ``sqrt(κ²J² + ρ²)``, one gain per model fitted on its folds as the gains are
  (``bands.fit_data``: ``κ²`` the geometric mean of ``max(e_j² − ρ_j², 0.01 e_j²)/J_j²``,
  ρ the projection share).

No constant is chosen on any set. A model whose folds have no ``J_j`` (fewer than
``N − 2`` records to refit, or a refit refused) keeps today's estimate for ``"gain"`` and
today's fold estimates for the band's quantile of every rule (counted in
``jack_fallback``)."""
JACK_FULL = False
"""``--jack-full``: ``J`` about the full model's prediction (``jack_full``, ``fold_jack_full``)
instead of about the folds' mean."""


def jack_estimates(rows, rule: str):
    """``(estimates of the rows, the folds' own, fell back)`` of one model under a
    :data:`JACK_RULES` rule."""
    r0 = rows.iloc[0]
    col, fcol = ("jack_full", "fold_jack_full") if JACK_FULL else ("jack", "fold_jack")
    e = rows["error_estimate"].to_numpy(float)
    J = rows[col].to_numpy(float)
    e_f = _floats(r0.fold_estimates)
    J_f = _floats(r0[fcol]) if isinstance(r0.get(fcol), str) else np.full(e_f.size, np.nan)
    have = bool(np.all(np.isfinite(J_f) & (J_f > 0)))
    if rule == "J":
        est, own = J, J_f
    elif rule == "hypot":
        est, own = np.hypot(e, J), np.hypot(e_f, J_f)
    elif rule == "geomean":
        est, own = np.sqrt(e * J), np.sqrt(e_f * J_f)
    else:
        if not have:
            return e, e_f, True
        err = _floats(r0.fold_errors)
        rho_f = _floats(r0.fold_rho)
        y = np.maximum(err ** 2 - rho_f ** 2, 0.01 * err ** 2)
        k2 = float(np.exp(np.mean(np.log(y / J_f ** 2))))
        rho = rows["projection_share"].to_numpy(float)
        rho = np.where(np.isfinite(rho), rho, 0.0)
        est, own = np.sqrt(k2 * J ** 2 + rho ** 2), np.sqrt(k2 * J_f ** 2 + rho_f ** 2)
    if not have:
        own = e_f
    return est, own, not have


def jack_diagnostics(df) -> str:
    """What ``J`` shows, per method: its log₂ ratio to the realized error over the
    predictions; per model, the Spearman between today's level miss (median
    log₂(e/realized)) and ``J``'s share (median log₂(J/e)), the within-model Spearman, the
    folds' Spearman of ``J_j`` with ``e_j``; and within ×2 of ``J``, ``J_full`` and ``e``
    times one constant per method fitted leave-one-model-out on the other models' truth
    (the issue's prototype protocol, a meta-model no user has: a diagnostic, not a rule)."""
    from scipy.stats import spearmanr

    ok = df[df["status"] == "ok"].copy()
    ok["model"] = [f"{c}|{m}|{s}|{n}" for c, m, s, n in
                   zip(ok.cls, ok.method, ok.seed, ok.noise, strict=True)]
    lines = []
    for col in ("jack", "jack_full", "error_estimate"):
        for m, g in ok.groupby("method"):
            lr = np.log2(g[col] / g.total_error)
            lines.append(f"{col} {m}: log2(x/realized) median {lr.median():+.2f}, quartiles "
                         f"{lr.quantile(0.25):+.2f} … {lr.quantile(0.75):+.2f}; Spearman "
                         f"{spearmanr(g[col], g.total_error).statistic:.3f}")
    for m, gm in ok.groupby("method"):
        rows = []
        for _, g in gm.groupby("model"):
            r0 = g.iloc[0]
            rows.append((np.median(np.log2(g.error_estimate / g.total_error)),
                         np.median(np.log2(g.jack / g.error_estimate)),
                         np.median(np.log2(g.jack / g.total_error)),
                         spearmanr(g.jack, g.total_error).statistic,
                         spearmanr(_floats(r0.fold_jack), _floats(r0.fold_errors)).statistic))
        a = np.array(rows)
        lines.append(f"{m}: Spearman(model's miss of e, log2 J/e) "
                     f"{spearmanr(a[:, 0], a[:, 1]).statistic:+.2f}; models off by more than "
                     f"x2: e {np.sum(np.abs(a[:, 0]) > 1)}, J {np.sum(np.abs(a[:, 2]) > 1)} of "
                     f"{len(a)}; within-model Spearman of J (median) {np.nanmedian(a[:, 3]):.2f}; "
                     f"folds' Spearman(J_j, e_j) (median) {np.nanmedian(a[:, 4]):.2f}")
    for col in ("jack", "jack_full", "error_estimate"):
        hit = []
        for _, r in ok.iterrows():
            o = ok[(ok.method == r.method) & (ok.model != r.model)]
            k = float(np.exp(np.median(np.log(o.total_error / o[col]))))
            hit.append(abs(math.log2(k * r[col] / r.total_error)) <= 1.0)
        hit = np.array(hit)
        lines.append(f"{col} x one constant per method, leave-one-model-out: within x2 "
                     f"{hit.mean():.3f} (MDS {hit[ok.method.to_numpy() == 'MDS'].mean():.3f}, "
                     f"ML {hit[ok.method.to_numpy() == 'ML'].mean():.3f})")
    return "\n".join(lines)


def score_rule(df, rule: str, mondrian: str = "none") -> dict:
    """The held-out scores (``bands_heldout.scores``) of ``rule`` on the stored rows
    (``mondrian``: the band's quantile per category, :data:`MONDRIAN`); a
    :data:`JACK_RULES` rule through :func:`jack_estimates`."""
    import pandas as pd

    from benchmarks.bands_heldout import scores

    out = df.copy()
    chosen = []
    fallback = 0
    for _, rows in df.groupby(["cls", "method", "seed", "noise"], sort=False):
        if rule in JACK_RULES:
            est, own, fell = jack_estimates(rows, rule)
            fallback += int(fell)
            applied = rule
            EXPONENTS_CHOSEN.append(1.0)
        else:
            est, own, applied = _model_estimates(rows, rule)
        if RECENTER:
            c = float(np.exp(-np.median(np.log(own / _floats(rows.iloc[0].fold_errors)))))
            est, own = est * c, own * c
        cov, isc, csc = _band(rows, est, own, mondrian=mondrian)
        out.loc[rows.index, "error_estimate"] = est
        for col, v in (("coverage", cov), ("interval_score", isc),
                       ("constant_interval_score", csc)):
            out.loc[rows.index, col] = v if np.isfinite(v).any() else np.nan
        chosen.append(applied)
    s = scores(out)
    ok = out[out["status"] == "ok"]
    for m in ("MDS", "ML"):
        g = ok[ok["method"] == m]
        r = g["error_estimate"] / g["total_error"]
        s[f"within_factor_2_{m}"] = float(np.mean((r >= 0.5) & (r <= 2)))
    s["models_on_folds"] = f"{sum(c != 'gains' for c in chosen)}/{len(chosen)}"
    if rule in JACK_RULES:
        s["jack_fallback"] = f"{fallback}/{len(chosen)}"
    s.update(_oracle_and_bias(ok))
    g = np.array(EXPONENTS_CHOSEN[-len(chosen):])
    s["leverage_exponents"] = " ".join(f"{x:g}:{np.count_nonzero(g == x)}"
                                       for x in sorted(set(g.tolist()), reverse=True))
    if np.isfinite(ok["coverage"].to_numpy(float)).any():
        for (m, c, lv), g in ok.groupby(["method", "cls", "noise"]):
            s[f"coverage {m} {c} {100 * lv:g} %"] = float(g["coverage"].mean())
    return pd.Series(s)


def main(argv=None) -> int:
    import pandas as pd

    from podbench.sysid.methods import bands

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", help="a CSV of bands_heldout.py --features")
    ap.add_argument("--rules", nargs="*", default=list(RULES), choices=RULES + JACK_RULES)
    ap.add_argument("--jack-full", action="store_true",
                    help="the jackknife rules' J about the full prediction (jack_full)")
    ap.add_argument("--leverage-powers", nargs="*", type=float,
                    default=[bands.LEVERAGE_POWER])
    ap.add_argument("--mondrian", nargs="*", default=["none"], choices=MONDRIAN,
                    help="the band's quantile per category of folds (MONDRIAN); one column "
                         "each")
    ap.add_argument("--growth", action="store_true",
                    help="\"folds-gains\" beyond the folds' leverage: the folds' estimate times "
                         "the gains' growth (bands.FOLDS_GAINS_GROWTH)")
    ap.add_argument("--recenter", action="store_true",
                    help="divide each model's estimates by its folds' median estimate/error")
    ap.add_argument("--l1", action="store_true",
                    help="fit the gains by least absolute log residuals (fit_l1)")
    ap.add_argument("--leverage-exponents", nargs="*", type=float, default=None,
                    help="the \"gains\" rule's leverage exponents γ the folds choose from "
                         "(bands.GAINS_LEVERAGE_EXPONENTS; default: the band code's)")
    ap.add_argument("--jack-diagnostics", action="store_true",
                    help="print what the jackknife J shows (jack_diagnostics) and stop")
    args = ap.parse_args(argv)
    if args.jack_diagnostics:
        print(jack_diagnostics(pd.read_csv(args.rows)))
        return 0
    bands.FOLDS_GAINS_GROWTH = args.growth
    if args.leverage_exponents:
        bands.GAINS_LEVERAGE_EXPONENTS = tuple(args.leverage_exponents)
    global RECENTER, JACK_FULL
    RECENTER = args.recenter
    JACK_FULL = args.jack_full
    if args.l1:
        bands._fit = fit_l1
    df = pd.read_csv(args.rows)
    df = df[df["status"] == "ok"]
    cols = {}
    for rule in args.rules:
        for p in (args.leverage_powers if rule == "folds-leverage" else [None]):
            old = bands.LEVERAGE_POWER
            bands.LEVERAGE_POWER = old if p is None else p
            try:
                for mon in args.mondrian:
                    name = (rule if p is None else f"{rule} p={p:g}") + \
                        ("" if mon == "none" else f", Mondrian {mon}")
                    cols[name] = score_rule(df, rule, mon)
            finally:
                bands.LEVERAGE_POWER = old
    table = pd.DataFrame(cols)
    print("| score | " + " | ".join(table.columns) + " |")
    print("|---" * (len(table.columns) + 1) + "|")
    for name, row in table.iterrows():
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in row]
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
