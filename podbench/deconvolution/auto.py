"""``"auto"``: the exact solver on clean data, the noise-robust one otherwise.

The choice is made from the training data only, by two tests that must both pass for the
exact answer: the exact solver — ``"block"`` with ``max_growth`` (default 1e4), else ``"ls"``
— succeeds (noise in a force before its first large sample makes the block substitution's
growth explode: measured 1.5 on the clean LTI beam, overflow at 0.01 % force noise), and the
kernel-based solver's evidence-maximizing noise estimate ``σ_l/rms(y_l)`` of the best-fitted
column (:class:`~podbench.deconvolution.KernelRegularized`, hyper-parameters only) is at most
``threshold`` (measured 0 on the clean beam, 3e-5 at 0.01 % noise, 3e-4 at 0.1 %; 6e-7 on a
clean chain). Otherwise the robust solution is returned: ``robust="kernel"`` (default, the
empirical-Bayes kernel solution) or ``robust="realization"``
(:class:`~podbench.deconvolution.Realization`, a low-order realization with its order from a
hold-out of the training record). Neither wins everywhere (docs/noise.md): on the
beam_forced_noise ML set (n = 250, k = 4, seeds 0–4) the realization's median error is 0.041
at 1 % and 0.150 at 5 % noise against the kernel's 0.049 and 0.210, but on the benchmark's
LTI-beam pulses at n = 1000, k = 6 (1 %) it is 0.112 against the kernel's 0.029, so the
default stays the kernel solver.
``info["choice"]`` records the solver whose solution was returned and
``info["noise_floor"]`` the estimate.
"""

from __future__ import annotations

from .._validation import check_choice, check_positive
from ..errors import ConvergenceError, IllConditionedError, InputError
from ._base import Solver
from .block import BlockSubstitution
from .dense import LeastSquares
from .kernel import DEFAULT_N_HYPER, KernelRegularized
from .realization import Realization
from .system import ConvolutionSystem

__all__ = ["Auto", "AUTO_THRESHOLD"]

AUTO_THRESHOLD = 1e-3
"""Default ``threshold`` of :class:`Auto`: a relative noise floor below 0.1 % counts as clean."""


class Auto(Solver):
    """Exact (``"block"``, else ``"ls"``) on clean data, ``"kernel"`` (or ``"realization"``)
    on noisy data (``"auto"``).

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
        Samples for its evidence (:class:`KernelRegularized`).
    robust : {"kernel", "realization"}
        The solver used on noisy data (default ``"kernel"``; ``"realization"`` with its
        defaults).

    Diagnostics: those of the solver chosen, plus ``choice`` (``"block"``, ``"ls"``,
    ``"realization"`` or ``"kernel"``), ``noise_floor``, ``threshold``.
    """

    name = "auto"
    structured = True

    def __init__(self, *, threshold: float = AUTO_THRESHOLD, max_growth: float = 1e4,
                 kernel: str = "dc", n_hyper: int | None = DEFAULT_N_HYPER,
                 robust: str = "kernel"):
        self.threshold = threshold
        self.max_growth = max_growth
        self.kernel = kernel
        self.n_hyper = n_hyper
        self.robust = robust

    def _robust(self) -> KernelRegularized:
        return KernelRegularized(kernel=self.kernel, n_hyper=self.n_hyper)

    def _validate_params(self) -> None:
        check_positive(self.threshold, "threshold")
        check_positive(self.max_growth, "max_growth")
        self._robust()._validate_params()
        check_choice(self.robust, "robust", ("kernel", "realization"))

    def _solve(self, system: ConvolutionSystem):
        extra = {"threshold": float(self.threshold)}
        exact = None
        for candidate in (BlockSubstitution(max_growth=self.max_growth), LeastSquares()):
            try:
                exact = candidate.solve(system)
                break
            except (IllConditionedError, ConvergenceError, InputError):
                continue
        robust = self._robust()
        hyper = robust.hyperparameters(system)
        floor = hyper["noise_floor_min"]
        extra["noise_floor"] = floor
        if exact is not None and floor <= self.threshold:
            info = {k: v for k, v in exact.info.items() if k not in ("solver", "residual")}
            return exact.X, {**info, "choice": exact.info["solver"], **extra}
        if self.robust == "realization":
            res = Realization().solve(system)
            info = {k: v for k, v in res.info.items() if k not in ("solver", "residual")}
            return res.X, {**info, "choice": "realization", **extra}
        X, info = robust._solve(system, hyper)
        return X, {**info, "choice": "kernel", **extra}
