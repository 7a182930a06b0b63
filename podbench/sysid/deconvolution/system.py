"""The block lower-triangular Toeplitz system of Eq. 3.43 / 3.48, validated once.

With ``G[s]`` the ``n_cases × k`` matrix of modal-force samples at ``t_s`` (row ``j`` = load
case ``j``) and ``X[p]`` the ``k × r`` kernel at lag ``p`` (``X[p][i, l] = c_li[p]``, row
``i·n + p`` of ``C̄``, Eq. 3.42), Eq. 3.48 reads::

    Y[s] = Δt Σ_{p≤s} G[s−p] X[p],   s = 0 … n−1,

``A C̄ = B`` in matrix form, ``A`` (``n_cases·n × k·n``) the block convolution matrix and
``B`` the stacked scaled POC histories. A :class:`ConvolutionSystem` holds ``G``, ``Y`` and
``Δt`` and applies ``A`` and ``Aᵀ`` by FFT; only :meth:`ConvolutionSystem.dense` forms ``A``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, IllConditionedError, InputError
from podbench.sysid.deconvolution.convolution import block_conv, force_blocks

__all__ = ["ConvolutionSystem", "DENSE_MAX_BYTES"]

DENSE_MAX_BYTES = 2**31
"""Largest dense convolution matrix (bytes, 2 GiB) that :meth:`ConvolutionSystem.dense`
builds (and so the dense solvers ``"ls"``, ``"tls"``); beyond it :class:`InputError`
suggests a structured solver. Pass ``max_dense_bytes=`` to a dense solver to override."""


class ConvolutionSystem:
    """``A X ≈ B`` with ``A`` the block convolution matrix of Eq. 3.48 (Eq. 3.43 for one mode).

    Validated once on construction (shapes, NaN/Inf, ``dt > 0``); the solvers take it as
    it is. ``G`` and ``Y`` are read-only.

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like, or one (k, n) array
        Modal forces of each load case (lbf); for a scalar deconvolution (SL, MR) one
        ``(1, n)`` array.
    B : (n_cases·n,) or (n_cases·n, r) array_like
        Stacked scaled POC histories (in): rows ``j·n … j·n+n−1`` are load case ``j``.
    dt : float
        Sampling interval Δt (s), > 0.

    Attributes
    ----------
    G : (n, n_cases, k) ndarray
        ``G[s, j, i] = ʲq_i[s]`` (lbf).
    Y : (n, n_cases, r) ndarray
        ``Y[s, j] = B[j·n + s]`` (in).
    dt : float
        Δt (s).
    vector : bool
        Whether ``B`` was given as a vector (solutions are then ``(k·n,)``).
    n, n_cases, k : int
        Samples per load case, load cases, modes (kernel rows per lag): ``G.shape``.
    n_rhs : int
        Right-hand sides ``r`` (columns of ``B``; 1 for a vector).
    """

    def __init__(self, Q_list, B, dt: float):
        dt = check_positive(dt, "dt")
        G = force_blocks(Q_list)
        n, n_cases, _ = G.shape
        B = as_finite_array(B, "B")
        vector = B.ndim == 1
        if vector:
            B = B[:, None]
        if B.ndim != 2 or B.shape[0] != n_cases * n or B.shape[1] == 0:
            raise DimensionError(
                f"Parameter `B`: expected {n_cases * n} rows (n_cases·n = {n_cases}·{n}), got "
                f"shape {B.shape}"
            )
        Y = np.ascontiguousarray(B.reshape(n_cases, n, B.shape[1]).transpose(1, 0, 2))
        G.flags.writeable = False
        Y.flags.writeable = False
        self.G = G
        self.Y = Y
        self.dt = dt
        self.vector = vector
        self._B2 = B
        self.n, self.n_cases, self.k = G.shape
        self.n_rhs = B.shape[1]

    # ------------------------------------------------------------------ sizes
    @property
    def shape(self) -> tuple[int, int]:
        """Shape ``(n_cases·n, k·n)`` of ``A``."""
        return (self.n_cases * self.n, self.k * self.n)

    @property
    def Q_list(self) -> list[np.ndarray]:
        """The modal forces, one ``(k, n)`` array per load case."""
        return [self.G[:, j, :].T for j in range(self.n_cases)]

    @property
    def B(self) -> np.ndarray:
        """``B`` as given: ``(n_cases·n,)`` or ``(n_cases·n, r)``."""
        return self._B2[:, 0] if self.vector else self._B2

    def __repr__(self) -> str:
        return (f"ConvolutionSystem(n={self.n}, k={self.k}, n_cases={self.n_cases}, "
                f"n_rhs={self.n_rhs}, dt={self.dt!r})")

    # ------------------------------------------------------------------ layout
    def leading_zeros(self, zero_tol: float = 0.0) -> int:
        """Number ``d`` of leading force samples treated as zero
        (``‖G[s]‖_F <= zero_tol·max_s ‖G[s]‖_F``); :class:`IllConditionedError` if every
        sample is zero."""
        return first_sample(self.G, zero_tol)

    def stack(self, Xb: np.ndarray) -> np.ndarray:
        """Kernel samples ``(n, k, r)`` → ``C̄`` ``(k·n, r)`` (Eq. 3.42), a vector if ``B`` was."""
        return _unstack(Xb, self.vector)

    def blocks(self, X) -> np.ndarray:
        """``C̄`` ``(k·n,)`` or ``(k·n, r')`` → kernel samples ``(n, k, r')``."""
        Xm = self._check_x(X)
        return Xm.reshape(self.k, self.n, Xm.shape[1]).transpose(1, 0, 2)

    def _check_x(self, X) -> np.ndarray:
        X = as_finite_array(X, "X")
        Xm = X[:, None] if X.ndim == 1 else X
        if Xm.ndim != 2 or Xm.shape[0] != self.k * self.n:
            raise DimensionError(
                f"Parameter `X`: expected {self.k * self.n} rows (k·n), got {X.shape}"
            )
        return Xm

    # ------------------------------------------------------------------ operators
    def matvec(self, X) -> np.ndarray:
        """``A X`` by FFT (as :func:`convolution_product`).

        Parameters
        ----------
        X : (k·n,) or (k·n, r') array_like

        Returns
        -------
        (n_cases·n,) or (n_cases·n, r') ndarray
        """
        X = np.asarray(X)
        Z = self.dt * block_conv(self.G, self.blocks(X))  # (n, n_cases, r')
        out = Z.transpose(1, 0, 2).reshape(self.n_cases * self.n, Z.shape[2])
        return out[:, 0] if X.ndim == 1 else out

    def rmatvec(self, Z) -> np.ndarray:
        """``Aᵀ Z`` by FFT cross-correlation, ``(Aᵀz)[p] = Δt Σ_{s≥p} G[s−p]ᵀ z[s]``.

        Parameters
        ----------
        Z : (n_cases·n,) or (n_cases·n, r') array_like

        Returns
        -------
        (k·n,) or (k·n, r') ndarray
        """
        Z = as_finite_array(Z, "Z")
        Zm = Z[:, None] if Z.ndim == 1 else Z
        n, n_cases, k = self.G.shape
        if Zm.ndim != 2 or Zm.shape[0] != n_cases * n:
            raise DimensionError(
                f"Parameter `Z`: expected {n_cases * n} rows (n_cases·n), got {Z.shape}"
            )
        Zb = Zm.reshape(n_cases, n, Zm.shape[1]).transpose(1, 0, 2)
        Gt = np.ascontiguousarray(self.G.transpose(0, 2, 1))  # G[s]ᵀ, (n, k, n_cases)
        Xb = self.dt * block_conv(Gt, Zb[::-1])[::-1]
        out = np.ascontiguousarray(Xb.transpose(1, 0, 2)).reshape(k * n, Zm.shape[1])
        return out[:, 0] if Z.ndim == 1 else out

    def residual(self, X) -> float:
        """Relative residual ``‖A X − B‖_F / ‖B‖_F`` (by FFT, ``A`` never formed).

        0 if ``A X = B = 0``; ``inf`` if ``B = 0`` but ``A X ≠ 0``.
        """
        Xm = self._check_x(X)
        if Xm.shape[1] != self.n_rhs:
            raise DimensionError(
                f"Parameter `X`: expected {self.n_rhs} column(s) like `B`, got {np.shape(X)}"
            )
        R = self.matvec(Xm) - self._B2
        num = float(np.linalg.norm(R))
        den = float(np.linalg.norm(self._B2))
        if den > 0:
            return num / den
        return 0.0 if num == 0 else float("inf")

    def check_dense(self, max_bytes: float | None = None, *, solver: str | None = None) -> None:
        """Refuse a dense matrix ``A`` above ``max_bytes`` (default :data:`DENSE_MAX_BYTES`)
        with an :class:`InputError` suggesting a structured solver (what :meth:`dense` checks
        before forming it; a dense solver that forms another matrix of ``A``'s size checks
        the same)."""
        limit = check_positive(DENSE_MAX_BYTES if max_bytes is None else max_bytes,
                               "max_dense_bytes")
        n, n_cases, k = self.G.shape
        size = 8.0 * (n_cases * n) * (k * n)
        if size > limit:
            who = f"solver {solver!r}" if solver else "ConvolutionSystem.dense"
            raise InputError(
                f"{who}: the dense convolution matrix would be {n_cases * n} × "
                f"{k * n} ({size / 2**30:.3g} GiB > max_dense_bytes = {limit / 2**30:.3g} "
                "GiB; its pseudo-inverse costs O((k·n)³)); use a structured solver: 'block' "
                "(exact), 'fft' or 'cgls' (Tikhonov-regularized)"
            )

    def dense(self, max_bytes: float | None = None, *, solver: str | None = None) -> np.ndarray:
        """The dense matrix ``A`` (``n_cases·n × k·n``; block ``(j, i)`` is
        ``convolution_matrix(ʲq_i, dt)``), as :func:`block_convolution_matrix`.

        Parameters
        ----------
        max_bytes : float, optional
            Size limit (default :data:`DENSE_MAX_BYTES`): a larger matrix raises
            :class:`InputError` suggesting a structured solver.
        solver : str, optional
            Name of the solver asking, for the message.
        """
        self.check_dense(max_bytes, solver=solver)
        n, n_cases, k = self.G.shape
        out = np.zeros((n_cases * n, k * n))
        for j in range(n_cases):
            for i in range(k):
                q = self.G[:, j, i]
                out[j * n : (j + 1) * n, i * n : (i + 1) * n] = (
                    self.dt * scipy.linalg.toeplitz(q, np.zeros_like(q)))
        return out


def _unstack(X: np.ndarray, vector: bool) -> np.ndarray:
    """(n, k, r) kernel samples → C̄ (k·n, r) of Eq. 3.42 (or a vector)."""
    n, k, r = X.shape
    out = np.ascontiguousarray(X.transpose(1, 0, 2)).reshape(k * n, r)
    return out[:, 0] if vector else out


def first_sample(G: np.ndarray, zero_tol: float) -> int:
    """Number ``d`` of leading force samples treated as zero (``‖G[s]‖ <= zero_tol·max‖G‖``)."""
    norms = np.sqrt(np.sum(G.reshape(G.shape[0], -1) ** 2, axis=1))
    gmax = float(norms.max())
    if gmax == 0:
        raise IllConditionedError(
            "Parameter `Q_list`: every modal force sample is zero; nothing to deconvolve"
        )
    return int(np.flatnonzero(norms > zero_tol * gmax)[0])
