"""The error decomposition as a figure: one stacked bar per method and target of a scenario
(the columns of ``summary.csv``, :mod:`podbench.harness.metrics`).

Left panel: the total error ‖Ŵ − W‖_F / ‖W‖_F in percent, on a log axis (the methods of a
scenario span four decades). Right panel: what the error is made of, as each part's share
of the sum

    projection + diagonalization + linearization + residual

(or, where those three attributions are undefined, projection + the unattributed subspace
error). The parts are norms of different error vectors, so they do *not* add up to the
total: exactly, ``total² = projection² + subspace²`` (a POD prediction lies in span U), and
by the triangle inequality ``subspace ≤ diagonalization + linearization + residual``, so
the sum of the parts is at least the total. The ratio sum / total is printed at the end of
each bar (1.00: the parts are aligned and add up; larger: some parts cancel). The caption
(:data:`CAPTION`) says so on the page.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd

from podbench.report.figures import DPI, RC, percent

__all__ = ["CAPTION", "PARTS", "decomposition_figure", "decomposition_rows"]

PARTS = (
    ("projection_error", "projection", "#7f8c99", None),
    ("diagonalization_error", "diagonalization", "#E69F00", None),
    ("linearization_error", "linearization", "#CC79A7", None),
    ("residual_error", "residual", "#009E73", None),
    ("subspace_error", "subspace, not attributed", "#d9dee3", "///"),
)
"""(column, legend label, colour, hatch) of each stacked part, in stacking order."""

CAPTION = (
    "Left: total error ‖Ŵ − W‖<sub>F</sub> / ‖W‖<sub>F</sub> in percent (log scale). Right: "
    "each part's share of the sum projection + diagonalization + linearization + residual "
    "(definitions: <a href=\"#decomposition\">Error decomposition</a>). The parts are norms "
    "of different error vectors and do not add up to the total: exactly, total² = "
    "projection² + subspace² (every POD prediction lies in span U), and subspace ≤ "
    "diagonalization + linearization + residual (triangle inequality), so their sum is at "
    "least the total; the ratio sum / total is printed at each bar's end. Where the coupled "
    "twin is missing or worse than the method, the three attributions are undefined and the "
    "hatched part is the subspace error, not attributed. A method without a basis (a peer) "
    "has a total error only.")
"""The figure's caption on the report page (HTML)."""


def _finite(v) -> bool:
    return isinstance(v, (int, float, np.floating)) and math.isfinite(float(v))


def decomposition_rows(sub: pd.DataFrame) -> list[dict]:
    """One entry per row of a scenario's table: its label, total error and the stacked
    parts (column → value; empty when the method has no basis or failed) and sum / total."""
    out = []
    for r in sub.to_dict("records"):
        label = f"{r['structure']}, {r['target']}: {r['method']}"
        total = r.get("total_error")
        parts: dict[str, float] = {}
        if _finite(total) and _finite(r.get("projection_error")):
            attributed = all(_finite(r.get(c)) for c in
                             ("diagonalization_error", "linearization_error", "residual_error"))
            cols = ([c for c, *_ in PARTS[:4]] if attributed
                    else ["projection_error", "subspace_error"])
            parts = {c: float(r[c]) for c in cols if _finite(r.get(c))}
        ratio = (sum(parts.values()) / float(total)
                 if parts and _finite(total) and float(total) > 0 else math.nan)
        out.append({"label": label, "total": float(total) if _finite(total) else math.nan,
                    "parts": parts, "ratio": ratio})
    return out


def _draw(rows: list[dict], title: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(rows)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11.0, 1.6 + 0.3 * n), sharey=True,
                                 layout="constrained",
                                 gridspec_kw={"width_ratios": [1, 1.6], "wspace": 0.01})
    y = np.arange(n)
    totals = np.array([100 * r["total"] for r in rows])
    ok = np.isfinite(totals) & (totals > 0)
    a1.barh(y[ok], totals[ok], color="#0b5cad", height=0.62)
    a1.set_xscale("log")
    lo = 10.0 ** math.floor(math.log10(max(totals[ok].min() / 1.5, 1e-3))) if ok.any() else 0.1
    hi = 10.0 ** math.ceil(math.log10(totals[ok].max() * 6)) if ok.any() else 100.0
    a1.set_xlim(lo, hi)
    for yi, t in zip(y, totals, strict=True):
        a1.text(t * 1.15 if np.isfinite(t) and t > 0 else lo * 1.2, yi,
                f"{percent(t)} %" if np.isfinite(t) else "failed", va="center", fontsize=8.5)
    a1.set_xlabel("total error, % of ‖W‖$_F$")
    a1.set_yticks(y, [r["label"] for r in rows], fontsize=9)
    a1.invert_yaxis()
    a1.grid(axis="x", which="major", color="#e3e6ea", lw=0.6)
    handles = {}
    for yi, r in zip(y, rows, strict=True):
        s = sum(r["parts"].values())
        left = 0.0
        for col, lab, colour, hatch in PARTS:
            if col not in r["parts"] or s <= 0:
                continue
            w = 100 * r["parts"][col] / s
            h = a2.barh(yi, w, left=left, color=colour, hatch=hatch, height=0.62,
                        edgecolor="#ffffff" if hatch is None else "#8a949e", lw=0.4)
            handles.setdefault(lab, h)
            left += w
        note = (f"{r['ratio']:.2f}" if math.isfinite(r["ratio"]) else
                "no basis" if math.isfinite(r["total"]) else "")
        a2.text(101.5, yi, note, va="center", fontsize=8.5)
    a2.set_xlim(0, 112)
    a2.set_xticks([0, 25, 50, 75, 100])
    a2.set_title("sum / total", loc="right", fontsize=8.5)
    a2.set_xlabel("share of the sum of the parts, %")
    a2.tick_params(axis="y", length=0)
    order = [lab for _, lab, *_ in PARTS if lab in handles]
    if order:
        fig.legend([handles[k] for k in order], order, loc="outside lower center",
                   ncol=len(order), fontsize=8.5,
                   frameon=False)
    fig.suptitle(title, fontsize=11)
    return fig


def decomposition_figure(sub: pd.DataFrame, path, *, title: str) -> bytes:
    """Draw the decomposition of a scenario's rows ``sub`` (a slice of ``summary.csv``) into
    ``path`` (its suffix gives the format: png, svg or pdf) and return it as PNG bytes for
    embedding."""
    import matplotlib.pyplot as plt

    rows = decomposition_rows(sub)
    with plt.rc_context(RC):
        fig = _draw(rows, title)
        try:
            path = Path(path)
            buf = io.BytesIO()
            fig.savefig(buf, dpi=DPI, format="png", metadata={"Software": None})
            png = buf.getvalue()
            if path.suffix == ".png":
                path.write_bytes(png)
            else:
                meta = {".svg": {"Date": None}, ".pdf": {"CreationDate": None}}[path.suffix]
                fig.savefig(path, dpi=DPI, format=path.suffix[1:], metadata=meta)
            return png
        finally:
            plt.close(fig)
