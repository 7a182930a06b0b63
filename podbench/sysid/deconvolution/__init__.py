"""Discrete convolution, the block convolution system and deconvolution solvers (§3.3, §3.5).

Convolution convention (Eq. 3.39, with the Δt factor kept; the dissertation's MATLAB drops
it, so its identified kernel is Δt times podbench's, with identical predictions)::

    v[s] = Δt Σ_{p=0}^{s} c[p] q[s−p],   s = 0 … n−1,

with sample ``j`` at ``t_j = j·Δt`` (index 0 is ``t = 0``). In matrix form ``v = Q̌ c`` with
the lower-triangular Toeplitz convolution matrix ``Q̌ = Δt·toeplitz(q)`` (Eq. 3.40).

Solvers
-------
A deconvolution solves ``A X ≈ B`` for ``X`` where ``A`` is the (block) convolution matrix of
Eq. 3.40 / 3.48 (``n_cases·n × k·n``, lower-triangular block Toeplitz) and ``B`` the stacked
scaled POC histories, held by a :class:`ConvolutionSystem`. A solver is an object (as in
opinf's ``lstsq``): hyper-parameters in the constructor, ``solve(system)`` returning a
:class:`SolverResult` (``X`` and ``info``: residual, chosen Tikhonov parameter, iterations,
rank, growth, …)::

    result = CGLS(reg="gcv").solve(ConvolutionSystem(Q_list, B, dt))
    result.X, result.info["reg"], result.info["iterations"]
    deconvolve(Q_list, B, dt, solver="block")          # X; SL/ML/MR call this
    deconvolve(Q_list, B, dt, "fft", return_info=True)  # SolverResult
    solve(A, B, solver="tls-dt", rcond=1e-3)            # dense solvers on a given matrix
    make_solver("my_solvers.py:Mine", {"alpha": 2})     # a Solver subclass of one's own

Dense (form ``A``; the reference, ``O((kn)³)`` time and ``O((kn)²)`` memory):

``"ls"``    :class:`LeastSquares` (:func:`least_squares`), minimum-norm least squares
            ``X = A⁺ B`` (Eq. 3.76) by an SVD-based LAPACK driver.
``"tls-dt"`` :class:`TruncatedTLS` (:func:`truncated_tls`), truncated total least squares
            (Eqs. 3.78–3.80, several right-hand sides) of the Δt-scaled matrix, rank by
            :func:`tls_rank`; its cut depends on Δt and the units (``scale=True``
            equilibrates the columns first); refused above :data:`TLS_MAX_COLUMNS`
            columns. Formerly ``"tls"``, which still names it (with a warning).
``"tls-appendix"`` :class:`AppendixTLS` (:func:`appendix_tls`), the dissertation's TLS: the
            appendix's ``tlsdeconv`` on the raw force samples (no Δt), ``σ_1/σ_i <= tol``
            (``tol = 1000``, or ``tol="snr"``: the SNR of the forces), one right-hand side at
            a time — Chapter 5's solver.
``"tls-balanced"`` :class:`BalancedTLS`, the same with each force block and each right-hand
            side divided by its norm first: the answer does not depend on units (the
            recommended TLS for noisy data).

Structured (never form ``A``):

``"block"`` :class:`BlockSubstitution` (:func:`block_substitution`), exact block forward
            substitution (divide and conquer with FFT updates, ``O(k³ n log² n)``) after
            shifting past leading zero force samples; equals ``"ls"`` when the load cases are
            as many as the modes and the first nonzero force sample is nonsingular; refuses
            ill-conditioned systems.
``"fft"``   :class:`FFTTikhonov` (:func:`fft_tikhonov`), per-frequency matrix deconvolution
            with Tikhonov regularization (circular: fast but biased by the record's
            truncation).
``"cgls"``  :class:`CGLS` (:func:`cgls_fft`), Tikhonov-regularized least squares on the exact
            system by conjugate gradients with FFT products and a circulant preconditioner;
            ``reg=0`` is plain least squares (also over-determined ML).
``"kernel"`` :class:`KernelRegularized`, empirical-Bayes (DC/TC prior) regularization.
``"realization"`` :class:`Realization`, a low-order state-space realization (ERA poles of a
            pilot kernel, residues refitted on the whole record, order by hold-out).
``"subspace"`` :class:`Subspace`, poles by PO-MOESP subspace identification of the records
            (instrumental variables: consistent under measurement noise), residues refitted
            on the whole record, order by hold-out above a rank floor.
``"stls"``  :class:`STLS`, regularized structured total least squares: the kernel and a
            correction of the measured force samples (the convolution matrix stays block
            Toeplitz), Gauss–Newton steps by LSQR with FFT products, λ by GCV.
``"auto"``  :class:`Auto`, exact on clean data, ``"subspace"`` (or ``"kernel"``,
            ``"realization"``) on noisy.

The Tikhonov parameter of ``"fft"`` and ``"cgls"`` is chosen by generalized
cross-validation unless given (``reg="gcv"``, the default; :func:`gcv_regularization`).
"""

from podbench.sysid.deconvolution._api import (
    RENAMED,
    available_solvers,
    current_name,
    deconvolve,
    get_solver,
    make_solver,
    renamed_warned,
    solve,
    structured_solvers,
)
from podbench.sysid.deconvolution._base import INFO_KEYS, Solver, SolverResult, UnknownOptionError
from podbench.sysid.deconvolution.auto import AUTO_THRESHOLD, Auto
from podbench.sysid.deconvolution.block import BlockSubstitution, block_substitution
from podbench.sysid.deconvolution.convolution import (
    block_convolution_matrix,
    convolution_matrix,
    convolution_product,
    convolve,
    convolve_kernel,
)
from podbench.sysid.deconvolution.dense import (
    DEFAULT_APPENDIX_TOL,
    DEFAULT_TLS_RCOND,
    TLS_MAX_COLUMNS,
    AppendixTLS,
    BalancedTLS,
    DenseSolver,
    LeastSquares,
    TruncatedTLS,
    appendix_tls,
    least_squares,
    snr_tol,
    tls_rank,
    truncated_tls,
)
from podbench.sysid.deconvolution.kernel import (
    DEFAULT_N_HYPER,
    KernelRegularized,
    kernel_matrix,
    log_marginal_likelihood,
)
from podbench.sysid.deconvolution.realization import (
    DEFAULT_MAX_ORDER,
    MAX_HANKEL_ROWS,
    Realization,
    pole_basis,
    pole_realization,
    pole_regressors,
)
from podbench.sysid.deconvolution.snr import noise_std, snr, system_snr
from podbench.sysid.deconvolution.stls import DEFAULT_STLS_MAX_ITER, DEFAULT_STLS_TOL, STLS
from podbench.sysid.deconvolution.subspace import RANK_TOL, Subspace
from podbench.sysid.deconvolution.system import DENSE_MAX_BYTES, ConvolutionSystem
from podbench.sysid.deconvolution.tikhonov import (
    CGLS,
    DEFAULT_TIKHONOV_REG,
    GCV_BOUNDS,
    TRIAL_ITER,
    FFTTikhonov,
    cgls_fft,
    fft_tikhonov,
    gcv_regularization,
)

__all__ = [
    "RENAMED",
    "current_name",
    "renamed_warned",
    # convolution
    "convolution_matrix",
    "block_convolution_matrix",
    "convolve",
    "convolve_kernel",
    "convolution_product",
    # the system and the solver contract
    "ConvolutionSystem",
    "Solver",
    "SolverResult",
    "DenseSolver",
    "INFO_KEYS",
    "UnknownOptionError",
    # solver objects
    "LeastSquares",
    "TruncatedTLS",
    "AppendixTLS",
    "BalancedTLS",
    "BlockSubstitution",
    "FFTTikhonov",
    "CGLS",
    "KernelRegularized",
    "Realization",
    "Subspace",
    "RANK_TOL",
    "STLS",
    "Auto",
    "make_solver",
    "kernel_matrix",
    "log_marginal_likelihood",
    "pole_basis",
    "pole_realization",
    "pole_regressors",
    # function forms
    "least_squares",
    "truncated_tls",
    "appendix_tls",
    "snr_tol",
    "tls_rank",
    "solve",
    "deconvolve",
    "block_substitution",
    "fft_tikhonov",
    "cgls_fft",
    "gcv_regularization",
    "noise_std",
    "snr",
    "system_snr",
    "get_solver",
    "available_solvers",
    "structured_solvers",
    # constants
    "DEFAULT_TLS_RCOND",
    "DEFAULT_APPENDIX_TOL",
    "DEFAULT_TIKHONOV_REG",
    "GCV_BOUNDS",
    "TRIAL_ITER",
    "TLS_MAX_COLUMNS",
    "DENSE_MAX_BYTES",
    "DEFAULT_N_HYPER",
    "AUTO_THRESHOLD",
    "DEFAULT_MAX_ORDER",
    "MAX_HANKEL_ROWS",
    "DEFAULT_STLS_TOL",
    "DEFAULT_STLS_MAX_ITER",
]
