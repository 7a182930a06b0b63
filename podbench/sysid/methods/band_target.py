"""The target's own difficulty, for the error estimate and band of a prediction.

A linear identification method predicts a target as a combination of its training records:
MDS exactly (``Ŵ = U Σ_l c_l Uᵀ ˡW`` with ``c = V̂0⁺ Uᵀ w̃0``, Eqs. 3.27–3.29), ML frequency
by frequency (``V̂(f) = Σ_l c_l(f) ˡV̂(f)`` with ``c(f) = Q(f)⁺ q̃(f)``, Eqs. 3.48–3.49 in
the frequency domain, the modal forces ``Q = [ˡq …]``), the input/output methods likewise
with the measured inputs. The coefficients ``c`` are computed here from the excitations
alone (what the method sees of a record: ``Uᵀw0``, ``UᵀF``, the inputs ``u``), for a
target and, leaving each training record out, for every fold. Three terms follow
(:class:`TargetTerms`), each computable before the truth is known:

* **leverage** ``Λ² = Σ_f Σ_l |c_l(f)|² ‖ˡV̂(f)‖² / Σ_f ‖Σ_l c_l(f) ˡV̂(f)‖²``: how large a
  combination of training responses the prediction is made of, relative to the prediction
  (1 for a target equal to a training record; large when the prediction is a difference of
  large, nearly cancelling parts). An error of each training record proportional to its
  response (noise per channel, the part of it no k-mode model explains) reaches the
  prediction multiplied by ``Λ``;
* **blind spot** ``Δ² = Σ_f ‖x̃(f) − Σ_l c_l(f) ˡx(f)‖² / Σ_f ‖Uᵀx̃(f)‖²``: the part of the
  target's excitation in the sensors' full space (``w̃0``, ``F̃``) that the combination
  matching its modal excitation ``Uᵀx̃`` leaves over, relative to that modal excitation. It
  lies outside the basis (the modal parts match), the method cannot see it, and the
  structure responds to it, in the basis (coupling) and outside it; with point loads at
  new positions it grows with the leverage and with how little of the load the basis
  holds (a load near a clamp). Where the basis spans the loads' space (every sensor a
  mode, or loads the records span) it is exactly 0, and what is computed is the round-off
  of the coefficient solve: a ``Δ²`` below :func:`roundoff_floor` is returned as 0;
* **projection share** ``ρ = ‖(I − UUᵀ) w̃0‖/‖w̃0‖`` of an initial displacement: the
  prediction's exact relative error at ``t = 0`` (the prediction lies in the span of
  ``U``, the truth starts at ``w̃0``).

How large an error each unit of ``Λ`` and ``Δ`` brings is not known from theory: it is
calibrated on the folds (:mod:`podbench.sysid.methods.bands`), whose realized errors are
known without the truth. Nothing here reads a target's response.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["TargetTerms", "Excitations", "excitations", "target_terms", "fold_terms",
           "roundoff_floor", "RCOND"]

RCOND = 1e-6
"""Singular values of the training excitations below ``RCOND`` × the largest (over all
frequencies) are treated as zero in ``c = X⁺ x̃``: a frequency at which no training record
is excited contributes nothing that the records could express."""

COEFFICIENT_ROUTE = "qr"
"""How ``c = E⁺e`` is computed for bins of several excitation rows: ``"qr"``
(:func:`_coefficients_qr`, where its bounds prove the SVD's cut keeps every singular value
of a bin or none, else the SVD) or ``"svd"`` (the batched SVD of every bin: the same
numbers at a higher cost, docs/bands.md *Cost*). The two differ in ``c`` at round-off
only, and nothing downstream reads round-off: a blind spot at or below
:func:`roundoff_floor` is 0."""


@dataclass(frozen=True)
class TargetTerms:
    """The target's difficulty relative to the training records (module docstring).

    ``leverage2`` (Λ²), ``blind2`` (Δ²) and ``rho`` (ρ; None when the excitation is not an
    initial displacement) are dimensionless."""

    leverage2: float
    blind2: float
    rho: float | None = None


@dataclass
class Excitations:
    """What the leverage needs of a set of records in one basis: per record the modal
    excitation ``E`` (B, p), the full-space excitation ``X`` (B, m) or None, and the
    response in the basis ``R`` (B, q), over B frequency bins (one for a free response)."""

    E: np.ndarray  # (B, p, N)
    X: np.ndarray | None  # (B, m, N)
    R: np.ndarray  # (B, q, N)
    nfft: int


def _inputs(record):
    """The excitation history of a forced or input/output record (F or u)."""
    for name in ("F", "u"):
        v = getattr(record, name, None)
        if v is not None:
            return np.asarray(v, dtype=float)
    return None


def _outputs(record):
    for name in ("W", "y"):
        v = getattr(record, name, None)
        if v is not None:
            return np.asarray(v, dtype=float)
    return None


def _initial(model, record):
    """The initial profile a free-response method reads (``w0`` or ``v0``), with
    ``W[:, 0]`` for a displacement record without ``w0``."""
    name = "v0" if getattr(model, "excitation", "displacement") == "velocity" else "w0"
    x = getattr(record, name, None)
    if x is None and name == "w0":
        W = _outputs(record)
        x = None if W is None else W[:, 0]
    return None if x is None else np.asarray(x, dtype=float).ravel()


def kind_of(model) -> str:
    """``"free"``, ``"forced"``, ``"io"`` or ``""`` (no target terms: mixed responses)."""
    kind = getattr(model, "excitation_kind", "")
    return kind if kind in ("free", "forced", "io") else ""


def _one(model, record, U: np.ndarray, nfft: int, *, response: bool):
    """``(E, X, R)`` of one record in the basis ``U``: E (B, p), X (B, m) or None,
    R (B, q) or None (``response=False``: a target)."""
    kind = kind_of(model)
    if kind == "free":
        x = _initial(model, record)
        if x is None:
            return None
        R = None
        if response:
            R = (U.T @ _outputs(record)).reshape(1, -1)
        return (U.T @ x)[None, :], x[None, :], R
    F = _inputs(record)
    if F is None:
        return None
    R = np.fft.rfft(U.T @ _outputs(record), n=nfft, axis=1).T if response else None
    if kind == "forced" and F.shape[0] == U.shape[0]:
        return np.fft.rfft(U.T @ F, n=nfft, axis=1).T, np.fft.rfft(F, n=nfft, axis=1).T, R
    # inputs elsewhere than at the outputs: the inputs themselves are the excitation
    return np.fft.rfft(F, n=nfft, axis=1).T, None, R


def excitations(model, records, U) -> Excitations | None:
    """The excitations and responses of ``records`` in the basis ``U`` (None when the
    method has no target terms or a record lacks its excitation)."""
    if not kind_of(model):
        return None
    U = np.asarray(U, dtype=float)
    n = max(_outputs(r).shape[1] for r in records)
    nfft = 2 * n  # zero-padded: the products are linear convolutions, not circular
    parts = [_one(model, r, U, nfft, response=True) for r in records]
    if any(p is None for p in parts):
        return None
    shapes = {(p[0].shape, p[2].shape) for p in parts}
    if len(shapes) != 1:
        return None  # records of different lengths (measured records): no common bins
    X = None if parts[0][1] is None else np.stack([p[1] for p in parts], -1)
    return Excitations(np.stack([p[0] for p in parts], -1), X,
                       np.stack([p[2] for p in parts], -1), nfft)


def _coefficients(E: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``c = E⁺ e`` per bin (B, N), singular values below :data:`RCOND` × the largest of
    all bins dropped.

    With one excitation row per bin (one input, one mode) the pseudo-inverse has a closed
    form: a 1 × N matrix ``E_b`` has the single singular value ``‖E_b‖`` and the
    minimum-norm solution of ``E_b c = e_b`` is ``c = E_bᴴ e_b / ‖E_b‖²`` — the same
    numbers as the SVD's, without a batched decomposition of every bin."""
    if E.shape[1] == 1:
        return _coefficients_one_row(E[:, 0, :], e[:, 0])
    c = _coefficients_qr(E, e) if COEFFICIENT_ROUTE == "qr" else None
    return _coefficients_svd(E, e) if c is None else c


def _coefficients_qr(E: np.ndarray, e: np.ndarray) -> np.ndarray | None:
    """``c = E⁺ e`` per bin through a batched QR, where the bounds below prove that the
    SVD's cut (:data:`RCOND` × the largest singular value of all bins) keeps every singular
    value of a bin or none; None otherwise (the SVD decides).

    ``top``, the largest singular value of all bins, lies between ``F/√r`` and ``F``,
    ``F`` the largest Frobenius norm of a bin and ``r = min(p, N)``. A bin whose norm is at
    most ``RCOND·F/√r`` has no singular value above the cut: its ``c`` is 0. Of ``E_bᴴ =
    QR`` (p ≤ N) or ``E_b = QR`` (p > N) the smallest singular value is at least
    ``1/‖R⁻¹‖_F``; where that exceeds ``RCOND·F`` the bin has full rank above the cut and
    its minimum-norm solution is ``Q R⁻ᴴ e_b`` (wide) or ``R⁻¹ Qᴴ e_b`` (tall) — the SVD's
    ``V Σ⁻¹ Uᴴ e_b`` to round-off (both backward stable), at a third of its cost."""
    B, p, N = E.shape
    fro = np.sqrt(np.sum(np.abs(E) ** 2, axis=(1, 2)))
    F = float(np.max(fro)) if fro.size else 0.0
    if not np.isfinite(F):
        return None
    c = np.zeros((B, N), dtype=np.result_type(E, e))
    if F == 0:
        return c
    live = np.flatnonzero(fro > RCOND * F / math.sqrt(min(p, N)))
    A = np.conj(np.swapaxes(E[live], 1, 2)) if p <= N else E[live]
    q, r = np.linalg.qr(A)
    try:
        r_inv = np.linalg.inv(r)
    except np.linalg.LinAlgError:
        return None
    bound = 1.0 / np.sqrt(np.sum(np.abs(r_inv) ** 2, axis=(1, 2)))
    if not np.all(np.isfinite(bound) & (bound > RCOND * F)):
        return None
    rhs = e[live][..., None]
    if p <= N:  # E_b = Rᴴ Qᴴ: c = Q R⁻ᴴ e_b
        c[live] = (q @ (np.conj(np.swapaxes(r_inv, 1, 2)) @ rhs))[..., 0]
    else:  # E_b = Q R: c = R⁻¹ Qᴴ e_b
        c[live] = (r_inv @ (np.conj(np.swapaxes(q, 1, 2)) @ rhs))[..., 0]
    return c


def _coefficients_svd(E: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``c = E⁺ e`` per bin through a batched SVD (any number of rows)."""
    u, s, vh = np.linalg.svd(E, full_matrices=False)
    top = float(np.max(s)) if s.size else 0.0
    if top == 0:
        return np.zeros((E.shape[0], E.shape[2]), dtype=E.dtype)
    inv = np.where(s > RCOND * top, 1.0 / np.where(s > 0, s, 1.0), 0.0)
    return np.einsum("bji,bj,bkj,bk->bi", vh.conj(), inv, u.conj(), e)


def _coefficients_one_row(E: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``c = E_bᴴ e_b / ‖E_b‖²`` per bin for rows ``E`` (B, N) and right-hand sides ``e``
    (B,), bins whose norm is below :data:`RCOND` × the largest dropped (zero)."""
    norm2 = np.sum(E.real ** 2 + E.imag ** 2, axis=1) if np.iscomplexobj(E) \
        else np.sum(E ** 2, axis=1)
    s = np.sqrt(norm2)
    top = float(np.max(s)) if s.size else 0.0
    if top == 0:
        return np.zeros(E.shape, dtype=np.result_type(E, e))
    inv2 = np.where(s > RCOND * top, 1.0 / np.where(s > 0, norm2, 1.0), 0.0)
    return E.conj() * (inv2 * e)[:, None]


def _terms(ex: Excitations, keep, e: np.ndarray, x, rho, U_full=None) -> TargetTerms:
    E, R = ex.E[..., keep], ex.R[..., keep]
    c = _coefficients(E, e)
    power = np.sum(np.abs(R) ** 2, axis=1)  # (B, N)
    num = float(np.sum(np.abs(c) ** 2 * power))
    den = float(np.sum(np.abs((R @ c[..., None])[..., 0]) ** 2))
    lev2 = num / den if den > 0 else math.inf
    blind2 = 0.0
    if ex.X is not None and x is not None:
        X = ex.X[..., keep]
        left = x - (X @ c[..., None])[..., 0]
        if U_full is not None:  # a fold in fewer modes: only what the whole basis misses
            left = left - (left @ U_full) @ U_full.T
        inside = float(np.sum(np.abs(e) ** 2))
        blind2 = float(np.sum(np.abs(left) ** 2)) / inside if inside > 0 else math.inf
        if blind2 <= roundoff_floor(E.shape[1], X, c, x, inside, ex.nfft):
            blind2 = 0.0
    return TargetTerms(lev2, blind2, rho)


def roundoff_floor(p: int, X: np.ndarray, c: np.ndarray, x: np.ndarray, inside: float,
                   nfft: int) -> float:
    """The largest blind spot ``Δ²`` that the round-off of its own computation can produce:
    ``(τ ε)² Σ_b (‖X_b‖_F ‖c_b‖ + ‖x_b‖)² / Σ_b ‖e_b‖²`` (``inside`` the denominator), with
    ``τ = p N + log₂ n_fft``: ``p`` modal excitation rows and ``N`` records per bin,
    ``ε`` the double-precision machine epsilon, ``log₂ n_fft`` only for a spectrum (more
    than one bin ``b``).

    The residual ``x_b − X_b c_b`` of the coefficients ``c_b = E_b⁺ e_b`` is computed, not
    exact: the minimum-norm solve is backward stable, so the computed ``c_b`` solves a
    system perturbed by ``‖δE_b‖ ≤ γ_{pN} ‖E_b‖_F``, ``γ_{pN} ≈ pN u`` (Householder QR:
    Higham 2002, *Accuracy and Stability of Numerical Algorithms*, Thm 21.4; the SVD's
    bound is of the same order), which leaves up to ``γ_{pN}‖X_b‖_F‖c_b‖`` of the target's
    excitation unmatched (``‖E_b‖_F ≤ ‖X_b‖_F``, ``E = UᵀX``); the product ``X_b c_b``
    adds at most ``N u ‖X_b‖_F‖c_b‖``, and the FFTs that form ``E``, ``e``, ``X``, ``x``
    separately ``O(u log₂ n_fft)`` of each (Higham, Thm 24.2). ``τ ε`` (``ε = 2u``) is the
    sum of these first-order bounds. A blind spot at or below it is not resolved by the
    solve — a basis spanning the whole sensor space, or loads at the sensors whose space the
    records span, make Δ exactly 0 — and is returned as 0 by :func:`_terms`."""
    B, _, N = X.shape
    if not inside > 0:
        return 0.0
    tau = p * N + (math.log2(nfft) if B > 1 else 0.0)
    scale = np.sqrt(np.sum(np.abs(X) ** 2, axis=(1, 2))) * np.linalg.norm(c, axis=1) \
        + np.linalg.norm(x, axis=1)
    return float((tau * np.finfo(float).eps) ** 2 * np.sum(scale ** 2) / inside)


def _rho(model, record, U) -> float | None:
    if kind_of(model) != "free" or getattr(model, "excitation", "displacement") != \
            "displacement":
        return None
    x = _initial(model, record)
    scale = float(np.linalg.norm(x))
    if scale == 0:
        return None
    return float(np.linalg.norm(x - U @ (U.T @ x))) / scale


def target_terms(model, ex: Excitations | None, record, U) -> TargetTerms | None:
    """The terms of a target ``record`` against all training records ``ex`` (their
    :func:`excitations` in ``U``); None when they cannot be computed."""
    if ex is None:
        return None
    U = np.asarray(U, dtype=float)
    part = _one(model, record, U, ex.nfft, response=False)
    if part is None or part[0].shape != ex.E.shape[:2]:
        return None
    N = ex.E.shape[2]
    return _terms(ex, list(range(N)), part[0], part[1], _rho(model, record, U))


def fold_terms(model, records, U, U_full=None, ex=None, fitted=None
               ) -> list[TargetTerms] | None:
    """The terms of each training record against the others (its fold), in the fold's
    basis ``U``; the projection share and the blind spot outside ``U_full`` (default
    ``U``): a fold refitted in fewer modes than the model is charged the whole basis's
    projection error, not the mode it leaves out. ``ex``: the records'
    :func:`excitations` in ``U`` when already computed. ``fitted``: for each record, the
    records its fold was fitted on (default: all the others)."""
    if ex is None:
        ex = excitations(model, records, U)
    if ex is None:
        return None
    U_full = np.asarray(U if U_full is None else U_full, dtype=float)
    N = len(records)
    keeps = fitted or [[i for i in range(N) if i != j] for j in range(N)]
    extra = U_full if U_full.shape[1] > np.shape(U)[1] else None
    stacked = _stacked_terms(ex, keeps, extra)
    out = []
    for j in range(N):
        rho = _rho(model, records[j], U_full)
        if stacked[j] is not None:
            out.append(TargetTerms(*stacked[j], rho))
            continue
        x = None if ex.X is None else ex.X[..., j]
        out.append(_terms(ex, keeps[j], ex.E[..., j], x, rho, extra))
    return out


def _stacked_terms(ex: Excitations, keeps, U_full=None) -> list:
    """``(Λ², Δ²)`` of every fold at once (record ``j`` against the records ``keeps[j]``),
    or None for a fold that :func:`_terms` must compute alone. The same arithmetic as
    :func:`_terms` with :func:`_coefficients_qr`, each fold's arrays a slab of one stack
    (the batched QR, inverse and products act on each matrix as on its own, and every
    threshold is the fold's own), so the same numbers; a fold whose bins the QR route
    does not take as a whole (a cut inside a bin, a bin below the cut in one fold only,
    one excitation row or more rows than records) is left to :func:`_terms`. Only a free
    response's single bin is stacked: there the folds' arrays are a few numbers and the
    calls cost more than the arithmetic; a spectrum's folds are batched over their bins
    already, and a stack of them only moves more memory."""
    J, N = len(keeps), ex.E.shape[2]
    B, p = ex.E.shape[:2]
    if COEFFICIENT_ROUTE != "qr" or B > 1 or p == 1 or len({len(k) for k in keeps}) != 1 \
            or p > len(keeps[0]):
        return [None] * J
    K = len(keeps[0])
    E = np.stack([ex.E[..., k] for k in keeps])  # (J, B, p, K): each fold's E
    fro = np.sqrt(np.sum(np.abs(E) ** 2, axis=(2, 3)))  # (J, B)
    F = np.max(fro, axis=1)
    live = fro > (RCOND * F / math.sqrt(min(p, K)))[:, None]
    common = np.all(live, axis=0)
    ok = np.isfinite(F) & (F > 0) & np.all(live == common, axis=1)
    if not np.any(common) or not np.any(ok):
        return [None] * J
    q, r = np.linalg.qr(np.conj(np.swapaxes(E[:, common], 2, 3)))
    try:
        r_inv = np.linalg.inv(r)
    except np.linalg.LinAlgError:
        return [None] * J
    bound = 1.0 / np.sqrt(np.sum(np.abs(r_inv) ** 2, axis=(2, 3)))
    ok &= np.all(np.isfinite(bound) & (bound > (RCOND * F)[:, None]), axis=1)
    e = np.stack([ex.E[..., j] for j in range(N)])  # (J, B, p): each record's own
    c = np.zeros((J, B, K), dtype=np.result_type(E, e))
    c[:, common] = (q @ (np.conj(np.swapaxes(r_inv, 2, 3)) @ e[:, common][..., None]))[..., 0]
    R = np.stack([ex.R[..., k] for k in keeps])
    power = np.sum(np.abs(R) ** 2, axis=2)  # (J, B, K)
    num = np.sum(np.abs(c) ** 2 * power, axis=(1, 2))
    den = np.sum(np.abs((R @ c[..., None])[..., 0]) ** 2, axis=(1, 2))
    blind = [0.0] * J
    if ex.X is not None:
        X = np.stack([ex.X[..., k] for k in keeps])  # (J, B, m, K)
        x = np.stack([ex.X[..., j] for j in range(N)])
        left = x - (X @ c[..., None])[..., 0]
        if U_full is not None:
            left = left - (left @ U_full) @ U_full.T
        inside = np.sum(np.abs(e) ** 2, axis=(1, 2))
        blind2 = np.sum(np.abs(left) ** 2, axis=(1, 2))
        for j in range(J):
            b = float(blind2[j]) / float(inside[j]) if inside[j] > 0 else math.inf
            blind[j] = 0.0 if b <= roundoff_floor(p, X[j], c[j], x[j], float(inside[j]),
                                                  ex.nfft) else b
    return [(float(num[j]) / float(den[j]) if den[j] > 0 else math.inf, blind[j])
            if ok[j] else None for j in range(J)]
