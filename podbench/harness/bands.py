"""Band columns of the study tables: every prediction's ``error_estimate`` and the
``coverage`` of its 90 % band (:mod:`podbench.sysid.methods.bands`), scored against the truth.

``coverage`` is the fraction of the truth's samples (every sensor and time) inside the band;
``error_estimate`` the predicted ``total_error``. A method without bands (a user's method
without ``coverage=``, a windowed fit) or a band that fails gets NaN in both and the reason in
``band_status`` of :func:`band_row` (the table keeps ``status`` for the prediction itself).
"""

from __future__ import annotations

import numpy as np

from podbench.errors import PodbenchError
from podbench.harness.digits import coverage_digits
from podbench.sysid.methods.bands import interval_score

__all__ = ["BAND_COLUMNS", "BAND_COVERAGE", "band_row", "band_prediction", "band_stats"]

BAND_COVERAGE = 0.9
"""The nominal coverage of the band every study table scores."""
BAND_COLUMNS = ("error_estimate", "coverage")


def band_prediction(est, record, coverage: float = BAND_COVERAGE):
    """``est.predict(record, coverage=coverage)`` or None when the method has no band (a
    method without the ``coverage`` keyword, or one whose band fails)."""
    try:
        return est.predict(record, coverage=coverage)
    except TypeError:
        return None  # a user's method or a wrapped (windowed) fit without coverage=
    except (PodbenchError, np.linalg.LinAlgError, ValueError):
        return None


def band_row(prediction, W) -> dict:
    """The band columns of one table row (NaN without a band; a prediction without an
    error estimate, whose ``note`` says why, has neither)."""
    if prediction is None or not hasattr(prediction, "lower") or \
            not np.isfinite(prediction.error_estimate):
        return dict.fromkeys(BAND_COLUMNS, float("nan"))
    return {"error_estimate": float(prediction.error_estimate),
            "coverage": coverage_digits(prediction.covers(W))}


def band_stats(prediction, W) -> dict:
    """Sharpness of one band against the truth ``W``: its mean interval score (Gneiting &
    Raftery 2007), that of the best constant-width band with the same realized coverage
    (half-width: that quantile of ``|W − Ŵ|``, an oracle that knows the truth) and the mean
    half-width relative to the truth's RMS."""
    nan = float("nan")
    if prediction is None or not hasattr(prediction, "lower") or \
            not np.isfinite(prediction.error_estimate):
        return {"interval_score": nan, "constant_interval_score": nan,
                "relative_half_width": nan, "source": ""}
    W = np.asarray(W, dtype=float)
    mean = prediction.mean
    n = min(W.shape[1], mean.shape[1])
    W, mean = W[:, :n], mean[:, :n]
    c = prediction.coverage
    realized = prediction.covers(W)
    h = float(np.quantile(np.abs(W - mean), min(max(realized, 0.0), 1.0)))
    rms = float(np.sqrt(np.mean(W ** 2))) or 1.0
    half = 0.5 * (prediction.upper[:, :n] - prediction.lower[:, :n])
    return {"interval_score": interval_score(W, prediction.lower, prediction.upper, c) / rms,
            "constant_interval_score": interval_score(W, mean - h, mean + h, c) / rms,
            "relative_half_width": float(np.mean(half)) / rms, "source": prediction.source}
