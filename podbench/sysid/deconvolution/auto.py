"""``"auto"``: the exact solver on clean data, the noise-robust one otherwise.

The choice is made from the training data only. First the noise test: the kernel-based
solver's evidence-maximizing noise estimate ``σ_l/rms(y_l)`` of the best-fitted column
(:class:`~podbench.deconvolution.KernelRegularized`, hyper-parameters only, on the first
``m`` samples) must be at most ``threshold``. With the default robust path the window is
``m = max(16, 256 // k)`` samples (:data:`AUTO_TEST_UNKNOWNS`): measured on the LTI-beam
pulses at n = 8000, k = 16 (benchmarks/robust.py) the estimate is 1.2e-7 clean, 7.6e-4 at
0.1 % and 7.7e-3 at 1 % noise, in 0.7–1.0 s (the kernel solver's own 64-sample window:
11.4 s). Only if the data pass it the exact solver runs — ``"block"`` with ``max_growth``
(default 1e4), else ``"ls"`` — and its solution is returned if it succeeds (noise in a force
before its first large sample makes the block substitution's growth explode: measured 1.5
on the clean LTI beam, overflow at 0.01 % force noise). Otherwise the robust solution:
``robust="subspace"`` (default; :class:`~podbench.deconvolution.Subspace`, poles by
subspace identification of the records), ``"kernel"`` (the empirical-Bayes kernel solution,
its evidence on the kernel solver's own window) or ``"realization"``
(:class:`~podbench.deconvolution.Realization`).

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
``info["choice"]`` records the solver whose solution was returned and
``info["noise_floor"]`` the estimate.
"""

from __future__ import annotations

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

__all__ = ["Auto", "AUTO_THRESHOLD", "AUTO_TEST_UNKNOWNS"]

AUTO_THRESHOLD = 1e-3
"""Default ``threshold`` of :class:`Auto`: a relative noise floor below 0.1 % counts as clean."""

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
        Largest relative noise floor ``σ/rms(y)`` (the kernel solver's evidence estimate,
        smallest over the columns of ``B``) treated as clean (default :data:`AUTO_THRESHOLD`).
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

    Diagnostics: those of the solver chosen, plus ``choice`` (``"block"``, ``"ls"``,
    ``"subspace"``, ``"realization"`` or ``"kernel"``), ``noise_floor``, ``threshold``.
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
        extra = {"threshold": float(self.threshold)}
        robust = self._test(system)
        hyper = robust.hyperparameters(system)
        floor = hyper["noise_floor_min"]
        extra["noise_floor"] = floor
        if floor <= self.threshold:  # the exact solvers only when the data look clean
            for candidate in (BlockSubstitution(max_growth=self.max_growth), LeastSquares()):
                try:
                    exact = candidate.solve(system)
                except (IllConditionedError, ConvergenceError, InputError):
                    continue
                info = {k: v for k, v in exact.info.items() if k not in ("solver", "residual")}
                return exact.X, {**info, "choice": exact.info["solver"], **extra}
        if self.robust in ("subspace", "realization"):
            res = (Subspace() if self.robust == "subspace" else Realization()).solve(system)
            info = {k: v for k, v in res.info.items() if k not in ("solver", "residual")}
            return res.X, {**info, "choice": self.robust, **extra}
        X, info = robust._solve(system, hyper)
        return X, {**info, "choice": "kernel", **extra}
