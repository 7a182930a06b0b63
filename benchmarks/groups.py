"""The benchmark groups: structured deconvolution (``deconv``), POD of tall matrices (``pod``),
Newmark at scale (``newmark``) and the identification methods side by side (``methods``).
Each ``bench_*`` function measures its cases in fresh processes (:func:`measure.run_isolated`)
and returns CSV rows (:func:`report.row`) with speed-ups against the group's baseline
measured in the same run.
"""

from __future__ import annotations

import math

from .measure import available_bytes, mb, measure, rel_diff, run_isolated, speedup
from .report import row

__all__ = ["DECONV_SIZES", "DECONV_SIZES_QUICK", "POD_SIZE", "POD_SIZE_QUICK",
           "bench_deconv", "bench_pod", "bench_newmark", "NEWMARK_STORAGE",
           "METHODS_N", "METHODS_N_QUICK", "bench_methods"]

DECONV_SIZES = ((500, 4), (1000, 6), (2000, 8), (8000, 16))
DECONV_SIZES_QUICK = ((500, 4), (1000, 6))
STRUCTURED = ("block", "fft", "cgls")
DENSE = ("pinv", "ls", "tls")
DT = 1e-4  # s, the simulate() default


POD_SIZE = (100_000, 2_000, 20)
POD_SIZE_QUICK = (20_000, 500, 20)
"""(m, n, k) of the POD benchmark: m sensors × n samples, k leading modes."""


def _beam_cases(n: int, k: int):
    """k pulse load cases on the LTI beam (§4.1) and a new load; W, F at the 25 sensors."""
    import numpy as np

    import podbench as pb
    from podbench.dynamics.excitations import Pulse

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

    from podbench.sysid.methods import MultipleLoad, SingleLoad

    train, new, positions = _beam_cases(n, k)
    W = [r.W for r in train]
    F = [r.F for r in train]
    if solver == "pinv":
        # the dissertation's MATLAB: pinv(X)*y on the dense matrix (Eq. 3.48), outside the
        # methods; the POD and modal forces exactly as MultipleLoad / SingleLoad form them
        from podbench.sysid import deconvolution as dc
        from podbench.sysid.pod import snapshot_svd

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

        kernel, t, peak = measure(run)
        pred = U @ dc.convolve_kernel(kernel, U.T @ new.F, DT)
        return {"time_s": t, "peak": peak, "pred": pred, "truth": new.W}

    if method == "ML":
        model = MultipleLoad(n_modes=k, solver=solver)
        fit = lambda: model.fit(W, F, dt=DT)  # noqa: E731
    else:
        model = SingleLoad(n_modes=k, solver=solver)
        fit = lambda: model.fit(W[0], F[0], dt=DT)  # noqa: E731
    _, t, peak = measure(fit)
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
    from podbench.sysid.pod import method_of_snapshots, snapshot_svd

    W = _tall_matrix(m, n)
    if method == "svd":
        fn = lambda: snapshot_svd(W, k)  # noqa: E731  (full economy SVD, then k modes)
    else:
        fn = lambda: method_of_snapshots(W, k)  # noqa: E731
    p, t, peak = measure(fn, max_repeat=1)
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

    from podbench.structures import VariableMass, chain

    s = chain(n_dofs, masses=1.0, springs=1.0e4, rayleigh=(1e-3, 1e-6),
              sensors=np.linspace(n_dofs - 1, 0, 10).astype(np.int64), name=f"chain{n_dofs}")
    if variable_mass:
        vm = VariableMass(dof=n_dofs - 1, law=lambda t: 0.5 + 0.25 * np.sin(200.0 * t),
                          description="0.5 + 0.25 sin(200 t) lbf·s²/in at the tip")
        s = replace(s, variable_mass=vm)
    return s


def _chain_build_task(n_dofs: int):
    from podbench.structures import chain

    s, t, peak = measure(lambda: chain(n_dofs, masses=1.0, springs=1.0e4,
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
        W, t, peak = measure(run, max_repeat=1)
    finally:
        spla.splu = original
    nnz = s.M.nnz + s.K.nnz + s.C.nnz
    return {"time_s": t, "peak": peak, "nnz": nnz, "factorizations": calls["splu"], "W": W}


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
                        rows.append(row(group="deconv", case=method, n=n, k=k, m=25,
                                         solver=solver, status="skipped", note=note))
                        log(f"  {method} n={n} k={k} {solver}: {note}")
                        continue
                log(f"  {method} n={n} k={k} {solver} ...")
                timeout = max(3 * dense_budget, 600) if solver in DENSE else 1800
                status, out = run_isolated(_deconv_task, (method, n, k, solver), timeout)
                if status != "ok":
                    msg = out.splitlines()[0] if isinstance(out, str) else str(out)
                    rows.append(row(group="deconv", case=method, n=n, k=k, m=25,
                                     solver=solver, status=status, note=msg))
                    log(f"    {status}: {msg}")
                    continue
                results[solver] = out
                if solver in DENSE:
                    dense_rate.setdefault((method, solver), out["time_s"] / (mats * cols**3))
                log(f"    {out['time_s']:.3g} s, {mb(out['peak'])} MB")
            base = results.get("pinv")
            ref_name = "ls" if "ls" in results else "block"
            ref = results.get(ref_name)
            for solver in DENSE + STRUCTURED:
                if solver not in results:
                    continue
                out = results[solver]
                speed = speedup(base["time_s"], out["time_s"]) if base else None
                diff = rel_diff(out["pred"], ref["pred"]) if ref is not None else None
                err = rel_diff(out["pred"], out["truth"])
                note = (f"fit residual {out['fit_residual']:.2g}" if "fit_residual" in out
                        else "pinv(A) @ B outside the method (the MATLAB's formula)")
                rows.append(row(
                    group="deconv", case=method, n=n, k=k, m=25, solver=solver, status="ok",
                    time_s=f"{out['time_s']:.4g}", peak_mb=mb(out["peak"]),
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


def bench_pod(quick: bool, log, size: tuple[int, int, int] | None = None):
    """Method of snapshots against the economy SVD on a tall matrix of ``size`` (m, n, k),
    default :data:`POD_SIZE` (:data:`POD_SIZE_QUICK` with ``quick``)."""
    rows = []
    m, n, k = size or (POD_SIZE_QUICK if quick else POD_SIZE)
    results = {}
    for method in ("snapshots", "svd"):
        w_gb = 8.0 * m * n / 2**30
        avail = available_bytes()
        need = 5 * 8.0 * m * n if method == "svd" else 2 * 8.0 * m * n
        if avail is not None and need + 8.0 * m * n > 0.6 * avail:
            note = (f"skipped: needs about {need / 2**30:.2g} GiB besides W ({w_gb:.2g} GiB), "
                    f"{avail / 2**30:.2g} GiB available")
            rows.append(row(group="pod", case="tall", n=n, k=k, m=m, solver=method,
                             status="skipped", note=note))
            log(f"  POD {method}: {note}")
            continue
        log(f"  POD {m} × {n} {method} ...")
        status, out = run_isolated(_pod_task, (m, n, k, method), 3600)
        if status != "ok":
            rows.append(row(group="pod", case="tall", n=n, k=k, m=m, solver=method,
                             status=status, note=out.splitlines()[0]))
            log(f"    {status}: {out.splitlines()[0]}")
            continue
        results[method] = out
        log(f"    {out['time_s']:.3g} s, {mb(out['peak'])} MB")
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
        speed = speedup(svd["time_s"], out["time_s"]) if svd is not None else None
        rows.append(row(
            group="pod", case="tall", n=n, k=k, m=m, solver=method, status="ok",
            time_s=f"{out['time_s']:.4g}", peak_mb=mb(out["peak"]),
            baseline="svd" if svd else "", baseline_time_s=f"{svd['time_s']:.4g}" if svd else "",
            speedup=f"{speed:.3g}" if speed else "", max_rel_diff=diff,
            reference="svd" if svd else "",
            note=(note + f"; W itself is {mb(out['w_bytes'])} MB").lstrip("; ")))
    return rows


def bench_newmark(quick: bool, max_gb: float, log):
    """Sparse chains built by ``podbench.fem.chain``: the build itself, then Newmark with the
    three storage modes of ``NEWMARK_STORAGE``; 2-sample runs isolate the set-up
    (matrices and factorizations, memory per nonzero)."""
    rows = []
    sizes = (10_000,) if quick else (10_000, 100_000)
    for n_dofs in sizes:
        log(f"  chain build, {n_dofs} DOFs ...")
        status, out = run_isolated(_chain_build_task, (n_dofs,), 600)
        if status != "ok":
            rows.append(row(group="newmark", case="chain build", m=n_dofs, solver="sparse",
                             status=status, note=out.splitlines()[0]))
            continue
        dense_gib = 8.0 * n_dofs * n_dofs / 2**30
        note = (f"podbench.fem.chain with Rayleigh C; nnz(M)+nnz(K)+nnz(C) = {out['nnz']}; "
                f"{out['peak'] / out['nnz']:.0f} bytes per nonzero (with the 2 × {n_dofs} "
                f"DOF/sensor label strings); one dense n × n matrix would be "
                f"{dense_gib:.3g} GiB")
        rows.append(row(group="newmark", case="chain build", m=n_dofs, solver="sparse",
                         status="ok", time_s=f"{out['time_s']:.4g}",
                         peak_mb=mb(out["peak"]), note=note))
        log(f"    {out['time_s']:.3g} s, {mb(out['peak'])} MB")
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
                    status, out = run_isolated(
                        _newmark_task, (n_dofs, n_samples, variable_mass, storage), 3600)
                    if status != "ok":
                        skipped[storage] = out.splitlines()[0]
                        log(f"    {status}: {skipped[storage]}")
                        continue
                    results[storage] = out
                    log(f"    {out['time_s']:.3g} s, {mb(out['peak'])} MB")
                base = results.get("previous")
                for storage in modes:
                    if storage in skipped:
                        status = "skipped" if skipped[storage].startswith("skipped") else "error"
                        rows.append(row(group="newmark", case=case, n=n_samples, m=n_dofs,
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
                    rows.append(row(
                        group="newmark", case=case, n=n_samples, m=n_dofs, solver=storage,
                        status="ok", time_s=f"{out['time_s']:.4g}", peak_mb=mb(out["peak"]),
                        baseline="previous" if cmp else "",
                        baseline_time_s=f"{base['time_s']:.4g}" if cmp else "",
                        speedup=f"{speedup(base['time_s'], out['time_s']):.3g}" if cmp else "",
                        max_rel_diff=f"{rel_diff(out['W'], base['W']):.1e}" if cmp else "",
                        reference="previous" if cmp else "", note=note))
    return rows


METHODS_N = 500
METHODS_N_QUICK = 200
"""Samples of the ``methods`` group: the peers study's 500 (0.05 s at Δt = 0.1 ms)."""

METHOD_CASES = (
    ("ML", "ML", {"solver": "block"}),
    ("ML (basis all)", "ML", {"solver": "block", "basis": "all"}),
    ("ML (n_lags auto)", "ML", {"solver": "block", "n_lags": "auto"}),
    ("ML (ls)", "ML", {"solver": "ls"}),
    ("SL", "SL", {"n_modes": 4, "solver": "block"}),
    ("ERA", "ERA", {}),
    ("DMDc", "DMDc", {}),
    ("OpInf", "OpInf", {}),
)
"""(label, method, options) of the ``methods`` group; ML (block) is the baseline."""


def _methods_task(n: int):
    """Every method of :data:`METHOD_CASES` on the peers study's data (LTI beam, 500-lbf,
    0.5-ms pulses at 2, 7, 11, 16 in; target: the pulse at 23 in), fit + predict timed in
    this one process."""
    import numpy as np

    import podbench as pb
    from podbench.dynamics.excitations import Pulse
    from podbench.sysid.methods import BUILTIN_METHODS

    s = pb.load_structure("lti_beam")
    train = [pb.simulate(s, n_samples=n, dt=DT, force=Pulse(x, 500.0, 5e-4))
             for x in (2.0, 7.0, 11.0, 16.0)]
    new = pb.simulate(s, n_samples=n, dt=DT, force=Pulse(23.0, 500.0, 5e-4))
    out = {}
    for label, name, options in METHOD_CASES:
        est = BUILTIN_METHODS[name](**options)
        recs = train[:1] if name == "SL" else train

        def run(est=est, recs=recs):
            return est.fit(recs).predict(new)

        try:
            pred, t, peak = measure(run)
        except Exception as exc:  # noqa: BLE001 (a missing extra, a failing fit: reported)
            out[label] = {"error": f"{type(exc).__name__}: {exc}".splitlines()[0]}
            continue
        err = float(np.linalg.norm(pred - new.W) / np.linalg.norm(new.W))
        out[label] = {"time_s": t, "peak": peak, "error": None, "rel_err": err,
                      "k": int(est.n_modes_), "m": int(pred.shape[0])}
    return out


def bench_methods(quick: bool, log, n: int | None = None):
    """Fit + predict time of every identification method (:data:`METHOD_CASES`) on the same
    records, as ratios to ML (``solver="block"``) measured in the same process."""
    n = n or (METHODS_N_QUICK if quick else METHODS_N)
    log(f"  methods, n = {n} ...")
    status, out = run_isolated(_methods_task, (n,), 3600)
    if status != "ok":
        log(f"    {status}: {out.splitlines()[0]}")
        return [row(group="methods", case="all", n=n, status=status,
                    note=out.splitlines()[0])]
    base = out.get("ML", {}).get("time_s")
    rows = []
    for label, _, _ in METHOD_CASES:
        r = out[label]
        if r.get("error"):
            rows.append(row(group="methods", case=label, n=n, solver=label, status="error",
                            note=r["error"]))
            log(f"    {label}: {r['error']}")
            continue
        speed = speedup(base, r["time_s"]) if base else None
        rows.append(row(
            group="methods", case=label, n=n, k=r["k"], m=r["m"], solver=label, status="ok",
            time_s=f"{r['time_s']:.4g}", peak_mb=mb(r["peak"]), baseline="ML",
            baseline_time_s=f"{base:.4g}" if base else "",
            speedup=f"{speed:.3g}" if speed else "",
            error_vs_truth=f"{r['rel_err']:.3g}",
            note="fit on load1 only" if label == "SL" else ""))
        log(f"    {label}: {r['time_s']:.3g} s")
    return rows
