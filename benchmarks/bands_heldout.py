"""Held-out evaluation of the prediction bands and error estimates: designs and targets of
its own, never the calibration study's.

Each *model* is one random training design on one structure class (LTI, LTV, NL beam; the
satellite truss), one method (ML on displacement/force records, MDS on free responses:
``W``, ``dt``, ``w0``) and one noise level (clean, 1 %, 5 % per-channel noise on the measured
channels — ``W``, the loaded rows of ``F``, ``w0`` — of the training AND the target records,
:func:`podbench.noise.noisy`). The design draws the number of records, load positions,
amplitudes, pulse shapes, durations, double hits and record lengths from a seed; its targets
are drawn the same way, some outside the training amplitudes and shapes. Every model
predicts its targets with ``predict(target, coverage=0.9)`` (what ``podbench predict
--coverage 0.9`` runs) and is scored against the noise-free simulated truth:

* coverage of the 90 % band per method × class × noise (mean over targets; target
  0.85–0.95);
* Spearman(error_estimate, realized total error) over all predictions (≥ 0.8) and within
  each fitted model (median over models, ≥ 0.6);
* the share of estimates within a factor of 2 of the realized error (≥ 0.8; a prediction
  without an estimate counts as a miss);
* the summed interval score over that of the best constant-width band with the same
  realized coverage per prediction (an oracle that knows the truth; ≤ 0.85).

Two sets: ``dev`` (seeds 0…, the set any choice was looked at on) and ``test`` (seeds
1000…, other shape families and durations; never used to choose anything). The cost of a
band against the plain fit and predict is ``benchmarks/bands.py``'s.

    python benchmarks/bands_heldout.py --set dev            # half an hour on 2 cores
    python benchmarks/bands_heldout.py --set test --rows out.csv
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

CLASSES = {"LTI": "lti_beam", "LTV": "ltv_beam", "NL": "nl_beam", "truss": "satellite_truss"}
NOISE = (0.0, 0.01, 0.05)
METHODS = ("ML", "MDS")
SETS = {"dev": 0, "test": 1000}
"""First design seed of each set."""
MODELS_PER_CELL = 2
"""Designs per class × method (each run at every noise level)."""
TARGETS = 5
"""Targets per design."""


@dataclass
class Design:
    """One training design and its targets (excitation objects, not yet simulated)."""

    cls: str
    method: str
    seed: int
    n_samples: int
    dt: float
    train: list = field(default_factory=list)
    targets: list = field(default_factory=list)
    n_modes: int | None = None


def _beam_positions(rng, n, lo=2, hi=24):
    return [float(x) for x in rng.choice(np.arange(lo, hi + 1), size=n, replace=False)]


def _truss_locations(rng, n):
    faces = rng.choice(np.arange(2, 99), size=n, replace=False)
    sides = rng.choice(["d_bot", "d_top"], size=n)
    return [f"face{int(f)}.{s}" for f, s in zip(faces, sides, strict=True)]


def _shape_family(set_name):
    """Pulse shapes and durations (fractions of the class's base duration) per set."""
    if set_name == "dev":
        return ("rectangular", "half_sine"), (0.6, 3.0)
    return ("triangle", "rectangular", "half_sine"), (0.4, 4.0)


def _pulse(rng, loc, amp, base_dur, set_name, *, same_shape=None, hits_p=0.25):
    from podbench.dynamics.excitations import Pulse

    shapes, (dlo, dhi) = _shape_family(set_name)
    shape = same_shape or str(rng.choice(shapes))
    dur = base_dur * float(np.exp(rng.uniform(np.log(dlo), np.log(dhi))))
    hits = []
    if rng.uniform() < hits_p:
        hits = [[float(rng.uniform(4, 12) * base_dur), float(rng.uniform(0.2, 0.7))]]
    return Pulse(loc, float(amp), dur, shape=shape, hits=hits)


def forced_design(cls, seed, set_name) -> Design:
    """ML: 3–6 forced records; one amplitude and shape (as Chapter 4's designs) or varied."""
    rng = np.random.default_rng([seed, 1])
    truss = cls == "truss"
    n_train = int(rng.integers(3, 7))
    dt, base_dur, amp0 = (0.05, 0.4, 225.0) if truss else (1e-4, 5e-4, 500.0)
    n_samples = 200 if truss else int(rng.integers(40, 61)) * 10
    amp0 *= float(np.exp(rng.uniform(np.log(0.5), np.log(1.6))))
    locs = (_truss_locations(rng, n_train + TARGETS) if truss
            else _beam_positions(rng, n_train + TARGETS))
    varied = rng.uniform() < 0.5
    shapes, _ = _shape_family(set_name)
    one_shape = None if varied else str(rng.choice(shapes))
    d = Design(cls, "ML", seed, n_samples, dt)
    for j in range(n_train):
        amp = amp0 * (float(np.exp(rng.uniform(np.log(0.5), np.log(2.0)))) if varied else 1.0)
        amp *= float(rng.choice([-1.0, 1.0])) if varied else 1.0
        d.train.append(_pulse(rng, locs[j], amp, base_dur, set_name,
                              same_shape=one_shape, hits_p=0.25 if varied else 0.0))
    for j in range(TARGETS):
        amp = amp0 * float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        d.targets.append(_pulse(rng, locs[n_train + j], amp, base_dur, set_name))
    return d


def free_design(cls, seed, set_name) -> Design:
    """MDS: 3–6 free responses from static deflections under 1–3 point loads."""
    rng = np.random.default_rng([seed, 2])
    truss = cls == "truss"
    n_train = int(rng.integers(3, 7))
    dt = 0.05 if truss else 1e-4
    n_samples = 200 if truss else int(rng.integers(40, 61)) * 10
    amp0 = (150.0 if truss else 300.0) * float(np.exp(rng.uniform(np.log(0.5), np.log(1.6))))
    d = Design(cls, "MDS", seed, n_samples, dt)
    if rng.uniform() < 0.3 and n_train > 3:
        d.n_modes = n_train - 1
    for j in range(n_train + TARGETS):
        n_loads = int(rng.integers(1, 4))
        locs = _truss_locations(rng, n_loads) if truss else _beam_positions(rng, n_loads)
        scale = 1.0 if j < n_train else float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        loads = [(loc, float(amp0 * scale * rng.uniform(-1.0, 1.0))) for loc in locs]
        (d.train if j < n_train else d.targets).append(loads)
    return d


def designs(set_name: str, classes=tuple(CLASSES), methods=METHODS,
            per_cell: int = MODELS_PER_CELL) -> list[Design]:
    first = SETS[set_name]
    out = []
    for cls in classes:
        for method in methods:
            for r in range(per_cell):
                # the seed names the design whatever subset of classes/methods is run
                seed = first + 100 * list(CLASSES).index(cls) + 10 * METHODS.index(method) + r
                make = forced_design if method == "ML" else free_design
                out.append(make(cls, seed, set_name))
    return out


def simulate_design(d: Design):
    """``(train, targets)``: the noise-free responses."""
    import podbench as pb
    from podbench.dynamics.excitations import StaticDisplacement

    s = pb.load_structure(CLASSES[d.cls])
    ref = s if d.cls == "truss" else pb.load_structure("lti_beam")

    def sim(x):
        if d.method == "ML":
            return pb.simulate(s, n_samples=d.n_samples, dt=d.dt, force=x)
        return pb.simulate(s, n_samples=d.n_samples, dt=d.dt,
                           initial_displacement=StaticDisplacement(x, reference=ref))

    return [sim(x) for x in d.train], [sim(x) for x in d.targets]


def noisy_record(resp, level: float, d: Design, name: str):
    """The record a laboratory measures: per-channel noise on W, the loaded rows of F, and
    w0 (free responses), seeded by the design and the record's name."""
    from podbench.core.records import Record
    from podbench.sysid.noise import NoiseSpec, noisy

    on = ("W", "w0") if d.method == "MDS" else ("W", "F")
    if level > 0:
        resp = noisy(resp, NoiseSpec(level=level, seed=d.seed, on=on), "bands_heldout",
                     d.cls, name)
    if d.method == "MDS":
        return Record(W=np.asarray(resp.W, float), w0=np.asarray(resp.w0, float), dt=resp.dt)
    return Record(W=np.asarray(resp.W, float), F=np.asarray(resp.F, float), dt=resp.dt)


def make_method(d: Design):
    from podbench.sysid.methods import MDS, MultipleLoad

    if d.method == "ML":
        return MultipleLoad(n_modes=d.n_modes)
    return MDS(n_modes=d.n_modes)


FEATURES = False
"""``--features``: each row also carries the estimate's terms and the fold data it was
calibrated on (to study other estimators offline; the scores do not read them)."""


def _features(model, p) -> dict:
    """The target's terms, the calibration's gains and its folds (``;``-joined)."""
    cal = model.band_calibration_
    det = p.details
    out = {k: det.get(k, math.nan) for k in ("leverage", "blind_spot", "projection_share",
                                             "level_excursion", "level_power",
                                             "conformal_quantile")}
    out.update(n_modes=int(model.modes_.shape[1]), n_sensors=int(model.modes_.shape[0]),
               source=cal.source, cv_modes=cal.cv_modes if cal.cv_modes is not None else -1,
               noise_std_max=det.get("noise_std_max", math.nan))
    if cal.gains is not None:
        out.update(gain_lev=cal.gains[0], gain_blind=cal.gains[1])
    join = lambda xs: ";".join(f"{float(x):.6g}" for x in xs)  # noqa: E731
    if cal.fold_errors is not None:
        out.update(fold_errors=join(cal.fold_errors), fold_estimates=join(cal.fold_estimates),
                   fold_factors=join(cal.fold_factors),
                   fold_excursions=join(cal.fold_excursions))
        out.update(fold_lev2=join(t.leverage2 for t in cal.fold_terms),
                   fold_blind2=join(t.blind2 for t in cal.fold_terms),
                   fold_rho=join((t.rho or 0.0) for t in cal.fold_terms))
    return out


SCALE_GRID = np.logspace(-4, 4, 321)
"""``--features``: band half-widths ``k`` (in units of a prediction's difficulty at an
estimate whose ``e/sqrt(1 + e²)`` is 1) at which each fold's and each target's coverage and
interval score are stored, so that any estimate rule's band can be scored offline."""
COVERAGE_GRID = np.concatenate([np.linspace(0.0, 0.9, 91)[:-1], np.linspace(0.9, 1.0, 101)])
"""Realized coverages at which the best constant-width band's interval score is stored."""


def _grid_features(model, p, truth) -> dict:
    """Each fold's and the target's residuals against the band's difficulty shape: the
    fraction of samples inside ``k ×`` that shape (:data:`SCALE_GRID`; the folds' give the
    pooled conformal quantile of any rule, the target's its coverage), the target's
    interval score there over the truth's RMS, and the best constant-width band's interval
    score at each :data:`COVERAGE_GRID` coverage. A rule's band at estimate ``e`` is
    ``k = q e/sqrt(1 + e²)`` with ``q`` the pooled quantile of the folds' scores
    ``r_j sqrt(1 + e_j²)/e_j`` (:func:`podbench.sysid.methods.bands._difficulty`)."""
    from podbench.sysid.methods import bands

    cal = model.band_calibration_
    if cal.source != "cross-validation" or not cal.fold_sizes:
        return {}
    join = lambda xs: ";".join(f"{float(x):.4g}" for x in xs)  # noqa: E731
    c = np.asarray(cal.fold_estimates, float)
    c = c / np.sqrt(1.0 + c ** 2)
    folds = np.split(cal.scores, np.cumsum(cal.fold_sizes)[:-1])
    cdfs = [np.searchsorted(np.sort(sc * cj), SCALE_GRID, side="right") / sc.size
            for sc, cj in zip(folds, c, strict=True)]
    mean = np.asarray(p.mean, float)
    n = min(mean.shape[1], truth.shape[1])
    R = np.abs(truth[:, :n] - mean[:, :n])
    u = math.sqrt(2.0) * bands._difficulty(mean, cal, 1.0)[:, :n]
    r = (R / u).ravel()
    u = u.ravel()
    rms = float(np.sqrt(np.mean(truth[:, :n] ** 2))) or 1.0
    alpha = 1.0 - p.coverage
    cov = np.searchsorted(np.sort(r), SCALE_GRID, side="right") / r.size
    isc = [float(np.mean(u * (2 * k + (2 / alpha) * np.maximum(r - k, 0)))) / rms
           for k in SCALE_GRID]
    h = np.quantile(R.ravel(), COVERAGE_GRID)
    const = [float(np.mean(2 * hh + (2 / alpha) * np.maximum(R.ravel() - hh, 0))) / rms
             for hh in h]
    return {"fold_sizes": join(cal.fold_sizes), "fold_cdf": "|".join(join(f) for f in cdfs),
            "target_cdf": join(cov), "target_is": join(isc), "constant_is": join(const)}


def _pair_sets(n: int):
    """Every pair ``(i, l)``, ``i < l``, of ``n`` records (a leave-two-out refit each)."""
    return [(i, l) for i in range(n) for l in range(i + 1, n)]


def _jack2(preds, centre) -> float:
    """``J² = (N − 1)/N · Σ_j ‖ŷ_(j) − centre‖²`` over the ``N`` fold predictions ``preds``
    (the jackknife variance of a prediction, Efron's; unnormalized)."""
    n = len(preds)
    return (n - 1) / n * float(sum(np.sum((P - centre) ** 2) for P in preds))


@dataclass
class Jackknife:
    """The band's fold models of one fitted model (leave one record out, in the folds'
    modes, at the full fit's frozen choices: ``bands._refit`` as ``bands._residuals``
    would) and each fold's own jackknife on the record it leaves out (leave two out, in
    the first ``N − 2`` modes where the model has more: ``bands.folds_per_mode`` one step
    further), for ``--features`` (``jack``, ``fold_jack``)."""

    folds: list
    fold_jack: np.ndarray
    fold_jack_full: np.ndarray
    refit_seconds: float


def jackknife(model) -> Jackknife | None:
    """:class:`Jackknife` of a fitted, band-calibrated ``model``; None where its band is
    not cross-validated (or folds are grouped, ``bands.MAX_FOLDS``) or a fold refit fails.
    ``fold_jack[j]²`` is fold ``j``'s ``J²`` on record ``j`` over ``‖ŷ_(j)‖²`` (its own
    prediction of that record); NaN where ``N − 2`` records are too few to refit."""
    import time

    from podbench.sysid.methods import bands

    cal = model.band_calibration_
    if cal.source != "cross-validation" or bands.MAX_FOLDS is not None:
        return None
    t0 = time.process_time()
    recs = list(model.training_records_)
    U = np.asarray(model.modes_, float)
    N, k = len(recs), int(U.shape[1])
    frozen = bands._frozen(model)
    k1 = cal.cv_modes
    U1 = U if k1 is None else U[:, :k1]
    try:
        folds = [bands._refit(model, recs[:j] + recs[j + 1:], n_modes=k1, basis=U1,
                              frozen=frozen) for j in range(N)]
    except Exception:  # noqa: BLE001 — a fold the method refuses: no jackknife
        return None
    own = [np.asarray(f.predict(recs[j]), float) for j, f in enumerate(folds)]
    fj, fjf = np.full(N, np.nan), np.full(N, np.nan)
    lo = getattr(model, "n_records", (1, None))[0]
    if N - 2 >= max(lo, 1):
        k2 = N - 2 if bands.folds_per_mode(model) and k > N - 2 else None
        U2 = U if k2 is None else U[:, :k2]
        pred2: dict = {}  # (j, i): record j predicted without j and i
        try:
            for i, l in _pair_sets(N):
                sub = bands._refit(model, [recs[m] for m in range(N) if m not in (i, l)],
                                   n_modes=k2, basis=U2, frozen=frozen)
                pred2[(i, l)] = np.asarray(sub.predict(recs[i]), float)
                pred2[(l, i)] = np.asarray(sub.predict(recs[l]), float)
        except Exception:  # noqa: BLE001 — a leave-two-out refit refused: no fold jackknife
            pred2 = {}
        if pred2:
            for j in range(N):
                P = [pred2[(j, i)] for i in range(N) if i != j]
                y2 = max(float(np.sum(own[j] ** 2)), 1e-300)
                fj[j] = math.sqrt(_jack2(P, np.mean(P, axis=0)) / y2)
                fjf[j] = math.sqrt(_jack2(P, own[j]) / y2)
    return Jackknife(folds, fj, fjf, time.process_time() - t0)


def _jack_features(jk: Jackknife | None, rec, mean) -> dict:
    """``jack``: the target's jackknife spread over the fold models, ``J`` with
    ``J² = (N − 1)/N · Σ_j ‖ŷ_(j) − ȳ_(·)‖²/‖ŷ‖²`` (``ŷ`` the full model's prediction);
    ``jack_full`` the same about ``ŷ`` instead of the folds' mean ``ȳ_(·)``; the folds'
    own (leave two out) and the seconds of CPU of the fold refits and of the fold
    predictions of this target."""
    import time

    if jk is None:
        return {"jack": math.nan, "jack_full": math.nan}
    t0 = time.process_time()
    P = [np.asarray(f.predict(rec), float) for f in jk.folds]
    n = min(min(p.shape[1] for p in P), mean.shape[1])
    P = [p[:, :n] for p in P]
    y2 = max(float(np.sum(mean[:, :n] ** 2)), 1e-300)
    join = lambda xs: ";".join(f"{float(x):.6g}" for x in xs)  # noqa: E731
    return {"jack": math.sqrt(_jack2(P, np.mean(P, axis=0)) / y2),
            "jack_full": math.sqrt(_jack2(P, mean[:, :n]) / y2),
            "fold_jack": join(jk.fold_jack), "fold_jack_full": join(jk.fold_jack_full),
            "jack_refit_s": jk.refit_seconds, "jack_predict_s": time.process_time() - t0}


def run_design(d: Design, level: float, sims=None, coverage: float = 0.9):
    """One row per target: realized error, estimate, coverage, interval scores."""
    from podbench.harness.bands import band_stats

    train, targets = sims if sims is not None else simulate_design(d)
    recs = [noisy_record(r, level, d, f"train{j}") for j, r in enumerate(train)]
    model = make_method(d)
    rows = []
    try:
        model.fit(recs)
    except Exception as exc:  # a design the method refuses is a row saying so
        return [dict(cls=d.cls, method=d.method, seed=d.seed, noise=level, target=j,
                     status=f"fit: {type(exc).__name__}: {exc}"[:120])
                for j in range(len(targets))]
    jk = False  # --features: the fold models, built after the band's calibration
    for j, t in enumerate(targets):
        rec = noisy_record(t, level, d, f"target{j}")
        truth = np.asarray(t.W, float)
        row = dict(cls=d.cls, method=d.method, seed=d.seed, noise=level, target=j,
                   n_train=len(recs), status="ok")
        try:
            p = model.predict(rec, coverage=coverage)
        except Exception as exc:
            row["status"] = f"band: {type(exc).__name__}: {exc}"[:120]
            rows.append(row)
            continue
        mean = np.asarray(p.mean, float)
        n = min(mean.shape[1], truth.shape[1])
        row["total_error"] = float(np.linalg.norm(mean[:, :n] - truth[:, :n])
                                   / np.linalg.norm(truth[:, :n]))
        est = p.error_estimate
        row["error_estimate"] = float(est) if est is not None else math.nan
        row["coverage"] = p.covers(truth)
        st = band_stats(p, truth)
        row["interval_score"] = st["interval_score"]
        row["constant_interval_score"] = st["constant_interval_score"]
        row["relative_half_width"] = st["relative_half_width"]
        row["note"] = getattr(p, "note", "") or ""
        if FEATURES:
            row.update(_features(model, p))
            row.update(_grid_features(model, p, truth))
            if jk is False:
                jk = jackknife(model)
            row.update(_jack_features(jk, rec, mean))
        rows.append(row)
    return rows


def evaluate(set_name: str, *, classes=tuple(CLASSES), methods=METHODS, levels=NOISE,
             per_cell: int = MODELS_PER_CELL, progress=False):
    import pandas as pd

    rows = []
    for d in designs(set_name, classes, methods, per_cell):
        sims = simulate_design(d)
        for level in levels:
            rows += run_design(d, level, sims)
        if progress:
            print(f"  {d.cls} {d.method} seed {d.seed}: done", file=sys.stderr, flush=True)
    return pd.DataFrame(rows)


def _spearman(x, y) -> float:
    from scipy.stats import spearmanr

    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3:
        return math.nan
    return float(spearmanr(x[ok], y[ok]).statistic)


def scores(df) -> dict:
    """The acceptance scores of a table of :func:`evaluate` rows."""
    ok = df[df["status"] == "ok"]
    est = ok["error_estimate"].to_numpy(float)
    tot = ok["total_error"].to_numpy(float)
    ratio = np.where(np.isfinite(est) & (tot > 0), est / np.where(tot > 0, tot, 1), np.nan)
    within = np.isfinite(ratio) & (ratio >= 0.5) & (ratio <= 2.0)
    per_model = []
    for _, g in ok.groupby(["cls", "method", "seed", "noise"]):
        if len(g) >= 3:
            per_model.append(_spearman(g["error_estimate"].to_numpy(float),
                                       g["total_error"].to_numpy(float)))
    cells = ok.groupby(["method", "cls", "noise"])["coverage"].mean()
    isc, csc = ok["interval_score"].to_numpy(float), ok["constant_interval_score"].to_numpy(float)
    okc = np.isfinite(isc) & np.isfinite(csc)
    return {
        "predictions": int(len(ok)), "failed": int(len(df) - len(ok)),
        "coverage_cells_in_0.85_0.95": float(np.mean((cells >= 0.85) & (cells <= 0.95))),
        "coverage_cell_min": float(cells.min()), "coverage_cell_max": float(cells.max()),
        "median_coverage": float(np.median(ok["coverage"])),
        "spearman": _spearman(est, tot),
        "spearman_within_model_median": float(np.nanmedian(per_model)) if per_model else math.nan,
        "within_factor_2": float(np.mean(within)),
        "no_estimate": float(np.mean(~np.isfinite(est))),
        "interval_score_ratio": float(isc[okc].sum() / csc[okc].sum()) if okc.any()
        else math.nan,
        "median_log2_ratio": float(np.nanmedian(np.log2(ratio))),
    }


def report(df) -> str:
    s = scores(df)
    lines = ["| score | value | target |", "|---|---|---|"]
    targets = {"coverage_cells_in_0.85_0.95": "1", "spearman": "≥ 0.8",
               "spearman_within_model_median": "≥ 0.6", "within_factor_2": "≥ 0.8",
               "interval_score_ratio": "≤ 0.85"}
    for k, v in s.items():
        lines.append(f"| {k} | {v:.3g} | {targets.get(k, '')} |")
    ok = df[df["status"] == "ok"]
    lines += ["", "| method | class | noise | n | coverage | within ×2 | median est/real |",
              "|---|---|---|---|---|---|---|"]
    for (m, c, lv), g in ok.groupby(["method", "cls", "noise"]):
        r = g["error_estimate"] / g["total_error"]
        w2 = float(np.mean((r >= 0.5) & (r <= 2)))
        lines.append(f"| {m} | {c} | {100 * lv:g} % | {len(g)} | {g['coverage'].mean():.3f} | "
                     f"{w2:.2f} | {float(np.nanmedian(r)):.2g} |")
    return "\n".join(lines)


def _loo_jack(model, rec) -> float:
    """The target's ``J`` as a band would compute it: the ``N`` leave-one-record-out fold
    models refitted (``bands._refit``, in the folds' modes) and each predicting ``rec``."""
    from podbench.sysid.methods import bands

    cal = model.band_calibration_
    recs = list(model.training_records_)
    U = np.asarray(model.modes_, float)
    U1 = U if cal.cv_modes is None else U[:, :cal.cv_modes]
    frozen = bands._frozen(model)
    P = [np.asarray(bands._refit(model, recs[:j] + recs[j + 1:], n_modes=cal.cv_modes,
                                 basis=U1, frozen=frozen).predict(rec), float)
         for j in range(len(recs))]
    return math.sqrt(_jack2(P, np.mean(P, axis=0)))


def _best_cpu(fn, repeat: int) -> float:
    import time

    ts = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        ts.append(time.process_time() - t0)
    return min(ts)


def _time_design(d: Design, repeat: int) -> dict:
    """:func:`jack_cost`'s timings of one design (clean records, its first target)."""
    train, targets = simulate_design(d)
    recs = [noisy_record(r, 0.0, d, f"train{j}") for j, r in enumerate(train)]
    rec = noisy_record(targets[0], 0.0, d, "target0")

    def plain(band=False):
        m = make_method(d).fit(recs)
        return m, (m.predict(rec, coverage=0.9) if band else m.predict(rec))

    model, _ = plain(True)
    _loo_jack(model, rec)  # warm-up
    best = {"plain": _best_cpu(plain, repeat),
            "band": _best_cpu(lambda: plain(True), repeat),
            "jack": _best_cpu(lambda: _loo_jack(model, rec), repeat)}
    return dict(cls=d.cls, method=d.method, seed=d.seed, n_train=len(recs), **best,
                band_over_plain=best["band"] / best["plain"],
                band_jack_over_plain=(best["band"] + best["jack"]) / best["plain"])


def jack_cost(set_name: str, repeat: int = 3) -> list[dict]:
    """CPU seconds (best of ``repeat``, one process, clean records, the first design of
    each class × method) of the plain fit + predict of one target, of the fit + band
    (``predict(target, coverage=0.9)``, the calibration included) and of the target's
    ``J`` on top of it (:func:`_loo_jack`: the band's folds are not kept as models, so
    ``J`` refits them)."""
    out = []
    for d in designs(set_name, per_cell=1):
        try:
            out.append(_time_design(d, repeat))
        except Exception as exc:  # a design the method refuses: no timing
            print(f"  {d.cls} {d.method} {d.seed}: {exc}", file=sys.stderr)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=tuple(SETS), default="dev")
    ap.add_argument("--classes", nargs="*", default=list(CLASSES))
    ap.add_argument("--methods", nargs="*", default=list(METHODS))
    ap.add_argument("--per-cell", type=int, default=MODELS_PER_CELL)
    ap.add_argument("--rows", default=None, help="write every prediction's row to this CSV")
    ap.add_argument("--features", action="store_true",
                    help="the rows also carry the estimate's terms and fold data")
    ap.add_argument("--max-folds", type=int, default=None,
                    help="the variant bands.MAX_FOLDS (default: leave-one-record-out)")
    ap.add_argument("--jack-cost", action="store_true",
                    help="only time the target's jackknife J against the plain fit + predict "
                         "and the band (jack_cost)")
    args = ap.parse_args(argv)
    if args.jack_cost:
        import pandas as pd

        print(pd.DataFrame(jack_cost(args.set)).to_string(float_format="%.4g"))
        return 0
    global FEATURES
    FEATURES = args.features
    if args.max_folds is not None:
        from podbench.sysid.methods import bands

        bands.MAX_FOLDS = args.max_folds
    df = evaluate(args.set, classes=tuple(args.classes), methods=tuple(args.methods),
                  per_cell=args.per_cell, progress=True)
    if args.rows:
        df.to_csv(args.rows, index=False)
    print(report(df))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
