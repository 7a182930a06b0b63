"""The study's figures: the displacement norm (Eq. 4.1) of the truth and of every method
against time, over the percent error of the norm (Eq. 4.2), in the manner of Figs. 4.6–4.58.

One figure per (scenario, structure, target). The title names the study, the structure and
the target's excitation in words (:func:`describe_case`, from the scenario file's table);
the upper panel's y-axis is fitted to the truth with a margin, so a method that leaves it is
drawn clipped, marked by triangles where it leaves and labelled "off scale" with its peak
in the legend; each method's total error ‖Ŵ − W‖_F / ‖W‖_F is in the legend; the
structure's events (e.g. the truss's fracture at 3 s) are dashed vertical lines.

Figures render with matplotlib's Agg backend (no display), in PNG (150 dpi, 1200 × 840
px), SVG or PDF (:data:`FIGURE_FORMATS`); :func:`draw_figure` is a module-level function of
one picklable :class:`FigureTask`, so the study's executor draws them in worker processes.
"""

from __future__ import annotations

import base64
import io
import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["FIGURE_FORMATS", "FigureTask", "describe_case", "draw_figure", "make_figure",
           "percent", "time_unit"]

FIGURE_FORMATS = ("png", "svg", "pdf")
"""Formats of ``podbench run --figure-format`` (PNG default; SVG and PDF are vectors)."""

DPI = 150
SIZE = (8.0, 5.6)  # inches: 1200 × 840 px at 150 dpi (the height grows with the header)
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9")
"""Okabe–Ito colours (distinguishable with the common colour-vision deficiencies)."""
STYLES = ("--", "-.", (0, (1, 1.2)), (0, (6, 1.5, 1, 1.5, 1, 1.5)))
MARGIN = 0.12
"""Head-room above the truth's peak, as a fraction of the truth's range."""


@dataclass(frozen=True)
class FigureTask:
    """Everything one figure needs (picklable: drawn in a worker process).

    ``series`` is a unit's entry of :attr:`podbench.harness.runner.UnitResult.series`
    (``t``, ``truth`` and, per method label, its norm and ``<label>__pe``); ``methods`` the
    reported method labels with their total error (NaN when the method failed); ``events``
    ``(time in s, description)`` of the structure's events; ``embed`` asks for a PNG data
    URI of the figure in return (for ``report.html``).
    """

    path: Path
    title: str
    subtitle: str
    series: dict
    methods: tuple[tuple[str, float], ...]
    events: tuple[tuple[float, str], ...] = ()
    fmt: str = "png"
    embed: bool = False
    meta: dict = field(default_factory=dict)


def time_unit(t_end: float) -> tuple[float, str]:
    """Scale and unit of a time axis ending at ``t_end`` s: ms below one second."""
    return (1e3, "ms") if t_end < 1.0 else (1.0, "s")


def _num(x: float) -> str:
    s = f"{x:.4g}"
    return s.replace("-", "−")


def _where(loc, by: str = "position") -> str:
    if isinstance(loc, str):
        return f"at {loc}"
    if by == "dof":
        return f"at DOF {loc}"
    return f"at {_num(float(loc))} in"


def _dur(seconds: float, unit: tuple[float, str]) -> str:
    scale, name = unit
    return f"{_num(seconds * scale)} {name}"


def _loads(pairs, by, what: str) -> str:
    parts = [f"{_num(float(f))} lbf {_where(loc, by)}" for loc, f in pairs]
    return what + ", ".join(parts)


def _force_words(d: dict, unit, dt: float) -> str:
    kind = d.get("kind")
    if kind == "pulse":
        shape = {"rectangular": "rectangular pulse", "half_sine": "half-sine pulse",
                 "triangle": "triangular pulse"}.get(d.get("shape", "rectangular"), "pulse")
        dur = _dur(float(d["duration"]), unit).replace(" ", "-")
        s = (f"{_num(float(d['amplitude']))}-lbf {dur} {shape} "
             f"{_where(d['location'], d.get('by', 'position'))}")
        start = d.get("start")
        if start is not None and not math.isclose(float(start), dt):
            s += f" from t = {_dur(float(start), unit)}"
        return s
    if kind == "combined":
        return " + ".join(_force_words(p, unit, dt) for p in d.get("parts", []))
    if kind == "force_history":
        return "a force history given as a matrix"
    return f"a {kind} force"


def describe_case(case, *, dt: float, t_end: float) -> str:
    """The excitation of a scenario case in words, e.g. ``"500-lbf 0.5-ms rectangular pulse
    at 23 in"`` or ``"initial displacement from static loads: 2000 lbf at 14 in, −1300 lbf
    at 18 in"`` (times in the unit of the figure's time axis, :func:`time_unit`).

    Parameters
    ----------
    case : podbench.scenarios.Case
        The case (its excitation tables as written in the scenario file).
    dt, t_end : float
        The record's time step and last sample time (s).
    """
    unit = time_unit(t_end)
    words = []
    d = case.initial_displacement
    if d is not None:
        words.append(_loads(d.get("loads", []), d.get("by", "position"),
                            "initial displacement from static loads: "))
    v = case.initial_velocity
    if v is not None:
        dur = _dur(float(v.get("duration", dt)), unit)
        words.append(_loads(v.get("impulses", []), v.get("by", "position"),
                            f"initial velocity from {dur.replace(' ', '-')} impulses: "))
    for f in case.force:
        words.append(_force_words(f, unit, dt))
    if not words:
        if getattr(case, "file", None) is not None:
            return case.description or f"measured record {case.file}"
        return case.description or "no excitation"
    return "; ".join(words)


def _pct(x: float) -> str:
    if x is None or not math.isfinite(x):
        return "failed"
    return f"{percent(100 * x)} %"


def percent(v: float) -> str:
    """A percentage to three significant digits, without exponent (``"1985"``, ``"4.23"``)."""
    if not math.isfinite(v):
        return "—"
    return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.3g}"


def _exits(y: np.ndarray, top: float, gap: int = 1) -> np.ndarray:
    """Indices where ``y`` rises above ``top`` (the first sample of each excursion), one per
    ``gap`` samples at most (a curve that flickers across the edge gets one mark)."""
    above = y > top
    starts = np.flatnonzero(above & ~np.concatenate(([False], above[:-1])))
    kept: list[int] = []
    for j in starts:
        if not kept or j - kept[-1] >= gap:
            kept.append(int(j))
    return np.asarray(kept, dtype=int)


def _legend_columns(labels) -> int:
    """Columns of the legend row(s) above the axes: as many as fit in the figure's width."""
    width = [0.7 + 0.09 * len(lab) for lab in labels]  # inches at 11 pt
    for ncol in range(len(labels), 1, -1):
        cols = [max(width[j::ncol]) for j in range(ncol)]
        if sum(cols) + 0.25 * (ncol - 1) <= SIZE[0] - 0.4:
            return ncol
    return 1


def _y_limits(truth: np.ndarray) -> tuple[float, float]:
    lo, hi = float(np.nanmin(truth)), float(np.nanmax(truth))
    span = hi - lo if hi > lo else (abs(hi) or 1.0)
    bottom = 0.0 if lo >= 0 else lo - MARGIN * span
    return bottom, hi + MARGIN * span


def _png(fig) -> bytes:
    """``fig`` as a PNG of 256 colours (lossless to the eye for line art, a quarter of the
    size of the RGBA file)."""
    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, dpi=DPI, format="png", metadata={"Software": None})
    img = Image.open(io.BytesIO(buf.getvalue())).convert("RGB")
    out = io.BytesIO()
    img.quantize(colors=256, method=Image.Quantize.FASTOCTREE).save(out, "png", optimize=True)
    return out.getvalue()


RC = {"font.size": 12, "axes.labelsize": 12, "legend.fontsize": 11, "xtick.labelsize": 11,
      "ytick.labelsize": 11, "svg.hashsalt": "podbench", "svg.fonttype": "path",
      "pdf.fonttype": 42}
"""matplotlib settings of every figure (fonts readable at 150 dpi; reproducible SVG ids)."""


def make_figure(task: FigureTask):
    """The matplotlib Figure of ``task`` (Agg backend; the caller closes it). Its axes are
    ``fig.axes[0]`` (‖w(t)‖) and ``fig.axes[1]`` (Eq. 4.2 error, log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    s = task.series
    t = np.asarray(s["t"], dtype=float)
    truth = np.asarray(s["truth"], dtype=float)
    scale, unit = time_unit(float(t[-1]))
    x = scale * t
    with plt.rc_context(RC):
        fig, (a1, a2) = plt.subplots(2, 1, figsize=SIZE, sharex=True,
                                     gridspec_kw={"height_ratios": [3, 2]})
        try:
            bottom, top = _y_limits(truth)
            a1.plot(x, truth, color="black", lw=2.0, zorder=5)
            handles = [Line2D([], [], color="black", lw=2.0,
                              label="measured" if task.meta.get("measured") else
                              "truth (simulated)")]
            pe_all = _plot_methods(task, x, truth, (bottom, top), a1, a2, handles)
            a1.set_ylim(bottom, top)
            a1.set_ylabel("Norm ‖w(t)‖, in")
            a1.grid(True, alpha=0.3)
            a2.set_yscale("log")
            finite = (np.concatenate([p[np.isfinite(p)] for p in pe_all]) if pe_all
                      else np.empty(0))
            if len(finite):
                a2.set_ylim(max(float(np.min(finite)), 1e-3) / 2, float(np.max(finite)) * 2)
            a2.set_ylabel("Eq. 4.2 error, %")
            a2.set_xlabel(f"Time, {unit}")
            a2.grid(True, which="major", alpha=0.3)
            a1.set_xlim(x[0], x[-1])
            _mark_events(task.events, x, scale, unit, a1, a2)
            _lay_out(fig, task, handles, a1, a2)
        except BaseException:
            plt.close(fig)
            raise
    return fig


def _plot_methods(task: FigureTask, x, truth, limits, a1, a2, handles: list) -> list:
    """Each method's ‖ŵ(t)‖ on ``a1`` (a marker where it leaves the scale) and its Eq. 4.2
    error on ``a2``; appends the legend handles; returns the error curves."""
    from matplotlib.lines import Line2D

    s = task.series
    bottom, top = limits
    pe_all = []
    for i, (label, total) in enumerate(task.methods):
        color, ls = PALETTE[i % len(PALETTE)], STYLES[i % len(STYLES)]
        name = f"{label}: total error {_pct(total)}"
        if label not in s:
            handles.append(Line2D([], [], color=color, ls=ls, lw=1.6, label=name))
            continue
        y = np.asarray(s[label], dtype=float)
        off = bool(np.any(y > top) or np.any(y < bottom))
        if off:
            peak = float(np.nanmax(y)) / float(np.nanmax(truth))
            name += f", off scale (peak {peak:.2g}× the truth's)"
        a1.plot(x, y, color=color, ls=ls, lw=1.6, zorder=4 - 0.1 * i)
        band = s.get(label + "__band")
        if band is not None:  # the norm of the 90 % band's half-width per time
            h = np.asarray(band, dtype=float)
            # shaded only where it stays on the axis: a band wider than the truth's scale
            # would cover the whole plot; the legend says where it was left out
            fits = np.isfinite(h) & (y + h <= top)
            a1.fill_between(x, np.maximum(y - h, 0), y + h, where=fits, color=color,
                            alpha=0.15, lw=0, zorder=1)
            if not np.all(fits):
                name += (f", 90 % band off scale at {100 * np.mean(~fits):.0f} % of the "
                         "samples")
        ex = _exits(y, top, gap=max(1, y.size // 25))
        if ex.size:
            a1.plot(x[ex], np.full(ex.size, top), ls="none", marker="^", ms=9,
                    color=color, clip_on=False, zorder=6)
        handles.append(Line2D([], [], color=color, ls=ls, lw=1.6,
                              marker="^" if off else None, ms=8, label=name))
        pe = np.asarray(s.get(label + "__pe", np.full(x.shape, np.nan)), dtype=float)
        pe = np.where(pe > 0, pe, np.nan)
        pe_all.append(pe)
        a2.plot(x, pe, color=color, ls=ls, lw=1.4)
    return pe_all


def _mark_events(events, x, scale: float, unit: str, a1, a2) -> None:
    """A dashed line on both axes and a label on ``a2`` at each structure event in view."""
    for te, desc in events:
        if not x[0] <= scale * te <= x[-1]:
            continue
        for ax in (a1, a2):
            ax.axvline(scale * te, color="0.3", ls=(0, (4, 3)), lw=1.2, zorder=1)
        what = desc.split(":")[0].strip() or "event"
        a2.annotate(f"{what} (t = {_num(te * scale)} {unit})",
                    xy=(scale * te, 0.0), xycoords=("data", "axes fraction"),
                    xytext=(5, 5), textcoords="offset points", ha="left",
                    va="bottom", fontsize=10.5, color="0.2", zorder=7,
                    bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.7",
                          "alpha": 0.9})


def _lay_out(fig, task: FigureTask, handles: list, a1, a2) -> None:
    """Title, subtitle and legend above the axes; the figure grows by their height."""
    sub = textwrap.wrap(task.subtitle, 92) if task.subtitle else []
    title = textwrap.wrap(task.title, 68) or [""]
    ncol = _legend_columns([h.get_label() for h in handles])
    rows = -(-len(handles) // ncol)
    head = 0.14 + 0.3 * len(title) + 0.06 + 0.25 * len(sub) + 0.29 * rows + 0.1
    # (inches above the axes: margin, title, subtitle, legend rows)
    height = 4.9 + head
    fig.set_size_inches(SIZE[0], height)
    y = 1 - 0.14 / height
    fig.suptitle("\n".join(title), fontsize=14, fontweight="bold", y=y, va="top",
                 linespacing=1.2)
    y -= (0.3 * len(title) + 0.06) / height
    if sub:
        fig.text(0.5, y, "\n".join(sub), ha="center", va="top", fontsize=12,
                 color="0.15", linespacing=1.25)
        y -= 0.25 * len(sub) / height
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, y),
               ncol=ncol, frameon=False, handlelength=2.6, columnspacing=1.6,
               borderaxespad=0.0)
    fig.align_ylabels([a1, a2])
    fig.subplots_adjust(left=0.11, right=0.975, top=1 - head / height,
                        bottom=0.6 / height, hspace=0.07)


def draw_figure(task: FigureTask) -> str | None:
    """Draw one figure into ``task.path`` (in ``task.fmt``) and close it; with
    ``task.embed``, return it as a ``data:`` URI for the self-contained report (the SVG
    itself for SVG, a PNG otherwise)."""
    import matplotlib.pyplot as plt

    fig = make_figure(task)
    try:
        with plt.rc_context(RC):
            if task.fmt == "png":
                Path(task.path).write_bytes(_png(fig))
            else:
                meta = {"svg": {"Date": None}, "pdf": {"CreationDate": None}}[task.fmt]
                fig.savefig(task.path, dpi=DPI, format=task.fmt, metadata=meta)
            if not task.embed:
                return None
            if task.fmt == "svg":
                data = Path(task.path).read_bytes()
                return "data:image/svg+xml;base64," + base64.b64encode(data).decode("ascii")
            data = Path(task.path).read_bytes() if task.fmt == "png" else _png(fig)
            return "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    finally:
        plt.close(fig)
