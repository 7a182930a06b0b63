"""Choosing the mixed-response training sets by a rule on the training data (§3.4).

§3.4 asks for "three distinct sets of response data that all result from separate
combinations of both applied loads and initial conditions", whose Eqs. 3.55–3.63 form "a
system of linear equations that may be solved"; Figs. 4.27–4.28 only draw the sets used.
:func:`design_conditioning` measures, from the three training records alone (never a
target), how well that system can be solved, so that a design can be chosen — and designs
compared — without looking at any prediction.

Definition (per POM ``i`` of case ``a``; the elimination of :mod:`podbench.methods.mixed`).
With ``r_bd, r_cd, r_bv, r_cv`` the POV ratios of Eqs. 3.58–3.61, ``R = (r_cv − r_cd) /
(r_bv − r_bd)`` and ``q_a, q_b, q_c`` the modal forces ``u_iᵀF``, MR performs two
cancellations whose relative condition numbers (the condition number of a sum,
``Σ|terms| / |Σ terms|``, ≥ 1) are

* separation of the displacement and velocity histories (divide by ``r_bv − r_bd``)::

      κ_sep,i = (|r_bv| + |r_bd|) / |r_bv − r_bd|

* the combined force of the kernel's deconvolution::

      g = q_c − r_cd q_a − R (q_b − r_bd q_a)
      κ_g,i = (‖q_c‖ + |r_cd| ‖q_a‖ + |R| (‖q_b‖ + |r_bd| ‖q_a‖)) / ‖g‖

A relative error ε in the data (the POV ratios, the modal forces, the responses) reaches
``V`` amplified by up to ``κ_sep`` and the kernel right-hand side by up to ``κ_g``, so the
design's value is the worst of both over the modes::

    κ = max_i max(κ_sep,i, κ_g,i).

``κ = ∞`` (or NaN) when a division of Eqs. 3.58–3.61 is by zero (case ``a`` has no share of
a mode), when ``r_bv = r_bd`` (``D`` and ``V`` cannot be separated) or when ``g = 0`` (the
loads cannot be separated from the initial conditions): the system "may not be solved".
A design is *admissible* when ``κ <= 1/tol`` with MR's default ``tol = 1e-6``
(:data:`ADMISSIBLE_BOUND`), the same scale as the guards of
:meth:`MixedResponse.fit <podbench.methods.MixedResponse.fit>`. The rule does not include
the conditioning of the deconvolution of ``g`` itself (its convolution matrix), which depends
on the loads' shape rather than on how the sets are combined.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from podbench.errors import InputError
from podbench.sysid.methods.base import as_record, check_n_modes, select_basis

__all__ = ["ADMISSIBLE_BOUND", "DesignConditioning", "choose_design", "design_conditioning"]

ADMISSIBLE_BOUND = 1e6
"""``1/tol`` with MR's default ``tol = 1e-6``: designs with ``κ`` above it are inadmissible."""


@dataclass(frozen=True)
class DesignConditioning:
    """Conditioning of MR's elimination for one design (module docstring).

    Attributes
    ----------
    value : float
        ``κ = max_i max(κ_sep,i, κ_g,i)`` (``inf`` if the system cannot be solved).
    separation : (k,) ndarray
        ``κ_sep,i`` per mode.
    force : (k,) ndarray
        ``κ_g,i`` per mode.
    n_modes : int
        ``k``.
    """

    value: float
    separation: np.ndarray
    force: np.ndarray
    n_modes: int

    @property
    def admissible(self) -> bool:
        """``κ`` finite and ``<= ADMISSIBLE_BOUND``."""
        return bool(np.isfinite(self.value) and self.value <= ADMISSIBLE_BOUND)


def design_conditioning(records, n_modes=None, *, energy=0.99) -> DesignConditioning:
    """Conditioning ``κ`` of MR's system (Eqs. 3.55–3.63) for the training sets ``a, b, c``.

    Uses only the three training records: the POMs of ``W_a`` (Eq. 3.50), the initial
    displacements ``w0`` and velocities ``v0`` (Eqs. 3.58–3.61) and the loads ``F``.

    Parameters
    ----------
    records : sequence of three records
        Cases ``a``, ``b``, ``c`` (objects with ``W``, ``F``, ``w0``, ``v0``, ``dt``).
    n_modes : int, optional
        Number of POMs of case ``a``; default from ``energy``, as MR.
    energy : float
        Cumulative energy fraction (Eq. 2.3) when ``n_modes`` is None.

    Returns
    -------
    DesignConditioning
    """
    recs = [as_record(r, f"records[{j}]") for j, r in enumerate(records)]
    if len(recs) != 3:
        raise InputError(f"Parameter `records`: MR needs exactly three sets, got {len(recs)}")
    U, _, _ = select_basis(recs[0].W, check_n_modes(n_modes), None, energy=energy)
    k = U.shape[1]
    D0 = U.T @ np.column_stack([cast(np.ndarray, r.w0) for r in recs])
    V0 = U.T @ np.column_stack([cast(np.ndarray, r.v0) for r in recs])
    qn = np.stack([np.linalg.norm(U.T @ r.F, axis=1) for r in recs])  # 3 × k
    with np.errstate(divide="ignore", invalid="ignore"):
        r_bd, r_cd = D0[:, 1] / D0[:, 0], D0[:, 2] / D0[:, 0]
        r_bv, r_cv = V0[:, 1] / V0[:, 0], V0[:, 2] / V0[:, 0]
        den = r_bv - r_bd
        k_sep = (np.abs(r_bv) + np.abs(r_bd)) / np.abs(den)
        R = (r_cv - r_cd) / den
        Q = np.stack([U.T @ r.F for r in recs])  # 3 × k × n
        g = (Q[2] - r_cd[:, None] * Q[0]) - R[:, None] * (Q[1] - r_bd[:, None] * Q[0])
        terms = qn[2] + np.abs(r_cd) * qn[0] + np.abs(R) * (qn[1] + np.abs(r_bd) * qn[0])
        k_g = terms / np.linalg.norm(g, axis=1)
    k_sep = np.where(np.isfinite(k_sep), k_sep, np.inf)
    k_g = np.where(np.isfinite(k_g), k_g, np.inf)
    value = float(np.max(np.maximum(k_sep, k_g)))
    return DesignConditioning(value=value, separation=k_sep, force=k_g, n_modes=k)


def choose_design(candidates, n_modes=None, *, energy=0.99):
    """The candidate design with the smallest ``κ`` (first one on ties).

    Parameters
    ----------
    candidates : mapping of name → three records
        Candidate designs (training sets ``a, b, c``).
    n_modes, energy :
        As :func:`design_conditioning`.

    Returns
    -------
    name : key of ``candidates``
    values : dict
        ``κ`` of every candidate.
    """
    values = {name: design_conditioning(recs, n_modes, energy=energy).value
              for name, recs in candidates.items()}
    best = min(values, key=lambda name: (values[name], list(values).index(name)))
    return best, values
