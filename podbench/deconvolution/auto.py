"""``"auto"``: the exact solver on clean data, the noise-robust one otherwise.

The choice is made from the training data only: the kernel-based solver
(:class:`~podbench.deconvolution.KernelRegularized`) is run first, and its evidence-maximizing
noise estimate ``noise_floor = σ/rms(y)`` (largest over the columns of ``B``) decides. On
clean data the evidence puts ``σ`` at the round-off / discretization level (measured ~1e-6
on a chain, ≤ 1e-4 on the beams) and the exact solver's answer is returned — ``"block"``,
falling back to ``"ls"`` if it refuses the system; above ``threshold`` the kernel solution is
returned. ``info["choice"]`` records the solver whose solution was returned and
``info["noise_floor"]`` the estimate.
"""

from __future__ import annotations

from .._validation import check_positive
from ..errors import ConvergenceError, IllConditionedError, InputError
from ._base import Solver
from .block import BlockSubstitution
from .dense import LeastSquares
from .kernel import DEFAULT_N_HYPER, KernelRegularized
from .system import ConvolutionSystem

__all__ = ["Auto", "AUTO_THRESHOLD"]

AUTO_THRESHOLD = 1e-3
"""Default ``threshold`` of :class:`Auto`: a relative noise floor below 0.1 % counts as clean."""


class Auto(Solver):
    """Exact (``"block"``, else ``"ls"``) on clean data, ``"kernel"`` on noisy data
    (``"auto"``).

    Parameters
    ----------
    threshold : float
        Largest relative noise floor ``σ/rms(y)`` (the kernel solver's evidence estimate)
        treated as clean (default :data:`AUTO_THRESHOLD`).
    kernel : {"dc", "tc"}
        Prior of the robust solver.
    n_hyper : int
        Samples for its evidence (:class:`KernelRegularized`).

    Diagnostics: those of the solver chosen, plus ``choice`` (``"block"``, ``"ls"`` or
    ``"kernel"``), ``noise_floor``, ``threshold``.
    """

    name = "auto"
    structured = True

    def __init__(self, *, threshold: float = AUTO_THRESHOLD, kernel: str = "dc",
                 n_hyper: int = DEFAULT_N_HYPER):
        self.threshold = threshold
        self.kernel = kernel
        self.n_hyper = n_hyper

    def _robust(self) -> KernelRegularized:
        return KernelRegularized(kernel=self.kernel, n_hyper=self.n_hyper)

    def _validate_params(self) -> None:
        check_positive(self.threshold, "threshold")
        self._robust()._validate_params()

    def _solve(self, system: ConvolutionSystem):
        robust = self._robust().solve(system)
        floor = robust.info["noise_floor"]
        extra = {"noise_floor": floor, "threshold": float(self.threshold)}
        if floor is not None and floor <= self.threshold:
            for exact in (BlockSubstitution(), LeastSquares()):
                try:
                    out = exact.solve(system)
                except (IllConditionedError, ConvergenceError, InputError):
                    continue
                info = {k: v for k, v in out.info.items() if k not in ("solver", "residual")}
                return out.X, {**info, "choice": exact.name, **extra}
        info = {k: v for k, v in robust.info.items() if k not in ("solver", "residual")}
        return robust.X, {**info, "choice": "kernel", **extra}
