"""modal.csv: a fit's modes against the finite-element modes, checked against scipy's
eigensolution of the structure's M, C, K computed here (with the trapezoidal map of the
Newmark records), and the excited band of known spectra."""

import numpy as np
import scipy.linalg

import podbench as pb
from podbench.core.records import Record
from podbench.harness.modal import MODAL_COLUMNS, excited_band, modal_rows, pom_rows
from podbench.sysid.methods import MultipleLoad


def test_the_excited_band_ends_at_the_records_spectrum():
    dt, n = 0.01, 2000
    t = np.arange(n) * dt
    rec = Record(W=np.vstack([np.sin(2 * np.pi * 7.0 * t), 0.5 * np.sin(2 * np.pi * 3.0 * t)]),
                 dt=dt)
    top = excited_band([rec], dt)
    assert 7.0 <= top <= 7.0 + 2.0 / (n * dt)  # within two bins above the highest line
    wide = Record(W=np.vstack([np.sin(2 * np.pi * 21.0 * t)] * 2), dt=dt)
    assert excited_band([rec, wide], dt) >= 21.0


def _chain_records():
    chain = pb.load_structure("chain_coupled")
    dt, n = 0.002, 800
    recs = []
    for j in range(5):
        F = np.zeros((5, n))
        F[j, 1:6] = 10.0 + j  # a short push on mass j (lbf): every mode excited
        r = pb.simulate(chain, n, dt, force=F)
        recs.append(Record(W=r.W, F=F, dt=dt))
    return chain, recs, dt


def _independent_modes(chain, dt):
    M, K, C = (x.toarray() for x in (chain.mass(0.0), chain.stiffness(0.0), chain.C))
    n = M.shape[0]
    Ac = np.block([[np.zeros((n, n)), np.eye(n)],
                   [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = scipy.linalg.eigvals(Ac)
    lam = lam[lam.imag > 0]
    s = np.log((1 + lam * dt / 2) / (1 - lam * dt / 2)) / dt  # what Newmark records hold
    order = np.argsort(np.abs(s))
    return np.abs(s[order]) / (2 * np.pi), -s[order].real / np.abs(s[order])


def test_an_exact_fit_finds_every_band_mode_of_the_chain():
    chain, recs, dt = _chain_records()
    est = MultipleLoad(solver="block").fit(recs)
    base = {"scenario": "s", "structure": chain.name, "method": "ML"}
    rows = modal_rows(est, chain, base, recs, dt)
    assert set(rows[0]) == set(MODAL_COLUMNS)
    f, z = _independent_modes(chain, dt)
    top = excited_band(recs, dt)
    in_band = f <= top
    assert in_band.sum() == len(rows) >= 3
    for r, fi, zi in zip(rows, f[in_band], z[in_band], strict=True):
        assert r["status"] == "ok" and r["mac"] >= 0.9999
        assert abs(r["frequency_hz"] - fi) <= 1e-4 * fi
        assert abs(r["damping_ratio"] - zi) <= 1e-2 * zi
        assert abs(r["frequency_error_pct"]) <= 1e-3 and abs(r["damping_error"]) <= 1e-5
    poms = pom_rows(est, chain, base)
    assert len(poms) == est.modes_.shape[1] and all(0 <= p["mac"] <= 1 for p in poms)


def test_a_method_without_state_space_form_gets_one_row_with_the_reason():
    chain, recs, dt = _chain_records()

    class NoForm:  # a fitted method with POMs but neither kernel nor state space
        modes_ = np.eye(5)[:, :2]

    rows = modal_rows(NoForm(), chain, {"scenario": "s", "structure": "c", "method": "X"},
                      recs, dt)
    assert len(rows) == 1 and rows[0]["status"].startswith("no modes: ")


def test_the_report_section_counts_the_modes_found_and_lists_every_row():
    import pandas as pd

    from podbench.harness.modal import POM_COLUMNS
    from podbench.report.modal import modal_html

    rows = [{"scenario": "s", "structure": "c", "method": "ML", "mode": i + 1,
             "frequency_hz": f, "damping_ratio": 0.01, "identified_frequency_hz": f * 1.001,
             "identified_damping_ratio": 0.011, "frequency_error_pct": 0.1,
             "damping_error": 0.001, "mac": 0.999, "truth": "finite-element modes",
             "status": "ok"} for i, f in enumerate((2.0, 5.0))]
    rows.append({**rows[0], "mode": 3, "frequency_hz": 9.0, "mac": float("nan"),
                 "identified_frequency_hz": float("nan"), "status": "unmatched"})
    modal = pd.DataFrame(rows, columns=list(MODAL_COLUMNS))
    poms = pd.DataFrame([{"scenario": "s", "structure": "c", "method": "ML", "pom": 1,
                          "mode": 1, "frequency_hz": 2.0, "mac": 0.98}],
                        columns=list(POM_COLUMNS))
    page = modal_html(modal, poms, None)
    assert "2 of 3 band modes found" in page and "median MAC 0.999" in page
    assert page.count("<tr><td>") == 3 + 1  # every modal row and the POM row
    assert modal_html(None, None, None) == ""
