"""Runs the substructuring study (Chapter 6): a finite-element parent coupled with components
known by exact or identified kernels, against Newmark on the assembled system.

For every component of the plan (:mod:`podbench.study.substructuring`):

* truth: Newmark on the assembled structure (:func:`podbench.structures.assembly.attach`;
  the tip mass: the structure that has it, ``ltv_beam``), timed per step;
* the floor: the parent alone (component ignored);
* exact kernels (:func:`podbench.dynamics.coupling.newmark_kernel` / ``point_mass_kernel``),
  implicit and two-step;
* identified kernels from interface records of the component alone (white force from
  rest; per-channel noise ``level × channel RMS`` on force and response, streams keyed by
  :func:`podbench.sysid.noise.noise_generator`): time-invariant
  (:func:`podbench.sysid.components.identify_kernel`, acceleration, velocity and
  displacement records) and time-varying (:func:`podbench.sysid.components.identify_lagged`).

Every coupled run continues unloaded to ``horizon × n_samples`` steps; a run whose
displacements exceed ``divergence ×`` the truth's peak there has diverged: its error is NaN
and ``diverged_at_step`` says where. A two-step run refused by the growth-factor check is
run anyway (unchecked) only to find that step.
"""

from __future__ import annotations

import time

import numpy as np

from podbench.core.threads import single_blas_thread
from podbench.dynamics.coupling import (
    Component,
    UnstableCouplingError,
    couple,
    growth_factor,
    newmark_kernel,
    newmark_realization,
    point_mass_kernel,
)
from podbench.dynamics.excitations import Pulse
from podbench.dynamics.newmark import newmark
from podbench.structures import Structure, load_structure
from podbench.structures.assembly import attach
from podbench.study.substructuring import ComponentEntry, SubstructuringPlan
from podbench.sysid.components import identify_kernel, identify_lagged
from podbench.sysid.noise import noise_generator
from podbench.sysid.passivity import enforce_passivity, realization_kernel

__all__ = ["run_substructuring", "COLUMNS"]

COLUMNS = ["parent", "component", "scheme", "kernel", "records", "n_records", "noise", "seed",
           "total_error", "diverged_at_step", "time_ratio", "growth", "record_error", "status",
           "detail"]
REPEATS = 5
"""Timings are the fastest of this many runs (a shared machine's noise), the coupled run and
the assembled truth alternating so that both see the same load."""


def _best_times(*fns) -> list[float]:
    best = [np.inf] * len(fns)
    for _ in range(REPEATS):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            best[i] = min(best[i], time.perf_counter() - t0)
    return best


def _scaled(s: Structure, k: float, name: str) -> Structure:
    return Structure(name=name, M=s.M * k, K=s.K * k, C=None if s.C is None else s.C * k,
                     sensor_dofs=s.sensor_dofs, sensor_positions=s.sensor_positions)


class _Case:
    """One component on the parent: truth, exact component, record generator."""

    def __init__(self, plan: SubstructuringPlan, parent: Structure, entry: ComponentEntry):
        self.plan, self.parent, self.entry = plan, parent, entry
        n, dt = plan.n_samples, plan.dt
        self.N = parent.n_dofs
        load = plan.load
        F = Pulse(load["location"], load["amplitude"], load["duration"]).sample(parent, n, dt)
        self.f = parent.to_dofs(F)
        self.long = np.hstack([self.f, np.zeros((self.N, (plan.horizon - 1) * n))])
        self.dof = plan.interface_dof
        if entry.tip_mass:
            truth_s = load_structure(entry.structure)
            self.m = truth_s.variable_mass(np.arange(plan.horizon * n) * dt)
            fa = self.f
            self.exact = Component((self.dof,), point_mass_kernel(self.m), name=entry.name)
        else:
            cs = _scaled(load_structure(entry.structure), entry.scale, entry.name)
            self.cs = cs
            truth_s = attach(parent, cs, [self.dof], [entry.component_dof])
            fa = np.vstack([self.f, np.zeros((truth_s.n_dofs - self.N, n))])
            self.exact = self._chain_component("acceleration")
        z = np.zeros(truth_s.n_dofs)
        res = newmark(truth_s, z, z, fa, dt)
        self.truth_run = lambda: newmark(truth_s, z, z, fa, dt)
        self.Y_true = parent.sensor_matrix() @ res.q[:self.N]
        self.limit = plan.divergence * float(np.max(np.abs(res.q[:self.N])))

    def _chain_component(self, quantity: str) -> Component:
        cs, dt, d = self.cs, self.plan.dt, self.entry.component_dof
        return Component((self.dof,), newmark_kernel(cs.M, cs.C, cs.K, [d], self.plan.n_samples,
                                                     dt, quantity=quantity),
                         quantity=quantity, name=self.entry.name,
                         realization=newmark_realization(cs.M, cs.C, cs.K, [d], dt,
                                                         quantity=quantity))

    def records(self, n_rec: int, n_samp: int, quantity: str, noise: float, seed: int):
        """Interface records of the component alone: white force from rest (seed 0 stream:
        the same forces at every noise seed), per-channel noise (``seed`` streams)."""
        key = ("substructuring", self.entry.name)
        forces, resp = [], []
        for r in range(n_rec):
            g = noise_generator(0, *key, f"record{r}", "force").standard_normal(n_samp)
            if self.entry.tip_mass:
                y = g / self.m[:n_samp]
            else:
                A, B, C, D = self._chain_component(quantity).realization
                x = np.zeros(A.shape[0])
                y = np.empty(n_samp)
                for j in range(n_samp):
                    y[j] = C[0] @ x + D[0, 0] * g[j]
                    x = A @ x + B[:, 0] * g[j]
            if noise > 0:
                g = g + noise * np.sqrt(np.mean(g ** 2)) * noise_generator(
                    seed, *key, f"record{r}", "F", "0").standard_normal(n_samp)
                y = y + noise * np.sqrt(np.mean(y ** 2)) * noise_generator(
                    seed, *key, f"record{r}", quantity, "0").standard_normal(n_samp)
            forces.append(g[None])
            resp.append(y[None])
        return forces, resp

    def run(self, comps, scheme: str) -> dict:
        """Couple and measure: error, divergence, time ratio, growth, status."""
        n, z = self.plan.n_samples, np.zeros(self.N)
        row = {"scheme": scheme, "status": "ok", "detail": ""}
        try:
            growth = growth_factor(self.parent, comps, self.plan.dt, scheme) if comps else 1.0
        except Exception as exc:  # noqa: BLE001 - a kernel that cannot be coupled: say why
            return {**row, "status": "failed", "detail": str(exc).splitlines()[0],
                    "total_error": np.nan, "diverged_at_step": np.nan, "time_ratio": np.nan,
                    "growth": np.nan}
        row["growth"] = growth
        if scheme == "two-step":
            try:
                couple(self.parent, z, z, self.f[:, :2], self.plan.dt, comps, scheme=scheme)
            except UnstableCouplingError as exc:
                row["status"], row["detail"] = "refused", str(exc)
        res = couple(self.parent, z, z, self.long, self.plan.dt, comps, scheme=scheme,
                     check=False, limit=self.limit)
        t, t_truth = _best_times(lambda: couple(self.parent, z, z, self.f, self.plan.dt, comps,
                                                scheme=scheme, check=False), self.truth_run)
        row["time_ratio"] = t / t_truth
        row["diverged_at_step"] = res.diverged_at_step if res.diverged_at_step >= 0 else np.nan
        Y = self.parent.sensor_matrix() @ res.q[:, :n]
        err = float(np.linalg.norm(Y - self.Y_true) / np.linalg.norm(self.Y_true))
        # record_error: over the n-sample record alone, for an implicit run that diverges
        # only after it (what a 500-sample comparison would have shown); never for a refused
        # scheme nor a run that diverged within the record
        row["record_error"] = err if (row["status"] == "ok" and scheme == "implicit"
                                      and not 0 <= res.diverged_at_step < n) else np.nan
        if row["status"] == "refused":  # never a number from a refused (diverging) scheme
            row["total_error"] = np.nan
        elif res.diverged_at_step >= 0:
            row["total_error"] = np.nan
            row["status"] = "diverged"
        else:
            row["total_error"] = err
            row["Y"] = Y
        return row


def _identified_rows(case: _Case, ident: dict, noise_levels, seeds, progress):
    rows, e, n, dt = [], case.entry, case.plan.n_samples, case.plan.dt
    if e.tip_mass:
        for n_rec in ident.get("ltv_records", [2, 5, 10, 50]):
            for lev in noise_levels:
                for seed in (seeds if lev > 0 else seeds[:1]):
                    F, Y = case.records(n_rec, ident.get("ltv_samples", n), "acceleration",
                                        lev, seed)
                    fits = [("ltv", identify_lagged(F, Y, solver=ident.get("ltv_solver", "ls")))]
                    if n_rec == max(ident.get("ltv_records", [2])):
                        fits.append(("lti", identify_lagged(F, Y, n_basis=1)))
                    for kind, fit in fits:
                        comp = Component((case.dof,), fit.kernel, name=e.name)
                        for scheme in ("implicit", "two-step"):
                            rows.append({**case.run([comp], scheme), "kernel": kind,
                                         "records": "acceleration", "n_records": n_rec,
                                         "noise": lev, "seed": seed})
                    progress(f"{e.name}: {n_rec} records, noise {lev:g}, seed {seed}")
        return rows
    plans = [("acceleration", lev) for lev in noise_levels]
    for quantity in ("velocity", "displacement"):
        if e.name in ident.get(f"{quantity}_components", []):
            plans += [(quantity, lev) for lev in ident.get(f"{quantity}_noise", [])]
    n_rec = int(ident.get("lti_records", 4))
    for quantity, lev in plans:
        for seed in (seeds if lev > 0 else seeds[:1]):
            F, Y = case.records(n_rec, int(ident.get("lti_samples", 2 * n)), quantity, lev, seed)
            fit = identify_kernel(F, Y, dt, n_lags=n, solver=ident.get("lti_solver", "realization"),
                                  options=dict(ident.get("lti_options", {})) or None)
            for kind, comp, detail in _lti_components(case, fit, quantity, (F, Y), ident):
                for scheme in ("implicit", "two-step"):
                    row = case.run([comp], scheme)
                    rows.append({**row, "kernel": kind, "records": quantity,
                                 "n_records": n_rec, "noise": lev, "seed": seed,
                                 "order": fit.info.get("order"),
                                 "detail": row["detail"] or detail})
            progress(f"{e.name}: {quantity} records, noise {lev:g}, seed {seed}")
    return rows


def _lti_components(case: _Case, fit, quantity: str, records, ident: dict):
    """The identified time-invariant component as fitted (``"lti"``) and made passive
    (``"lti_passive"``, :func:`podbench.sysid.passivity.enforce_passivity` with the poles
    fixed: the passive kernel closest to the fitted one over the coupled run's ``n`` lags
    (``passive_fit = "kernel"``, default) or the records' passivity-constrained least squares
    (``"records"``)), with a detail."""
    n, name = case.plan.n_samples, case.entry.name
    out = [("lti", Component((case.dof,), fit.kernel, quantity=quantity, name=name,
                             realization=fit.realization), "")]
    if ident.get("passive", True) and fit.realization is not None:
        by_records = ident.get("passive_fit", "kernel") == "records"
        pr = enforce_passivity(fit.realization, quantity, n_lags=n,
                               records=records if by_records else None)
        i = pr.info
        detail = (f"made passive (margin before {i['margin_before']:.3g}, poles moved "
                  f"{i['poles_moved']}, kernel change {i['kernel_change']:.3g})")
        out.append(("lti_passive", Component((case.dof,), realization_kernel(pr.realization, n),
                                             quantity=quantity, name=name,
                                             realization=pr.realization), detail))
    return out


def run_substructuring(plan: SubstructuringPlan, progress=None) -> tuple[list, dict]:
    """Rows of the summary table (dicts, :data:`COLUMNS`; coupled responses under ``"Y"``)
    and, per component, the truth ``Y_true`` and ``dt``."""
    progress = progress or (lambda msg: None)
    with single_blas_thread():  # one BLAS thread: fair timings, as every podbench task
        return _run(plan, progress)


def _run(plan: SubstructuringPlan, progress) -> tuple[list, dict]:
    parent = load_structure(plan.parent)
    rows, truths = [], {}
    for entry in plan.components:
        case = _Case(plan, parent, entry)
        truths[entry.name] = case.Y_true
        base = {"parent": plan.parent, "component": entry.name}
        floor = case.run([], "implicit")
        rows.append({**base, **floor, "scheme": "ignored", "kernel": "none", "records": "",
                     "n_records": 0, "noise": 0.0, "seed": 0})
        for scheme in ("implicit", "two-step"):
            rows.append({**base, **case.run([case.exact], scheme), "kernel": "exact",
                         "records": "", "n_records": 0, "noise": 0.0, "seed": 0})
        progress(f"{entry.name}: exact kernels")
        for r in _identified_rows(case, plan.identification, plan.noise, plan.seeds, progress):
            rows.append({**base, **r})
    return rows, truths
