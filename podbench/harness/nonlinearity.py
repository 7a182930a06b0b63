"""The nonlinearity checks of §5.2 on the rubber-band beam: superposition (Fig. 5.12) and phase
lag against impulse magnitude (Fig. 5.13), as functions of the band's slack or pre-stretch.

§5.2: "five impulses of increasing strength were applied to the point 4 inches from the root
of the beam ... The tip displacement of the beam in response to each impulse was measured and
then scaled by the corresponding impulse magnitude. For a linear system, the principle of
superposition dictates that the scaled tip displacements should be equal. Instead, the scaled
tip displacements for this system, shown in Fig. 5.12, decrease as the impulse magnitude is
increased" and "The response to the 1.8-lb impulse was defined as a baseline and the phase lag
of the other responses behind the baseline was measured at 500, 1000, 1500, and 2000 ms after
impact. The phase lags are shown as percentages of the fundamental period of the reference
linear beam (10.24 ms) ... the lowest frequency of the system increases with the excitation
magnitude".

Readings (the text is open; Fig. 5.11 with the five loads is not in the text):

* Loads: half-sine pulses of 1 ms (a shaker-sting impact; §5.1's Fig. 5.4 is not in the text
  either) at the 4-in sensor with peaks :data:`PEAKS` = 0.36, 0.72, 1.08, 1.44, 1.8 lbf —
  "1.8-lb" read as the largest load's peak force (the text's unit is a force, lb, not lbf·s),
  the five evenly spaced. The scaling uses the impulse ``I = Σ F_j dt`` (lbf·s), as the text
  says "impulse magnitude"; for equal shapes this is the peak times a constant.
* Period: "the reference linear beam (10.24 ms)" is read as §5.1's "fundamental period of
  0.1024 s" (§5.2's ms are a factor 10 off, as its "sampled every 0.01 ms" for 1024 samples
  of "10.24 ms" is): the bare beam's own computed first period is 0.0995 s (10.05 Hz), which
  :func:`reference_period` returns and the lags are divided by.
* Times: 500 ... 2000 ms are read literally (0.5 ... 2.0 s, 5 to 20 periods after impact),
  so the nonlinearity check's records are 2.2 s long at 0.1 ms (a separate test from the
  one-period records used for identification). The alternative "ms a factor 10 off" reading
  (50 ... 200 ms) is :data:`LAG_TIMES_SCALED`.
* Lag: the shift that maximizes the normalized cross-correlation of the two tip records over
  one reference period centred on the time, tracked period by period from the impact so that
  lags beyond half a period are unwrapped (:func:`phase_lag`). Positive: the response arrives
  later than the baseline's (a lower frequency).

The literal band (no slack, no pre-stretch) is positively homogeneous: both checks then find
exactly nothing (scaled responses equal to round-off). The text states no slack or
pre-stretch, so :func:`nonlinearity_table` reports both verdicts as functions of either, over
0 ... 1.5 times the largest tip amplitude, undamped and with 0.5 % modal damping.

Units: inch, lbf, second.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from ..dynamics import simulate
from ..errors import InputError
from ..excitations import Pulse
from ..fem import OneSidedSpring, Structure
from ..fem.beam import modal_damping_matrix
from ..fem.files import load_structure

__all__ = [
    "PEAKS", "PULSE_DURATION", "LOCATION", "DT", "LAG_TIMES", "LAG_TIMES_SCALED",
    "FRACTIONS", "band_variant", "modal_damping", "reference_period", "impulse_responses",
    "superposition_check", "phase_lag", "phase_lags", "nonlinearity_table", "markdown_table",
    "figure_scaled_tip", "figure_phase_lag", "ImpulseSet", "response_nonlinearity",
]

PEAKS = (0.36, 0.72, 1.08, 1.44, 1.8)
"""Peak forces (lbf) of the five impulses; the last is the text's "1.8-lb" baseline."""
PULSE_DURATION = 1.0e-3
"""Duration (s) of the half-sine impacts (the text states none)."""
LOCATION = 4.0
"""Where the impulses act (in from the root), §5.2."""
DT = 1.0e-4
"""Sampling step (s), §5.1's 0.1 ms."""
LAG_TIMES = (0.5, 1.0, 1.5, 2.0)
"""§5.2's "500, 1000, 1500, and 2000 ms after impact", read literally (s)."""
LAG_TIMES_SCALED = (0.05, 0.10, 0.15, 0.20)
"""The alternative reading: the ms a factor 10 off as in "10.24 ms" (s)."""
FRACTIONS = (0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5)
"""Slack / pre-stretch swept, as fractions of the largest tip amplitude of the literal band."""


def band_variant(structure: Structure, **changes) -> Structure:
    """``structure`` with its :class:`OneSidedSpring` changed (``slack``, ``prestretch``, ...)."""
    els = [el for el in structure.nonlinear if isinstance(el, OneSidedSpring)]
    if len(els) != 1:
        raise InputError(f"Parameter `structure`: {structure.name!r} has {len(els)} one-sided "
                         "springs, expected exactly one (the rubber band)")
    new = tuple(dataclasses.replace(el, **changes) if el is els[0] else el
                for el in structure.nonlinear)
    return dataclasses.replace(structure, nonlinear=new)


def modal_damping(structure: Structure, zeta: float) -> Structure:
    """``structure`` with modal damping ``ζ`` in every mode of its band-free linear part.

    ``C = M Φ diag(2 ζ ω_r) Φᵀ M`` (:func:`podbench.fem.beam.modal_damping_matrix`;
    lbf·s/in), replacing the structure's own damping (``ζ = 0``: undamped), so that the
    checks can be run at any ``ζ`` whatever the structure file states.
    """
    if not 0.0 <= zeta < 1.0:
        raise InputError(f"Parameter `zeta`: expected 0 <= zeta < 1, got {zeta!r}")
    if zeta == 0.0:
        return dataclasses.replace(structure, C=None)
    return dataclasses.replace(structure, C=modal_damping_matrix(structure.M, structure.K, zeta))


def reference_period(structure: Structure) -> float:
    """First natural period (s) of the "reference linear beam": ``structure`` without its
    nonlinear elements (for the rubber-band beam, the bare §5.1 beam: 0.0995 s)."""
    bare = dataclasses.replace(structure, nonlinear=())
    return float(1.0 / bare.natural_frequencies(1)[0])


@dataclass(frozen=True)
class ImpulseSet:
    """Tip responses to a set of impulses: ``t`` (n,) s, ``peaks`` (lbf), ``impulses``
    (lbf·s, ``Σ F dt``), ``tip`` (n_loads, n) in, the last load the baseline."""

    t: np.ndarray
    peaks: tuple
    impulses: np.ndarray
    tip: np.ndarray

    @property
    def scaled(self) -> np.ndarray:
        """Tip displacement per unit impulse (in per lbf·s), Fig. 5.12."""
        return self.tip / self.impulses[:, None]


def impulse_responses(structure: Structure, peaks=PEAKS, *, duration: float = PULSE_DURATION,
                      location: float = LOCATION, t_end: float = 2.2,
                      dt: float = DT, cache=None) -> ImpulseSet:
    """Tip displacement (the last sensor) for half-sine pulses of ``peaks`` (lbf) at
    ``location`` (in), ``duration`` s, from rest, over ``[0, t_end]`` s.

    ``cache``: a :class:`podbench.harness.cache.TruthCache` (or None): each response is
    keyed by the structure's fingerprint and the load, and read back exactly."""
    from .cache import TruthCache, structure_fingerprint

    n = int(round(t_end / dt)) + 1
    fp = structure_fingerprint(structure) if cache is not None else ""
    tips, imps = [], []
    for p in peaks:
        key = TruthCache.key(what="nonlinearity.impulse_responses", structure=fp,
                             peak=float(p), duration=float(duration),
                             location=float(location), n=n, dt=float(dt))
        hit = cache.load(key, (1, n)) if cache is not None else None
        if hit is not None:  # W: the tip row; F: the impulse (lbf·s) in every entry
            tips.append(hit["W"][0])
            imps.append(float(hit["F"][0, 0]))
            continue
        f = Pulse(location, float(p), duration, shape="half_sine")
        r = simulate(structure, n_samples=n, dt=dt, force=f, dof_histories=False)
        tips.append(r.W[-1])
        imps.append(float(r.F.sum() * dt))
        if cache is not None:
            cache.store(key, {"W": r.W[-1][None, :], "F": np.full((1, n), imps[-1]),
                              "w0": np.zeros(1), "v0": np.zeros(1), "t": np.arange(n) * dt})
    return ImpulseSet(t=np.arange(n) * dt, peaks=tuple(float(p) for p in peaks),
                      impulses=np.array(imps), tip=np.array(tips))


def _trend(values, rtol: float = 1e-6) -> str:
    """"falls" / "rises" / "equal": the last value against the first (relative ``rtol``)."""
    a, b = float(values[0]), float(values[-1])
    if abs(b - a) <= rtol * max(abs(a), abs(b)):
        return "equal"
    return "falls" if b < a else "rises"


def superposition_check(data: ImpulseSet, window: float, side: int = 1) -> dict:
    """The superposition check of Fig. 5.12 over the first ``window`` s.

    Per load, of the tip displacement per unit impulse (in/(lbf·s)): ``away`` its largest
    excursion away from the band (``side · w``, the side where the band is stretched),
    ``toward`` the largest toward the band, ``rms`` its RMS, and ``deviation``
    ‖scaled − scaled_baseline‖ / ‖scaled_baseline‖ (the baseline the largest load). ``spread``
    (max − min)/max of ``rms``; ``trend_*`` the smallest load's value against the largest's
    (``"falls"``: the scaled response decreases as the impulse grows, Fig. 5.12's words).
    """
    m = data.t <= window + 1e-12
    sc = data.scaled[:, m]
    away = np.max(side * sc, axis=1)
    toward = np.max(-side * sc, axis=1)
    rms = np.sqrt(np.mean(sc**2, axis=1))
    base = sc[-1]
    dev = np.linalg.norm(sc - base, axis=1) / np.linalg.norm(base)
    return {"away": away, "toward": toward, "rms": rms, "deviation": dev,
            "spread": float((rms.max() - rms.min()) / rms.max()),
            "trend_away": _trend(away), "trend_toward": _trend(toward),
            "trend_rms": _trend(rms)}


def phase_lag(t: np.ndarray, ref: np.ndarray, sig: np.ndarray, times, period: float,
              *, lowpass: float | None = None) -> np.ndarray:
    """Lag (s) of ``sig`` behind ``ref`` at ``times`` (s), tracked one ``period`` at a time.

    At each centre ``c`` the lag is the shift ``τ`` maximizing the normalized correlation
    ``Σ ref(t) sig(t + τ)`` over ``t ∈ [c − T/2, c + T/2]``, searched within half a period of
    the previous centre's lag (centres every period from ``T`` on, the first searched around
    0), refined between samples by a parabola through the three best correlations. Positive
    ``τ``: ``sig`` arrives later (for ``sig(t) = ref(t − τ)`` the result is ``τ``).
    """
    t = np.asarray(t, dtype=float)
    ref = np.asarray(ref, dtype=float)
    sig = np.asarray(sig, dtype=float)
    dt = float(t[1] - t[0])
    P = int(round(period / dt))
    half = P // 2
    if half < 2:
        raise InputError(f"Parameter `period`: {period!r} s spans fewer than 4 samples")
    times = np.atleast_1d(np.asarray(times, dtype=float))
    n = t.size
    if lowpass is not None:
        from scipy.signal import butter, sosfiltfilt

        sos = butter(4, lowpass, fs=1.0 / dt, output="sos")
        ref, sig = sosfiltfilt(sos, ref), sosfiltfilt(sos, sig)
    grid = np.arange(P, int(round(times.max() / dt)) + 1, max(P // 4, 1))
    want = np.round(times / dt).astype(int)
    centres = np.unique(np.concatenate([grid, want]))
    if centres.min() < half or centres.max() + 2 * half + 1 + half >= n:
        raise InputError(f"Parameter `times`: {times.tolist()} s need the record to run a "
                         f"period beyond the last time, it ends at {t[-1]:g} s")
    win = sliding_window_view(sig, 2 * half + 1)
    norms = np.sqrt(np.einsum("ij,ij->i", win, win))
    lag = 0.0
    out = {}
    for c in centres:
        r = ref[c - half:c + half + 1]
        m0 = int(round(lag))
        shifts = np.arange(m0 - half, m0 + half + 1)
        starts = c - half + shifts
        ok = (starts >= 0) & (starts < win.shape[0])
        shifts, starts = shifts[ok], starts[ok]
        corr = (win[starts] @ r) / (norms[starts] * np.linalg.norm(r) + 1e-300)
        k = int(np.argmax(corr))
        delta = 0.0
        if 0 < k < corr.size - 1:
            a, b, cc = corr[k - 1], corr[k], corr[k + 1]
            den = a - 2 * b + cc
            if den < 0:
                delta = 0.5 * (a - cc) / den
        lag = shifts[k] + delta
        out[int(c)] = lag * dt
    wanted = set(int(w) for w in want)
    for c in wanted:  # refine: matching zero crossings around c (unbiased for equal shapes)
        zc = _crossing_lag(t, ref, sig, t[c], period, out[c])
        if zc is not None:
            out[c] = zc
    return np.array([out[int(w)] for w in want])


def _crossings(t, x):
    """Times (s) and directions (+1 up, −1 down) of the zero crossings of ``x``, linear
    interpolation between samples."""
    s = np.signbit(x)
    i = np.flatnonzero(s[:-1] != s[1:])
    tc = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    return tc, np.where(s[i], 1, -1)


def _crossing_lag(t, ref, sig, c, period, coarse):
    """``t_sig − t_ref`` at ``c``: over ``ref``'s zero crossings within a period of ``c``, each
    matched to ``sig``'s crossing of the same direction nearest ``t_ref + coarse``, the
    straight line through (crossing time, lag) evaluated at ``c`` (a lag that grows with
    time is read at ``c``, not at the crossings); ``None`` when a match is further than a
    quarter period from the coarse lag."""
    tr, dr = _crossings(t, ref)
    ts, ds = _crossings(t, sig)
    sel = np.abs(tr - c) <= period
    lags = []
    for tc, d in zip(tr[sel], dr[sel], strict=True):
        cand = ts[ds == d]
        if cand.size == 0:
            return None
        j = int(np.argmin(np.abs(cand - (tc + coarse))))
        if abs(cand[j] - tc - coarse) > 0.25 * period:
            return None
        lags.append(cand[j] - tc)
    if len(lags) < 2:
        return None
    slope, icpt = np.polyfit(tr[sel] - c, np.array(lags), 1)
    return float(icpt)


def phase_lags(data: ImpulseSet, times, period: float, *,
               lowpass: float | None = "auto") -> np.ndarray:
    """Lag of every response behind the baseline (the last), in % of ``period``:
    (n_loads, n_times); the baseline's row is 0. ``lowpass="auto"``: 2 / period Hz (the
    fundamental kept, the second mode, 6.3 times higher on a cantilever, removed)."""
    if lowpass == "auto":
        lowpass = 2.0 / period
    base = data.tip[-1]
    return np.array([100.0 * phase_lag(data.t, base, w, times, period, lowpass=lowpass)
                     / period for w in data.tip])


def nonlinearity_table(structure: Structure | None = None, *, fractions=FRACTIONS,
                       zetas=(0.0, 0.005), peaks=PEAKS, times=LAG_TIMES,
                       cache=None) -> list[dict]:
    """Both checks over a slack or pre-stretch of ``fractions`` × the largest tip amplitude.

    ``structure``: the rubber-band beam (default ``rubber_band_beam``). The amplitude ``A`` is
    the largest |tip displacement| of the literal band (no slack) under the largest load,
    undamped, over the first reference period. One row per (damping, kind, fraction).
    ``cache``: see :func:`impulse_responses`.
    """
    s = load_structure("rubber_band_beam") if structure is None else structure
    s = band_variant(s, slack=0.0, prestretch=0.0)
    T = reference_period(s)
    t_end = max(times) + 2.0 * T
    first = impulse_responses(modal_damping(s, 0.0), peaks[-1:], t_end=T,
                              cache=cache)  # undamped A
    A = float(np.max(np.abs(first.tip)))
    rows = []
    for zeta in zetas:
        sd = modal_damping(s, zeta)
        for kind in ("slack", "prestretch"):
            for frac in fractions:
                if frac == 0.0 and kind == "prestretch":
                    continue
                sv = band_variant(sd, **{kind: frac * A})
                data = impulse_responses(sv, peaks, t_end=t_end, cache=cache)
                sup = superposition_check(data, T, side=sv.nonlinear[0].side)
                lags = phase_lags(data, times, T)
                rows.append({
                    "zeta": zeta, "kind": "none" if frac == 0.0 else kind, "fraction": frac,
                    "offset_in": frac * A, "amplitude_in": A, "period_s": T,
                    **sup, "lags": lags, "times": tuple(times), "data": data,
                })
    return rows


def _frequency_verdict(lags, tol: float = 0.01) -> str:
    """From the smallest load's lag (% of T) at the last time: "rises" with the load when
    it lags the baseline by more than ``tol`` %, "falls" when it leads, else "equal"."""
    lag = float(lags[0, -1])
    if abs(lag) < tol:
        return "equal"
    return "rises" if lag > 0 else "falls"


def markdown_table(rows) -> str:
    """The table of :func:`nonlinearity_table` in markdown (scaled values in in/(lbf·s))."""
    times = rows[0]["times"]
    head = ("| ζ | band | offset (in) | offset / A | away peak, 0.36 → 1.8 lbf | toward peak "
            "| RMS | deviation of 0.36 lbf | "
            + " | ".join(f"lag @ {t:g} s (% T)" for t in times)
            + " | scaled tip with load (away / toward / RMS) | first frequency with load |")
    sep = "|" + "---|" * (8 + len(times) + 2)
    lines = [head, sep]

    def pair(x):
        return f"{x[0]:.3f} → {x[-1]:.3f}"

    for r in rows:
        lines.append(
            f"| {100 * r['zeta']:g} % | {r['kind']} | {r['offset_in']:.4g} | {r['fraction']:g} "
            f"| {pair(r['away'])} | {pair(r['toward'])} | {pair(r['rms'])} "
            f"| {r['deviation'][0]:.2e} | "
            + " | ".join(f"{x:+.2f}" for x in r["lags"][0])
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


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())


def response_nonlinearity(structure: Structure, force, n_samples: int, dt: float) -> float:
    """‖W − W_twin‖_F / ‖W‖_F: how far the response to ``force`` is from the linear twin's
    (:meth:`Structure.linear_twin`) — the part of the truth no linear model of the twin's
    kind can reproduce, a method-free stand-in for the linearization error (the methods'
    own linearization error comes from a study run)."""
    W = simulate(structure, n_samples=n_samples, dt=dt, force=force, dof_histories=False).W
    Wl = simulate(structure.linear_twin(), n_samples=n_samples, dt=dt, force=force,
                  dof_histories=False).W
    return float(np.linalg.norm(W - Wl) / np.linalg.norm(W))
