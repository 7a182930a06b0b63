"""Painter Street's deck modes per event (:func:`podbench.harness.painter_street.deck_modes`)
on records of a known system: a 4-Hz mode largest at a deck channel is found in every event
at its frequency and damping, a 12-Hz mode largest at the column top is not a deck mode."""

import numpy as np
import pytest
import scipy.linalg

from podbench.core.records import Record
from podbench.harness.painter_street import deck_modes


def _events(n_events=3, n=3000, dt=0.01):
    modes = [(4.0, 0.03, np.array([1.0, 0.5, 0.4])), (12.0, 0.05, np.array([0.2, -0.3, 1.0]))]
    blocks, Bc, Cc = [], [], []
    rng = np.random.default_rng(11)
    for f, z, phi in modes:
        w = 2 * np.pi * f
        blocks.append(np.array([[0.0, 1.0], [-w * w, -2 * z * w]]))
        Bc.append(np.vstack([np.zeros((1, 3)), rng.normal(size=(1, 3))]))
        Cc.append(np.outer(phi, [-w * w, -2 * z * w]))  # acceleration of the modal coordinate
    Ac = scipy.linalg.block_diag(*blocks)
    B, C = np.vstack(Bc), np.hstack(Cc)
    E = scipy.linalg.expm(np.block([[Ac, B], [np.zeros((3, 7))]]) * dt)
    Ad, Bd = E[:4, :4], E[:4, 4:]
    D = np.hstack([np.outer(phi, [1.0]) for _, _, phi in modes]) @ np.vstack(
        [b[1:] for b in Bc])
    out = []
    for j in range(n_events):
        u = rng.normal(size=(3, n))
        x = np.zeros(4)
        y = np.empty((3, n))
        for s in range(n):
            y[:, s] = C @ x + D @ u[:, s]
            x = Ad @ x + Bd @ u[:, s]
        out.append(Record(u=u, y=y, dt=dt, input_units="m/s^2", output_units="m/s^2",
                          input_channels=("3", "17", "20"), output_channels=("7", "9", "4"),
                          name=f"e{j}"))
    return out


@pytest.mark.heavy
def test_the_deck_mode_is_found_in_every_event_at_its_frequency_and_damping():
    rows, reference = deck_modes(_events())
    assert len(reference) == 1  # the 12-Hz mode is largest at the column top (ch 4)
    assert abs(reference[0]["frequency_hz"] - 4.0 * np.sqrt(1 - 0.03**2)) < 0.05
    assert len(rows) == 3
    for r in rows:
        assert r["mac"] > 0.999
        assert abs(r["frequency_hz"] - 4.0) < 4e-3 and abs(r["damping_ratio"] - 0.03) < 1e-3
