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

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from podbench.dynamics import simulate
from podbench.dynamics.excitations import Pulse
from podbench.dynamics.newmark import newmark_batch
from podbench.errors import InputError
from podbench.harness.cache import TruthCache, structure_fingerprint
from podbench.harness.executor import execute
from podbench.harness.progress import as_stage
from podbench.structures import OneSidedSpring, Structure
from podbench.structures.beam import modal_damping_matrix
from podbench.structures.files import load_structure
from podbench.study.nonlinearity import NonlinearitySpec

__all__ = [
    "PEAKS", "PULSE_DURATION", "LOCATION", "DT", "LAG_TIMES", "LAG_TIMES_SCALED",
    "FRACTIONS", "band_variant", "modal_damping", "reference_period", "impulse_responses",
    "superposition_check", "phase_lag", "phase_lags", "nonlinearity_table", "run_checks",
    "ImpulseSet", "response_nonlinearity", "check_task", "check_tasks", "check_rows",
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

    n = int(round(t_end / dt)) + 1
    fp = structure_fingerprint(structure) if cache is not None else ""
    tips: list = [None] * len(peaks)
    imps: list = [None] * len(peaks)
    keys, todo = [], []
    for i, p in enumerate(peaks):
        key = TruthCache.key(what="nonlinearity.impulse_responses", structure=fp,
                             peak=float(p), duration=float(duration),
                             location=float(location), n=n, dt=float(dt),
                             scheme="newmark-propagator-batch")
        keys.append(key)
        hit = cache.load(key, (1, n)) if cache is not None else None
        if hit is not None:  # W: the tip row; F: the impulse (lbf·s) in every entry
            tips[i], imps[i] = hit["W"][0], float(hit["F"][0, 0])
        else:
            todo.append(i)
    if todo:
        F = np.stack([Pulse(location, float(peaks[i]), duration, shape="half_sine")
                      .sample(structure, n, dt) for i in todo])
        for i, Fi, tip in zip(todo, F, _tip_responses(structure, F, dt), strict=True):
            tips[i], imps[i] = tip, float(Fi.sum() * dt)
            if cache is not None:
                cache.store(keys[i], {"W": tip[None, :], "F": np.full((1, n), imps[i]),
                                      "w0": np.zeros(1), "v0": np.zeros(1),
                                      "t": np.arange(n) * dt})
    return ImpulseSet(t=np.arange(n) * dt, peaks=tuple(float(p) for p in peaks),
                      impulses=np.array(imps), tip=np.array(tips))


def _tip_responses(structure: Structure, F: np.ndarray, dt: float) -> np.ndarray:
    """The tip sensor's displacement (in) from rest under each of the sensor loads ``F``
    (runs, sensors, samples; lbf): the Newmark integration of
    :func:`podbench.dynamics.simulate`, with the linear part stepped by its transition matrix
    and the runs stepped together (:func:`podbench.dynamics.newmark.newmark_batch`: one
    matrix product per step for all of them, each run's own Newton iteration; equal to
    single runs to round-off), recording the last sensor only: (runs, samples)."""
    S = structure.sensor_matrix()
    return newmark_batch(structure, F, dt, force_map=S.T, record=S[-1:])[:, 0, :]


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
        s0, s1 = int(starts[0]), int(starts[-1]) + 1  # consecutive: one slice of ``sig``
        corr = (np.correlate(sig[s0:s1 + 2 * half], r, "valid")
                / (norms[s0:s1] * np.linalg.norm(r) + 1e-300))
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


def response_nonlinearity(structure: Structure, force, n_samples: int, dt: float) -> float:
    """‖W − W_twin‖_F / ‖W‖_F: how far the response to ``force`` is from the linear twin's
    (:meth:`Structure.linear_twin`) — the part of the truth no linear model of the twin's
    kind can reproduce, a method-free stand-in for the linearization error (the methods'
    own linearization error comes from a study run)."""
    W = simulate(structure, n_samples=n_samples, dt=dt, force=force, dof_histories=False).W
    Wl = simulate(structure.linear_twin(), n_samples=n_samples, dt=dt, force=force,
                  dof_histories=False).W
    return float(np.linalg.norm(W - Wl) / np.linalg.norm(W))


def check_task(args) -> list[dict]:
    """One task of :func:`run_checks`: ``(structure name, ζ, fraction, cache folder)``."""
    structure, zeta, frac, cache_dir = args
    return nonlinearity_table(load_structure(structure), fractions=(frac,), zetas=(zeta,),
                              cache=TruthCache(cache_dir) if cache_dir is not None else None)


_ORDER = {"none": 0, "slack": 1, "prestretch": 2}


def check_tasks(spec: NonlinearitySpec, cache_dir=None) -> list[tuple]:
    """The tasks of :func:`run_checks` for :func:`check_task`, one per (ζ, fraction)."""
    return [(spec.structure, z, f, None if cache_dir is None else str(cache_dir))
            for z in spec.zetas for f in spec.fractions]


def check_rows(parts) -> list[dict]:
    """The rows of :func:`run_checks` from its tasks' results, in a fixed order: ζ, then the
    band's own row, the slacks and the pre-stretches by fraction."""
    rows = [r for part in parts for r in part]
    return sorted(rows, key=lambda r: (r["zeta"], _ORDER[r["kind"]], r["fraction"]))


def run_checks(spec: NonlinearitySpec, *, jobs: int = 1, progress=None,
               cache_dir=None) -> list[dict]:
    """The rows of :func:`~podbench.harness.nonlinearity.nonlinearity_table` for ``spec``, one
    task per (ζ, fraction) (``jobs`` processes; ``progress`` as
    :func:`podbench.harness.progress.as_stage`; ``cache_dir``: the truth cache's folder, the
    2.2-s responses are read back exactly on a rerun), in the order of :func:`check_rows`."""
    tasks = check_tasks(spec, cache_dir)
    with as_stage(progress, "nonlinearity checks", len(tasks), "task") as stage:
        parts = execute(check_task, tasks, jobs=jobs, progress=lambda *_: stage.advance())
    return check_rows(parts)
