"""Cached training/target data sets shared by the method tests (built with ``_truth``).

Systems (``_truth``): the *coupled* chain breaks the diagonal assumptions (non-diagonal mass,
non-proportional damping); the *ideal* chain meets them (identity mass, light Rayleigh
damping). Both have 5 DOFs, every DOF is a sensor (m = 5).
"""

from __future__ import annotations

from functools import cache
from types import SimpleNamespace

import numpy as np

from ._truth import coupled_chain, ideal_chain, newmark, pulse, smooth_load

D = 5  # DOFs = sensors

# Sampling: coupled chain, 16+ samples per shortest period; ideal chain, a longer record
# (4 s ≈ 18 periods of the slowest mode) so that the POMs approach the eigenmodes.
COUPLED_DT, COUPLED_N = 0.002, 200
IDEAL_DT, IDEAL_N = 0.01, 400


def system(name: str):
    return coupled_chain(D) if name == "coupled" else ideal_chain(D)


def sampling(name: str) -> tuple[float, int]:
    return (COUPLED_DT, COUPLED_N) if name == "coupled" else (IDEAL_DT, IDEAL_N)


@cache
def free_case(name: str, excitation: str) -> SimpleNamespace:
    """D + 1 free responses: D training sets (independent random profiles) and a target."""
    M, C, K = system(name)
    dt, n = sampling(name)
    rng = np.random.default_rng(11 if excitation == "displacement" else 12)
    scale = 0.01 if excitation == "displacement" else 1.0  # in, in/s
    x0 = [scale * rng.standard_normal(D) for _ in range(D + 1)]
    key = "w0" if excitation == "displacement" else "v0"
    W = [newmark(M, C, K, dt, n, **{key: x})[0] for x in x0]
    return SimpleNamespace(W=W[:D], x0=x0[:D], W_new=W[D], x0_new=x0[D], dt=dt, n=n,
                           M=M, C=C, K=K)


@cache
def forced_case(name: str, start: int = 1) -> SimpleNamespace:
    """D pulse load cases (one per DOF, all starting at sample ``start``) and a new smooth
    load on every DOF whose first sample is zero."""
    M, C, K = system(name)
    dt, n = sampling(name)
    F = [pulse(D, n, j, start=start, width=5) for j in range(D)]
    W = [newmark(M, C, K, dt, n, F=Fj)[0] for Fj in F]
    F_new = smooth_load(D, n, np.random.default_rng(13))
    W_new = newmark(M, C, K, dt, n, F=F_new)[0]
    return SimpleNamespace(W=W, F=F, W_new=W_new, F_new=F_new, dt=dt, n=n, M=M, C=C, K=K)


@cache
def mixed_case(name: str, seed: int = 14) -> SimpleNamespace:
    """Three mixed responses a, b, c (random w0, v0; pulses at DOFs 4, 2, 0) and new
    excitations (a new initial displacement, a new initial velocity, a new load)."""
    M, C, K = system(name)
    dt, n = sampling(name)
    rng = np.random.default_rng(seed)
    w0 = [0.01 * rng.standard_normal(D) for _ in range(3)]
    v0 = [rng.standard_normal(D) for _ in range(3)]
    F = [pulse(D, n, j, width=3) for j in (4, 2, 0)]
    W = [newmark(M, C, K, dt, n, w0=a, v0=b, F=c)[0] for a, b, c in zip(w0, v0, F, strict=True)]
    w0_new = 0.01 * rng.standard_normal(D)
    v0_new = rng.standard_normal(D)
    F_new = pulse(D, n, 1, width=4) - pulse(D, n, 3, width=2)
    return SimpleNamespace(
        W=W, w0=w0, v0=v0, F=F, dt=dt, n=n, M=M, C=C, K=K,
        w0_new=w0_new, v0_new=v0_new, F_new=F_new,
        W_w0=newmark(M, C, K, dt, n, w0=w0_new)[0],
        W_v0=newmark(M, C, K, dt, n, v0=v0_new)[0],
        W_F=newmark(M, C, K, dt, n, F=F_new)[0],
        W_all=newmark(M, C, K, dt, n, w0=w0_new, v0=v0_new, F=F_new)[0],
    )
