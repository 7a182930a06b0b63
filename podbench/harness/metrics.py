"""The error decomposition the harness tabulates (definitions also in docs/error-decomposition.md).

For a target truth ``W`` (m × n), a method's prediction ``Ŵ`` and the basis ``U`` (m × k,
orthonormal) the method used, with ``P = U Uᵀ`` and ``N = ‖W‖_F`` (Frobenius norms over the
whole record):

* ``total_error        = ‖Ŵ − W‖ / N``
* ``projection_error   = ‖W − P W‖ / N``      the floor of any prediction confined to span U
* ``subspace_error     = ‖Ŵ − P W‖ / N``      what the method loses inside span U;
  every POD method predicts inside span U, so ``total² = projection² + subspace²``
* ``diagonalization_error = ‖Ŵ − Ŵ_c‖ / N``   ``Ŵ_c``: the coupled twin (MDS for POVR, ML
  for SL, MDS+MDS+ML superposition for MR) fitted in the same basis ``U`` on its own training
  cases; 0 for a coupled method (it is its own twin); NaN when no twin is declared
* ``linearization_error = ‖(Ŵ_c − P W) − (Ŵ_c^lin − P W^lin)‖ / N``  the same twin fitted
  and evaluated on the structure's linear twin (nonlinear elements removed, same excitations,
  same basis); 0 for a structure without nonlinear elements
* ``residual_error     = ‖Ŵ_c^lin − P W^lin‖ / N``  what remains when neither the diagonal
  assumption nor the nonlinearity is in play: dynamics outside span U, time variance of the
  structure, deconvolution and numerics.

Because ``Ŵ − PW = (Ŵ − Ŵ_c) + [(Ŵ_c − PW) − (Ŵ_c^lin − PW^lin)] + (Ŵ_c^lin − PW^lin)``,
the triangle inequality gives ``subspace ≤ diagonalization + linearization + residual``.
All components are non-negative; on an LTI system with k = m every projection is exact.

The three attributions above are measured against the twin, so when the twin itself fails
they would repeat its failure, not the method's. Hence:

* ``twin_error = ‖Ŵ_c − W‖ / N``, the twin's own total error; when it exceeds the method's
  ``total_error`` the attributions diagonalization, linearization and residual are
  *undefined* (NaN), not numbers;
* ``own_linearization_error = ‖(Ŵ − P W) − (Ŵ^lin − P W^lin)‖ / N``: the method itself
  refitted on the structure's linear twin with the same modes (``Ŵ^lin``), so the
  nonlinearity's share of the method's own error (0 for a linear structure);
* ``linear_diagonalization_error = ‖Ŵ^lin − Ŵ_c^lin‖ / N``: the diagonal assumption's cost
  measured on the linear twin, where the coupled twin is exact up to the basis (equal to
  ``diagonalization_error`` on a linear structure; undefined when the twin's error on the
  linear twin exceeds the method's).

Eq. 4.2's displacement-norm percent error ``100 |‖ŵ(t)‖ − ‖w(t)‖| / ‖w(t)‖`` is summarized
by its median, 90th percentile and maximum over the samples where ``‖w(t)‖ > 0``;
``norm_peak_ratio = max_t ‖ŵ(t)‖ / max_t ‖w(t)‖``.
"""

from __future__ import annotations

import numpy as np

from podbench.core.response import displacement_norm, norm_percent_error

__all__ = ["decompose", "norm_summaries", "ERROR_COLUMNS", "NORM_COLUMNS", "ERROR_ROUNDOFF",
           "ROUNDOFF_COLUMNS", "roundoff_errors"]

ERROR_COLUMNS = (
    "total_error",
    "projection_error",
    "diagonalization_error",
    "linearization_error",
    "residual_error",
    "subspace_error",
    "twin_error",
    "own_linearization_error",
    "linear_diagonalization_error",
)
NORM_COLUMNS = ("norm_pe_median", "norm_pe_p90", "norm_pe_max", "norm_peak_ratio")
#: A relative error below this is round-off and is written as 0 (the Eq. 4.2 percent errors
#: below ``100·ERROR_ROUNDOFF`` likewise): an exact fit (ML on a noise-free LTI record, k = m)
#: leaves 1e-16…1e-14 whose digits depend on the CPU and even on the process that summed them
#: (1.84e-15 in one process, 2.05e-15 in another, same inputs), which would make a table
#: differ between ``--jobs`` settings. No error of a committed table lies below 1e-8.
ERROR_ROUNDOFF = 1e-10

#: The columns :func:`roundoff_errors` floors, with each one's scale (1: a relative error;
#: 100: a percent error). ``norm_peak_ratio`` is a ratio near 1 and is not floored.
ROUNDOFF_COLUMNS = {**{c: 1.0 for c in ("total_error", "projection_error",
                                         "diagonalization_error", "linearization_error",
                                         "residual_error", "subspace_error", "twin_error",
                                         "own_linearization_error",
                                         "linear_diagonalization_error")},
                    "norm_pe_median": 100.0, "norm_pe_p90": 100.0, "norm_pe_max": 100.0}


def roundoff_errors(df):
    """``df`` (a pandas DataFrame of rows with :data:`ERROR_COLUMNS` and
    :data:`NORM_COLUMNS`) with every error below :data:`ERROR_ROUNDOFF` (relative; percent
    errors below ``100·ERROR_ROUNDOFF``) written as 0; NaN and larger values unchanged."""
    for c, scale in ROUNDOFF_COLUMNS.items():
        if c in df and df[c].dtype.kind == "f":
            df[c] = df[c].mask(df[c].abs() < scale * ERROR_ROUNDOFF, 0.0)
    return df


TWIN_RTOL = 1e-6
"""A twin "exceeds" the method's total error only beyond this relative margin: a twin equal
to the method up to round-off (e.g. ERA-free against MDS in one basis) leaves the
attribution defined."""


def _fro(A) -> float:
    return float(np.linalg.norm(A))


def _proj(U, W):
    return U @ (U.T @ W)


def decompose(W, W_hat, U=None, *, W_twin=None, coupled: bool = False, W_lin=None,
              W_twin_lin=None, nonlinear: bool = False, W_own_lin=None) -> dict:
    """The error components of one prediction (see the module docstring).

    Parameters
    ----------
    W, W_hat : (m, n) arrays
        Target truth and prediction (in).
    U : (m, k) array or None
        Basis of the method; None makes the basis-dependent components NaN.
    W_twin : (m, n) array or None
        The coupled twin's prediction in basis U (ignored if ``coupled``).
    coupled : bool
        The method is its own coupled twin (MDS, ML): diagonalization error 0.
    W_lin, W_twin_lin : (m, n) arrays or None
        Truth and twin prediction on the linear twin of the structure (``nonlinear`` only).
    nonlinear : bool
        The structure has nonlinear elements.
    W_own_lin : (m, n) array or None
        The method's own prediction on the linear twin, refitted there in basis U
        (``nonlinear`` only).
    """
    W = np.asarray(W, dtype=float)
    W_hat = np.asarray(W_hat, dtype=float)
    N = _fro(W)
    nan = float("nan")
    out = dict.fromkeys(ERROR_COLUMNS, nan)
    if N == 0.0:
        return out
    out["total_error"] = _fro(W_hat - W) / N
    if U is None:
        return out
    PW = _proj(U, W)
    out["projection_error"] = _fro(W - PW) / N
    out["subspace_error"] = _fro(W_hat - PW) / N
    if nonlinear:
        if W_lin is not None and W_own_lin is not None:
            PW_lin = _proj(U, W_lin)
            out["own_linearization_error"] = _fro((W_hat - PW) - (W_own_lin - PW_lin)) / N
    else:
        out["own_linearization_error"] = 0.0
    twin = W_hat if coupled else W_twin
    if twin is None:
        return out
    out["twin_error"] = _fro(twin - W) / N
    undefined = out["twin_error"] > out["total_error"] * (1 + TWIN_RTOL)
    diag = 0.0 if coupled else _fro(W_hat - twin) / N
    if not nonlinear:
        lin, resid, lin_diag = 0.0, _fro(twin - PW) / N, (nan if undefined else diag)
    elif W_lin is None or W_twin_lin is None:
        lin = resid = lin_diag = nan
    else:
        PW_lin = _proj(U, W_lin)
        lin = _fro((twin - PW) - (W_twin_lin - PW_lin)) / N
        resid = _fro(W_twin_lin - PW_lin) / N
        lin_diag = nan
        if coupled:
            lin_diag = 0.0
        elif W_own_lin is not None and _fro(W_twin_lin - W_lin) <= _fro(W_own_lin - W_lin) * (
                1 + TWIN_RTOL):
            lin_diag = _fro(W_own_lin - W_twin_lin) / N
    out["linear_diagonalization_error"] = lin_diag
    if not undefined:
        out["diagonalization_error"] = diag
        out["linearization_error"] = lin
        out["residual_error"] = resid
    return out


def norm_summaries(W, W_hat) -> dict:
    """Median, 90th percentile and max of Eq. 4.2 (percent), and the peak-norm ratio."""
    pe = norm_percent_error(W, W_hat)
    finite = pe[np.isfinite(pe)]
    nan = float("nan")
    if finite.size == 0:
        return dict.fromkeys(NORM_COLUMNS, nan)
    peak = float(np.max(displacement_norm(W)))
    return {
        "norm_pe_median": float(np.median(finite)),
        "norm_pe_p90": float(np.percentile(finite, 90)),
        "norm_pe_max": float(np.max(finite)),
        "norm_peak_ratio": float(np.max(displacement_norm(W_hat)) / peak) if peak else nan,
    }
