"""podbench benchmarks: structured deconvolution, POD of tall matrices, Newmark at scale.

Run from the repository root::

    python benchmarks/run.py             # full run (about 15 minutes on 2 cores)
    python benchmarks/run.py --quick     # small sizes only (about a minute)

Options:

``--quick``              (n, k) ∈ {(500, 4), (1000, 6)} with the dense pseudo-inverse at
                         (500, 4) only; POD 20,000 × 500; Newmark 10,000 DOFs.
``--only GROUP ...``     any of ``deconv``, ``pod``, ``newmark`` (default: all).
``--out PATH``           CSV file (default ``results/benchmarks.csv``), written atomically
                         (temporary file + ``os.replace``).
``--readme PATH``        Markdown file whose block between ``<!-- results:start -->`` and
                         ``<!-- results:end -->`` receives the table (default
                         ``benchmarks/README.md``); ``--no-readme`` leaves it alone.
``--dense-budget S``     skip a dense solve whose predicted time exceeds S seconds (default
                         900); predicted from the cube of the matrix size and the first dense
                         measurement.
``--dense-max-gb G``     skip a dense solve whose matrix exceeds G GiB (default 2).
``--newmark-max-gb G``   skip a Newmark storage mode whose n_dofs × n_samples history
                         arrays exceed G GiB (default 2).
``--no-merge``           with ``--only``, the other groups' rows of ``--out`` are kept
                         (merged, and shown in the README table under the earlier run's
                         header) unless this is given.

Every measurement runs in a fresh process (``multiprocessing`` spawn, one BLAS thread):
wall time of the call, and peak memory as the growth of the resident set size over the
process's size just before the call (Linux ``VmHWM`` after resetting it through
``/proc/self/clear_refs``; this counts LAPACK and SuperLU allocations that tracemalloc
misses). Timings are the best of up to three repeats when a call takes under a second.

Speed and memory are measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import math
import multiprocessing as mp
import os
import platform
import sys
import tempfile
import time
import traceback
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
FIELDS = (
    "group", "case", "n", "k", "m", "solver", "status", "time_s", "peak_mb", "baseline",
    "baseline_time_s", "speedup", "max_rel_diff", "reference", "error_vs_truth", "note",
)
DECONV_SIZES = ((500, 4), (1000, 6), (2000, 8), (8000, 16))
DECONV_SIZES_QUICK = ((500, 4), (1000, 6))
STRUCTURED = ("block", "fft", "cgls")
DENSE = ("pinv", "ls", "tls")
DT = 1e-4  # s, the simulate() default


# ======================================================================== child side
def _status() -> dict[str, int]:
    out = {}
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(("VmHWM:", "VmRSS:")):
                key, val = line.split(":")
                out[key] = int(val.split()[0]) * 1024
    return out


def _reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _measure(fn, repeat_below: float = 1.0, max_repeat: int = 3):
    """Run ``fn`` and return ``(result, best_time_s, peak_bytes)``."""
    exact = _reset_peak()
    rss0 = _status().get("VmRSS", 0)
    t0 = time.perf_counter()
    result = fn()
    best = time.perf_counter() - t0
    peak = _status().get("VmHWM", 0) - rss0 if exact else float("nan")
    for _ in range(max_repeat - 1):
        if best >= repeat_below:
            break
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return result, best, peak


def _beam_cases(n: int, k: int):
    """k pulse load cases on the LTI beam (§4.1) and a new load; W, F at the 25 sensors."""
    import numpy as np

    import podbench as pb
    from podbench.excitations import Pulse

    s = pb.load_structure("lti_beam")
    # k distinct load positions from the tip inwards (in), one sensor per inch
    positions = [float(x) for x in np.round(np.linspace(24.0, 24.0 - 1.5 * (k - 1), k))]
    train = [pb.simulate(s, n_samples=n, dt=DT, force=Pulse(x, 10.0, 5 * DT))
             for x in positions]
    new = pb.simulate(s, n_samples=n, dt=DT,
                      force=Pulse(23.0, 10.0, 3 * DT, shape="half_sine"))
    return train, new, positions


def _deconv_task(method: str, n: int, k: int, solver: str):
    import numpy as np

    from podbench.methods import MultipleLoad, SingleLoad

    train, new, positions = _beam_cases(n, k)
    W = [r.W for r in train]
    F = [r.F for r in train]
    if solver == "pinv":
        # the dissertation's MATLAB: pinv(X)*y on the dense matrix (Eq. 3.48), outside the
        # methods; the POD and modal forces exactly as MultipleLoad / SingleLoad form them
        from podbench import deconvolution as dc
        from podbench.pod import snapshot_svd

        U = snapshot_svd(W[0], k).modes

        def run():
            if method == "ML":
                Qs = [U.T @ Fj for Fj in F]
                B = np.vstack([(U.T @ Wj).T for Wj in W])
                Cbar = np.linalg.pinv(dc.block_convolution_matrix(Qs, DT)) @ B
                kernel = np.stack([Cbar[i * n:(i + 1) * n].T for i in range(k)], axis=1)
                return kernel
            kernel = np.zeros((k, k, n))
            for i in range(k):
                q = U[:, i] @ F[0]
                kernel[i, i] = np.linalg.pinv(dc.convolution_matrix(q, DT)) @ (U[:, i] @ W[0])
            return kernel

        kernel, t, peak = _measure(run)
        pred = U @ dc.convolve_kernel(kernel, U.T @ new.F, DT)
        return {"time_s": t, "peak": peak, "pred": pred, "truth": new.W}

    if method == "ML":
        model = MultipleLoad(n_modes=k, solver=solver)
        fit = lambda: model.fit(W, F, dt=DT)  # noqa: E731
    else:
        model = SingleLoad(n_modes=k, solver=solver)
        fit = lambda: model.fit(W[0], F[0], dt=DT)  # noqa: E731
    _, t, peak = _measure(fit)
    return {"time_s": t, "peak": peak, "pred": model.predict(new.F), "truth": new.W,
            "fit_residual": model.fit_residual_}


def _tall_matrix(m: int, n: int, seed: int = 0):
    """W = X diag(σ) Yᵀ + 1e-6·noise: 40 separated leading POVs (σ_i = 0.8^i), full rank."""
    import numpy as np

    rng = np.random.default_rng(seed)
    r = 40
    X = rng.standard_normal((m, r)) / math.sqrt(m)
    Y = np.linalg.qr(rng.standard_normal((n, r)))[0]
    W = rng.standard_normal((m, n))
    W *= 1e-6
    W += (X * 0.8 ** np.arange(r)) @ Y.T
    return W


def _pod_task(m: int, n: int, k: int, method: str):
    from podbench.pod import method_of_snapshots, snapshot_svd

    W = _tall_matrix(m, n)
    if method == "svd":
        fn = lambda: snapshot_svd(W, k)  # noqa: E731  (full economy SVD, then k modes)
    else:
        fn = lambda: method_of_snapshots(W, k)  # noqa: E731
    p, t, peak = _measure(fn, max_repeat=1)
    return {"time_s": t, "peak": peak, "modes": p.modes, "povs": p.povs,
            "w_bytes": W.nbytes}


NEWMARK_STORAGE = ("previous", "full", "sensors")
"""How a Newmark benchmark run stores its data: ``previous`` — simulate as it was before
issue 5's recording option (the sensor force expanded to an n_dofs × n_samples DOF load array,
q, v, a kept at every DOF and sample); ``full`` — ``simulate(dof_histories=True)`` (per-step
force, full q, v, a); ``sensors`` — ``simulate(dof_histories=False)`` (only W = S q)."""
NEWMARK_HISTORY_ARRAYS = {"previous": 4, "full": 3, "sensors": 0}
"""n_dofs × n_samples float arrays each storage mode allocates (for the skip rule)."""


def _chain_structure(n_dofs: int, variable_mass: bool):
    """``podbench.fem.chain``: fixed-free, unit masses, 1e4 lbf/in springs, light Rayleigh
    damping, 10 sensors from the tip to the root; optionally a sinusoidally varying tip mass
    (a rank-1 update)."""
    from dataclasses import replace

    import numpy as np

    from podbench.fem import VariableMass, chain

    s = chain(n_dofs, masses=1.0, springs=1.0e4, rayleigh=(1e-3, 1e-6),
              sensors=np.linspace(n_dofs - 1, 0, 10).astype(np.int64), name=f"chain{n_dofs}")
    if variable_mass:
        vm = VariableMass(dof=n_dofs - 1, law=lambda t: 0.5 + 0.25 * np.sin(200.0 * t),
                          description="0.5 + 0.25 sin(200 t) lbf·s²/in at the tip")
        s = replace(s, variable_mass=vm)
    return s


def _chain_build_task(n_dofs: int):
    from podbench.fem import chain

    s, t, peak = _measure(lambda: chain(n_dofs, masses=1.0, springs=1.0e4,
                                        rayleigh=(1e-3, 1e-6)))
    return {"time_s": t, "peak": peak, "nnz": s.M.nnz + s.K.nnz + s.C.nnz}


def _newmark_task(n_dofs: int, n_samples: int, variable_mass: bool, storage: str):
    import numpy as np
    import scipy.sparse.linalg as spla

    from podbench.dynamics import newmark, simulate

    s = _chain_structure(n_dofs, variable_mass)
    calls = {"splu": 0}
    original = spla.splu

    def counting_splu(*args, **kwargs):
        calls["splu"] += 1
        return original(*args, **kwargs)

    force = np.zeros((s.n_sensors, n_samples))
    force[0, 1:6] = 100.0  # lbf on the tip (sensor 0 is the last DOF), from sample 1
    zeros = np.zeros(s.n_dofs)

    def previous():  # simulate before the recording option: DOF loads, q, v, a everywhere
        res = newmark(s, zeros, zeros, s.to_dofs(force), DT)
        return s.observe(res.q)

    run = {
        "previous": previous,
        "full": lambda: simulate(s, n_samples=n_samples, dt=DT, force=force,
                                 dof_histories=True).W,
        "sensors": lambda: simulate(s, n_samples=n_samples, dt=DT, force=force,
                                    dof_histories=False).W,
    }[storage]
    spla.splu = counting_splu  # newmark calls scipy.sparse.linalg.splu at run time
    try:
        W, t, peak = _measure(run, max_repeat=1)
    finally:
        spla.splu = original
    nnz = s.M.nnz + s.K.nnz + s.C.nnz
    return {"time_s": t, "peak": peak, "nnz": nnz, "factorizations": calls["splu"], "W": W}


_TASKS = {"deconv": _deconv_task, "pod": _pod_task, "newmark": _newmark_task,
          "chain": _chain_build_task}


def _child(task: str, args: tuple, queue) -> None:
    try:
        queue.put(("ok", _TASKS[task](*args)))
    except BaseException as exc:  # report every failure to the parent as a row
        queue.put(("error", f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
                   + "\n" + traceback.format_exc(limit=3)))


# ======================================================================== parent side
def _run(task: str, args: tuple, timeout: float):
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(task, args, queue))
    proc.start()
    try:
        status, payload = queue.get(timeout=timeout)
    except Exception:  # queue.Empty: the child ran out of time
        proc.terminate()
        proc.join()
        return "timeout", f"over {timeout:.0f} s"
    proc.join()
    return status, payload


def _rel(a, b) -> float:
    import numpy as np

    nb = float(np.linalg.norm(b))
    return float(np.linalg.norm(a - b) / nb) if nb > 0 else float(np.linalg.norm(a))


def _mb(x) -> float:
    return round(x / 2**20, 1) if x == x else float("nan")


def _row(**kw) -> dict:
    row = {f: "" for f in FIELDS}
    row.update({k: v for k, v in kw.items() if v is not None})
    return row


def _fmt_time(t) -> str:
    return f"{t:.3g}" if isinstance(t, float) else str(t)


def bench_deconv(sizes, dense_budget: float, dense_max_gb: float, quick: bool, log):
    """ML (block system n·k × n·k) and SL (k systems n × n) on LTI-beam pulse data."""
    rows = []
    dense_rate = {}  # (method, solver) -> seconds per (matrix columns)³
    for method in ("ML", "SL"):
        for n, k in sizes:
            results = {}
            cols = n * k if method == "ML" else n
            mats = 1 if method == "ML" else k
            for solver in DENSE + STRUCTURED:
                note = ""
                if solver in DENSE:
                    gb = 8.0 * cols * cols / 2**30
                    rate = dense_rate.get((method, solver))
                    predicted = rate * mats * cols**3 if rate else None
                    if quick and (n, k) != sizes[0]:
                        note = "skipped (--quick: dense only at the smallest size)"
                    elif gb > dense_max_gb:
                        note = (f"skipped: dense matrix {cols} × {cols} = {gb:.2g} GiB > "
                                f"{dense_max_gb:g} GiB")
                    elif predicted is not None and predicted > dense_budget:
                        note = (f"skipped: predicted {predicted:.0f} s (cubic scaling of the "
                                f"measured {solver}) > budget {dense_budget:g} s")
                    elif solver == "tls" and cols + (k if method == "ML" else 1) > 4096:
                        note = ("skipped: above TLS_MAX_COLUMNS = 4096 (InputError by "
                                "design)")
                    if note:
                        rows.append(_row(group="deconv", case=method, n=n, k=k, m=25,
                                         solver=solver, status="skipped", note=note))
                        log(f"  {method} n={n} k={k} {solver}: {note}")
                        continue
                log(f"  {method} n={n} k={k} {solver} ...")
                timeout = max(3 * dense_budget, 600) if solver in DENSE else 1800
                status, out = _run("deconv", (method, n, k, solver), timeout)
                if status != "ok":
                    msg = out.splitlines()[0] if isinstance(out, str) else str(out)
                    rows.append(_row(group="deconv", case=method, n=n, k=k, m=25,
                                     solver=solver, status=status, note=msg))
                    log(f"    {status}: {msg}")
                    continue
                results[solver] = out
                if solver in DENSE:
                    dense_rate.setdefault((method, solver), out["time_s"] / (mats * cols**3))
                log(f"    {out['time_s']:.3g} s, {_mb(out['peak'])} MB")
            base = results.get("pinv")
            ref_name = "ls" if "ls" in results else "block"
            ref = results.get(ref_name)
            for solver in DENSE + STRUCTURED:
                if solver not in results:
                    continue
                out = results[solver]
                speed = (base["time_s"] / out["time_s"]) if base else None
                diff = _rel(out["pred"], ref["pred"]) if ref is not None else None
                err = _rel(out["pred"], out["truth"])
                note = (f"fit residual {out['fit_residual']:.2g}" if "fit_residual" in out
                        else "pinv(A) @ B outside the method (the MATLAB's formula)")
                rows.append(_row(
                    group="deconv", case=method, n=n, k=k, m=25, solver=solver, status="ok",
                    time_s=f"{out['time_s']:.4g}", peak_mb=_mb(out["peak"]),
                    baseline="pinv" if base else "",
                    baseline_time_s=f"{base['time_s']:.4g}" if base else "",
                    speedup=f"{speed:.3g}" if speed else "",
                    max_rel_diff=f"{diff:.2e}" if diff is not None and solver != ref_name
                    else ("0 (reference)" if solver == ref_name else ""),
                    reference=ref_name if ref is not None else "",
                    error_vs_truth=f"{err:.3g}", note=note))
    order = {name: i for i, name in enumerate(DENSE + STRUCTURED)}
    rows.sort(key=lambda r: (("ML", "SL").index(r["case"]), r["n"], order[r["solver"]]))
    return rows


def bench_pod(quick: bool, log):
    rows = []
    m, n, k = (20_000, 500, 20) if quick else (100_000, 2_000, 20)
    results = {}
    for method in ("snapshots", "svd"):
        w_gb = 8.0 * m * n / 2**30
        avail = _available_bytes()
        need = 5 * 8.0 * m * n if method == "svd" else 2 * 8.0 * m * n
        if avail is not None and need + 8.0 * m * n > 0.6 * avail:
            note = (f"skipped: needs about {need / 2**30:.2g} GiB besides W ({w_gb:.2g} GiB), "
                    f"{avail / 2**30:.2g} GiB available")
            rows.append(_row(group="pod", case="tall", n=n, k=k, m=m, solver=method,
                             status="skipped", note=note))
            log(f"  POD {method}: {note}")
            continue
        log(f"  POD {m} × {n} {method} ...")
        status, out = _run("pod", (m, n, k, method), 3600)
        if status != "ok":
            rows.append(_row(group="pod", case="tall", n=n, k=k, m=m, solver=method,
                             status=status, note=out.splitlines()[0]))
            log(f"    {status}: {out.splitlines()[0]}")
            continue
        results[method] = out
        log(f"    {out['time_s']:.3g} s, {_mb(out['peak'])} MB")
    svd = results.get("svd")
    for method, out in results.items():
        import numpy as np

        if svd is not None and method != "svd":
            dm = float(np.max(np.linalg.norm(out["modes"] - svd["modes"], axis=0)))
            dp = float(np.max(np.abs(out["povs"] / svd["povs"] - 1)))
            diff, note = f"{dm:.2e}", (f"max over the {k} leading modes of ‖u − u_svd‖₂; "
                                       f"POVs to {dp:.1e} relative")
        else:
            diff, note = ("0 (reference)" if method == "svd" else ""), ""
        speed = svd["time_s"] / out["time_s"] if svd is not None else None
        rows.append(_row(
            group="pod", case="tall", n=n, k=k, m=m, solver=method, status="ok",
            time_s=f"{out['time_s']:.4g}", peak_mb=_mb(out["peak"]),
            baseline="svd" if svd else "", baseline_time_s=f"{svd['time_s']:.4g}" if svd else "",
            speedup=f"{speed:.3g}" if speed else "", max_rel_diff=diff,
            reference="svd" if svd else "",
            note=(note + f"; W itself is {_mb(out['w_bytes'])} MB").lstrip("; ")))
    return rows


def bench_newmark(quick: bool, max_gb: float, log):
    """Sparse chains built by ``podbench.fem.chain``: the build itself, then Newmark with the
    three storage modes of ``NEWMARK_STORAGE``; 2-sample runs isolate the set-up
    (matrices and factorizations, memory per nonzero)."""
    rows = []
    sizes = (10_000,) if quick else (10_000, 100_000)
    for n_dofs in sizes:
        log(f"  chain build, {n_dofs} DOFs ...")
        status, out = _run("chain", (n_dofs,), 600)
        if status != "ok":
            rows.append(_row(group="newmark", case="chain build", m=n_dofs, solver="sparse",
                             status=status, note=out.splitlines()[0]))
            continue
        dense_gib = 8.0 * n_dofs * n_dofs / 2**30
        note = (f"podbench.fem.chain with Rayleigh C; nnz(M)+nnz(K)+nnz(C) = {out['nnz']}; "
                f"{out['peak'] / out['nnz']:.0f} bytes per nonzero (with the 2 × {n_dofs} "
                f"DOF/sensor label strings); one dense n × n matrix would be "
                f"{dense_gib:.3g} GiB")
        rows.append(_row(group="newmark", case="chain build", m=n_dofs, solver="sparse",
                         status="ok", time_s=f"{out['time_s']:.4g}",
                         peak_mb=_mb(out["peak"]), note=note))
        log(f"    {out['time_s']:.3g} s, {_mb(out['peak'])} MB")
    for variable_mass in (False, True):
        case = "chain, tip mass m(t)" if variable_mass else "chain, LTI"
        for n_dofs in sizes:
            for n_samples in (2, 200, 2000):
                modes = ("sensors",) if n_samples == 2 else NEWMARK_STORAGE
                results, skipped = {}, {}
                for storage in modes:
                    arrays = NEWMARK_HISTORY_ARRAYS[storage]
                    need = arrays * 8.0 * n_dofs * n_samples
                    if need > max_gb * 2**30:
                        skipped[storage] = (f"skipped: {arrays} n_dofs × n_samples float "
                                            f"arrays = {need / 2**30:.2g} GiB > {max_gb:g} "
                                            "GiB (--newmark-max-gb)")
                        log(f"  Newmark {case} {n_dofs} × {n_samples} {storage}: "
                            f"{skipped[storage]}")
                        continue
                    log(f"  Newmark {case} {n_dofs} DOFs × {n_samples} samples, {storage} ...")
                    status, out = _run("newmark", (n_dofs, n_samples, variable_mass, storage),
                                       3600)
                    if status != "ok":
                        skipped[storage] = out.splitlines()[0]
                        log(f"    {status}: {skipped[storage]}")
                        continue
                    results[storage] = out
                    log(f"    {out['time_s']:.3g} s, {_mb(out['peak'])} MB")
                base = results.get("previous")
                for storage in modes:
                    if storage in skipped:
                        status = "skipped" if skipped[storage].startswith("skipped") else "error"
                        rows.append(_row(group="newmark", case=case, n=n_samples, m=n_dofs,
                                         solver=storage, status=status, note=skipped[storage]))
                        continue
                    out = results[storage]
                    note = (f"nnz = {out['nnz']}; sparse LU factorizations: "
                            f"{out['factorizations']}; peak = {out['peak'] / out['nnz']:.0f} "
                            "bytes per nonzero")
                    if n_samples == 2:
                        note += " (set-up: matrices and factorizations, one step)"
                    else:
                        per_step = out["time_s"] / (n_samples - 1) * 1e3
                        note += f"; {per_step:.3g} ms per step"
                    if base is None and storage == "sensors" and n_samples > 2:
                        # q, v, a of `previous` and `full` (its DOF load array is mostly
                        # untouched zero pages and hardly counts in the resident peak)
                        est = NEWMARK_HISTORY_ARRAYS["full"] * 8.0 * n_dofs * n_samples
                        note += (f"; q, v, a at every DOF (`previous`, `full`) would take "
                                 f"{est / 2**30:.2g} GiB, {est / out['peak']:.0f} × this peak")
                    cmp = base is not None and storage != "previous"
                    rows.append(_row(
                        group="newmark", case=case, n=n_samples, m=n_dofs, solver=storage,
                        status="ok", time_s=f"{out['time_s']:.4g}", peak_mb=_mb(out["peak"]),
                        baseline="previous" if cmp else "",
                        baseline_time_s=f"{base['time_s']:.4g}" if cmp else "",
                        speedup=f"{base['time_s'] / out['time_s']:.3g}" if cmp else "",
                        max_rel_diff=f"{_rel(out['W'], base['W']):.1e}" if cmp else "",
                        reference="previous" if cmp else "", note=note))
    return rows


def _available_bytes():
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def machine() -> str:
    import numpy
    import scipy

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as fh:
            mem = f", {int(fh.readline().split()[1]) / 2**20:.0f} GiB RAM"
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}, NumPy {numpy.__version__}, "
            f"SciPy {scipy.__version__}; one BLAS thread "
            f"(OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')})")


def _publish(tmp: str, path: Path) -> None:
    """Give the temporary file the usual permissions and move it into place atomically."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)


def write_csv(rows, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".benchmarks-", suffix=".csv", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=FIELDS)
            w.writeheader()
            w.writerows(rows)
        _publish(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _diff_cell(r) -> str:
    diff = r["max_rel_diff"]
    if diff and r["reference"] and diff != "0 (reference)":
        diff = f"{diff} (vs {r['reference']})"
    return diff


def table(rows) -> str:
    """Markdown tables, one per benchmark group."""
    out = []
    deconv = [r for r in rows if r["group"] == "deconv"]
    if deconv:
        out += ["**Deconvolution** (LTI beam, 25 sensors, k pulse load cases; ML solves one "
                "n·k × n·k block system, SL k systems n × n; time = the method's `fit`)", "",
                "| method | n | k | solver | time (s) | peak memory (MB) | speed-up vs dense "
                "pinv | prediction vs reference (rel.) | prediction error vs truth | note |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in deconv:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['case']} | {r['n']} | {r['k']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {r['speedup']} | {_diff_cell(r)} | "
                       f"{r['error_vs_truth']} | {r['note']} |")
        out.append("")
    pod = [r for r in rows if r["group"] == "pod"]
    if pod:
        out += ["**POD of a tall snapshot matrix** (m sensors × n samples, k leading modes)", "",
                "| m | n | k | method | time (s) | peak memory (MB) | speed-up vs SVD | "
                "modes vs SVD (max ‖u − u_svd‖₂) | note |", "|---|---|---|---|---|---|---|---|---|"]
        for r in pod:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['m']} | {r['n']} | {r['k']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {r['speedup']} | {_diff_cell(r)} | {r['note']} |")
        out.append("")
    nm = [r for r in rows if r["group"] == "newmark"]
    if nm:
        prev = {(r["case"], str(r["m"]), str(r["n"])): r for r in nm
                if r["solver"] == "previous" and r["status"] == "ok"}

        def mem_ratio(r):
            b = prev.get((r["case"], str(r["m"]), str(r["n"])))
            if b is None or r["solver"] == "previous" or r["status"] != "ok":
                return ""
            return f"{float(b['peak_mb']) / float(r['peak_mb']):.3g}"

        out += ["**Newmark on a sparse chain** (`podbench.fem.chain`: tridiagonal M = I, K, "
                "Rayleigh C, 10 sensors; storage `previous` = the DOF load array and q, v, a "
                "at every DOF and sample as before, `full` = `simulate(dof_histories=True)`, "
                "`sensors` = `simulate(dof_histories=False)`, only W = S q recorded)", "",
                "| case | DOFs | samples | storage | time (s) | peak memory (MB) | memory: "
                "previous / this | time: previous / this | W vs previous (rel.) | note |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in nm:
            t = r["time_s"] if r["status"] == "ok" else r["status"]
            out.append(f"| {r['case']} | {r['m']} | {r['n']} | {r['solver']} | {t} | "
                       f"{r['peak_mb']} | {mem_ratio(r)} | {r['speedup']} | "
                       f"{r['max_rel_diff']} | {r['note']} |")
        out.append("")
    return "\n".join(out).rstrip()


GROUPS = ("deconv", "pod", "newmark")


def read_csv(path: Path) -> list[dict]:
    """Rows of an earlier results file (missing columns read as "")."""
    with open(path, newline="") as fh:
        return [{f: r.get(f) or "" for f in FIELDS} for r in csv.DictReader(fh)]


def _previous_header(path: Path) -> str:
    """The first line of the results block of an earlier README ("Measured ... on: ...")."""
    start = "<!-- results:start -->"
    if not path.exists() or start not in (text := path.read_text()):
        return ""
    lines = text.split(start, 1)[1].strip().splitlines()
    return lines[0] if lines and lines[0].startswith("Measured") else ""


def write_readme(rows, path: Path, header: str) -> None:
    start, end = "<!-- results:start -->", "<!-- results:end -->"
    text = path.read_text() if path.exists() else f"# Benchmarks\n\n{start}\n{end}\n"
    if start not in text or end not in text:
        text = text.rstrip() + f"\n\n{start}\n{end}\n"
    before, rest = text.split(start, 1)
    after = rest.split(end, 1)[1]
    block = f"{start}\n{header}\n\n{table(rows)}\n{end}"
    new = before + block + after
    fd, tmp = tempfile.mkstemp(prefix=".README-", suffix=".md", dir=path.parent)
    with os.fdopen(fd, "w") as fh:
        fh.write(new)
    _publish(tmp, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes only")
    ap.add_argument("--only", nargs="+", choices=GROUPS, default=GROUPS)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "benchmarks.csv")
    ap.add_argument("--no-merge", action="store_true",
                    help="with --only: do not keep the other groups' rows of --out")
    ap.add_argument("--readme", type=Path, default=ROOT / "benchmarks" / "README.md")
    ap.add_argument("--no-readme", action="store_true")
    ap.add_argument("--dense-budget", type=float, default=900.0)
    ap.add_argument("--dense-max-gb", type=float, default=2.0)
    ap.add_argument("--newmark-max-gb", type=float, default=2.0)
    args = ap.parse_args(argv)

    def log(msg):
        print(msg, flush=True)

    started = time.perf_counter()
    rows = []
    if "deconv" in args.only:
        log("Deconvolution (ML and SL on LTI-beam pulse data):")
        sizes = DECONV_SIZES_QUICK if args.quick else DECONV_SIZES
        rows += bench_deconv(sizes, args.dense_budget, args.dense_max_gb, args.quick, log)
    if "pod" in args.only:
        log("POD of a tall snapshot matrix:")
        rows += bench_pod(args.quick, log)
    if "newmark" in args.only:
        log("Newmark on a large sparse chain:")
        rows += bench_newmark(args.quick, args.newmark_max_gb, log)
    kept = []
    if set(args.only) != set(GROUPS) and not args.no_merge and args.out.exists():
        kept = [r for r in read_csv(args.out) if r["group"] not in args.only]
        log(f"kept {len(kept)} rows of the other groups from {args.out}")
    rows = sorted(kept + rows, key=lambda r: GROUPS.index(r["group"]))  # stable
    write_csv(rows, args.out)
    log(f"wrote {args.out} ({len(rows)} rows) in {time.perf_counter() - started:.0f} s")
    if not args.no_readme:
        stamp = _dt.datetime.now().strftime("%Y-%m-%d")
        mode = "--quick" if args.quick else "full run"
        command = "python benchmarks/run.py" + (" --quick" if args.quick else "")
        if set(args.only) != set(GROUPS):
            command += " --only " + " ".join(args.only)
        header = f"Measured {stamp} ({mode}, `{command}`) on: {machine()}."
        previous = _previous_header(args.readme) if kept else ""
        if previous:
            groups = ", ".join(sorted({r["group"] for r in kept}, key=GROUPS.index))
            header = (f"{previous}\n\n{header.replace('Measured', 'Re-measured', 1)} "
                      f"Rows of {groups} are from the run above.")
        write_readme(rows, args.readme, header)
        log(f"updated {args.readme}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
