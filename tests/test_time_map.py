"""The time map: the friction level times max(0, 1 + s(t)), s the natural cubic spline through
(knot, factor) pairs over the simulation time t, constant beyond the knots (a drift of the
level: heating, run-in, wear). The C API's spline against scipy's CubicSpline at the samples'
own time; the MJCF rig against the scipy reference (which evaluates the map with CubicSpline)
and against the level it follows; the C API against the plugin to rounding; bad maps named."""
from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from vibrofriction import laws
from vibrofriction.oracle import reference
from vibrofriction.rigs import planar
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import FrictionParameters, ParameterError, RigParameters, \
    apply_overrides, default_friction

LEVEL_N = 5.0  # mu 0.5 on 10 N
COULOMB = FrictionParameters(law="coulomb", friction_coefficient=0.5)
# the paper's rig (0.5 kg, 1e6 N/m, 55.2 N, 4 kHz) sliding without reversal: v_d 5 mm/s,
# v_a 1.5 mm/s (as tests/test_level_maps.py)
RIG = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3, drive_velocity_m_per_s=5e-3)
DURATION_S = 0.04
RISE = 0.1  # the level rises 10 % linearly over the run
WINDOW_S = 0.005  # 20 vibration periods


def test_the_time_map_is_the_cubic_spline_at_the_samples_time():
    """A record that starts at 0.9 s: the map is read at each sample's own time (not the time
    since the record's start), constant beyond its knots."""
    knots, factors = (1.0, 1.2, 1.5, 2.0), (0.1, -0.2, 0.3, -0.1)
    friction = dataclasses.replace(COULOMB, time_map_knots_s=knots, time_map_factors=factors)
    t = np.linspace(0.9, 2.2, 2601)
    run = laws.run_law(friction, t, np.full(t.size, 1e-2), normal_force_N=10.0)
    s = CubicSpline(knots, factors, bc_type="natural")(np.clip(t, knots[0], knots[-1]))
    np.testing.assert_allclose(run.friction_force_N, LEVEL_N * (1 + s), rtol=0, atol=1e-10)


def _mean_friction_N(time_s, drive_N, velocity_m_per_s, start_s, end_s) -> float:
    """The mean friction over [start_s, end_s] from the drive force: its mean less the slider's
    momentum change over the window (the drive spring rings at 225 Hz after breakaway, undamped
    while the friction is saturated: the drive force's plain mean moves by +-2 % in a window)."""
    k = (time_s >= start_s - 1e-12) & (time_s <= end_s + 1e-12)
    t, drive, v = time_s[k], drive_N[k], velocity_m_per_s[k]
    return float((np.trapezoid(drive, t) - RIG.mass_kg * (v[-1] - v[0])) / (t[-1] - t[0]))


@pytest.mark.parametrize("law", ["dahl", "lugre"])
def test_the_rig_with_a_time_map_matches_the_reference_and_follows_the_level(law):
    """The level rises 10 % linearly over the run. The MJCF rig's drive force against
    reference.simulate_reference's within 1e-3 of the level at every sample (measured 2.6e-4
    Dahl, 3.8e-4 LuGre). The mean friction (from the drive force) over 5 ms windows: against
    the reference's within 5e-4 (measured 1.6e-4: the element's own error at dt 1e-5, the same
    without the map), and over the same run without the map it is 1 + 0.1 t/T at the window's
    middle within 3e-4 (measured -1.2e-4: the bristles lag the rising level by about
    z_c / v_d = 28 us, 6.5e-5 of the level at this slope)."""
    plain_friction = default_friction(law, RIG)
    friction = dataclasses.replace(plain_friction, time_map_knots_s=(0.0, DURATION_S),
                                   time_map_factors=(0.0, RISE))
    ref = reference.simulate_reference(RIG, friction, DURATION_S, sample_dt_s=1e-5)
    run = rig_module.simulate(RIG, friction, duration_s=DURATION_S)
    plain = rig_module.simulate(RIG, plain_friction, duration_s=DURATION_S)
    level = friction.friction_coefficient * RIG.normal_force_N
    expected = np.interp(run.time_s, ref.time_s, ref.drive_force_N)
    assert np.max(np.abs(run.drive_force_N - expected)) < 1e-3 * level
    for start in np.arange(0.01, DURATION_S - 1e-9, WINDOW_S):  # after breakaway (~3 ms)
        end = start + WINDOW_S
        mapped = _mean_friction_N(run.time_s, run.drive_force_N, run.slider_velocity_m_per_s,
                                  start, end)
        oracle = _mean_friction_N(ref.time_s, ref.drive_force_N, ref.slider_velocity_m_per_s,
                                  start, end)
        unmapped = _mean_friction_N(plain.time_s, plain.drive_force_N,
                                    plain.slider_velocity_m_per_s, start, end)
        factor = 1 + RISE * 0.5 * (start + end) / DURATION_S
        assert mapped == pytest.approx(oracle, rel=5e-4), start
        assert mapped / unmapped == pytest.approx(factor, abs=3e-4), start


@pytest.mark.parametrize("law", ["dahl", "dupont", "lugre"])
def test_the_c_api_with_a_time_map_equals_the_plugin(law):
    """laws.run_law along the rig's relative velocity reproduces the plugin's deflection and
    force to rounding when its samples carry the times the plugin's step reads (the deflection's
    update over [t_i, t_i + dt] takes the input at mid-step, d->time - dt/2 once time has
    advanced; the C API's over [t_i, t_i+1] the input at t_i+1). No bristle damping: the C API
    takes the damping term at the sample's velocity, the plugin at the step's trapezoidal
    mean. The map is not linear and ends before the run does."""
    friction = dataclasses.replace(default_friction(law, RIG), bristle_damping_N_s_per_m=0.0,
                                   time_map_knots_s=(0.005, 0.02, 0.035),
                                   time_map_factors=(0.0, 0.15, 0.1))
    run = rig_module.simulate(RIG, friction, duration_s=DURATION_S)
    level = friction.friction_coefficient * RIG.normal_force_N
    at_mid_step = run.time_s - 0.5 * run.timestep_s
    law_run = laws.run_law(friction, at_mid_step, run.relative_velocity_m_per_s,
                           normal_force_N=RIG.normal_force_N)
    np.testing.assert_allclose(law_run.friction_force_N, run.friction_force_N, rtol=0,
                               atol=1e-10 * level)
    np.testing.assert_allclose(law_run.deflection_m, run.deflection_m, rtol=0,
                               atol=1e-10 * level / friction.contact_stiffness_N_per_m)
    # the map acts and its time matters: without it, or read at t_i, the runs differ
    unmapped = laws.run_law(dataclasses.replace(friction, time_map_knots_s=(),
                                                time_map_factors=()),
                            at_mid_step, run.relative_velocity_m_per_s,
                            normal_force_N=RIG.normal_force_N)
    assert np.max(np.abs(unmapped.friction_force_N - run.friction_force_N)) > 0.1 * level
    shifted = laws.run_law(friction, run.time_s, run.relative_velocity_m_per_s,
                           normal_force_N=RIG.normal_force_N)
    assert np.max(np.abs(shifted.friction_force_N - run.friction_force_N)) > 1e-5 * level


def test_the_steady_deflection_takes_the_maps_factor_at_its_time():
    friction = FrictionParameters(law="lugre", friction_coefficient=0.5,
                                  time_map_knots_s=(0.0, 1.0), time_map_factors=(0.0, 0.5))
    z_c = LEVEL_N / friction.contact_stiffness_N_per_m
    assert laws.steady_deflection_m(friction, 1e-3, normal_force_N=10.0) == \
        pytest.approx(z_c, rel=1e-9)
    assert laws.steady_deflection_m(friction, 1e-3, normal_force_N=10.0, time_s=0.5) == \
        pytest.approx(1.25 * z_c, rel=1e-9)


def _compile_error(config: dict[str, str]) -> str:
    spec = rig_module.build_spec(RigParameters(), default_friction("dahl"))
    for plugin in spec.plugins:
        if plugin.name == "friction":
            plugin.config = {**dict(plugin.config), **config}
    with pytest.raises(ValueError) as error:
        spec.compile()
    return str(error.value)


@pytest.mark.parametrize("config, named", [
    ({"time_map_knots": "0 1", "time_map_factors": "0 0 0"},
     "'time_map_knots' has 2 values and 'time_map_factors' 3; give one factor per knot"),
    ({"time_map_knots": "0 1"}, "'time_map_knots' has 2 values and 'time_map_factors' 0"),
    ({"time_map_knots": "0 2 1", "time_map_factors": "0 0 0"},
     "the knots of 'time_map_knots' must increase"),
    ({"time_map_knots": "0 1", "time_map_factors": "0 -1"},
     "attribute 'time_map_factors'=\"-1\" has a factor <= -1"),
    ({"time_map_knots": "0 1", "time_map_factors": "0 2000"},
     "attribute 'time_map_factors'=\"0 2000\" holds 2000, out of its physical range"),
    ({"time_map_knots": "-1 0", "time_map_factors": "0 0"},
     "attribute 'time_map_knots'=\"-1\" has a knot < 0; the knots are times t >= 0 (s)"),
], ids=["counts", "no-factors", "order", "factor", "factor-range", "negative-time"])
def test_a_bad_time_map_in_mjcf_is_named(config, named):
    message = _compile_error(config)
    assert named in message
    assert message.count("vibrofriction.friction") == 1  # one error, not a cascade


@pytest.mark.parametrize("knots, factors, named", [
    ((0, 1), (0, 0, 0), "time_map_knots_s has 2 values and time_map_factors 3; give one "
                        "factor per knot"),
    ((0, 2, 1), (0, 0, 0), "parameter time_map_knots_s=(0.0, 2.0, 1.0) must increase"),
    ((0, 1), (0, -1), "parameter time_map_factors=(0.0, -1.0) must hold factors > -1"),
    ((0, 1), (0, 2000), "parameter time_map_factors=(0.0, 2000.0) must lie within +-1000"),
    ((-1, 0), (0, 0), "parameter time_map_knots_s=(-1.0, 0.0) must be times >= 0"),
], ids=["counts", "order", "factor", "factor-range", "negative-time"])
def test_a_bad_time_map_in_python_is_named(knots, factors, named):
    with pytest.raises(ParameterError) as error:
        dataclasses.replace(COULOMB, time_map_knots_s=knots, time_map_factors=factors).validate()
    assert named in str(error.value)


def test_set_takes_the_time_map_and_the_rig_writes_it():
    _, friction = apply_overrides(RigParameters(), COULOMB, {
        "time_map_knots_s": "0,0.01,0.02", "time_map_factors": "0 0.05 0.1"})
    assert friction.time_map_knots_s == (0.0, 0.01, 0.02)
    spec = rig_module.build_spec(RigParameters(), friction)
    config = next(dict(p.config) for p in spec.plugins if p.name == "friction")
    assert config["time_map_knots"] == "0.0 0.01 0.02"
    assert config["time_map_factors"] == "0.0 0.05 0.1"
    model = spec.compile()
    mujoco.mj_step(model, mujoco.MjData(model))  # the MJCF takes the lists as written
    # the planar element has no time map (a 1D-element effect): refused, named
    with pytest.raises(ParameterError, match="time_map_factors"):
        planar.check_planar(friction)
