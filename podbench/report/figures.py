"""The study's figures: per target, the displacement norm (Eq. 4.1) of the truth and of every
method against time over the percent error of the norm (Eq. 4.2), in the manner of
Figs. 4.6–4.58, and beside it the response at two sensors and the amplitude spectrum over
all sensors (:mod:`podbench.harness.series` keeps them; this module computes nothing).

One figure per (scenario, structure, target). The title names the study, the structure and
the target's excitation in words (:func:`describe_case`, from the scenario file's table);
every panel's y-axis is fitted to the truth with a margin, so a method that leaves it is
drawn clipped, marked by triangles where it leaves and labelled "off scale" with its peak
in the legend; each method's total error ‖Ŵ − W‖_F / ‖W‖_F is in the legend; the
structure's events (e.g. the truss's fracture at 3 s) are dashed vertical lines.

Figures render with matplotlib's Agg backend (no display), in PNG (150 dpi, 1800 px wide;
1200 px for a series without sensors), SVG or PDF (:data:`FIGURE_FORMATS`);
:func:`draw_figure` is a module-level function of one picklable :class:`FigureTask`, so the
study's executor draws them in worker processes.
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
WIDE = 12.0
"""Width (in) of a figure with the sensor and spectrum panels: 1800 px at 150 dpi."""
SPECTRUM_FLOOR = 1e-4
"""The spectrum panel's lower limit, as a fraction of the truth's peak amplitude."""
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


def _legend_columns(labels, width: float = SIZE[0]) -> int:
    """Columns of the legend row(s) above the axes: as many as fit in the figure's width."""
    size = [0.7 + 0.09 * len(lab) for lab in labels]  # inches at 11 pt
    for ncol in range(len(labels), 1, -1):
        cols = [max(size[j::ncol]) for j in range(ncol)]
        if sum(cols) + 0.25 * (ncol - 1) <= width - 0.4:
            return ncol
    return 1


def _y_limits(truth: np.ndarray) -> tuple[float, float]:
    lo, hi = float(np.nanmin(truth)), float(np.nanmax(truth))
    span = hi - lo if hi > lo else (abs(hi) or 1.0)
    bottom = 0.0 if lo >= 0 else lo - MARGIN * span
    return bottom, hi + MARGIN * span


def _png(fig) -> bytes:
    """``fig`` as a PNG of 256 colours (lossless to the eye for line art, a quarter of the
    size of the RGBA file), from the Agg canvas at :data:`DPI` (no intermediate PNG), at
    zlib's default level (``optimize`` would take seven times as long for a 6 % smaller
    file)."""
    from PIL import Image

    fig.set_dpi(DPI)
    fig.canvas.draw()
    w, h = fig.canvas.get_width_height(physical=True)
    img = Image.frombuffer("RGBA", (w, h), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
    out = io.BytesIO()
    img.convert("RGB").quantize(colors=256, method=Image.Quantize.FASTOCTREE).save(out, "png")
    return out.getvalue()


RC = {"font.size": 12, "axes.labelsize": 12, "legend.fontsize": 11, "xtick.labelsize": 11,
      "ytick.labelsize": 11, "svg.hashsalt": "podbench", "svg.fonttype": "path",
      "pdf.fonttype": 42}
"""matplotlib settings of every figure (fonts readable at 150 dpi; reproducible SVG ids)."""


def _axes(plt, wide: bool):
    """The figure and its axes: ``norm`` over ``pe`` (Eq. 4.2), and with ``wide`` beside
    them the two sensors over the spectrum (``sensors``, ``spectrum``)."""
    fig = plt.figure(figsize=(WIDE if wide else SIZE[0], SIZE[1]), dpi=DPI)
    outer = fig.add_gridspec(1, 2 if wide else 1, **({"width_ratios": [1.08, 1],
                                                        "wspace": 0.2} if wide else {}))
    left = outer[0].subgridspec(2, 1, height_ratios=[3, 2], hspace=0.07)
    ax = {"norm": fig.add_subplot(left[0])}
    ax["pe"] = fig.add_subplot(left[1], sharex=ax["norm"])
    ax["norm"].tick_params(labelbottom=False)
    if wide:
        right = outer[1].subgridspec(2, 1, height_ratios=[2, 1.2], hspace=0.42)
        pair = right[0].subgridspec(2, 1, hspace=0.08)
        # the sensors share their time axis with each other only: matplotlib lays out a
        # shared axis's label against every sibling's ticks, four siblings cost twice two
        top = fig.add_subplot(pair[0])
        ax["sensors"] = [top, fig.add_subplot(pair[1], sharex=top)]
        ax["sensors"][0].tick_params(labelbottom=False)
        ax["spectrum"] = fig.add_subplot(right[1])
    return fig, ax


def make_figure(task: FigureTask):
    """The matplotlib Figure of ``task`` (Agg backend; the caller closes it). Its axes are
    ``fig.axes[0]`` (‖w(t)‖, Eq. 4.1) and ``fig.axes[1]`` (Eq. 4.2 error, log scale) and,
    when the series has them (:func:`podbench.harness.series.truth_series`), the two
    sensors' histories ``fig.axes[2:4]`` and the amplitude spectrum ``fig.axes[4]``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    s = task.series
    t = np.asarray(s["t"], dtype=float)
    truth = np.asarray(s["truth"], dtype=float)
    scale, unit = time_unit(float(t[-1]))
    x = scale * t
    wide = "sensors" in s and "freq" in s
    du = s.get("unit", "in")
    with plt.rc_context(RC):
        fig, ax = _axes(plt, wide)
        a1, a2 = ax["norm"], ax["pe"]
        try:
            bottom, top = _y_limits(truth)
            a1.plot(x, truth, color="black", lw=2.0, zorder=5)
            handles = [Line2D([], [], color="black", lw=2.0,
                              label="measured" if task.meta.get("measured") else
                              "truth (simulated)")]
            pe_all = _plot_methods(task, x, truth, (bottom, top), a1, a2, handles)
            a1.set_ylim(bottom, top)
            a1.set_ylabel(f"‖w(t)‖ (Eq. 4.1), {du}")
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
            timed = [a1, a2]
            if wide:
                for a, k in zip(ax["sensors"], range(len(s["sensors"])), strict=False):
                    _plot_sensor(task, x, k, a)
                    timed.append(a)
                ax["sensors"][-1].set_xlabel(f"Time, {unit}")
                ax["sensors"][0].set_xlim(x[0], x[-1])
                _plot_spectrum(task, ax["spectrum"])
            _mark_events(task.events, x, scale, unit, timed, a2)
            _lay_out(fig, task, handles, ax)
        except BaseException:
            plt.close(fig)
            raise
    return fig


def _off_marks(a, x, y, lo: float, hi: float, color) -> bool:
    """Triangles where ``y`` leaves ``[lo, hi]`` (up at the top, down at the bottom; at most
    25 per edge); returns whether it leaves."""
    gap = max(1, y.size // 25)
    up, down = _exits(y, hi, gap), _exits(-y, -lo, gap)
    for idx, edge, mark in ((up, hi, "^"), (down, lo, "v")):
        if idx.size:
            a.plot(x[idx], np.full(idx.size, edge), ls="none", marker=mark, ms=7,
                   color=color, clip_on=False, zorder=6)
    return bool(up.size or down.size)


def _panel_label(a, text: str, right: bool = False) -> None:
    a.text(0.99 if right else 0.01, 0.96, text, transform=a.transAxes,
           ha="right" if right else "left", va="top", fontsize=10.5,
           zorder=8, bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.75",
                           "alpha": 0.9})


def _plot_sensor(task: FigureTask, x, k: int, a) -> None:
    """The truth and every method at the ``k``-th chosen sensor, on ``a`` (the y-axis
    fitted to the truth; a method that leaves it is clipped and marked)."""
    s = task.series
    sensor = s["sensors"][k]
    truth = np.asarray(s["sensor_truth"][k], dtype=float)
    lo, hi = float(np.min(truth)), float(np.max(truth))
    span = hi - lo if hi > lo else (abs(hi) or 1.0)
    lo, hi = lo - MARGIN * span, hi + MARGIN * span
    a.plot(x, truth, color="black", lw=1.6, zorder=5)
    for i, (label, _) in enumerate(task.methods):
        y = s.get(label + "__sensors")
        if y is None:
            continue
        y = np.asarray(y[k], dtype=float)
        color, ls = PALETTE[i % len(PALETTE)], STYLES[i % len(STYLES)]
        a.plot(x, np.clip(y, lo - span, hi + span), color=color, ls=ls, lw=1.3,
               zorder=4 - 0.1 * i)
        _off_marks(a, x, y, lo, hi, color)
    a.set_ylim(lo, hi)
    pos = sensor.get("position")
    where = "" if pos is None or _num(pos) in sensor["label"] else f" (x = {_num(pos)} in)"
    _panel_label(a, f"{sensor['role']}: {sensor['label']}{where}")
    a.set_ylabel(f"w, {s.get('unit', 'in')}")
    a.grid(True, alpha=0.3)


def _plot_spectrum(task: FigureTask, a) -> None:
    """The amplitude spectrum over all sensors of the truth and every method
    (:func:`podbench.harness.series.amplitude_spectrum`), log scale, on ``a``: up to the
    frequency where the truth falls below 1e-3 of its peak for good (×1.3), down to
    :data:`SPECTRUM_FLOOR` of the peak."""
    s = task.series
    f = np.asarray(s["freq"], dtype=float)
    truth = np.asarray(s["spectrum"], dtype=float)
    peak = float(np.max(truth)) if truth.size and np.max(truth) > 0 else 1.0
    lo, hi = SPECTRUM_FLOOR * peak, 3.0 * peak
    strong = np.flatnonzero(truth >= 1e-3 * peak)
    f_hi = min(float(f[-1]), 1.3 * float(f[strong[-1]])) if strong.size else float(f[-1])
    a.semilogy(f, np.maximum(truth, lo / 10), color="black", lw=1.6, zorder=5)
    for i, (label, _) in enumerate(task.methods):
        y = s.get(label + "__spectrum")
        if y is None:
            continue
        y = np.asarray(y, dtype=float)
        color, ls = PALETTE[i % len(PALETTE)], STYLES[i % len(STYLES)]
        a.semilogy(f, np.clip(y, lo / 10, hi * 10), color=color, ls=ls, lw=1.3,
                   zorder=4 - 0.1 * i)
        _off_marks(a, f, y, -np.inf, hi, color)
    a.set_xlim(0.0, f_hi if f_hi > 0 else 1.0)
    a.set_ylim(lo, hi)
    a.set_xlabel("Frequency, Hz")
    a.set_ylabel(f"Amplitude, {s.get('unit', 'in')}")
    _panel_label(a, "amplitude spectrum over all sensors (Hann window)", right=True)
    a.grid(True, which="major", alpha=0.3)


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


def _mark_events(events, x, scale: float, unit: str, axes, labelled) -> None:
    """A dashed line on every time axis of ``axes`` and a label on ``labelled`` at each
    structure event in view."""
    for te, desc in events:
        if not x[0] <= scale * te <= x[-1]:
            continue
        for ax in axes:
            ax.axvline(scale * te, color="0.3", ls=(0, (4, 3)), lw=1.2, zorder=1)
        what = desc.split(":")[0].strip() or "event"
        labelled.annotate(f"{what} (t = {_num(te * scale)} {unit})",
                          xy=(scale * te, 0.0), xycoords=("data", "axes fraction"),
                          xytext=(5, 5), textcoords="offset points", ha="left",
                          va="bottom", fontsize=10.5, color="0.2", zorder=7,
                          bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.7",
                                "alpha": 0.9})


def _lay_out(fig, task: FigureTask, handles: list, ax: dict) -> None:
    """Title, subtitle and legend above the axes; the figure grows by their height."""
    width = fig.get_size_inches()[0]
    chars = int(92 * width / SIZE[0])
    sub = textwrap.wrap(task.subtitle, chars) if task.subtitle else []
    title = textwrap.wrap(task.title, int(68 * width / SIZE[0])) or [""]
    ncol = _legend_columns([h.get_label() for h in handles], width)
    rows = -(-len(handles) // ncol)
    head = 0.14 + 0.3 * len(title) + 0.06 + 0.25 * len(sub) + 0.29 * rows + 0.1
    # (inches above the axes: margin, title, subtitle, legend rows)
    height = 4.9 + head
    fig.set_size_inches(width, height)
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
    fig.align_ylabels([ax["norm"], ax["pe"]])
    if "sensors" in ax:
        fig.align_ylabels([*ax["sensors"], ax["spectrum"]])
    fig.subplots_adjust(left=0.88 / width, right=1 - 0.2 / width, top=1 - head / height,
                        bottom=0.6 / height)


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
