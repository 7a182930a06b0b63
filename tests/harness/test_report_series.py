"""The series the report's figures draw beside the norm: the two sensors chosen from the
truth alone, and the amplitude spectrum over all sensors, checked against sinusoids whose
amplitudes are known."""

import numpy as np
import pytest

from podbench.harness.series import (
    amplitude_spectrum,
    pick_sensors,
    prediction_series,
    truth_series,
)

DT = 1e-3
N = 1000


def _sine(amplitude, cycles, n=N):
    """A sinusoid with an integer number of cycles in the record: its frequency is a bin
    frequency, cycles / (n·dt)."""
    return amplitude * np.sin(2 * np.pi * cycles * np.arange(n) / n + 0.3)


def test_a_sinusoid_at_a_bin_frequency_has_its_amplitude():
    f, a = amplitude_spectrum(_sine(2.5, 40)[None, :], DT)
    assert f[1] == pytest.approx(1 / (N * DT)) and f[-1] == pytest.approx(0.5 / DT)
    k = int(np.argmax(a))
    assert f[k] == pytest.approx(40.0)
    # Hann window, coherent gain divided out: the amplitude to the window's 1/n asymmetry
    assert a[k] == pytest.approx(2.5, rel=2e-3)
    # a Hann window leaks into the two neighbouring bins only (half the amplitude each)
    assert a[k - 1] == pytest.approx(1.25, rel=5e-3) and a[k + 1] == pytest.approx(1.25,
                                                                                  rel=5e-3)
    assert np.max(np.delete(a, [k - 1, k, k + 1])) < 1e-2


def test_the_spectrum_over_sensors_is_their_root_sum_of_squares():
    """Sensors at one frequency (3 and 4 in) give 5 in; a constant offset is its own
    amplitude at 0 Hz (not doubled)."""
    W = np.vstack([_sine(3.0, 25), _sine(4.0, 25) + 0.7])
    f, a = amplitude_spectrum(W, DT)
    assert a[np.argmin(np.abs(f - 25))] == pytest.approx(5.0, rel=2e-3)
    assert a[0] == pytest.approx(0.7, rel=2e-3)
    # and it is linear in W: twice the record, twice the spectrum
    assert np.allclose(amplitude_spectrum(2 * W, DT)[1], 2 * a)


def _cantilever():
    x = np.arange(25.0)
    shape = (x / 24) ** 2 * (3 - x / 24)  # a static tip-load deflection: largest at the tip
    return x, np.outer(shape, _sine(1.0, 5, 200))


def test_a_cantilever_shows_its_tip_and_mid_span():
    x, W = _cantilever()
    labels = [f"w@{int(v)}in" for v in x]
    (a, b) = pick_sensors(W, x, labels)
    assert (a["index"], a["role"], a["label"], a["position"]) == (24, "tip", "w@24in", 24.0)
    assert (b["index"], b["role"], b["position"]) == (12, "mid-span", 12.0)


def test_a_structure_largest_at_mid_span_shows_the_quarter_span_too():
    """A pinned-pinned first mode with three coordinates per face (as the truss): the first
    sensor is the mid-span coordinate that moves most, the second the quarter span's, never
    another coordinate of the same face."""
    faces = np.repeat(np.arange(9.0), 3)  # positions 0..8, three sensors per face
    gain = np.tile([1.0, 1.2, 0.01], 9)  # d_top, d_bot, theta
    W = np.outer(np.sin(np.pi * faces / 8) * gain, _sine(1.0, 3, 100))
    (a, b) = pick_sensors(W, faces)
    assert (a["index"], a["role"]) == (13, "largest response")  # face 4, d_bot
    assert (b["index"], b["role"], b["position"]) == (7, "quarter span", 2.0)  # face 2, d_bot
    assert b["label"] == "sensor 7"


def test_without_positions_the_middle_sensor_by_index():
    W = np.outer([0.1, 0.2, 5.0, 0.3, 0.4], _sine(1.0, 3, 100))
    (a, b) = pick_sensors(W, None, ["a", "b", "c", "d", "e"])
    assert (a["label"], a["role"], b["label"], b["role"]) == ("c", "largest response",
                                                              "d", "middle sensor")
    assert [p["index"] for p in pick_sensors(W[:1])] == [0]  # one sensor: one panel


def test_the_series_carry_the_chosen_rows_and_spectra():
    x, W = _cantilever()
    s = truth_series(W, DT, positions=x, unit="in")
    assert [p["index"] for p in s["sensors"]] == [24, 12]
    assert np.array_equal(s["sensor_truth"], W[[24, 12]]) and s["unit"] == "in"
    p = prediction_series("ML", 2 * W, DT, s["sensors"])
    assert np.array_equal(p["ML__sensors"], 2 * W[[24, 12]])
    assert np.allclose(p["ML__spectrum"], 2 * s["spectrum"])
