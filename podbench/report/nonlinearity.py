"""The §5.2 nonlinearity checks (Figs. 5.12, 5.13) rendered: ``nonlinearity.md``,
``nonlinearity.csv`` and the figures of every row of
:func:`podbench.harness.nonlinearity.nonlinearity_table`; ``python -m
podbench.report.nonlinearity`` runs the sweep and prints its table."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from podbench.harness.nonlinearity import ImpulseSet, nonlinearity_table
from podbench.harness.tables import table_csv
from podbench.study.nonlinearity import ROUNDOFF_METRIC, row_label, zeta_label


def _frequency_verdict(lags, tol: float = 0.01) -> str:
    """From the smallest load's lag (% of T) at the last time: "rises" with the load when
    it lags the baseline by more than ``tol`` %, "falls" when it leads, else "equal"."""
    lag = float(lags[0, -1])
    if abs(lag) < tol:
        return "equal"
    return "rises" if lag > 0 else "falls"


def markdown_table(rows) -> str:
    """The table of :func:`nonlinearity_table` in markdown (scaled values in in/(lbf·s)).

    Round-off is not printed: a deviation below
    :data:`~podbench.study.nonlinearity.ROUNDOFF_METRIC` (a homogeneous band's deviation is
    round-off, whose digits differ between CPUs; docs/noise.md has the measurement) is
    written 0, as in ``nonlinearity.csv``, and a lag that rounds to 0.00 % as +0.00
    (its sign, at 1e-11 %, is round-off too)."""
    times = rows[0]["times"]
    head = ("| ζ | band | offset (in) | offset / A | away peak, 0.36 → 1.8 lbf | toward peak "
            "| RMS | deviation of 0.36 lbf | "
            + " | ".join(f"lag @ {t:g} s (% T)" for t in times)
            + " | scaled tip with load (away / toward / RMS) | first frequency with load |")
    sep = "|" + "---|" * (8 + len(times) + 2)
    lines = [head, sep]

    def pair(x):
        return f"{x[0]:.3f} → {x[-1]:.3f}"

    def deviation(x):  # round-off of a homogeneous band: 0, as in nonlinearity.csv
        return "0" if abs(x) < ROUNDOFF_METRIC else f"{x:.2e}"

    def lag(x):  # a lag that rounds to 0.00 is written +0.00, whatever its sign
        return f"{round(float(x), 2) + 0.0:+.2f}"

    for r in rows:
        lines.append(
            f"| {100 * r['zeta']:g} % | {r['kind']} | {r['offset_in']:.4g} | {r['fraction']:g} "
            f"| {pair(r['away'])} | {pair(r['toward'])} | {pair(r['rms'])} "
            f"| {deviation(r['deviation'][0])} | "
            + " | ".join(lag(x) for x in r["lags"][0])
            + f" | {r['trend_away']} / {r['trend_toward']} / {r['trend_rms']} "
            f"| {_frequency_verdict(r['lags'])} |")
    return "\n".join(lines)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(plt, fig, ax, path) -> Path:
    """Legend, grid, 150 dpi, close: the common end of Figs. 5.12 and 5.13."""
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return Path(path)


def figure_scaled_tip(data: ImpulseSet, path, *, window: float, title: str = ""):
    """Fig. 5.12: tip displacement per unit impulse over the first ``window`` s."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8.0, 4.8))
    m = data.t <= window
    for p, row in zip(data.peaks, data.scaled, strict=True):
        ax.plot(1e3 * data.t[m], row[m], lw=1.2, label=f"{p:g} lbf peak")
    ax.set_xlabel("time after impact (ms)")
    ax.set_ylabel("tip displacement / impulse (in/(lbf·s))")
    ax.set_title(title or "Scaled tip displacements (Fig. 5.12)")
    return _finish(plt, fig, ax, path)


def figure_phase_lag(data: ImpulseSet, lags: np.ndarray, times, path, *, title: str = ""):
    """Fig. 5.13: phase lag behind the baseline (% of the reference period) at ``times``."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8.0, 4.8))
    for p, row in zip(data.peaks[:-1], lags[:-1], strict=True):
        ax.plot(np.asarray(times) * 1e3, row, "o-", label=f"{p:g} lbf peak")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("time after impact (ms)")
    ax.set_ylabel(f"lag behind the {data.peaks[-1]:g}-lbf response (% of period)")
    ax.set_title(title or "Phase lag for various impulse magnitudes (Fig. 5.13)")
    return _finish(plt, fig, ax, path)


def main(argv=None) -> int:
    """``python -m podbench.harness.nonlinearity [--figures DIR] [--quick]``: print the table."""
    ap = argparse.ArgumentParser(prog="python -m podbench.harness.nonlinearity",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--figures", type=Path, help="write Figs. 5.12/5.13 per row here")
    ap.add_argument("--quick", action="store_true", help="undamped, fractions 0, 0.5, 1 only")
    ap.add_argument("--zeta", type=float, action="append",
                    help="modal damping ratio(s) (default 0 and 0.005)")
    a = ap.parse_args(argv)
    kw = {"fractions": (0.0, 0.5, 1.0), "zetas": (0.0,)} if a.quick else {}
    if a.zeta:
        kw["zetas"] = tuple(a.zeta)
    rows = nonlinearity_table(**kw)
    r0 = rows[0]
    print(f"A = {r0['amplitude_in']:.5g} in (largest tip amplitude, 1.8 lbf, no slack); "
          f"T = {r0['period_s']:.5g} s (bare beam)\n")
    print(markdown_table(rows))
    if a.figures:
        a.figures.mkdir(parents=True, exist_ok=True)
        for r in rows:
            tag = f"z{100 * r['zeta']:g}_{r['kind']}_{r['fraction']:g}"
            figure_scaled_tip(r["data"], a.figures / f"fig5_12_{tag}.png",
                              window=r["period_s"], title=f"Scaled tip, {tag}")
            figure_phase_lag(r["data"], r["lags"], r["times"],
                             a.figures / f"fig5_13_{tag}.png", title=f"Phase lag, {tag}")
    return 0


def write_outputs(rows, table: pd.DataFrame, folder: Path, *, figures: bool,
                  figure_format: str = "png") -> None:
    """``nonlinearity.md``, ``nonlinearity.csv`` and (``figures``) Figs. 5.12 / 5.13 per row."""
    folder = Path(folder)
    (folder / "nonlinearity.csv").write_text(table_csv(table), encoding="utf-8", newline="\n")
    r0 = rows[0]
    text = [
        "# The §5.2 nonlinearity checks (Figs. 5.12, 5.13)\n\n",
        "Generated by `podbench run` from the claims file's `[nonlinearity]` table "
        "(`podbench.harness.nonlinearity`); do not edit. Five half-sine impulses at "
        "4 in (peaks 0.36 … 1.8 lbf), 2.2-s records at 0.1 ms, tip sensor; offsets are "
        "fractions of A, the largest tip amplitude of the literal band (no slack) under the "
        "1.8-lbf load. Readings: docs/chapter5_nonlinearity.md.\n\n",
        f"A = {r0['amplitude_in']:.5g} in; T = {r0['period_s']:.5g} s (bare beam)\n\n",
        markdown_table(rows), "\n\n",
        "Claim metrics (`nonlinearity.csv`): deviation = ‖s₀ − s_b‖/‖s_b‖ of the 0.36-lbf "
        "scaled tip history; scaled_*_change = relative change of the scaled RMS / band-side "
        "peak from 0.36 to 1.8 lbf; lag_* = lag of the 0.36-lbf response behind the baseline "
        "(% of T) at the first / last time.\n\n",
        "| ζ | row | deviation | scaled RMS change | scaled peak change | lag first (% T) "
        "| lag last (% T) |\n|---|---|---|---|---|---|---|\n"]
    for r in table.to_dict("records"):
        text.append(f"| {r['target']} | {r['method']} | {r['deviation']:.3g} "
                    f"| {r['scaled_rms_change']:+.3g} | {r['scaled_away_change']:+.3g} "
                    f"| {r['lag_first']:+.3g} | {r['lag_last']:+.3g} |\n")
    (folder / "nonlinearity.md").write_text("".join(text), encoding="utf-8", newline="\n")
    if figures:
        fdir = folder / "figures"
        fdir.mkdir(exist_ok=True)
        for r in rows:
            tag = f"{zeta_label(r['zeta'])}__{row_label(r)}"
            figure_scaled_tip(r["data"], fdir / f"fig5_12__{tag}.{figure_format}",
                              window=r["period_s"], title=f"Scaled tip displacements, {tag}")
            figure_phase_lag(r["data"], r["lags"], r["times"],
                             fdir / f"fig5_13__{tag}.{figure_format}",
                             title=f"Phase lag behind the 1.8-lbf response, {tag}")
    return None


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
