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
           "noise_variance", "periodic_prediction", "distortion_fractions", "LINE_THRESHOLD",
           "PeriodSpectra"]

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
