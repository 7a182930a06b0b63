"""Mode conventions shared by the finite-element and the identified modes.

A mode is a continuous-time pole ``s`` (rad/s) and a shape at the output channels. Both the
finite-element truth (:mod:`podbench.dynamics.modes`) and an identified model's modes
(:mod:`podbench.sysid.modal`) are written with these conventions, so that they compare:

* natural frequency ``f = |s| / 2π`` (Hz) and damping ratio ``ζ = −Re s / |s|`` (the
  undamped natural frequency and the viscous damping ratio of the pole; for proportional
  damping ``|s|`` is the undamped ``ω``, as pyOMA2's and MATLAB's ``modalfit`` tables read);
* the shape reported is the *real, phase-aligned* shape: the complex shape rotated by the
  angle of its principal axis in the complex plane (where its components lie closest to one
  line through the origin), its real part, scaled so that its largest ``|component|`` is 1
  and that component is positive (the first such channel on ties);
* the modal assurance criterion ``MAC(a, b) = |aᴴb|² / ((aᴴa)(bᴴb))`` (Allemang & Brown
  1982) on the complex shapes, which is independent of their scale and phase;
* the modal phase collinearity ``MPC`` (Pappa, Elliott & Schenk 1993): 1 for a shape whose
  components share one phase (a normal mode), lower for a complex one.

A :class:`ModeSet` holds the modes of one model or structure; :meth:`ModeSet.table` is the
modes table (``mode, frequency_hz, damping_ratio, shape:<channel>…``, sorted by frequency).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from podbench.errors import DimensionError

__all__ = ["ModeSet", "mac", "real_shapes", "mpc", "frequency_damping", "SHAPE_PREFIX"]

SHAPE_PREFIX = "shape:"
"""Column prefix of a mode shape component in a modes table (``shape:<channel>``)."""


def frequency_damping(poles) -> tuple[np.ndarray, np.ndarray]:
    """``(f, ζ)`` of continuous-time poles ``s`` (rad/s): ``f = |s|/2π`` (Hz) and
    ``ζ = −Re s/|s|`` (a pole at ``s = 0``: ``f = 0``, ``ζ = 1``)."""
    s = np.asarray(poles, dtype=complex)
    mag = np.abs(s)
    zeta = np.where(mag > 0, -s.real / np.where(mag > 0, mag, 1.0), 1.0) + 0.0
    return mag / (2.0 * np.pi), zeta


def mac(a, b) -> np.ndarray:
    """The modal assurance criterion of every pair of columns of ``a`` (m × p) and ``b``
    (m × q), real or complex: ``MAC[i, j] = |a_iᴴ b_j|² / ((a_iᴴ a_i)(b_jᴴ b_j))``, in
    [0, 1] (0 where a column is zero). Returns (p, q)."""
    a = np.atleast_2d(np.asarray(a))
    b = np.atleast_2d(np.asarray(b))
    if a.ndim != 2 or b.ndim != 2 or a.shape[0] != b.shape[0]:
        raise DimensionError(f"mac: shapes {a.shape} and {b.shape} need the same rows "
                             "(one per channel)")
    num = np.abs(a.conj().T @ b) ** 2
    na = np.real(np.sum(a.conj() * a, axis=0))
    nb = np.real(np.sum(b.conj() * b, axis=0))
    den = np.outer(na, nb)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def _principal_angle(phi: np.ndarray) -> float:
    """The angle of the line through the origin closest (least squares) to the points
    ``(Re φ_i, Im φ_i)``: the principal axis of their second-moment matrix."""
    x, y = phi.real, phi.imag
    sxx, syy, sxy = float(x @ x), float(y @ y), float(x @ y)
    return 0.5 * float(np.arctan2(2.0 * sxy, sxx - syy))


def real_shapes(shapes) -> np.ndarray:
    """The real, phase-aligned shapes of complex shapes (columns of ``shapes``, m × r): each
    rotated onto its principal axis, its real part scaled to a largest ``|component|`` of 1,
    that component positive. A zero column stays zero. Returns (m, r) float."""
    Phi = np.atleast_2d(np.asarray(shapes, dtype=complex))
    out = np.zeros(Phi.shape)
    for j in range(Phi.shape[1]):
        phi = Phi[:, j] * np.exp(-1j * _principal_angle(Phi[:, j]))
        re = phi.real
        top = int(np.argmax(np.abs(re)))
        if re[top] != 0:
            out[:, j] = re / re[top] + 0.0  # + 0.0: no negative zeros in tables
    return out


def mpc(shapes) -> np.ndarray:
    """The modal phase collinearity of each column of ``shapes`` (m × r): with ``S`` the 2×2
    second-moment matrix of the components' real and imaginary parts and ``λ₁ ≥ λ₂`` its
    eigenvalues, ``MPC = ((λ₁ − λ₂)/(λ₁ + λ₂))²`` (1 for a real shape up to one phase)."""
    Phi = np.atleast_2d(np.asarray(shapes, dtype=complex))
    out = np.zeros(Phi.shape[1])
    for j in range(Phi.shape[1]):
        x, y = Phi[:, j].real, Phi[:, j].imag
        S = np.array([[x @ x, x @ y], [x @ y, y @ y]])
        lam = np.linalg.eigvalsh(S)
        tot = float(lam.sum())
        out[j] = ((lam[1] - lam[0]) / tot) ** 2 if tot > 0 else 0.0
    return out


@dataclass(frozen=True)
class ModeSet:
    """Modes of one model or structure (the module docstring's conventions).

    Attributes
    ----------
    poles : (r,) complex ndarray
        Continuous-time poles ``s`` (rad/s), one per mode (the one with ``Im s > 0`` of a
        conjugate pair).
    shapes : (m, r) complex ndarray
        The complex shapes at the ``m`` channels (any scale and phase).
    channels : tuple of str
        The channel names (``m``).
    source : str
        What the modes are of, in words (e.g. "finite-element model, complex modes").
    notes : tuple of str
        Statements about how the modes were obtained (shown with the table).
    stable : (r,) bool ndarray or None
        Which modes passed a stabilization rule (None: no rule applied).
    """

    poles: np.ndarray
    shapes: np.ndarray
    channels: tuple[str, ...]
    source: str = ""
    notes: tuple[str, ...] = ()
    stable: np.ndarray | None = field(default=None)

    def __post_init__(self):
        s = np.atleast_1d(np.asarray(self.poles, dtype=complex))
        Phi = np.asarray(self.shapes, dtype=complex).reshape(-1, s.size) if s.size else \
            np.zeros((len(self.channels), 0), dtype=complex)
        if Phi.shape != (len(self.channels), s.size):
            raise DimensionError(f"ModeSet: shapes {Phi.shape} for {len(self.channels)} "
                                 f"channels and {s.size} poles")
        order = np.lexsort((s.real, np.abs(s)))  # by frequency, then by decay
        object.__setattr__(self, "poles", s[order])
        object.__setattr__(self, "shapes", Phi[:, order])
        object.__setattr__(self, "channels", tuple(str(c) for c in self.channels))
        if self.stable is not None:
            st = np.asarray(self.stable, dtype=bool)
            if st.shape != s.shape:
                raise DimensionError(f"ModeSet: {st.size} stability flags for {s.size} poles")
            object.__setattr__(self, "stable", st[order])

    def __len__(self) -> int:
        return int(self.poles.size)

    @property
    def frequency_hz(self) -> np.ndarray:
        """Natural frequencies ``|s|/2π`` (Hz)."""
        return frequency_damping(self.poles)[0]

    @property
    def damping_ratio(self) -> np.ndarray:
        """Damping ratios ``−Re s/|s|``."""
        return frequency_damping(self.poles)[1]

    @property
    def real_shapes(self) -> np.ndarray:
        """The real, phase-aligned shapes (m × r, largest ``|component|`` 1)."""
        return real_shapes(self.shapes)

    def subset(self, keep) -> ModeSet:
        """The modes where ``keep`` (a boolean mask or indices) holds."""
        idx = np.arange(len(self))[np.asarray(keep)]
        return ModeSet(self.poles[idx], self.shapes[:, idx], self.channels, self.source,
                       self.notes, None if self.stable is None else self.stable[idx])

    def with_notes(self, *notes: str) -> ModeSet:
        """The same modes with more notes."""
        return ModeSet(self.poles, self.shapes, self.channels, self.source,
                       self.notes + tuple(notes), self.stable)

    def table(self, channels: Sequence[str] | None = None) -> pd.DataFrame:
        """The modes table, one row per mode sorted by frequency: ``mode`` (1, 2, …),
        ``frequency_hz``, ``damping_ratio``, then ``shape:<channel>`` for every channel
        (the real, phase-aligned shape)."""
        names = tuple(channels) if channels is not None else self.channels
        if len(names) != len(self.channels):
            raise DimensionError(f"ModeSet.table: {len(names)} channel names for "
                                 f"{len(self.channels)} channels")
        f, z = frequency_damping(self.poles)
        data: dict = {"mode": np.arange(1, len(self) + 1), "frequency_hz": f,
                      "damping_ratio": z}
        R = self.real_shapes
        for i, name in enumerate(names):
            data[SHAPE_PREFIX + str(name)] = R[i]
        return pd.DataFrame(data)
