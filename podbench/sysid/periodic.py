"""Periodic excitation: spectra over steady-state periods and the best linear approximation.

A multisine repeated over ``P`` periods of ``N`` samples puts all its power on a grid of
excited lines (DFT bins of one period); once the start-up transient has died out every
period of a linear response is the same, so the period-averaged spectra ``Ū(k)``, ``Ȳ(k)``
carry the steady state with the noise reduced ``P`` times. The *best linear approximation*
(BLA) of Pintelon & Schoukens (*System Identification: A Frequency Domain Approach*, 2nd
ed., 2012, Ch. 3–4) is the frequency response on the excited lines, ``Ĝ(k) = Ȳ(k)/Ū(k)``;
from several records (force levels) it is pooled by least squares,
``G(k) = Σ_l Ȳ_l(k) Ū_l(k)ᴴ (Σ_l Ū_l(k) Ū_l(k)ᴴ)⁻¹`` (one input: ``Σ Ȳ_l Ū_l* / Σ |Ū_l|²``).

What one multisine realization can and cannot separate:

* the **noise variance** of ``Ĝ`` (measurement noise and anything else that is not periodic)
  follows from the spread over the periods (:func:`noise_variance`);
* the **nonlinear distortions** are periodic: on a record of one realization they are the
  same in every period, so on the excited lines their stochastic part is inseparable from
  ``Ĝ`` (it enters as a bias that only other phase realizations would average out); they
  show, and are measured, on the non-excited lines (:func:`distortion_fractions`), where a
  linear system's steady state has nothing but noise.

Sampling: column ``j`` at ``t_j = j·Δt``; period ``p`` (counted from 0) holds samples
``p·N … (p+1)·N − 1``; line ``k`` is at ``k/(N·Δt)`` Hz. Units: ``G`` in (output unit) per
(input unit), e.g. (m/s²)/N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.errors import InputError

__all__ = ["steady_periods", "period_spectra", "excited_lines", "pooled_response",
           "noise_variance", "pooled_noise", "periodic_prediction", "distortion_fractions",
           "choose_lines", "period_kernel", "period_convolution", "input_rms",
           "interpolation_weights", "rational_poles", "LINE_THRESHOLD", "PeriodSpectra"]

LINE_THRESHOLD = 1e-3
"""A line is excited when its period-averaged input power is at least this fraction of the
strongest line's (30 dB). On the F-16 records the 267 excited lines lie within 7 dB of the
strongest and the strongest non-excited line 29–38 dB below the weakest excited one."""


def steady_periods(x: np.ndarray, period: int, transient: int, where: str) -> np.ndarray:
    """The whole steady-state periods of ``x`` (c × n) as an array (P, c, period).

    ``transient`` leading periods are dropped (the start-up); a remainder shorter than a
    period at the end is ignored. ``where`` names the record and field in the one-line
    error raised when fewer than one steady-state period remains.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    whole = n // period
    if whole < transient + 1:
        raise InputError(f"{where}: {n} samples hold {whole} whole period(s) of {period}; "
                         f"at least {transient + 1} are needed (the first "
                         f"{transient} is the start-up transient)")
    body = x[..., transient * period: whole * period]
    return body.reshape(x.shape[0], whole - transient, period).transpose(1, 0, 2)


@dataclass(frozen=True)
class PeriodSpectra:
    """DFT of every steady-state period of one record (one-sided, ``N//2 + 1`` lines).

    Attributes
    ----------
    U : (P, n_in, F) complex ndarray
        Input spectra per period.
    Y : (P, n_out, F) complex ndarray or None
        Output spectra per period (None: a target without outputs).
    """

    U: np.ndarray
    Y: np.ndarray | None

    @property
    def n_periods(self) -> int:
        return self.U.shape[0]

    @property
    def U_mean(self) -> np.ndarray:
        """``Ū`` (n_in, F): the period-averaged input spectrum."""
        return self.U.mean(axis=0)

    @property
    def Y_mean(self) -> np.ndarray | None:
        """``Ȳ`` (n_out, F), or None."""
        return None if self.Y is None else self.Y.mean(axis=0)


def period_spectra(u, y, period: int, transient: int, name: str = "record") -> PeriodSpectra:
    """:class:`PeriodSpectra` of inputs ``u`` (n_in × n) and outputs ``y`` (n_out × n or
    None) over their steady-state periods (:func:`steady_periods`)."""
    U = np.fft.rfft(steady_periods(u, period, transient, f"{name}: field `inputs`"), axis=2)
    Y = None if y is None else np.fft.rfft(
        steady_periods(y, period, transient, f"{name}: field `outputs`"), axis=2)
    return PeriodSpectra(U, Y)


def excited_lines(U_means, threshold: float = LINE_THRESHOLD) -> np.ndarray:
    """The lines (sorted DFT indices, DC excluded) whose period-averaged input power, summed
    over the inputs and over the records ``U_means`` (each (n_in, F)), is at least
    ``threshold`` × that of the strongest line."""
    power = sum(np.sum(np.abs(Um) ** 2, axis=0) for Um in U_means)
    power = np.asarray(power, dtype=float).copy()
    power[0] = 0.0  # the mean is no excitation
    top = float(np.max(power))
    if not top > 0:
        raise InputError("inputs: no excited line (the steady-state inputs are zero)")
    return np.flatnonzero(power >= threshold * top)


def pooled_response(U_means, Y_means, lines) -> np.ndarray:
    """The least-squares frequency response pooled over records on ``lines``:
    ``G(k) = Σ_l Ȳ_l Ū_lᴴ (Σ_l Ū_l Ū_lᴴ)⁺`` (n_out, n_in, L); with one input
    ``Σ Ȳ_l Ū_l* / Σ |Ū_l|²``. The pseudo-inverse leaves a line's direction that no record
    excites at zero (several inputs need as many records of independent input spectra)."""
    lines = np.asarray(lines)
    Syu = sum(np.einsum("ok,ik->kio", Ym[:, lines], np.conj(Um[:, lines]))
              for Um, Ym in zip(U_means, Y_means, strict=True))
    Suu = sum(np.einsum("ik,jk->kij", Um[:, lines], np.conj(Um[:, lines])) for Um in U_means)
    if Suu.shape[1] == 1:
        power = Suu[:, 0, 0].real
        dead = np.flatnonzero(power <= 1e-12 * np.max(power))  # round-off, not excitation
        if dead.size:
            raise InputError(f"Parameter `lines`: line {int(lines[dead[0]])} carries no "
                             "input power in the training records (nothing identifies it)")
        G = Syu / Suu  # (L, 1, n_out) / (L, 1, 1)
    else:
        G = np.linalg.pinv(Suu, hermitian=True) @ Syu  # (L, n_in, n_out)
    return G.transpose(2, 1, 0)


def noise_variance(spectra: PeriodSpectra, lines) -> np.ndarray:
    """Variance of ``Ĝ = Ȳ/Ū`` on ``lines`` from the spread over the periods (one input),
    (n_out, L): ``|Ĝ|²/P · (σ²_Y/|Ȳ|² + σ²_U/|Ū|² − 2 Re(σ²_YU/(Ȳ Ū*)))`` with the sample
    (co)variances over the ``P`` periods (Pintelon & Schoukens 2012, Sec. 2.5, first-order
    errors-in-variables). NaN with several inputs or a single period."""
    lines = np.asarray(lines)
    U, Y = spectra.U[:, :, lines], spectra.Y
    P = U.shape[0]
    if Y is None or U.shape[1] != 1 or P < 2:
        n_out = 0 if Y is None else Y.shape[1]
        return np.full((n_out, lines.size), np.nan)
    Y = Y[:, :, lines]
    u, y = U[:, 0, :], Y  # (P, L), (P, n_out, L)
    um, ym = u.mean(0), y.mean(0)
    du, dy = u - um, y - ym
    s_uu = np.sum(np.abs(du) ** 2, axis=0) / (P - 1)
    s_yy = np.sum(np.abs(dy) ** 2, axis=0) / (P - 1)
    s_yu = np.sum(dy * np.conj(du)[:, None, :], axis=0) / (P - 1)
    G = ym / um
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = (s_yy / np.abs(ym) ** 2 + s_uu / np.abs(um) ** 2
               - 2 * np.real(s_yu / (ym * np.conj(um))))
    return np.abs(G) ** 2 / P * np.maximum(rel, 0.0)


def periodic_prediction(G: np.ndarray, lines, U_mean: np.ndarray, period: int) -> np.ndarray:
    """One steady-state period of the response (n_out, period) to the period-averaged input
    spectrum ``U_mean`` (n_in, F): ``G(k)·Ū(k)`` on ``lines``, zero on every other line."""
    lines = np.asarray(lines)
    Yh = np.zeros((G.shape[0], period // 2 + 1), dtype=complex)
    Yh[:, lines] = np.einsum("oil,il->ol", G, U_mean[:, lines])
    return np.fft.irfft(Yh, n=period, axis=1)


def distortion_fractions(spectra: PeriodSpectra, lines) -> tuple[np.ndarray, np.ndarray]:
    """Per output: the share of the steady-state period-averaged output energy on the
    non-excited lines (the periodic nonlinear distortions, DC excluded), and the share the
    noise would leave there in the average of the ``P`` periods (its variance over the
    periods / ``P``). Both relative to the output's energy over all lines; square roots
    (RMS ratios), (n_out,) each."""
    Y = spectra.Y
    if Y is None:
        raise InputError("distortion_fractions: the record holds no outputs")
    P = Y.shape[0]
    other = np.ones(Y.shape[2], dtype=bool)
    other[np.asarray(lines)] = False
    other[0] = False
    ym = Y.mean(axis=0)
    total = np.sum(np.abs(ym) ** 2, axis=1)
    periodic = np.sum(np.abs(ym[:, other]) ** 2, axis=1)
    noise = np.sum(np.var(Y[:, :, other], axis=0, ddof=1), axis=1) / P if P > 1 else \
        np.full(Y.shape[1], np.nan)
    return np.sqrt(periodic / total), np.sqrt(noise / total)


def pooled_noise(spectra, lines) -> np.ndarray:
    """Noise variance of the pooled response (n_out, L): ``Σ_l w_l² var(Ĝ_l)`` with the
    pooling weights ``w_l = |Ū_l|²/Σ|Ū|²`` (one input)."""
    power = np.array([np.sum(np.abs(s.U_mean[:, lines]) ** 2, axis=0) for s in spectra])
    w = power / power.sum(axis=0)
    return sum(wl[None, :] ** 2 * noise_variance(s, lines)
               for wl, s in zip(w, spectra, strict=True))


def choose_lines(lines, U_means, period: int, threshold: float = LINE_THRESHOLD) -> np.ndarray:
    """The lines a frequency response is identified on: ``"auto"``, the excited ones
    (:func:`excited_lines` of the records' period-averaged input spectra ``U_means``), or
    the given increasing DFT indices in ``1 … period//2`` (checked: one line naming the
    parameter ``lines``)."""
    if isinstance(lines, str) and lines == "auto":
        return excited_lines(U_means, threshold)
    if isinstance(lines, str):
        raise InputError(f"Parameter `lines`: expected 'auto' or DFT line indices, got "
                         f"{lines!r}")
    out = np.asarray(lines)
    if out.ndim != 1 or out.size == 0 or out.dtype.kind not in "iu" or \
            out.min() < 1 or out.max() > period // 2 or np.any(np.diff(out) <= 0):
        raise InputError(f"Parameter `lines`: expected increasing indices in 1 … "
                         f"{period // 2}, got {lines!r}")
    return out


def period_kernel(G: np.ndarray, lines, period: int, dt: float) -> np.ndarray:
    """The kernel over one period ``H[p]`` (c, n_in, period) of a frequency response ``G``
    (c, n_in, L) on ``lines``: its inverse DFT over the period divided by ``Δt`` (the
    kernel of ``v = Δt Σ H u``, in (output unit)/(input unit·s)); zero on other lines."""
    full = np.zeros(G.shape[:2] + (period // 2 + 1,), dtype=complex)
    full[:, :, np.asarray(lines)] = G
    return np.fft.irfft(full, n=period, axis=2) / dt


def period_convolution(H: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    """``v[s] = Δt Σ_{p<N} H[p] u[s − p]`` (c × n) from rest: the *linear* convolution of
    the inputs ``u`` (n_in × n) with the kernel over one period (c, n_in, N), by FFT. In
    every period after the first it equals the circular one (the steady state)."""
    n = u.shape[1]
    nfft = 1 << int(np.ceil(np.log2(n + H.shape[2] - 1)))
    Uf = np.fft.rfft(u, nfft, axis=1)
    Hf = np.fft.rfft(H * dt, nfft, axis=2)
    return np.fft.irfft(np.einsum("kif,if->kf", Hf, Uf), nfft, axis=1)[:, :n]


def input_rms(u: np.ndarray, period: int, transient: int, where: str = "inputs") -> float:
    """RMS of inputs ``u`` (n_in × n) over their steady-state periods (all channels; the
    input unit, e.g. N): the force level a model of that record belongs to."""
    x = steady_periods(u, period, transient, where)
    return float(np.sqrt(np.mean(x ** 2)))


def interpolation_weights(levels, x: float, *, scale: str = "linear",
                          extrapolate: str = "clamp") -> np.ndarray:
    """Weights of piecewise-linear interpolation at ``x`` between the sorted, distinct
    ``levels``: the two neighbours of ``x`` share the weight by their distance (in ``x`` or,
    ``scale="log"``, in ``log x``). Outside the range ``extrapolate="clamp"`` gives the
    nearest level its whole weight, ``"linear"`` continues the end segment. One level: 1."""
    r = np.asarray(levels, dtype=float)
    w = np.zeros(r.size)
    if r.size == 1:
        w[0] = 1.0
        return w
    if scale == "log":
        r, x = np.log(r), float(np.log(x))
    if extrapolate == "clamp" and (x <= r[0] or x >= r[-1]):
        w[0 if x <= r[0] else -1] = 1.0
        return w
    i = int(np.clip(np.searchsorted(r, x), 1, r.size - 1))
    t = (x - r[i - 1]) / (r[i] - r[i - 1])
    w[i - 1], w[i] = 1.0 - t, t
    return w


def rational_poles(G: np.ndarray, freqs, *, n_poles: int = 2, iterations: int = 30,
                   tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray, float]:
    """The poles (rad/s) of a common-denominator rational fit of a frequency response.

    ``G`` (c, L): the responses of ``c`` channels at ``freqs`` (L, Hz). Each is fitted by
    ``N_c(p)/D(p)`` in ``p = jω/ω₀`` (``ω₀`` the band's centre), ``D`` monic of degree
    ``n_poles`` and real, every ``N_c`` real of the same degree (residual terms of the modes
    outside the band), by Sanathanan & Koerner's iteration (1963): the linear least-squares
    fit of ``N_c − G_c D`` weighted by ``1/|D|`` of the previous step, from ``D = 1``,
    until the denominator's coefficients change by less than ``tol`` (relative), at most
    ``iterations`` steps. The same modes at every channel: one denominator.

    Returns
    -------
    poles : (n_poles,) complex ndarray
        ``s = ω₀ p`` (rad/s) of the denominator's roots.
    residues : (c, n_poles) complex ndarray
        ``N_c(p_k)/D'(p_k)`` per channel and pole: the pole's shape at the channels (any
        scale; simple poles).
    misfit : float
        ``‖N/D − G‖ / ‖G‖`` over the channels and lines.
    """
    G = np.atleast_2d(np.asarray(G, dtype=complex))
    f = np.asarray(freqs, dtype=float)
    c, L = G.shape
    w0 = 2 * np.pi * 0.5 * (f[0] + f[-1])
    p = 1j * 2 * np.pi * f / w0
    n = int(n_poles)
    P = p[:, None] ** np.arange(n + 1)[None, :]  # (L, n+1): 1, p, …, p^n
    weight = np.ones(L)
    a = np.zeros(n)
    for _ in range(int(iterations)):
        # unknowns: the numerators' n+1 coefficients per channel, then a_0 … a_{n−1}
        A = np.zeros((c * L, c * (n + 1) + n), dtype=complex)
        b = np.zeros(c * L, dtype=complex)
        for ch in range(c):
            rows = slice(ch * L, (ch + 1) * L)
            A[rows, ch * (n + 1):(ch + 1) * (n + 1)] = P / weight[:, None]
            A[rows, c * (n + 1):] = -G[ch][:, None] * P[:, :n] / weight[:, None]
            b[rows] = G[ch] * P[:, n] / weight
        x = np.linalg.lstsq(np.vstack([A.real, A.imag]), np.concatenate([b.real, b.imag]),
                            rcond=None)[0]
        new = x[c * (n + 1):]
        done = np.linalg.norm(new - a) <= tol * max(np.linalg.norm(new), 1e-300)
        a = new
        weight = np.abs(P[:, :n] @ a + P[:, n])
        if done:
            break
    D = P[:, :n] @ a + P[:, n]
    num = np.stack([P @ x[ch * (n + 1):(ch + 1) * (n + 1)] for ch in range(c)])
    misfit = float(np.linalg.norm(num / D - G) / np.linalg.norm(G))
    den = np.concatenate([[1.0], a[::-1]])  # highest power first
    roots = np.roots(den)
    residues = np.stack([np.polyval(x[ch * (n + 1):(ch + 1) * (n + 1)][::-1], roots)
                         for ch in range(c)]) / np.polyval(np.polyder(den), roots)
    return w0 * roots, residues, misfit
