"""The report's "Modes" section: each fit's identified modes against the finite-element
modes (``modal.csv``: frequency error, damping error, MAC, matched by MAC) as a table and a
MAC figure, and the POMs against the normal modes (``pom_modes.csv``)."""

from __future__ import annotations

import html
import math

import numpy as np
import pandas as pd

__all__ = ["modal_figure", "modal_html"]


def _fmt(v) -> str:
    if isinstance(v, float):
        return "–" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def modal_figure(modal: pd.DataFrame, path) -> bytes:
    """The MAC of every band mode's identified partner (0 when unmatched), one group of bars
    per (scenario, structure), one bar per method and mode; written to ``path`` (its suffix
    gives the format) and returned as PNG bytes for embedding."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = modal[modal["mode"] > 0]
    groups = list(dict.fromkeys(zip(ok["scenario"], ok["structure"], strict=True)))
    fig, axes = plt.subplots(len(groups) or 1, 1, figsize=(10, 1.9 * max(len(groups), 1) + 0.6),
                             squeeze=False)
    try:
        for ax, (sc, st) in zip(axes[:, 0], groups, strict=False):
            sub = ok[(ok["scenario"] == sc) & (ok["structure"] == st)]
            methods = list(dict.fromkeys(sub["method"]))
            width = 0.8 / max(len(methods), 1)
            for i, m in enumerate(methods):
                g = sub[sub["method"] == m]
                ax.bar(g["mode"].to_numpy() + (i - (len(methods) - 1) / 2) * width,
                       np.nan_to_num(g["mac"].to_numpy(dtype=float)), width, label=m)
            ax.set_ylim(0, 1.05)
            ax.set_ylabel("MAC")
            ax.set_title(f"{sc} × {st}", fontsize=9)
            ax.set_xticks(sorted(sub["mode"].unique()))
            ax.legend(fontsize=7, ncol=min(len(methods), 6), loc="lower right")
        axes[-1, 0].set_xlabel("finite-element mode in the band (by frequency)")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80)
        return buf.getvalue()
    finally:
        plt.close(fig)


_HEADS = {"frequency_hz": "f<sub>FE</sub> (Hz)", "damping_ratio": "ζ<sub>FE</sub>",
          "identified_frequency_hz": "f<sub>id</sub> (Hz)",
          "identified_damping_ratio": "ζ<sub>id</sub>", "frequency_error_pct": "Δf (%)",
          "damping_error": "Δζ", "mac": "MAC"}


def _table(df: pd.DataFrame) -> str:
    out = ['<div class="scroll"><table><thead><tr>'
           + "".join(f'<th title="{html.escape(c)}">{_HEADS.get(c, html.escape(c))}</th>'
                     for c in df.columns) + "</tr></thead><tbody>"]
    for r in df.itertuples(index=False):
        out.append("<tr>" + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in r) + "</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def modal_html(modal: pd.DataFrame | None, poms: pd.DataFrame | None,
               figure_uri: str | None) -> str:
    """The report page's modes section (empty without ``modal.csv``)."""
    if modal is None or modal.empty:
        return ""
    found = modal[modal["status"] == "ok"]
    band = modal[modal["mode"] > 0]
    out = ["<p>Each fit's physical modes (its state-space realization, the hard criteria and "
           "the stabilization rule) matched by MAC to the finite-element modes in the band "
           "the training records excite, as the records sample them; a time-varying "
           "structure is compared with its linear part at t = 0, a nonlinear one with its "
           "linear twin (the <i>truth</i> column). Tables: <code>modal.csv</code>, "
           "<code>pom_modes.csv</code>.</p>",
           f"<p>{len(found)} of {len(band)} band modes found (MAC ≥ 0.5)"
           + (f"; median |Δf| {float(np.median(np.abs(found['frequency_error_pct']))):.2g} %, "
              f"median MAC {float(np.median(found['mac'])):.3g}" if len(found) else "")
           + ".</p>"]
    if figure_uri:
        out.append(f'<figure><img src="{figure_uri}" alt="MAC of each identified mode with '
                   'its finite-element partner, per scenario, structure and method" '
                   'style="max-width:100%"></figure>')
    cols = ["scenario", "structure", "method", "mode", *_HEADS, "status"]
    out.append(_table(modal[cols]))
    if poms is not None and not poms.empty:
        out.append("<h3>Proper orthogonal modes and normal modes</h3><p>The MAC of each POM "
                   "with its closest mass-normalized normal mode at the sensors: 1 when the "
                   "mass matrix is proportional to the identity and the damping light "
                   "(dissertation §2.1); below 1 the basis carries part of the "
                   "diagonalization error (§3.6).</p>")
        out.append(_table(poms))
    return "\n".join(out)
