"""Numbers of an iterative solve are written at the digits its stopping tolerance determines,
three digits above the BLAS kernel's round-off (issue 23, podbench.harness.digits)."""

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from podbench.deconvolution import CGLS, STLS

from podbench.harness.digits import (
    ITERATIVE_MARGIN,
    iterative_digits,
    iterative_note,
    iterative_row,
    solver_digits,
)

ROOT = Path(__file__).resolve().parents[2]


def test_digits_from_a_tolerance_and_a_roundoff():
    # a decade of tolerance moving a number by 2e-4 determines its 4th digit (unit >= 1e-4
    # of the value when its leading digit is 1... 9: 1e-3 of it at most); round-off of 1e-9
    # with three digits of margin would allow 7: the tolerance decides
    assert iterative_digits(2e-4, 1e-9) == 4
    assert iterative_digits(1.01e-4, 1e-12) == 4 and iterative_digits(9.9e-5, 1e-12) == 5
    # round-off of 3.3e-6 leaves 6 - 3 = 3 digits with the margin, whatever the tolerance
    assert iterative_digits(1e-12, 3.3e-6) == 3
    assert iterative_digits(1e-12, 3.3e-6, margin=1) == 5
    # never more than the tables' six, never fewer than one
    assert iterative_digits(1e-15, 1e-16) == 6 and iterative_digits(0.5, 0.1) == 1


def test_the_solvers_digits_follow_their_tolerances():
    # cgls: residual test, a decade of tol = 1e-10 moves a number by <= 1.7e4*tol = 1.7e-6
    # (6 digits determined); its round-off between kernels, 3.3e-6, leaves 3 with the margin
    assert CGLS.stopping.tolerance_move(CGLS().tol) == pytest.approx(1.7e-6)
    assert solver_digits("cgls") == 3
    # a looser tolerance determines fewer digits: 1e-6 moves by 1.7e-2 -> 2 digits
    assert solver_digits("cgls", 1e-6) == 2 and solver_digits("kernel") == 2
    # stls: objective-decrease test, the move grows as sqrt(tol): 5.3e-3 at 1e-6 -> 3 digits
    assert STLS.stopping.tolerance_move(STLS().tol) == pytest.approx(5.3e-3)
    assert solver_digits("stls") == 3 and solver_digits("stls", 1e-4) == 2
    # built on cgls's pilot; direct solvers keep the tables' digits; a superposition the
    # fewest of its parts'
    assert solver_digits("realization") == 3
    assert solver_digits("ls") is None and solver_digits("block+tls-dt") is None
    assert solver_digits("subspace") is None
    assert solver_digits("ls+cgls") == 3 and solver_digits("cgls+kernel") == 2


def test_a_margin_of_three_digits_makes_a_flip_rare():
    # values moved by the measured round-off (relative 3.3e-6, random sign) are written at
    # cgls's three digits: a written value changes only where the value lies within 3.3e-6
    # of a rounding boundary: 0.12 % of them (1e-3 of a unit for a leading 1, 9e-3 for a 9)
    rng = np.random.default_rng(0)
    v = 10.0 ** rng.uniform(-3, 3, 200_000)
    w = v * (1 + CGLS.stopping.roundoff * rng.choice([-1.0, 1.0], v.size))
    d = solver_digits("cgls")
    flips = np.mean([f"{a:.{d}g}" != f"{b:.{d}g}" for a, b in zip(v, w, strict=True)])
    assert 1e-4 < flips < 10.0 ** (1 - ITERATIVE_MARGIN)
    # at the tables' six digits the same round-off flips a large share
    six = [f"{a:.6g}" != f"{b:.6g}" for a, b in zip(v[:20_000], w[:20_000], strict=True)]
    assert np.mean(six) > 0.1


def test_iterative_row():
    row = {"scenario": "s", "method": "ML-cgls", "n_modes": 4, "total_error": 0.2972370553,
           "projection_error": 0.245438745, "norm_pe_max": 103.09877, "solver_iterations": 110,
           "solver_solves": 4, "diagonalization_error": 0.0, "residual_error": float("nan"),
           "converged": True, "status": "ok"}
    out = iterative_row(row, 3)
    assert out["total_error"] == 0.297 and out["norm_pe_max"] == 103.0
    # the basis's projection error is not the solver's; labels, counts of modes, flags kept
    assert out["projection_error"] == 0.245438745 and out["n_modes"] == 4
    assert out["converged"] is True and out["status"] == "ok" and out["method"] == "ML-cgls"
    # iteration counts are where round-off stops the iteration: not written
    assert math.isnan(out["solver_iterations"]) and math.isnan(out["solver_solves"])
    assert out["diagonalization_error"] == 0.0 and math.isnan(out["residual_error"])


def test_the_tables_say_so_when_a_solver_is_iterative():
    assert iterative_note(["ls", "auto", "", "block+tls-dt"]) == ""
    note = iterative_note(["ls", "stls", "cgls+ls", "cgls", "kernel"])
    assert "(significant digits `cgls`: 3, `kernel`: 2, `stls`: 3)" in note
    assert "iteration counts left empty" in note


# ------------------------------------------------------------------ across OpenBLAS kernels
def _avx512() -> bool:
    try:
        return "avx512f" in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


def _openblas() -> bool:
    import numpy  # noqa: F401 - load NumPy's BLAS before asking which it is
    from threadpoolctl import threadpool_info

    return any(i.get("internal_api") == "openblas" for i in threadpool_info())


CONTROL = r"""
import hashlib
import numpy as np
import scipy.fft
import podbench.deconvolution as dc

def h(a):
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]

# an ML-sized system (three load cases, three modes, 1 % noise), fitted by cgls and stls:
# their unrounded answers, which differ between OpenBLAS kernels
rng = np.random.default_rng(7)
n, k, J, dt = 300, 3, 3, 0.002
t = dt * np.arange(n)
freqs = rng.uniform(5.0, 40.0, (k, k))
X = np.exp(-3.0 * t)[:, None, None] * np.sin(2 * np.pi * freqs[None] * t[:, None, None])
G = np.zeros((n, J, k))
for j in range(J):
    G[1 + 3 * j: 6 + 3 * j, j, :] = rng.standard_normal(k)
N = scipy.fft.next_fast_len(2 * n - 1, real=True)
Y = dt * scipy.fft.irfft(np.einsum("fjk,fkr->fjr", scipy.fft.rfft(G, N, axis=0),
                                   scipy.fft.rfft(X, N, axis=0)), N, axis=0)[:n]
Gn = G + 0.01 * np.abs(G).max() * rng.standard_normal(G.shape) * (G != 0)
Yn = Y + 0.01 * np.sqrt(np.mean(Y**2)) * rng.standard_normal(Y.shape)
Q = [Gn[:, j, :].T for j in range(J)]
B = Yn.transpose(1, 0, 2).reshape(J * n, k)
print(" ".join(h(dc.deconvolve(Q, B, dt, s, return_info=True).X) for s in ("cgls", "stls")))
"""


def _env(coretype: str) -> dict:
    return {"PATH": os.environ.get("PATH", ""), "HOME": os.environ.get("HOME", "/root"),
            "PYTHONPATH": str(ROOT), "OPENBLAS_CORETYPE": coretype}


def _sweep(coretype: str, out: Path) -> bytes:
    cmd = [sys.executable, "-m", "podbench", "sweep",
           str(ROOT / "scenarios" / "sweeps" / "beam_forced_noise.toml"), "--noise", "0.05",
           "--seeds", "1", "--solvers", "cgls,stls", "-q", "-o", str(out / coretype),
           "--cache", str(out / ("cache-" + coretype))]
    subprocess.run(cmd, env=_env(coretype), check=True, cwd=ROOT, capture_output=True)
    return (out / coretype / "beam_forced_noise" / "sweep.csv").read_bytes()


@pytest.mark.slow
def test_cgls_and_stls_rows_identical_across_openblas_kernels(tmp_path):
    """SL and ML with cgls and stls on the LTI and NL beams at 5 % noise (one seed of the
    beam_forced_noise sweep, ~40 s): the same sweep.csv bytes on the Haswell and SkylakeX
    kernels. A control (the unrounded cgls and stls answers of an ML-sized system) must
    differ between them, else the test could not fail and is skipped."""
    if not _openblas():
        pytest.skip("NumPy's BLAS is not OpenBLAS: no OPENBLAS_CORETYPE to switch")
    if not _avx512():
        pytest.skip("the CPU has no AVX-512: OpenBLAS cannot run its SkylakeX kernels")
    controls = [subprocess.run([sys.executable, "-c", CONTROL], env=_env(c), check=True,
                               capture_output=True, text=True).stdout
                for c in ("Haswell", "SkylakeX")]
    if controls[0] == controls[1]:
        pytest.skip("the two kernels give the same unrounded cgls and stls answers here: "
                    "the test could not tell them apart")
    haswell, skylake = _sweep("Haswell", tmp_path), _sweep("SkylakeX", tmp_path)
    assert haswell.count(b"\n") == 9  # header and 8 rows: 2 structures x SL, ML x 2 solvers
    assert haswell == skylake


def test_a_solver_declares_its_digits_in_its_result_and_the_rows_follow():
    """The solver's result carries what its stopping tolerance determines; the harness
    writes a fit's rows from the fitted estimator's results, not from a table of names: a
    looser tolerance gives fewer digits, an answer built on an iterative pilot (realization)
    its pilot's, a direct solve none."""
    import podbench.deconvolution as dc
    from podbench.methods import SingleLoad

    from podbench.harness.digits import estimator_writer
    from podbench.sysid.deconvolution.determined import Determined

    rng = np.random.default_rng(0)
    n = 200
    q = np.zeros((1, n))
    q[0, 1:4] = [1.0, 2.0, 1.0]
    y = dc.convolution_product([q], np.exp(-0.05 * np.arange(n)) * np.sin(0.3 * np.arange(n)),
                               1e-3) + 1e-6 * rng.standard_normal(n)
    system = dc.ConvolutionSystem([q], y, 1e-3)
    res = dc.CGLS().solve(system)
    assert res.determined == Determined(1e-10, 3, 2)
    assert Determined.from_info(res.info["determined"]) == res.determined
    assert dc.CGLS(tol=1e-6).solve(system).determined.digits == 2
    assert dc.LeastSquares().solve(system).determined is None
    assert "determined" not in dc.LeastSquares().solve(system).info
    W = np.vstack([y, 0.5 * y])
    F = np.vstack([q[0], np.zeros(n)])
    import podbench as pb
    rec = pb.Record(W=W, F=F, dt=1e-3)
    row = {"total_error": 0.123456789, "scenario": "s"}
    loose = SingleLoad(n_modes=1, solver="cgls", solver_options={"tol": 1e-6}).fit([rec])
    assert estimator_writer(loose)(row)["total_error"] == 0.12
    tight = SingleLoad(n_modes=1, solver="cgls").fit([rec])
    assert estimator_writer(tight)(row)["total_error"] == 0.123
    assert estimator_writer(SingleLoad(n_modes=1, solver="ls").fit([rec])) is None
