"""The rig's prescribed motions are checked, not assumed: the table follows u = u0 sin(wt) and the
drive end moves at v_d, with the friction reaction acting on the table.

The table's joint velocity after a semi-implicit Euler step is the step mean
(u_{n+1} - u_n)/dt = v_a sinc(w dt/2) cos(w (t_n + dt/2)), sinc x = sin(x)/x: 0.26 % below
v_a at dt = 1e-5 s, 0.003 % at 1e-6 s.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibrofriction import sim
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import RigParameters, default_friction

FREQUENCY_HZ = 4000.0
VA = 3e-3


def _fit_cos_sin(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[float, float]:
    """Amplitude and phase of y ~ A cos(omega t + phi) (least squares with an offset)."""
    basis = np.column_stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t)])
    (a, b, _), *_ = np.linalg.lstsq(basis, y, rcond=None)
    return math.hypot(a, b), math.atan2(-b, a)


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
@pytest.mark.parametrize("timestep_s", [1e-5, 1e-6])
def test_table_follows_the_prescribed_vibration(law, timestep_s):
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA,
                        vibration_frequency_Hz=FREQUENCY_HZ)
    run = rig_module.simulate(rig, default_friction(law, rig), duration_s=0.03,
                              timestep_s=timestep_s, settle_time_s=0.01)
    omega = 2 * math.pi * FREQUENCY_HZ
    periods = run.time_s >= run.time_s[-1] - 40 / FREQUENCY_HZ
    t = run.time_s[periods]
    amplitude, phase = _fit_cos_sin(t, run.support_velocity_m_per_s[periods], omega)
    half = omega * timestep_s / 2
    assert amplitude == pytest.approx(VA, rel=5e-3)
    assert amplitude == pytest.approx(VA * math.sin(half) / half, rel=1e-5)
    assert phase == pytest.approx(-half, abs=1e-4)  # the step mean sits half a step back
    # position: exactly on u0 sin(w t) at every step
    u0 = rig.vibration_amplitude_m
    error = run.support_position_m - u0 * np.sin(omega * run.time_s)
    assert np.max(np.abs(error)) < 1e-6 * u0


def test_drive_end_moves_at_the_drive_velocity():
    """F_d = k_d (v_d t - x) exactly (h_d = 0), so the far end of the spring is at v_d t."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA)
    run = rig_module.simulate(rig, default_friction("dahl", rig), duration_s=0.03,
                              timestep_s=1e-5, settle_time_s=0.01)
    expected = rig.drive_stiffness_N_per_m * (rig.drive_velocity_m_per_s * run.time_s
                                              - run.slider_position_m)
    np.testing.assert_allclose(run.drive_force_N, expected, rtol=0, atol=1e-9)


def test_a_vibration_started_later_follows_the_reference_build_up():
    """vibration_from_s: the table stands still, then its amplitude builds up over
    VIBRATION_RAMP_PERIODS periods exactly as the scipy reference moves it."""
    from vibrofriction.oracle import reference
    from vibrofriction.params import VIBRATION_RAMP_PERIODS

    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA, vibration_from_s=0.004)
    run = rig_module.simulate(rig, default_friction("dahl", rig), duration_s=0.012,
                              timestep_s=1e-6, settle_time_s=0.011)
    expected, _ = reference.support_motion(rig, run.time_s)
    u0 = rig.vibration_amplitude_m
    assert np.max(np.abs(run.support_position_m - expected)) < 1e-6 * u0
    before = run.time_s < rig.vibration_from_s
    # (still: the friction's reaction on the heavy table, corrected a step later, is ~1e-17 m)
    assert np.max(np.abs(run.support_position_m[before])) < 1e-9 * u0
    ramp_end = rig.vibration_from_s + VIBRATION_RAMP_PERIODS / rig.vibration_frequency_Hz
    after = run.time_s > ramp_end
    assert np.max(np.abs(run.support_position_m[after])) == pytest.approx(u0, rel=1e-3)


@pytest.mark.parametrize("config, message", [
    ({"start_time": "-1", "frequency": "4000", "velocity_amplitude": "1e-3"}, "start_time"),
    ({"ramp_periods": "5"}, "set velocity_amplitude"),
    ({"displacement_from_ctrl": "true", "start_time": "0.01"}, "displacement_from_ctrl"),
])
def test_a_bad_vibration_start_is_refused_by_name(config, message):
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA)
    spec = rig_module.build_spec(rig, default_friction("dahl", rig))
    sim.set_plugin_config(spec, "table_shaker", config)
    with pytest.raises(ValueError, match=message):
        spec.compile()
