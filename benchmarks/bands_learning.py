"""The learning curve of ML's and MDS's leave-one-record-out folds on the held-out designs:
does a model fitted on N records err systematically less (or more) than its folds, fitted
on N − 1, and can the records tell by how much?

For every held-out model (``benchmarks/bands_heldout.py``'s designs, one noise level each)
this refits the method on every N − 2 of its N training records (leave two out, in the
first N − 2 modes when the model has more, as a fold of N − 1 records is refitted in
N − 1: ``bands.folds_per_mode``) and predicts each left-out record; its error is counted
as the band's folds count theirs (inside the refit's modes plus the full basis's
projection error, ``bands._residuals``). Per left-out record ``j`` the step from N − 2 to
N − 1 records is ``s_j = e1_j / geomean_l e2_{j,l}`` (``e1_j`` its leave-one-out error,
``e2_{j,l}`` its error with ``l`` left out too); the model's step is the geometric mean
over ``j``. The rows written (one per model) let ``bands_rules.py``-style scoring apply a
level correction ``c`` to every target estimate of that model offline:

* ``"step"``: ``c = s`` (the same ratio one record further);
* ``"power"``: ``e ∝ n^(−p)`` fitted through the two points, ``c = ((N − 1)/N)^p``
  with ``p = −ln s / ln((N − 1)/(N − 2))``;
* ``"pooled"``: no correction; the gains fitted on the leave-one-out folds and the
  leave-two-out predictions together (each with its own terms against the records it was
  predicted from), as more calibration points of the same two-gain law.

    python benchmarks/bands_learning.py --set dev --rows learn_dev.csv
    python benchmarks/bands_learning.py --score learn_dev.csv dev.csv
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402


def _errors(model, recs, keep, U, k_fold, frozen) -> np.ndarray:
    """Relative error of each ``recs[j]``, ``j`` in ``keep``, predicted by the method
    refitted on the other records of ``keep`` in the first ``k_fold`` modes of ``U`` (the
    band's own fold predictions, ``bands._fold_predictions``, and fold error,
    ``bands._residuals``)."""
    from podbench.sysid.methods import bands

    U_cv = U[:, :k_fold]
    sub = [recs[i] for i in keep]
    cv = k_fold if k_fold < U.shape[1] else None
    out = []
    for r, Wh in zip(sub, bands._fold_predictions(model, sub, U_cv, cv, frozen), strict=True):
        Wh = np.asarray(Wh, float)
        W = np.asarray(r.W, float)[:, :Wh.shape[1]]
        R = U_cv @ (U_cv.T @ W) - Wh + (W - U @ (U.T @ W))
        out.append(float(np.linalg.norm(R) / max(np.linalg.norm(W), 1e-300)))
    return np.array(out)


def learning_step(model, recs) -> dict:
    """``{n, k, e1 (geomean), e2 (geomean), step}`` of one fitted model (module doc)."""
    from podbench.sysid.methods import band_target, bands

    U = np.asarray(model.modes_, float)
    N, k = len(recs), int(U.shape[1])
    frozen = bands._frozen(model)
    k1 = min(k, N - 1) if bands.folds_per_mode(model) else k
    k2 = min(k, N - 2) if bands.folds_per_mode(model) else k
    lo = getattr(model, "n_records", (1, None))[0]
    if N - 2 < max(lo, 1) or k2 < 1:
        return {"n": N, "k": k, "e1": math.nan, "e2": math.nan, "step": math.nan}
    e1 = _errors(model, recs, list(range(N)), U, k1, frozen)
    e2 = np.full((N, N), np.nan)  # e2[j, l]: record j predicted without j and l
    pairs = []  # (e2, Λ², Δ², ρ) of every leave-two-out prediction, its terms as a fold's
    for l in range(N):
        keep = [i for i in range(N) if i != l]
        e2[keep, l] = _errors(model, recs, keep, U, k2, frozen)
        terms = band_target.fold_terms(model, [recs[i] for i in keep], U[:, :k2], U)
        for j, t in zip(keep, terms or [], strict=False):
            pairs.append((e2[j, l], t.leverage2, t.blind2, t.rho or 0.0))
    with np.errstate(divide="ignore"):
        g2 = np.exp(np.nanmean(np.log(e2), axis=1))
        step = float(np.exp(np.mean(np.log(e1) - np.log(g2))))
    return {"n": N, "k": k, "e1": float(np.exp(np.mean(np.log(e1)))),
            "e2": float(np.exp(np.mean(np.log(g2)))), "step": step,
            "e1_all": ";".join(f"{x:.6g}" for x in e1),
            "e2_all": ";".join(f"{x:.6g}" for x in g2),
            **{f"pair_{name}": ";".join(f"{p[i]:.6g}" for p in pairs)
               for i, name in enumerate(("errors", "lev2", "blind2", "rho"))}}


def run(set_name: str) -> list[dict]:
    from benchmarks.bands_heldout import NOISE, designs, make_method, noisy_record, simulate_design

    rows = []
    for d in designs(set_name):
        train, _ = simulate_design(d)
        for level in NOISE:
            recs = [noisy_record(r, level, d, f"train{j}") for j, r in enumerate(train)]
            model = make_method(d)
            try:
                model.fit(recs)
                out = learning_step(model, recs)
            except Exception as exc:  # a design the method refuses: no row
                print(f"  {d.cls} {d.method} {d.seed} {level}: {exc}", file=sys.stderr)
                continue
            rows.append(dict(cls=d.cls, method=d.method, seed=d.seed, noise=level, **out))
        print(f"  {d.cls} {d.method} seed {d.seed}: done", file=sys.stderr, flush=True)
    return rows


def correction(step: float, n: int, law: str) -> float:
    """The level correction ``c`` of a model's estimates (module doc); 1 where no step."""
    if not np.isfinite(step) or step <= 0:
        return 1.0
    if law == "step":
        return step
    p = -math.log(step) / math.log((n - 1) / (n - 2))
    return ((n - 1) / n) ** p


def _pooled(g, lrow):
    """``(target estimates, the leave-one-out folds' estimates)`` of one model under the
    ``"pooled"`` variant: the gains (:func:`podbench.sysid.methods.bands.fit_gains`) fitted
    on its leave-one-out folds (the stored rows') and its leave-two-out predictions
    together, each with its own terms."""
    from benchmarks.bands_rules import _floats
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    r0 = g.iloc[0]
    loo = [TargetTerms(a, b, c if c > 0 else None) for a, b, c in
           zip(_floats(r0.fold_lev2), _floats(r0.fold_blind2), _floats(r0.fold_rho),
               strict=True)]
    errors = list(_floats(r0.fold_errors))
    terms = list(loo)
    if isinstance(lrow.get("pair_errors"), str):
        errors += list(_floats(lrow["pair_errors"]))
        terms += [TargetTerms(a, b, c if c > 0 else None) for a, b, c in
                  zip(_floats(lrow["pair_lev2"]), _floats(lrow["pair_blind2"]),
                      _floats(lrow["pair_rho"]), strict=True)]
    gains = bands.fit_gains(np.array(errors), terms, np.ones(len(errors)))
    est = np.array([bands.estimate(gains, TargetTerms(
        r.leverage ** 2, r.blind_spot ** 2,
        r.projection_share if np.isfinite(r.projection_share) else None))
        for _, r in g.iterrows()])
    return est, np.array([bands.estimate(gains, t) for t in loo])


def score(learn_csv: str, rows_csv: str) -> None:
    """Within ×2, Spearman (and, for ``"pooled"``, the band's coverage cells and interval
    score) of the corrections on the stored rows, against the default rule."""
    import pandas as pd

    from benchmarks.bands_heldout import scores
    from benchmarks.bands_rules import _band, _model_estimates, score_rule

    learn = pd.read_csv(learn_csv).set_index(["cls", "method", "seed", "noise"])
    df = pd.read_csv(rows_csv)
    df = df[df["status"] == "ok"]
    cols = {"gains": score_rule(df, "gains")}
    for law in ("step", "power", "pooled"):
        out = df.copy()
        for key, g in df.groupby(["cls", "method", "seed", "noise"], sort=False):
            lrow = learn.loc[key] if key in learn.index else pd.Series(dtype=object)
            if law == "pooled":
                est, own = _pooled(g, lrow)
                cov, isc, csc = _band(g, est, own)
                out.loc[g.index, "coverage"] = cov
                out.loc[g.index, "interval_score"] = isc
                out.loc[g.index, "constant_interval_score"] = csc
            else:
                est = _model_estimates(g, "gains")[0]
                est = est * (correction(lrow["step"], int(lrow["n"]), law)
                             if len(lrow) else 1.0)
            out.loc[g.index, "error_estimate"] = est
        if law != "pooled":
            out = out.assign(coverage=np.nan)
        s = scores(out)
        if law != "pooled":  # the band is not recomputed under a level correction
            s["coverage_cells_in_0.85_0.95"] = s["interval_score_ratio"] = math.nan
        r = out["error_estimate"] / out["total_error"]
        for m in ("MDS", "ML"):
            sel = out["method"] == m
            s[f"within_factor_2_{m}"] = float(np.mean((r[sel] >= 0.5) & (r[sel] <= 2)))
        cols[law] = pd.Series(s)
    keys = ["within_factor_2", "within_factor_2_MDS", "within_factor_2_ML", "spearman",
            "spearman_within_model_median", "coverage_cells_in_0.85_0.95",
            "coverage_cell_min", "coverage_cell_max", "interval_score_ratio"]
    print(pd.DataFrame(cols).loc[keys].to_string())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("dev", "test"), default="dev")
    ap.add_argument("--rows", help="write one row per model to this CSV")
    ap.add_argument("--score", nargs=2, metavar=("LEARN", "ROWS"),
                    help="score the corrections on bands_heldout.py --features rows")
    args = ap.parse_args(argv)
    if args.score:
        score(*args.score)
        return 0
    import pandas as pd

    df = pd.DataFrame(run(args.set))
    if args.rows:
        df.to_csv(args.rows, index=False)
    print(df.round(4).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
