"""``"auto"``: the exact solver on clean data, the noise-robust one otherwise.

The choice is made from the training data only, by one of two noise tests.

**The kernel test** (whenever ``"block"`` solves the system: as many load cases as modes,
a well-conditioned first force sample, growth at most ``max_growth``, default 1e4). The
exact block solution runs first — it is the answer on clean data and costs
``O(k³ n log² n)`` — and its kernel is tested: records of a linear system of finite order
give as their exact kernel that system's impulse response, whose block Hankel matrix has rank at
most the order, so its trailing singular values are round-off; noise enters the exact
kernel as ``A⁻¹E``, of full rank, and lifts them (:func:`hankel_floor`, ``σ_j`` at
``j = ⌊0.9·N⌋`` of a Hankel matrix of at most 256 × 256, one SVD without vectors). The
floor is read as a noise level by comparing it with the floor of reference noise, white at
``threshold`` × each column's RMS, through the same block solve
(:func:`kernel_noise_floor`): ``noise_floor = threshold · σ_j(data) / σ_j(reference)``; the
data are clean when it is at most ``threshold``. Measured (benchmarks/auto_test.py; eight
structures — 150- and 40-storey shear frames, the LTI beam at 10 kHz and 1 kHz, the truss,
two chains, the aluminium beam — half-sine loads, ML and SL, noise per measured channel on
the responses): at most 8e-11 on every exact record (13 fits), 3e-8…8e-5 on records rounded
to single precision (13), and on noisy records 0.5…40× the true level (the undamped LTI beam
sampled at 1 kHz: up to 3500×; 0.3 %: 2.5e-3 and more, 13 of 13 judged noisy; 0.1 %: 11 of
13; 0.01 %: 4 of 13). Its cost is a block solve on the first ``L + J`` samples and two
SVDs: on the 150-DOF frame (n = 1000, k = 4) the ML fit with ``auto`` takes 2.3–2.5× the
fit with ``"block"`` (benchmarks/defaults.py). A clean record of a *nonlinear* structure
has no finite-order kernel and may be judged noisy (the robust solution is then returned).

**The evidence test** (when ``"block"`` refuses — noise in a force before its first large
sample makes the block substitution's growth explode: measured 1.5 on the clean LTI beam,
overflow at 0.01 % force noise — or the system is over-determined): the kernel-based
solver's evidence-maximizing noise estimate ``σ_l/rms(y_l)`` of the best-fitted column
(:class:`~podbench.deconvolution.KernelRegularized`, hyper-parameters only, on the first
``m`` samples) must be at most ``threshold``. With the default robust path the window is
``m = max(16, 256 // k)`` samples (:data:`AUTO_TEST_UNKNOWNS`): measured on the LTI-beam
pulses at n = 8000, k = 16 (benchmarks/robust.py) the estimate is 1.2e-7 clean, 7.6e-4 at
0.1 % and 7.7e-3 at 1 % noise, in 0.7–1.0 s (the kernel solver's own 64-sample window:
11.4 s); 25–50 eigendecompositions, about 40× a block solve. Data that pass it are solved
by the dense ``"ls"``.

Otherwise the robust solution: ``robust="subspace"`` (default;
:class:`~podbench.deconvolution.Subspace`, poles by subspace identification of the
records), ``"kernel"`` (the empirical-Bayes kernel solution, its evidence on the kernel
solver's own window) or ``"realization"`` (:class:`~podbench.deconvolution.Realization`).

The default robust path, by measurement (1 % noise per measured channel unless stated;
median (max) over seeds 0–4; docs/noise.md has the tables). No path wins everywhere:

* beam_forced_noise sweep, LTI beam ML (n = 250, k = 4): subspace 0.045 (0.069) at 1 %,
  0.161 (0.258) at 5 %; realization 0.0405 (0.066), 0.150 (0.26); kernel 0.049, 0.210;
  cgls 0.068 (0.103), 0.211 (0.33).
* benchmark pulses n = 1000, k = 6: subspace 0.026 (0.077) in about 0.6 s; kernel 0.040
  (0.085) in 8–37 s; realization 0.077 (0.26); cgls 0.084 (0.165).
* benchmark pulses n = 8000, k = 16 (seed 0): subspace 7.7 s (4.0× block), auto 9.0 s
  (4.6×); kernel 573 s, cgls 645 s, realization 531 s. None predicts: subspace 2.25, cgls
  0.90, kernel 1.3, realization 24 — twelve of the sixteen POMs of the noisy training record
  lie below its noise (POVs 5–16 are 1.2e-3 … 2e-6 of the first, the noise's ~2e-3); at
  0.1 % noise subspace 0.31 (5.2×), cgls 0.94 (288×).
* Chapter 5 records (n = 1024; total error against the measured 4-in record, 1 / 2 / 5 %):
  linear beam ML subspace 0.272 / 0.272 / 0.275 (cgls 0.273 / 0.275 / 0.287, realization
  0.264 / 0.264 / 0.268), SL 0.296 / 0.294 / 0.299 (cgls 0.298–0.304); rubber-band beam ML
  subspace 0.607 / 0.255 / 0.380 (cgls 0.238 / 0.242 / 0.260, realization 0.545), SL 0.282 /
  0.283 / 0.292 (cgls 0.275–0.291).

The subspace path is the only one within 10× of ``block`` at n = 8000, k = 16 and is best
or close to best on the ML sets of Chapter 4 and on Chapter 5's linear beam; on the
rubber-band beam's ML records cgls is better.
``info["choice"]`` records the solver whose solution was returned, ``info["noise_test"]``
the test that decided (``"kernel"`` or ``"evidence"``) and ``info["noise_floor"]`` its
estimate of the relative noise level.
"""

from __future__ import annotations

import numpy as np

from podbench.errors import ConvergenceError, IllConditionedError, InputError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution.block import BlockSubstitution
from podbench.sysid.deconvolution.dense import LeastSquares
from podbench.sysid.deconvolution.kernel import (
    DEFAULT_N_HYPER,
    MAX_HYPER_UNKNOWNS,
    KernelRegularized,
)
from podbench.sysid.deconvolution.realization import Realization
from podbench.sysid.deconvolution.subspace import Subspace
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.params import COUNT, POSITIVE, Options

__all__ = ["Auto", "AUTO_THRESHOLD", "AUTO_TEST_UNKNOWNS", "KERNEL_TEST_SIZE", "hankel_floor",
           "kernel_noise_floor"]

KERNEL_TEST_SIZE = 256
"""Largest side of the kernel test's Hankel matrix (:func:`hankel_floor`)."""

AUTO_THRESHOLD = 1e-3
"""Default ``threshold`` of :class:`Auto`: a relative noise level ``σ/rms(y)`` below 0.1 %
counts as clean (either test)."""

AUTO_TEST_UNKNOWNS = 256
"""Unknowns ``k·m`` of the noise-floor test's evidence window by default (``m = max(16,
256 // k)`` samples) when the robust path is not the kernel solver: at n = 8000, k = 16 the
test then costs about 1 s (the kernel solver's own window, ``k·m = 1024``: 11.4 s)."""


class Auto(Solver):
    """Exact (``"block"``, else ``"ls"``) on clean data, ``"subspace"`` (or ``"kernel"``,
    ``"realization"``) on noisy data (``"auto"``).

    Parameters
    ----------
    threshold : float
        Largest relative noise level ``σ/rms(y)`` treated as clean (default
        :data:`AUTO_THRESHOLD`): by the kernel test (:func:`kernel_noise_floor`, when
        ``"block"`` solves the system), else the kernel solver's evidence estimate (smallest
        over the columns of ``B``).
    max_growth : float
        Largest growth ``‖A‖‖X‖/‖B‖`` of the block substitution accepted (default 1e4;
        measured 1.5 on the clean LTI beam, overflow with 0.01 % noise on the forces).
    kernel : {"dc", "tc"}
        Prior of the kernel solver (the noise-floor test, and the robust solution if
        ``robust="kernel"``).
    n_hyper : int, optional
        Samples for its evidence (:class:`KernelRegularized`; default: ``max(16, 256 // k)``
        for the test, the kernel solver's own default with ``robust="kernel"``).
    robust : {"subspace", "kernel", "realization"}
        The solver used on noisy data (default ``"subspace"``; each with its defaults).

    Notes
    -----
    Diagnostics: those of the solver chosen, plus ``choice`` (``"block"``, ``"ls"``,
    ``"subspace"``, ``"realization"`` or ``"kernel"``), ``noise_test`` (``"kernel"`` or
    ``"evidence"``), ``noise_floor`` (the deciding test's estimate; with ``robust="kernel"``
    after the kernel test also ``evidence_noise_floor``), ``threshold``.
    """

    name = "auto"
    structured = True
    _parameter_constraints = {"threshold": [POSITIVE], "max_growth": [POSITIVE],
                              "kernel": [Options("dc", "tc")], "n_hyper": [None, COUNT],
                              "robust": [Options("subspace", "kernel", "realization")]}

    def __init__(self, *, threshold: float = AUTO_THRESHOLD, max_growth: float = 1e4,
                 kernel: str = "dc", n_hyper: int | None = DEFAULT_N_HYPER,
                 robust: str = "subspace"):
        self.threshold = threshold
        self.max_growth = max_growth
        self.kernel = kernel
        self.n_hyper = n_hyper
        self.robust = robust

    def _test(self, system: ConvolutionSystem | None = None) -> KernelRegularized:
        """The kernel solver whose evidence gives the noise floor (and, with
        ``robust="kernel"``, the robust solution)."""
        m = self.n_hyper
        if m is None and self.robust != "kernel" and system is not None:
            m = max(16, AUTO_TEST_UNKNOWNS // system.k)
            m = None if m * system.k >= MAX_HYPER_UNKNOWNS else m
        return KernelRegularized(kernel=self.kernel, n_hyper=m)

    def _solve(self, system: ConvolutionSystem):
        extra: dict[str, object] = {"threshold": float(self.threshold)}
        exact = self._block(system)
        if exact is not None:  # the kernel test, calibrated by reference noise
            floor = kernel_noise_floor(system, exact, self.threshold)
            extra.update(noise_test="kernel", noise_floor=floor)
            if floor <= self.threshold:
                return exact.X, {**_info(exact), "choice": "block", **extra}
            return self._robust(system, None, extra)
        robust = self._test(system)  # block refused: the kernel solver's evidence decides
        hyper = robust.hyperparameters(system)
        floor = hyper["noise_floor_min"]
        extra.update(noise_test="evidence", noise_floor=floor)
        if floor <= self.threshold:  # the dense exact solver only when the data look clean
            try:
                exact = LeastSquares().solve(system)
            except (IllConditionedError, ConvergenceError, InputError):
                exact = None
            if exact is not None:
                return exact.X, {**_info(exact), "choice": "ls", **extra}
        return self._robust(system, (robust, hyper), extra)

    def _block(self, system: ConvolutionSystem):
        """The exact block solution, or None where ``"block"`` refuses the system."""
        if system.n_cases != system.k:
            return None
        try:
            return BlockSubstitution(max_growth=self.max_growth).solve(system)
        except (IllConditionedError, ConvergenceError, InputError):
            return None

    def _robust(self, system: ConvolutionSystem, evidence, extra: dict):
        """The noise-robust solution (``evidence``: the kernel solver and its
        hyper-parameters when already computed)."""
        if self.robust in ("subspace", "realization"):
            res = (Subspace() if self.robust == "subspace" else Realization()).solve(system)
            return res.X, {**_info(res), "choice": self.robust, **extra}, res.realization
        robust, hyper = evidence if evidence is not None else (self._test(system), None)
        if hyper is None:
            hyper = robust.hyperparameters(system)
            extra = {**extra, "evidence_noise_floor": hyper["noise_floor_min"]}
        X, info = robust._solve(system, hyper)
        det = robust.determined()
        return X, {**info, "choice": "kernel", **extra,
                   **({"determined": det.as_info()} if det is not None else {})}


def _info(result) -> dict:
    return {k: v for k, v in result.info.items() if k not in ("solver", "residual")}


def hankel_floor(X: np.ndarray, shift: int = 0, size: int = KERNEL_TEST_SIZE,
                 blocks: tuple[int, int] | None = None) -> float:
    """Singular value ``σ_j`` (``j = ⌊0.9·N⌋``, 0-based) of the block Hankel matrix of the
    kernel ``X`` (``(n, k, r)`` samples, lags ``1 … n−1−shift``); 0 for a kernel too short.

    ``H[i, j] = X[1 + i + j]`` (block ``k × r``), ``L = min(size // k, n'/2)`` block rows
    and ``J = min(size // r, n' − L)`` block columns (``N = min(L·k, J·r)`` singular
    values; at most ``size × size``, one SVD without vectors; ``blocks=(L, J)`` imposes
    them, for ``L + J`` lags or more). The kernel of records from a
    linear system of finite order is the impulse response of that system, whose Hankel
    matrix has rank at most its order: its trailing singular values are round-off. Noise in
    the records enters the exact kernel as ``A⁻¹E``, of full rank, and lifts them.
    """
    n, k, r = X.shape
    X = X[1 : n - shift]
    m = X.shape[0]
    if m < 4:
        return 0.0
    L, J = _hankel_blocks(m, k, r, size) if blocks is None else blocks
    H = np.empty((L * k, J * r))
    for i in range(L):
        H[i * k : (i + 1) * k] = X[i : i + J].transpose(1, 0, 2).reshape(k, J * r)
    sv = np.linalg.svd(H, compute_uv=False)
    return float(sv[int(0.9 * len(sv))])


def _hankel_blocks(m: int, k: int, r: int, size: int) -> tuple[int, int]:
    """Block rows and columns of :func:`hankel_floor`'s matrix for ``m`` lags."""
    L = max(1, min(size // k, m // 2))
    return L, max(1, min(size // r, m - L))


def kernel_noise_floor(system: ConvolutionSystem, exact, threshold: float) -> float:
    """The kernel test's noise estimate: ``threshold · σ_j(H(X)) / σ_j(H(X_ref))``.

    ``X`` is the exact block kernel of the records (``exact``, a solved
    :class:`~podbench.deconvolution.BlockSubstitution` result) and ``X_ref = A⁻¹E_ref`` the
    exact kernel of reference noise alone: white, standard normal (a fixed stream, seed 0),
    scaled per load case and column of ``B`` to ``threshold`` × that column's RMS — noise
    at the level the test accepts, through the same triangular solve. ``σ_j`` is
    :func:`hankel_floor`. The estimate is at most ``threshold`` when the records' Hankel
    floor is no higher than that of noise at ``threshold``. Noise floors scale with the
    noise level, so the estimate reads as a relative noise level ``σ/rms(y)``; it is
    unchanged when the forces or the responses change units.
    """
    Y = system.Y  # (n, n_cases, r)
    shift = exact.info["shift"]
    n, n_cases, r = Y.shape
    # the Hankel matrix reads lags 1 … L+J−1 only, which the first shift + L + J equations fix
    L, J = _hankel_blocks(max(n - shift - 1, 1), system.k, r, KERNEL_TEST_SIZE)
    n_ref = min(n, shift + L + J + 1)
    rms = np.sqrt(np.mean(Y**2, axis=0))  # (n_cases, r), over the whole record
    E = np.random.default_rng(0).standard_normal((n_ref, n_cases, r)) * (threshold * rms)
    ref_system = ConvolutionSystem([q[:, :n_ref] for q in system.Q_list],
                                   E.transpose(1, 0, 2).reshape(-1, r), system.dt)
    with np.errstate(all="ignore"):
        ref = BlockSubstitution(max_growth=1e300).solve(ref_system)
    f_data = hankel_floor(system.blocks(exact.X), shift, blocks=(L, J))
    f_ref = hankel_floor(ref_system.blocks(ref.X), shift, blocks=(L, J))
    if not f_ref > 0:
        return 0.0 if f_data == 0 else float("inf")
    return float(threshold * f_data / f_ref)
