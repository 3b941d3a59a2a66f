"""Residual tracing beyond the vocabulary (issue 14, item 3): the ringing after reversals (a
damped oscillation of the residual, averaged over the reversals and signed by the new
direction) with its frequency and damping, and the time since the last reversal as a
regressor. A planted ringing comes back within its estimation error; noise alone reports none."""
from __future__ import annotations

import numpy as np
import pytest

from vibrofriction.identify.analysis import ringing_after_reversals, time_since_reversal

DT = 1.0 / 1024
TIME = np.arange(0.0, 6.0, DT)
VELOCITY = np.sin(2 * np.pi * TIME)  # a reversal every 0.5 s


def _ringing(frequency_Hz: float, zeta: float, amplitude_N: float) -> np.ndarray:
    since = time_since_reversal(TIME, VELOCITY)
    known = np.isfinite(since)
    omega_n = 2 * np.pi * frequency_Hz / np.sqrt(1 - zeta ** 2)
    out = np.zeros_like(TIME)
    out[known] = amplitude_N * np.exp(-zeta * omega_n * since[known]) * \
        np.sin(2 * np.pi * frequency_Hz * since[known])
    return out * np.sign(VELOCITY)


def test_time_since_reversal_restarts_at_each_reversal():
    since = time_since_reversal(TIME, VELOCITY)
    assert np.isinf(since[: 100]).all()  # before the first reversal (t = 0.5 s)
    assert since[np.searchsorted(TIME, 0.75)] == pytest.approx(0.25, abs=2 * DT)
    assert since[np.searchsorted(TIME, 1.25)] == pytest.approx(0.25, abs=2 * DT)


@pytest.mark.parametrize("frequency_Hz, zeta", [(37.0, 0.06), (12.0, 0.15)])
def test_a_planted_ringing_is_found_with_its_frequency_and_damping(frequency_Hz, zeta):
    rng = np.random.default_rng(3)
    residual = _ringing(frequency_Hz, zeta, 500.0) + 50.0 * rng.standard_normal(TIME.size)
    found = ringing_after_reversals(TIME, VELOCITY, residual)
    assert found is not None and found.reversals == 11
    # 11 averaged windows of 10 % noise: the frequency within 1 %, the damping within 20 %
    assert found.frequency_Hz == pytest.approx(frequency_Hz, rel=0.01)
    assert found.damping_ratio == pytest.approx(zeta, rel=0.2)
    assert found.amplitude_N == pytest.approx(500.0, rel=0.1)


def test_noise_and_a_steady_offset_are_no_ringing():
    rng = np.random.default_rng(4)
    assert ringing_after_reversals(TIME, VELOCITY, 50.0 * rng.standard_normal(TIME.size)) is None
    assert ringing_after_reversals(TIME, VELOCITY, 30.0 * np.sign(VELOCITY)) is None
    assert ringing_after_reversals(TIME, np.ones_like(TIME), TIME) is None  # no reversal


def test_a_record_ending_soon_after_a_reversal_keeps_the_window():
    """The last, cut-off window is left out; it does not shorten the others."""
    rng = np.random.default_rng(5)
    end = np.searchsorted(TIME, 5.53)  # 30 ms after the last reversal at 5.5 s
    residual = _ringing(37.0, 0.06, 500.0) + 50.0 * rng.standard_normal(TIME.size)
    found = ringing_after_reversals(TIME[:end], VELOCITY[:end], residual[:end])
    assert found is not None and found.reversals == 10
    assert found.frequency_Hz == pytest.approx(37.0, rel=0.01)
    assert found.window_s == pytest.approx(0.25, abs=2 * DT)


def test_a_stop_and_go_is_no_reversal():
    from vibrofriction.identify.analysis import reversal_indices
    velocity = np.concatenate([np.ones(100), np.full(5, -1e-4), np.ones(100), -np.ones(100)])
    indices, directions = reversal_indices(velocity)
    assert indices.tolist() == [205] and directions.tolist() == [-1]
