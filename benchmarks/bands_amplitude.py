"""An amplitude term measured between folds: does the error grow with the excitation's level
where the training records differ in level? Scored offline on the held-out rows.

The gains rule (:data:`podbench.sysid.methods.bands.ESTIMATE_RULE`) on records without a
measured input has no level factor (``GAINS_RESPONSE_LEVEL_POWER = 0``). A nonlinear
structure's error grows with the load's amplitude, which the folds can show only where the
training records differ in it. Each variant here reads a level per record, each fold's
excursion against the other folds' (:func:`~podbench.sysid.methods.bands.input_excursion`
for a load level, both ways from the others' effective level;
:func:`~podbench.sysid.methods.bands.extrapolation` for the prediction's RMS, above the
range), and picks β of the factor ``d = a^β`` from ``0, 1, 2, 3`` by the gains' own log loss
on the folds (:func:`~podbench.sysid.methods.bands._fit`) where at least two folds lie
outside the others' level (excursion above :data:`~podbench.sysid.methods.bands.LEVEL_SPREAD`);
elsewhere β = 0 (the default). β = 0 is a candidate: a linear structure's folds should
choose it. Levels:

* ``response``: the prediction's RMS (what the rows store; above the range only);
* ``peak``, ``impulse``, ``rms``: the load's peak ``|P|``, its impulse ``∫|F| dt`` and its
  RMS over the record (lbf, lbf·s, lbf·√s up to the record length), read from the
  design's noise-free pulses (ML designs only; an upper bound on what a measured load
  shows). The held-out targets' own load level is read the same way.

    python benchmarks/bands_heldout.py --set dev --features --rows dev.csv
    python benchmarks/bands_amplitude.py dev.csv --set dev
    python benchmarks/bands_amplitude.py dev.csv --set dev --note

``--note`` scores the per-target note instead (:func:`podbench.sysid.methods.bands.load_note`:
a target whose load lies beyond every training load by more than the folds measured): the
designs' records are rebuilt as the held-out run measured them (noise included), the note
computed for every target, and the rows' estimates compared between targets with and
without it (the note does not change an estimate; does it mark the low ones?).
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

LEVELS = ("none", "response", "peak", "impulse", "rms")
POWERS = (0.0, 1.0, 2.0, 3.0)
_MEAN = {"rectangular": 1.0, "half_sine": 2 / math.pi, "triangle": 0.5}
_SQUARE = {"rectangular": 1.0, "half_sine": 0.5, "triangle": 1 / 3}


def load_level(pulse, kind: str) -> tuple[float, float]:
    """``(level, energy)`` of a design's pulse (its hits included): the level ``kind`` and
    ``∫F² dt`` (the weight of the pooled fit's effective level)."""
    a = abs(pulse.amplitude)
    hits = 1.0 + sum(abs(h[1]) for h in pulse.hits)
    energy = a * a * pulse.duration * _SQUARE[pulse.shape] * \
        (1.0 + sum(h[1] ** 2 for h in pulse.hits))
    if kind == "peak":
        return a, energy
    if kind == "impulse":
        return a * pulse.duration * _MEAN[pulse.shape] * hits, energy
    return math.sqrt(energy), energy


def _folds(r0):
    from benchmarks.bands_rules import _floats
    from podbench.sysid.methods.band_target import TargetTerms

    errors = _floats(r0.fold_errors)
    terms = [TargetTerms(a, b, c if c > 0 else None) for a, b, c in
             zip(_floats(r0.fold_lev2), _floats(r0.fold_blind2), _floats(r0.fold_rho),
                 strict=True)]
    if "fold_excursions" in r0.index and isinstance(r0.fold_excursions, str):
        exc = _floats(r0.fold_excursions)
    else:  # rows of a run at β = 1: the factors are the excursions
        exc = _floats(r0.fold_factors) ** (1.0 / float(r0.level_power))
    return errors, terms, exc


def choose_power(errors, terms, excursions) -> float:
    """β from :data:`POWERS` by the gains' log loss on the folds, 0 unless two folds lie
    outside the others' level."""
    from podbench.sysid.methods import bands

    a = np.asarray(excursions, dtype=float)
    if np.count_nonzero(a > bands.LEVEL_SPREAD) < 2:
        return 0.0
    best = None
    for beta in POWERS:
        loss = bands._fit(errors, terms, a ** beta)[0]
        if best is None or loss < best[0] - 1e-12 * max(1.0, best[0]):
            best = (loss, beta)
    return float(best[1])


def model_estimates(rows, kind: str, set_name: str):
    """``(estimates, β)`` of one fitted model's rows under the level ``kind``."""
    from benchmarks import bands_heldout as H
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    r0 = rows.iloc[0]
    errors, terms, exc = _folds(r0)
    target_a = rows["level_excursion"].to_numpy(float)
    if kind in ("peak", "impulse", "rms"):
        if r0.method != "ML":
            kind = "none"
        else:
            d = H.forced_design(r0.cls, int(r0.seed), set_name)
            lv, en = zip(*(load_level(p, kind) for p in d.train), strict=True)
            lv, en = list(lv), list(en)
            exc = np.array([bands.input_excursion(lv[j], lv[:j] + lv[j + 1:],
                                                  en[:j] + en[j + 1:])
                            for j in range(len(lv))])
            target_a = np.array([bands.input_excursion(
                load_level(d.targets[int(t)], kind)[0], lv, en) for t in rows["target"]])
    beta = 0.0 if kind == "none" else choose_power(errors, terms, exc)
    gains = bands.fit_gains(errors, terms, np.asarray(exc, float) ** beta)
    est = []
    for (_, r), a in zip(rows.iterrows(), target_a, strict=True):
        rho = r.projection_share if np.isfinite(r.projection_share) else None
        est.append(bands.estimate(gains, TargetTerms(r.leverage ** 2, r.blind_spot ** 2,
                                                     rho), a ** beta))
    return np.array(est), beta


def notes(df, set_name: str):
    """The :func:`~podbench.sysid.methods.bands.load_note` of every row's target (the
    training and target records rebuilt as ``bands_heldout.run_design`` measures them)."""
    import pandas as pd

    from benchmarks import bands_heldout as H
    from podbench.sysid.methods import bands

    out = {}
    for d in H.designs(set_name):
        sel = df[df["seed"] == d.seed]
        if sel.empty:
            continue
        train, targets = H.simulate_design(d)
        for level in sorted(set(sel["noise"])):
            recs = [H.noisy_record(r, level, d, f"train{j}") for j, r in enumerate(train)]
            cal = bands.BandCalibration("cross-validation", np.zeros(0), 0.0,
                                        np.ones(bands.N_TIME_BINS), None, len(recs), 0)
            cal.load_levels = tuple(bands.load_levels(r) for r in recs)
            for i, r in sel[sel["noise"] == level].iterrows():
                t = H.noisy_record(targets[int(r.target)], level, d, f"target{int(r.target)}")
                out[i] = bands.load_note(t, cal)
    return pd.Series(out, dtype=object)


def note_report(df, set_name: str) -> None:
    """Estimate/realized of the targets with and without a note, per method × class."""
    df = df.assign(note_=notes(df, set_name))
    df["ratio"] = df["error_estimate"] / df["total_error"]
    df["noted"] = df["note_"].fillna("") != ""
    print("method class noted | targets | median estimate/realized | share below 1/2 | "
          "share within ×2 | mean coverage")
    for key, g in df.groupby(["method", "cls", "noted"]):
        r = g["ratio"]
        print(f"{key[0]} {key[1]} {key[2]} | {len(g)} | {r.median():.2f} | "
              f"{(r < 0.5).mean():.2f} | {((r >= 0.5) & (r <= 2)).mean():.2f} | "
              f"{g['coverage'].mean():.3f}")
    for noted, g in df.groupby("noted"):
        r = g["ratio"]
        print(f"all noted={noted} | {len(g)} | {r.median():.2f} | {(r < 0.5).mean():.2f} | "
              f"{((r >= 0.5) & (r <= 2)).mean():.2f} | {g['coverage'].mean():.3f}")


def main(argv=None) -> int:
    import pandas as pd

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", help="a CSV of bands_heldout.py --features")
    ap.add_argument("--set", required=True, help="the set the rows are of (dev, test)")
    ap.add_argument("--note", action="store_true",
                    help="score the per-target note (bands.load_note) instead")
    args = ap.parse_args(argv)
    df = pd.read_csv(args.rows)
    df = df[df["status"] == "ok"].copy()
    if args.note:
        note_report(df, args.set)
        return 0
    cols, fired = {}, {}
    for kind in LEVELS:
        ok = pd.Series(False, index=df.index)
        fired[kind] = []
        for key, rows in df.groupby(["cls", "method", "seed", "noise"], sort=False):
            est, beta = model_estimates(rows, kind, args.set)
            ratio = est / rows["total_error"].to_numpy(float)
            ok.loc[rows.index] = (ratio >= 0.5) & (ratio <= 2.0)
            if beta > 0:
                fired[kind].append(f"{key[0]} {key[1]} {key[2]} {100 * key[3]:g} %: β {beta:g}")
        col = ok.groupby([df["method"], df["cls"]]).mean()
        col[("all", "")] = float(ok.mean())
        cols[kind] = col
    table = pd.DataFrame(cols)
    print("within ×2 | " + " | ".join(table.columns))
    for name, row in table.iterrows():
        print(f"{name[0]} {name[1]} | " + " | ".join(f"{v:.3f}" for v in row))
    for kind, models in fired.items():
        if kind != "none":
            print(f"{kind}: β > 0 on {len(models)} models: " + "; ".join(models))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
