"""Calibration section of a study: how well the bands and error estimates of
:mod:`podbench.sysid.methods.bands` held, from the study's rows (``error_estimate``,
``coverage``) and the sharpness of each band (:func:`podbench.harness.bands.band_stats`).

Written by :func:`podbench.harness.report.write_study` as ``CALIBRATION.md`` and
``calibration.csv`` (deterministic: no timings) whenever the study has band columns; the
report page draws the predicted-vs-realized scatter and the coverage table.

Scores:

* ``coverage``: fraction of the truth's samples inside the 90 % band (target 0.85–0.95);
* Spearman rank correlation between ``error_estimate`` and ``total_error`` over the rows,
  and the share of rows whose estimate is within a factor of 2 of the realized error;
* interval score (Gneiting & Raftery 2007) of each band against the truth, relative to that
  of the best constant-width band with the same realized coverage (an oracle: its width is
  a quantile of the true residual); reported as the ratio of their sums (< 1: the band is
  sharper than any constant width).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["structure_class", "calibration_rows", "calibration_summary", "calibration_markdown",
           "findings_calibration", "target_scores"]

_CLASSES = {"lti_beam": "LTI", "ltv_beam": "LTV", "nl_beam": "NL",
            "satellite_truss": "truss (LTV)"}


def structure_class(name: str) -> str:
    return _CLASSES.get(name, name)


_BAND_SCALES = ("interval_score", "constant_interval_score", "relative_half_width")
"""Columns that scale with the band's width, whose sixth digit moves with the CPU's
round-off (docs/noise.md): written to three digits."""


def calibration_rows(df: pd.DataFrame, stats: list, scenarios: dict) -> pd.DataFrame:
    """One row per prediction with a band: the table's keys, class, training noise, errors,
    coverage and sharpness."""
    if "coverage" not in df or not np.isfinite(df["coverage"].astype(float)).any():
        return pd.DataFrame()
    key = ["scenario", "structure", "method", "target"]
    out = df[[*key, "total_error", "error_estimate", "coverage"]].copy()
    if stats:
        st = pd.DataFrame(stats)
        st = st[[*key, "source", "interval_score", "constant_interval_score",
                 "relative_half_width"]]
        out = out.merge(st, on=key, how="left")
    else:
        for c in ("interval_score", "constant_interval_score", "relative_half_width"):
            out[c] = float("nan")
        out["source"] = ""
    for c in _BAND_SCALES:  # the band's scale, stated to three digits (as error_estimate)
        out[c] = out[c].map(lambda v: float(f"{v:.3g}") if np.isfinite(v) else v)
    # the realized error as the table writes it (six digits): the scores are then computed
    # from calibration.csv's own values, and errors equal to round-off (methods whose
    # predictions agree to the last bits) tie exactly instead of ranking in an order the
    # CPU's round-off decides
    out["total_error"] = out["total_error"].map(
        lambda v: float(f"{v:.6g}") if np.isfinite(v) else v)
    out = out[np.isfinite(out["coverage"].astype(float))]
    out.insert(2, "class", [structure_class(s) for s in out["structure"]])
    out.insert(3, "training_noise", [
        float(getattr(scenarios.get(s), "training_noise", 0.0) or 0.0) for s in out["scenario"]])
    return out.reset_index(drop=True)


def _spearman(x, y) -> float:
    from scipy.stats import spearmanr

    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
        return float("nan")  # undefined: fewer than three pairs, or one side constant
    return float(spearmanr(x[ok], y[ok]).statistic)


def calibration_summary(rows: pd.DataFrame, *, split: bool = True) -> dict:
    """The study-wide scores over ``rows`` (:func:`calibration_rows`); with ``split`` also
    those of the cross-validated rows alone (``cv_…``)."""
    if rows.empty:
        return {}
    extra = {}
    if split and "source" in rows:
        cv = rows[rows["source"] == "cross-validation"]
        if len(cv):
            extra = {f"cv_{k}": v for k, v in calibration_summary(cv, split=False).items()}
    est = rows["error_estimate"].to_numpy(float)
    tot = rows["total_error"].to_numpy(float)
    ok = np.isfinite(est) & np.isfinite(tot) & (est > 0) & (tot > 0)
    ratio = est[ok] / tot[ok]
    isc = rows["interval_score"].to_numpy(float)
    csc = rows["constant_interval_score"].to_numpy(float)
    okc = np.isfinite(isc) & np.isfinite(csc)
    return {
        "predictions": int(len(rows)),
        "median_coverage": float(np.median(rows["coverage"])),
        "spearman": _spearman(est, tot),
        "within_factor_2": float(np.mean((ratio >= 0.5) & (ratio <= 2))) if ok.any()
        else float("nan"),
        "interval_score_ratio": float(isc[okc].sum() / csc[okc].sum()) if okc.any()
        and csc[okc].sum() > 0 else float("nan"),
        **extra,
    }


MODEL_KEY = ("scenario", "structure", "method")
"""The columns that name one fitted model: a method fitted on one scenario's training records
of one structure."""

FACTOR = 2.0
"""An estimate is counted right when it lies within this factor of the realized error."""


def _within(est: np.ndarray, tot: np.ndarray) -> np.ndarray:
    """Per prediction: the estimate lies within :data:`FACTOR` of the realized error; a
    prediction with no estimate (NaN: none could be made) is a miss."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.abs(np.log(est / tot))
    return np.isfinite(r) & (r <= math.log(FACTOR))


def _best_constant_hits(est: np.ndarray, tot: np.ndarray) -> int:
    """How many of one model's estimates one constant factor, chosen knowing the realized
    errors, can bring within :data:`FACTOR` (the most log ratios a window of width
    2 ln FACTOR holds)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.log(est / tot)
    r = np.sort(r[np.isfinite(r)])
    if not len(r):
        return 0
    ends = np.searchsorted(r, r + 2 * math.log(FACTOR), side="right")
    return int(np.max(ends - np.arange(len(r))))


def target_scores(rows: pd.DataFrame) -> dict:
    """The band's targets measured on ``rows`` (:func:`calibration_rows`), with the bound
    that an oracle knowing the truth puts on the one a per-model rescaling cannot reach.

    ``cells_in``/``cells``: cells (class × training noise × method) whose mean coverage lies
    in 0.85–0.95, ``coverage_lo``/``coverage_hi`` the cells' extremes; ``spearman``;
    ``within_model_spearman``: the median over fitted models (:data:`MODEL_KEY`) with at
    least three estimates of their Spearman; ``within_factor_2``: the share of *all*
    predictions whose estimate is within ×2, one without an estimate a miss
    (``no_estimate`` of them); ``oracle_model_constant``: over the ``oracle_predictions``
    of the ``oracle_models`` fitted models asked for at least three targets, the same share
    after each model's estimates are rescaled by the one constant that, knowing the truth,
    brings the most of them within ×2 (the misses left are then not a model's level),
    beside ``oracle_within_factor_2``, the share within ×2 of those predictions as made;
    ``interval_score_ratio`` as in :func:`calibration_summary`.
    """
    if rows.empty:
        return {}
    est = rows["error_estimate"].to_numpy(float)
    tot = rows["total_error"].to_numpy(float)
    cells = rows.groupby(["class", "training_noise", "method"], sort=True)["coverage"].mean()
    models = [(g["error_estimate"].to_numpy(float), g["total_error"].to_numpy(float))
              for _, g in rows.groupby(list(MODEL_KEY), sort=True)]
    rhos = [_spearman(e, t) for e, t in models if np.isfinite(e).sum() >= 3]
    rhos = [r for r in rhos if math.isfinite(r)]
    # a model asked for fewer than three targets is brought within x2 by a constant
    # whatever its estimate: the oracle is read on the models with three or more
    many = [(e, t) for e, t in models if len(t) >= 3]
    n_many = sum(len(t) for _, t in many)
    s = calibration_summary(rows, split=False)
    return {
        "predictions": int(len(rows)),
        "cells": int(len(cells)),
        "cells_in": int(((cells >= 0.85) & (cells <= 0.95)).sum()),
        "coverage_lo": float(cells.min()),
        "coverage_hi": float(cells.max()),
        "spearman": s["spearman"],
        "within_model_spearman": float(np.median(rhos)) if rhos else math.nan,
        "models_ranked": len(rhos),
        "models": len(models),
        "within_factor_2": float(np.mean(_within(est, tot))),
        "no_estimate": int((~np.isfinite(est)).sum()),
        "oracle_models": len(many),
        "oracle_predictions": n_many,
        "oracle_within_factor_2": (sum(int(_within(e, t).sum()) for e, t in many) / n_many
                                   if n_many else math.nan),
        "oracle_model_constant": (sum(_best_constant_hits(e, t) for e, t in many) / n_many
                                  if n_many else math.nan),
        "interval_score_ratio": s["interval_score_ratio"],
    }


def _targets_markdown(rows: pd.DataFrame) -> list:
    """The targets table of ``CALIBRATION.md``: all predictions and the cross-validated ones."""
    parts = [("all predictions", target_scores(rows))]
    if "source" in rows:
        cv = rows[rows["source"] == "cross-validation"]
        if len(cv):
            parts.append(("cross-validated", target_scores(cv)))
    head = "| score | target | " + " | ".join(n for n, _ in parts) + " |"
    lines = [head, "|" + "---|" * (2 + len(parts))]

    def row(label, target, cell):
        lines.append(f"| {label} | {target} | " + " | ".join(cell(t) for _, t in parts) + " |")

    row("cells (class × noise × method) with mean coverage in 0.85–0.95", "all",
        lambda t: f"{t['cells_in']} of {t['cells']} ({_fmt(t['coverage_lo'])}–"
                  f"{_fmt(t['coverage_hi'])})")
    row("Spearman(error_estimate, total_error)", "≥ 0.8", lambda t: _fmt(t["spearman"]))
    row("within-model Spearman (median over fitted models with ≥ 3 estimates)", "≥ 0.6",
        lambda t: f"{_fmt(t['within_model_spearman'])} ({t['models_ranked']} models)"
        if t["models_ranked"] else "no model with ≥ 3 estimates")
    row("estimate within ×2 (no estimate: a miss)", "≥ 0.8",
        lambda t: f"{_fmt(t['within_factor_2'])} ({t['no_estimate']} without)")
    row("… on the fitted models asked for ≥ 3 targets: as estimated → oracle (one "
        "constant per model, chosen knowing the truth)", "(bound)",
        lambda t: f"{_fmt(t['oracle_within_factor_2'])} → {_fmt(t['oracle_model_constant'])}"
                  f" ({t['oracle_predictions']} predictions, {t['oracle_models']} models)"
        if t["oracle_models"] else "no model asked for ≥ 3 targets")
    row("interval score / best constant width's", "≤ 0.85",
        lambda t: _fmt(t["interval_score_ratio"]))
    return lines


def _fmt(v) -> str:
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{v:.3g}"


def _md_table(df: pd.DataFrame) -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in df.itertuples(index=False):
        lines.append("| " + " | ".join(_fmt(v) for v in r) + " |")
    return "\n".join(lines)


def grouped(rows: pd.DataFrame) -> pd.DataFrame:
    """Coverage, estimate and sharpness by structure class, training noise and method."""
    def agg(g):
        est, tot = g["error_estimate"].to_numpy(float), g["total_error"].to_numpy(float)
        ok = (est > 0) & (tot > 0) & np.isfinite(est / np.where(tot > 0, tot, 1))
        r = est[ok] / tot[ok]
        isc, csc = g["interval_score"].to_numpy(float), g["constant_interval_score"].to_numpy(float)
        okc = np.isfinite(isc) & np.isfinite(csc)
        return pd.Series({
            "n": len(g),
            "coverage_mean": g["coverage"].mean(),
            "coverage_min": g["coverage"].min(),
            "in_0.85–0.95": float(np.mean((g["coverage"] >= 0.85) & (g["coverage"] <= 0.95))),
            "total_error_median": float(np.median(tot)),
            "estimate_median": float(np.median(est)),
            "within_factor_2": float(np.mean((r >= 0.5) & (r <= 2))) if len(r) else math.nan,
            "half_width_rel": g["relative_half_width"].median(),
            "IS/IS_const": float(isc[okc].sum() / csc[okc].sum()) if okc.any()
            and csc[okc].sum() > 0 else math.nan,
        })

    keys = ["class", "training_noise", "method"]
    out = rows.groupby(keys, sort=True).apply(agg, include_groups=False).reset_index()
    out["n"] = out["n"].astype(int)
    out["training_noise"] = [f"{100 * v:g} %" for v in out["training_noise"]]
    return out


def calibration_markdown(rows: pd.DataFrame, study: str) -> str:
    """``CALIBRATION.md``: the study-wide scores and the table by class, noise and method."""
    if rows.empty:
        return ""
    s = calibration_summary(rows)
    lines = [
        f"# Calibration of the prediction bands: {study}",
        "",
        "Every prediction's 90 % band and error estimate (`predict(target, coverage=0.9)`, "
        "podbench.sysid.methods.bands), scored against the noise-free truth. Coverage: fraction of "
        "the truth's samples inside the band (nominal 0.9; target 0.85–0.95). Estimate: the "
        "predicted total error ‖Ŵ − W‖/‖W‖ against the realized one. IS/IS_const: summed "
        "interval score (Gneiting & Raftery 2007) of the bands over that of the best "
        "constant-width band with the same realized coverage per prediction (an oracle "
        "that knows the truth; < 1 = sharper).",
        "",
        f"- predictions: {s['predictions']}",
        f"- median coverage: {_fmt(s['median_coverage'])}",
        f"- Spearman(error_estimate, total_error): {_fmt(s['spearman'])} (target ≥ 0.8)",
        f"- estimate within a factor of 2: {_fmt(s['within_factor_2'])} (target ≥ 0.8)",
        f"- IS/IS_const over all predictions: {_fmt(s['interval_score_ratio'])} "
        "(target ≤ 0.85)",
        "",
        *([f"Cross-validated bands alone (MDS, ML, peers with ≥ 2 records; "
           f"{s['cv_predictions']} predictions): median coverage "
           f"{_fmt(s['cv_median_coverage'])}, Spearman {_fmt(s['cv_spearman'])}, within a "
           f"factor of 2 {_fmt(s['cv_within_factor_2'])}, IS/IS_const "
           f"{_fmt(s['cv_interval_score_ratio'])}.", ""] if "cv_predictions" in s else []),
        "Cross-validated estimates are per target (docs/bands.md): the target's leverage "
        "(how large a combination of training responses its prediction is made of), its "
        "blind spot (the part of its excitation outside the basis that the training "
        "records do not match) and its projection share (initial displacements), with two "
        "gains fitted to the leave-one-record-out folds' realized errors, never to the "
        "truth; the band is normalized conformal, its width following the estimate. Every "
        "refit runs at the full fit's regularization; a prediction larger than every "
        "training record gets its estimate scaled by that ratio (on measured input/output "
        "records: the input's RMS outside the training inputs' range, above or below it, "
        "the ratio raised to a power the folds may increase). MDS and ML fitted with as "
        "many records as modes cross-validate in N − 1 modes; each fold is charged its "
        "error inside them plus the basis's projection error. Methods fitted on one design "
        "(POVR, SL: one record; MR: exactly three) have no split (`source = in-sample`): "
        "SL's and POVR's band and estimate rest on the diagonal assumption's split "
        "(`bands.diagonal_split`) and the noise; MR has no model-form term and gives no "
        "estimate (both columns empty). A target outside the training design that its "
        "excitation does not reveal (a load amplitude or shape the design never varied, on "
        "a nonlinear structure) is not exchangeable with the folds: no coverage is "
        "promised there.",
        "",
        "## The targets",
        "",
        "Each score against its target; the oracle row bounds what rescaling each fitted "
        "model's estimates by one constant could reach (it knows the truth, so no estimate "
        "made before it can exceed it by rescaling: the misses it leaves are not a model's "
        "level but its ranking of targets). Measured on designs, targets and seeds of their "
        "own: `python benchmarks/bands_heldout.py --set test` (docs/bands.md).",
        "",
        *_targets_markdown(rows),
        "",
        "## By structure class, training noise and method",
        "",
        _md_table(grouped(rows)),
        "",
    ]
    return "\n".join(lines)


def findings_calibration(rows: pd.DataFrame) -> str:
    """The calibration section appended to ``FINDINGS.md`` (empty without bands)."""
    if rows.empty:
        return ""
    s = calibration_summary(rows)
    by = rows.groupby(["class", "method"], sort=True)["coverage"].mean()
    cov = "; ".join(f"{c} {m} {v:.2f}" for (c, m), v in by.items())
    return (
        "\n## Calibration of the prediction bands\n\n"
        f"Every prediction's 90 % band and error estimate against the truth ({s['predictions']} "
        f"predictions; details in `CALIBRATION.md`): median coverage "
        f"{_fmt(s['median_coverage'])}, Spearman(estimate, realized total error) "
        f"{_fmt(s['spearman'])}, estimate within a factor of 2 for "
        f"{_fmt(s['within_factor_2'])} of them, summed interval score "
        f"{_fmt(s['interval_score_ratio'])} × that of the best constant-width band. Mean "
        f"coverage by structure class and method: {cov}.\n"
    )


def _estimate_scatter(a1, rows: pd.DataFrame, methods, colors: dict) -> None:
    """Predicted against realized total error, log axes, y = x and the factor-2 lines."""
    est = rows["error_estimate"].to_numpy(float)
    tot = rows["total_error"].to_numpy(float)
    ok = (est > 0) & (tot > 0) & np.isfinite(est) & np.isfinite(tot)
    for m in methods:
        sel = ok & (rows["method"] == m).to_numpy()
        a1.scatter(tot[sel], est[sel], s=18, alpha=0.75, color=colors[m], label=m)
    if ok.any():
        lo = float(min(est[ok].min(), tot[ok].min())) / 2
        hi = float(max(est[ok].max(), tot[ok].max())) * 2
        x = np.array([lo, hi])
        a1.plot(x, x, color="black", lw=1)
        a1.plot(x, 2 * x, color="grey", lw=0.8, ls="--")
        a1.plot(x, x / 2, color="grey", lw=0.8, ls="--")
        a1.set_xlim(lo, hi)
        a1.set_ylim(lo, hi)
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.set_xlabel("realized total error ‖Ŵ − W‖/‖W‖")
    a1.set_ylabel("error_estimate (before the truth)")
    a1.grid(True, which="both", alpha=0.25)
    a1.legend(fontsize=8, ncol=2)
    s = calibration_summary(rows)
    a1.set_title(f"Spearman {s['spearman']:.2f}, within ×2: {s['within_factor_2']:.0%}",
                 fontsize=10)


def _coverage_bars(a2, rows: pd.DataFrame, colors: dict) -> None:
    """The coverage of the 90 % bands by structure class and method (mean, min–max)."""
    g = rows.groupby(["class", "method"], sort=True)["coverage"]
    labels, means, mins, maxs, cols = [], [], [], [], []
    for (c, m), v in g:
        labels.append(f"{c} · {m}")
        means.append(v.mean())
        mins.append(v.min())
        maxs.append(v.max())
        cols.append(colors[m])
    y = np.arange(len(labels))
    a2.axvspan(0.85, 0.95, color="green", alpha=0.12, lw=0)
    a2.axvline(0.9, color="green", lw=1)
    a2.hlines(y, mins, maxs, colors=cols, lw=2, alpha=0.6)
    a2.scatter(means, y, color=cols, zorder=3, s=25)
    a2.set_yticks(y, labels, fontsize=7)
    a2.invert_yaxis()
    a2.set_xlim(0, 1.01)
    a2.set_xlabel("coverage of the truth by the 90 % band (mean, min–max over targets)")
    a2.grid(True, axis="x", alpha=0.25)


def calibration_figure(rows: pd.DataFrame, path, *, title: str = "") -> bytes:
    """Predicted vs realized total error (log axes, with y = x and the factor-2 lines) and
    the coverage of the 90 % bands by structure class and method; written to ``path`` (its
    suffix gives the format) and returned as PNG bytes for embedding."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5.2), gridspec_kw={"width_ratios": [1, 1.3]})
    try:
        methods = sorted(rows["method"].unique())
        cmap = plt.get_cmap("tab10")
        colors = {m: cmap(i % 10) for i, m in enumerate(methods)}
        _estimate_scatter(a1, rows, methods, colors)
        _coverage_bars(a2, rows, colors)
        if title:
            fig.suptitle(title, fontsize=11)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=90)
        return buf.getvalue()
    finally:
        plt.close(fig)


HEADS = {
    "class": "class", "training_noise": "training noise", "method": "method",
    "n": "predic&shy;tions", "coverage_mean": "coverage, mean", "coverage_min": "coverage, min",
    "in_0.85–0.95": "share with coverage in 0.85–0.95",
    "total_error_median": "realized total error, median",
    "estimate_median": "estimated error, median",
    "within_factor_2": "share of estimates within ×2",
    "half_width_rel": "band half-width / RMS of W, median",
    "IS/IS_const": "interval score / best constant width's",
}
"""The calibration table's column heads on the report page (HTML; they wrap, so the table
fits the page; the column's name is the tooltip)."""


def calibration_html(rows: pd.DataFrame, figure_uri: str | None) -> str:
    """The report page's calibration section (summary, figure, table by class/method)."""
    import html

    if rows.empty:
        return ""
    s = calibration_summary(rows)
    items = [("predictions", s["predictions"]), ("median coverage", s["median_coverage"]),
             ("Spearman(estimate, realized)", s["spearman"]),
             ("estimate within ×2", s["within_factor_2"]),
             ("IS / IS of best constant width", s["interval_score_ratio"])]
    if "cv_predictions" in s:
        items += [("cross-validated bands: predictions", s["cv_predictions"]),
                  ("… median coverage", s["cv_median_coverage"]),
                  ("… Spearman", s["cv_spearman"]), ("… within ×2", s["cv_within_factor_2"])]
    out = ["<p>Every prediction's 90 % band and error estimate "
           "(<code>predict(target, coverage=0.9)</code>), scored against the truth "
           "(<code>CALIBRATION.md</code>, <code>calibration.csv</code>).</p>", "<ul>"]
    out += [f"<li>{html.escape(k)}: <b>{html.escape(_fmt(v))}</b></li>" for k, v in items]
    out.append("</ul>")
    if figure_uri:
        out.append(f'<figure><img src="{figure_uri}" alt="Predicted vs realized total error '
                   'and coverage by structure class and method" style="max-width:100%">'
                   "</figure>")
    t = grouped(rows)
    for c in ("total_error_median", "estimate_median"):  # fractions of ‖W‖_F, shown in %
        t[c] = [f"{100 * v:.3g} %" if math.isfinite(v) else "–" for v in t[c]]
    out.append('<div class="scroll"><table><thead><tr>'
               + "".join(f'<th title="{html.escape(str(c))}">'
                         f"{HEADS.get(c, html.escape(str(c)))}</th>" for c in t.columns)
               + "</tr></thead><tbody>")
    for r in t.itertuples(index=False):
        out.append("<tr>" + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in r) + "</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)
