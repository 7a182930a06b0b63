"""Modes of an identified discrete state-space model, which of them are physical, and how they
match a reference set (the finite-element modes).

**Modes** (:func:`discrete_modes`): the eigenvalues ``λ`` of ``A`` (one per complex
conjugate pair, ``Im λ > 0``) mapped to continuous time, ``s = ln λ / Δt``, and the shapes
``C ψ`` at the output channels (:mod:`podbench.core.modeshapes`: frequency ``|s|/2π``,
damping ratio ``−Re s/|s|``, real phase-aligned shape). ``ln`` is the map of sampled
continuous signals (a record of a continuous structure holds ``λ = e^{sΔt}`` whatever the
hold of its inputs); records simulated by podbench's Newmark hold the trapezoidal map of
the structure's poles instead, which :func:`podbench.dynamics.modes.fe_modes` with ``dt``
gives for the comparison.

**One pole, one mode.** A realization may hold one pole several times, in two ways: a pole
model fitted per input (``"subspace"``, ``"realization"``: every input's response shares
the poles) has a residue of rank up to the number of inputs at each pole, and ERA realizes
that pole once per rank; and a diagonal kernel or free decay (SL, MR, POVR: one SISO
sequence per POC) holds a pole once per POC whose sequence carries it, which every POC's
does where the POMs are not the normal modes (the diagonalization error of the
dissertation's §3.6). Either way the model, a linear system, has one pole there whose
residue has rank above one: one mode of the identified model, since a structure has one
pole at that frequency. Its copies agree to round-off (1e-12 to 1e-9 of ``|λ|``
measured, Chapter 4's beams) and eig's vectors of a repeated eigenvalue are any basis of
its eigenspace (or, for a diagonal realization, one POM per copy), so each copy's ``C ψ``
is an arbitrary mixture or one POC's share. Given the input map ``B`` (or a free model's
initial-state map), eigenvalues within :data:`SAME_POLE_RTOL` of the spectral radius of
each other are one mode whose shape is the first left singular vector of the pole's residue
``C P B`` (``P`` the spectral projector of the copies: invariant to the basis eig chose),
the shape that explains most of the pole's response at the outputs (the polyreference
practice: a rank-one residue per mode). A pole held once keeps its ``C ψ``; distinct poles
stay distinct however close. The dissertation derives no modes from the identified models
(its comparisons are of responses), so this is podbench's reading; the former reading,
every copy a mode of its own shape, is :func:`discrete_modes` without ``B``
(:meth:`podbench.sysid.realize.StateSpaceModel.all_modes`).

**Physical modes** (:func:`physical_modes`), the hard criteria: ``0 < f < f_Nyquist = 1/(2Δt)``
and ``0 ≤ ζ < 1`` (real poles are not modes); and the soft criterion of a stabilization
diagram, as SSI practice states it (pyOMA2's ``SC_apply``, after Reynders, Houbrechts & De
Roeck 2012; Juang & Pappa's ERA users read the same diagram): a mode is *stable* when the
realizations of the same Markov parameters at higher orders hold a pole that differs by at
most :data:`STABILITY` — 1 % in frequency, 5 % in damping ratio (relative), MAC at least
0.97 (pyOMA2's defaults ``err_fn = 0.01``, ``err_xi = 0.05``, ``err_phi = 0.03``) — from
it, the pole of nearest frequency at each of those orders. podbench compares the model's
order ``N`` with ``N + 2`` and ``N + 4`` (:data:`STABILITY_ORDERS`): a physical mode
persists as the order grows, a computational one (noise, model error) moves or vanishes;
comparing with lower orders instead would drop the weakest physical mode of an exact model
(at ``N − 2`` it is gone). Modes that fail are left out of the modes table; how many is
stated in its notes. Where the model comes with no realization at other orders (a solver's
own pole model, whose order its hold-out rule chose) only the hard criteria apply, said so.

**Matching** (:func:`match_modes`): identified modes are paired with reference modes by MAC,
not by index: the assignment that maximizes the total MAC (Hungarian algorithm,
:func:`scipy.optimize.linear_sum_assignment`) among pairs with ``MAC ≥ mac_floor``
(:data:`MAC_FLOOR`); a reference mode without a partner above the floor is reported
unmatched. MACs are compared in steps of :data:`MAC_TIE` (the MAC's own digits as the tables
write them) and, within a step, the pair nearer in frequency (smaller ``|ln(f_id/f)|``)
wins (``rule="mac-frequency"``, the default): a model whose modes share one shape (SL's and
POVR's diagonal kernels realize every pole of a POC with that POM's shape) has several
poles at the same MAC with a reference mode, and MAC alone would pick any of them, often
one of another mode's frequency. A pair more than one step higher in MAC still wins over
a nearer frequency: the MAC decides, the frequency only orders its ties. The named variant
``rule="mac"`` is MAC alone (``1 − MAC`` as the assignment's cost, ties as the solver
meets them).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)

from podbench.core.modeshapes import ModeSet, frequency_damping, mac
from podbench.errors import DimensionError, InputError
from podbench.sysid.periodic import rational_poles

__all__ = ["discrete_modes", "physical_mask", "stability_mask", "physical_modes",
           "match_modes", "response_fit", "response_modes", "STABILITY", "STABILITY_ORDERS",
           "MAC_FLOOR", "MAC_TIE", "MATCH_RULES", "ZETA_ROUNDOFF", "RESPONSE_POLES",
           "SAME_POLE_RTOL"]

STABILITY = {"frequency": 0.01, "damping": 0.05, "mac": 0.97}
"""The stabilization criterion (module docstring): largest relative frequency difference,
largest relative damping-ratio difference, smallest MAC between a mode and its counterpart
at another order (pyOMA2's defaults)."""

STABILITY_ORDERS = (2, 4)
"""Orders above the model's at which a mode must persist to be stable."""

MAC_FLOOR = 0.5
"""Smallest MAC of a matched pair: below it an identified mode shares less than half of its
shape (in the MAC's sense) with the reference mode, and is not called the same mode."""

MAC_TIE = 1e-3
"""MAC step of the matching (``rule="mac-frequency"``): MACs within one step are a tie (the
MAC's own digits as the tables write them, 4 decimals, with a margin)."""

SAME_POLE_RTOL = 1e-8
"""Eigenvalues of ``A`` closer than this times its spectral radius are one pole held several
times (module docstring, *One pole, one mode*): copies of a shared pole differ by round-off
(about 1e-12), while two physical modes that close (at ``Δt`` = 1 ms, 1.6e-6 Hz apart) are
far below any record's frequency resolution ``1/T``."""

MATCH_RULES = ("mac", "mac-frequency")
"""The matching rules of :func:`match_modes` (module docstring)."""


def discrete_modes(A, C, dt: float, channels: Sequence[str] | None = None, *,
                   B=None, source: str = "") -> ModeSet:
    """All oscillatory modes of ``x_{j+1} = A x_j``, ``y_j = C x_j`` sampled at ``dt`` (s):
    the eigenvalues with ``Im λ > 0`` as ``s = ln λ / Δt`` and their shapes ``C ψ``.

    Parameters
    ----------
    A : (N, N) array_like
    C : (m, N) array_like
    dt : float
        Sampling interval (s).
    channels : sequence of str, optional
        Names of the ``m`` outputs (default ``"0"``, ``"1"``, …).
    B : (N, n_in) array_like, optional
        The input map (a free model's initial-state map): a pole held several times is then
        one mode, its shape from the residue (module docstring, *One pole, one mode*).
        Without it every eigenvalue is a mode.
    """
    A = np.asarray(A, dtype=float)
    C = np.asarray(C, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or C.ndim != 2 or C.shape[1] != A.shape[0]:
        raise DimensionError(f"discrete_modes: A {A.shape} must be square and C {C.shape} "
                             "have as many columns")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"Parameter `dt`: expected a positive sampling interval (s), got {dt!r}")
    names = tuple(str(c) for c in channels) if channels is not None else \
        tuple(str(i) for i in range(C.shape[0]))
    if len(names) != C.shape[0]:
        raise DimensionError(f"Parameter `channels`: {len(names)} names for {C.shape[0]} "
                             "outputs")
    if A.size == 0:
        return ModeSet(np.zeros(0), np.zeros((C.shape[0], 0)), names, source)
    lam, V = np.linalg.eig(A)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    up = lam.imag > 1e-12 * scale
    n_real = int(np.sum(~up & (np.abs(lam.imag) <= 1e-12 * scale)))
    notes = (f"{n_real} real poles (no oscillation) are not modes",) if n_real else ()
    lam_up, shapes = lam[up], C @ V[:, up]
    if B is not None:
        lam_up, shapes, merged = _one_mode_per_pole(lam_up, shapes, V, up, B, scale)
        if merged:
            notes += (f"{merged} repeated copies of poles held more than once (one per rank "
                      "of the residue, or one per POC of a diagonal kernel) merged: one mode "
                      "each, its shape from the residue",)
    return ModeSet(np.log(lam_up) / dt, shapes, names, source, notes)


def _one_mode_per_pole(lam_up, shapes, V, up, B, scale):
    """``(λ, shapes, n_merged)``: the eigenvalues ``lam_up`` within
    :data:`SAME_POLE_RTOL` ``× scale`` of each other as one pole (their mean), its shape the
    first left singular vector of the residue ``C V_c (V⁻¹B)_c`` scaled by its singular value
    (module docstring, *One pole, one mode*); single poles unchanged."""
    n = lam_up.size
    groups: list[list[int]] = []
    for i in range(n):
        for g in groups:
            if abs(lam_up[g[0]] - lam_up[i]) <= SAME_POLE_RTOL * scale:
                g.append(i)
                break
        else:
            groups.append([i])
    if all(len(g) == 1 for g in groups):
        return lam_up, shapes, 0
    WB = np.linalg.solve(V, np.asarray(B, dtype=float).astype(complex))[up]
    lam_out, cols = [], []
    for g in sorted(groups, key=min):
        if len(g) == 1:
            lam_out.append(lam_up[g[0]])
            cols.append(shapes[:, g[0]])
            continue
        R = shapes[:, g] @ WB[g]
        u, sv, _ = np.linalg.svd(R, full_matrices=False)
        lam_out.append(np.mean(lam_up[g]))
        cols.append(u[:, 0] * sv[0])
    merged = n - len(groups)
    return np.asarray(lam_out), np.column_stack(cols), merged


ZETA_ROUNDOFF = 1e-6
"""Damping ratios within this of zero are zero to round-off: an undamped structure's poles
identified from exact records lie on the unit circle to about ``1e-9``, on either side. The
hard criterion reads ``ζ ≥ −ZETA_ROUNDOFF``, and the stabilization criterion's damping
difference is met when within ``max(5 % of ζ, ZETA_ROUNDOFF)``."""


def physical_mask(modes: ModeSet, dt: float) -> np.ndarray:
    """The hard criteria: ``0 < f < 1/(2Δt)`` and ``0 ≤ ζ < 1`` (module docstring; ``ζ``
    within :data:`ZETA_ROUNDOFF` of zero counts as zero)."""
    f, z = frequency_damping(modes.poles)
    return (f > 0) & (f < 0.5 / dt) & (z >= -ZETA_ROUNDOFF) & (z < 1)


def _counterpart_ok(f0, z0, phi0, other: ModeSet, crit: dict) -> bool:
    if len(other) == 0:
        return False
    f, z = frequency_damping(other.poles)
    j = int(np.argmin(np.abs(f - f0)))
    if abs(f[j] - f0) > crit["frequency"] * f0:
        return False
    if abs(z[j] - z0) > max(crit["damping"] * abs(z0), ZETA_ROUNDOFF):
        return False
    return bool(mac(phi0[:, None], other.shapes[:, j : j + 1])[0, 0] >= crit["mac"])


RESPONSE_POLES = 24
"""Poles of the rational fit of a frequency response on its lines (:func:`response_modes`):
twelve modes over the band (the F-16 study's 2-15 Hz; its verdict over 16-32 poles is in
docs/studies/f16_gvt.md)."""


def response_fit(G, f, n_poles: int, channels, cache: dict | None = None,
                 source: str = "rational fit of the frequency response"):
    """``(modes, misfit)``: the upper-half-plane poles of the common-denominator rational
    fit of ``G`` (c, L) on the lines ``f`` (Hz) with ``n_poles`` poles
    (:func:`~podbench.sysid.periodic.rational_poles`) as a :class:`ModeSet` over
    ``channels``, and ``‖N/D − G‖/‖G‖``. ``cache``: pole count → fit, read and added to."""
    if cache is not None and n_poles in cache:
        return cache[n_poles]
    poles, residues, misfit = rational_poles(G, f, n_poles=n_poles)
    up = poles.imag > 0
    out = ModeSet(poles[up], residues[:, up], channels, source), misfit
    if cache is not None:
        cache[n_poles] = out
    return out


def response_modes(G, f, dt: float, channels, n_poles: int = RESPONSE_POLES,
                   cache: dict | None = None,
                   source: str = "rational fit of the frequency response"):
    """``(modes, misfit, rule)``: the modes of a frequency response ``G`` (c, L) on the
    lines ``f`` (Hz), sampled at ``dt`` (s): the poles of its rational fit with
    ``n_poles`` poles (:func:`response_fit`) that are physical (:func:`physical_mask`) and
    stable against the fits with :data:`STABILITY_ORDERS` more poles
    (:func:`stability_mask`); ``rule`` says so in words."""
    modes, misfit = response_fit(G, f, n_poles, channels, cache, source)
    modes = modes.subset(physical_mask(modes, dt))
    others = [response_fit(G, f, n_poles + step, channels, cache, source)[0]
              for step in STABILITY_ORDERS]
    modes = modes.subset(stability_mask(modes, others))
    more = ", ".join(str(n_poles + step) for step in STABILITY_ORDERS)
    rule = (f"{source}: {n_poles} poles over {f[0]:g}-{f[-1]:g} Hz (misfit {misfit:.3g}); "
            f"the physical modes stable against {more} poles")
    return modes, misfit, rule


def stability_mask(modes: ModeSet, others: Sequence[ModeSet],
                   criteria: dict | None = None) -> np.ndarray:
    """Which of ``modes`` are stable against every mode set of ``others`` (the same Markov
    parameters realized at other orders): the pole of nearest frequency in each differs by
    at most ``criteria`` (default :data:`STABILITY`)."""
    crit = {**STABILITY, **(criteria or {})}
    f, z = frequency_damping(modes.poles)
    out = np.ones(len(modes), dtype=bool)
    for i in range(len(modes)):
        out[i] = all(_counterpart_ok(f[i], z[i], modes.shapes[:, i], o, crit) for o in others)
    return out


def physical_modes(A, C, dt: float, channels: Sequence[str] | None = None, *,
                   realize_at: Callable[[int], tuple] | None = None,
                   criteria: dict | None = None, source: str = "", B=None) -> ModeSet:
    """The physical modes of a discrete model (module docstring): the hard criteria, then
    stability at the orders ``N + 2`` and ``N + 4`` realized by ``realize_at(order) -> (A,
    C)`` or ``(A, C, B)`` (None: the hard criteria only). With the input map ``B`` a pole
    held several times is one mode (*One pole, one mode*; the other orders' likewise when
    ``realize_at`` gives their ``B``). The mode set's ``stable`` flags are all True; its
    notes state the rule and what was left out."""
    every = discrete_modes(A, C, dt, channels, B=B, source=source)
    hard = physical_mask(every, dt)
    notes = list(every.notes)
    if np.any(~hard):
        notes.append(f"{int(np.sum(~hard))} modes outside 0 < f < {0.5 / dt:g} Hz (Nyquist) "
                     "or 0 ≤ ζ < 1 left out")
    modes = every.subset(hard)
    N = np.asarray(A).shape[0]
    others = []
    if realize_at is not None:
        for step in STABILITY_ORDERS:
            try:
                Ah, Ch, *Bh = realize_at(N + step)
            except InputError:
                break
            if np.asarray(Ah).shape[0] != N + step:
                break
            others.append(discrete_modes(Ah, Ch, dt, modes.channels,
                                         B=Bh[0] if Bh and B is not None else None))
    crit = {**STABILITY, **(criteria or {})}
    if others:
        stable = stability_mask(modes, others, crit)
        rule = (f"stable at orders {', '.join(str(N + s) for s in STABILITY_ORDERS[:len(others)])}"
                f" (model order {N}): frequency within {crit['frequency']:.0%}, damping ratio "
                f"within {crit['damping']:.0%}, MAC ≥ {crit['mac']:g}")
        notes.append(rule + (f"; {int(np.sum(~stable))} unstable (computational) modes left "
                             "out" if np.any(~stable) else ""))
        modes = modes.subset(stable)
    else:
        notes.append(f"no realization at orders above {N}: the hard criteria only")
    return ModeSet(modes.poles, modes.shapes, modes.channels, source, tuple(notes),
                   np.ones(len(modes), dtype=bool))


def match_modes(identified: ModeSet, reference: ModeSet, *,
                mac_floor: float = MAC_FLOOR, rule: str = "mac-frequency") -> pd.DataFrame:
    """Pair identified modes with reference modes by MAC (module docstring; ``rule``:
    ``"mac-frequency"``, MAC ties broken by frequency, or the variant ``"mac"``, MAC
    alone).

    Returns
    -------
    DataFrame
        One row per reference mode (sorted by frequency): ``mode`` (1, 2, …),
        ``frequency_hz``, ``damping_ratio`` (the reference's), ``identified`` (the matched
        identified mode's row number in its table, 1-based; NaN when unmatched),
        ``identified_frequency_hz``, ``identified_damping_ratio``, ``frequency_error_pct``
        (``100·(f_id − f)/f``), ``damping_error`` (``ζ_id − ζ``), ``damping_error_rel``
        (``(ζ_id − ζ)/ζ``; NaN for ``ζ = 0``) and ``mac``.
    """
    if identified.channels != reference.channels:
        raise InputError(f"match_modes: the identified modes' channels {list(identified.channels)}"
                         f" differ from the reference's {list(reference.channels)}")
    if rule not in MATCH_RULES:
        raise InputError(f"Parameter `rule`: expected one of {list(MATCH_RULES)}, got {rule!r}")
    M = mac(identified.shapes, reference.shapes)  # (n_id, n_ref)
    rows = np.full(len(reference), -1)
    if M.size:
        cost = np.where(M >= mac_floor, 1.0 - M, 2.0)
        if rule == "mac-frequency":  # MAC in steps of MAC_TIE, then the nearer frequency
            with np.errstate(divide="ignore", invalid="ignore"):
                gap = np.abs(np.log(identified.frequency_hz[:, None]
                                    / reference.frequency_hz[None, :]))
            near = np.where(np.isfinite(gap), gap / (1.0 + gap), 1.0)  # orders a step's pairs
            cost = np.where(M >= mac_floor, np.floor((1.0 - M) / MAC_TIE) + near,
                            2.0 / MAC_TIE + 1.0)
        r_id, r_ref = scipy.optimize.linear_sum_assignment(cost)
        for i, j in zip(r_id, r_ref, strict=True):
            if M[i, j] >= mac_floor:
                rows[j] = i
    f, z = reference.frequency_hz, reference.damping_ratio
    fi, zi = identified.frequency_hz, identified.damping_ratio
    hit = rows >= 0
    idx = np.where(hit, rows, 0)
    nan = np.full(len(reference), np.nan)
    f_id = np.where(hit, fi[idx] if len(identified) else nan, nan)
    z_id = np.where(hit, zi[idx] if len(identified) else nan, nan)
    m = np.where(hit, M[idx, np.arange(len(reference))] if M.size else nan, nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(z != 0, (z_id - z) / np.where(z != 0, z, 1.0), np.nan)
    return pd.DataFrame({"mode": np.arange(1, len(reference) + 1), "frequency_hz": f,
                         "damping_ratio": z, "identified": np.where(hit, rows + 1.0, np.nan),
                         "identified_frequency_hz": f_id, "identified_damping_ratio": z_id,
                         "frequency_error_pct": 100.0 * (f_id - f) / f,
                         "damping_error": z_id - z, "damping_error_rel": rel, "mac": m})
