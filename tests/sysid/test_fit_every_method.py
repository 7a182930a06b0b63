"""Every registered method fits through ``podbench fit`` on a record set it applies to, and
its model file reloads to the same prediction; where a form does not apply the fit says why
in one line (a table of reasons, checked against the registry so that a new method is
surveyed)."""

import numpy as np
import pytest

import podbench as pb
from podbench.core.recordfiles import write_record
from podbench.core.records import Record
from podbench.errors import InputError
from podbench.harness.fit import fit_files
from podbench.sysid import registry
from podbench.sysid.models import load_model

from ._cases import mixed_case

DT, N = 0.005, 240

KIND = {  # registered name -> the records it fits on
    "POVR": "free1", "MDS": "free", "SL": "forced1", "ML": "forced", "MR": "mixed",
    "FIR-LS": "io", "ERA": "forced", "DMDc": "forced", "OpInf": "forced", "mdof": "io",
    "ML-lags": "io", "ML-TC": "io", "ML-poles": "io", "ML-whole": "io", "FIR-LS-whole": "io",
    "ERA-measured": "io", "mdof-SRIM": "io", "mdof-OKID-ERA": "io",
}
REFUSED = {  # registered name -> why `podbench fit` cannot fit it from record files
    "superposition": "a sum of methods, each fitted on its own training records",
    "ML-k": "the configuration leaves n_modes to its caller",
    "FIR-LS-half": "the configuration leaves n_lags to its caller",
}
PERIODIC = {"BLA", "ML-periodic", "ML-interp"}
"""Fitted on steady-state periodic records that carry ``period_samples`` (the F-16 files:
tests/measured_io/test_f16_gvt.py fits, saves and predicts with each); on records without
the period they refuse in one line (below)."""


def _write(tmp_path, kind: str) -> list[str]:
    chain = pb.load_structure("chain_coupled")
    files = []
    rng = np.random.default_rng(3)
    count = 1 if kind.endswith("1") else 3 if kind == "mixed" else 4
    for j in range(count):
        F = np.zeros((5, N))
        w0 = None
        if kind.startswith("free"):
            w0 = np.linalg.solve(chain.K.toarray(), rng.normal(size=5))
            r = pb.simulate(chain, N, DT, initial_displacement=w0)
            rec = Record(W=r.W, w0=w0, dt=DT)
        elif kind == "mixed":  # MR's three cases (a: velocity, b: displacement, c: force)
            c = mixed_case("coupled")
            rec = Record(W=c.W[j], w0=c.w0[j], v0=c.v0[j], F=c.F[j], dt=c.dt)
        elif kind.startswith("forced"):
            F[j % 5, 1:] = rng.normal(size=N - 1)
            rec = Record(W=pb.simulate(chain, N, DT, force=F).W, F=F, dt=DT)
        else:  # measured input at mass 3, displacement outputs
            F[2, 1:] = rng.normal(size=N - 1)
            rec = Record(u=F[[2]], y=pb.simulate(chain, N, DT, force=F).W, dt=DT,
                         input_units="lbf", output_units="in", input_channels=("f3",))
        files.append(str(tmp_path / f"{kind}{j}.npz"))
        write_record(files[-1], rec)
    return files


def test_the_survey_covers_the_registry():
    names = {e.name for e in registry.ENTRIES}
    assert names == set(KIND) | set(REFUSED) | PERIODIC


@pytest.mark.parametrize("name", sorted(PERIODIC))
def test_a_periodic_method_on_records_without_a_period_says_why(name, tmp_path):
    files = _write(tmp_path, "io")
    with pytest.raises(InputError) as err:
        fit_files(name, files, tmp_path / "out")
    assert "\n" not in str(err.value) and "period_samples" in str(err.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.heavy
@pytest.mark.parametrize("name", sorted(KIND))
def test_every_registered_method_fits_and_reloads(name, tmp_path):
    if name.startswith("mdof"):
        pytest.importorskip("mdof")
    files = _write(tmp_path, KIND[name])
    res = fit_files(name, files, tmp_path / "out")
    model = load_model(tmp_path / "out" / "model.npz")
    target = __import__("podbench.core.recordfiles", fromlist=["read_record"]).read_record(
        files[-1])
    a, b = res.model.predict(target), model.predict(target)
    assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    assert (res.modes is None) == bool(res.note)  # a modes table, or the one line why


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_a_method_podbench_fit_cannot_fit_says_why(name, tmp_path):
    files = _write(tmp_path, "forced")
    with pytest.raises(InputError) as err:
        fit_files(name, files, tmp_path / "out")
    assert "\n" not in str(err.value) and REFUSED[name] in str(err.value)
