"""The level maps (issue 14, item 2): the friction level times max(0, 1 + s), s a cubic spline
along the relative position (``position_map``, natural or periodic) or over the speed
(``velocity_map``, linear beyond its knots). The plugin's spline against scipy's CubicSpline
(an independent implementation) to rounding; the MJCF rig with both maps against the scipy
reference, which evaluates them with CubicSpline, within the step's error; bad maps named."""
from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from vibrofriction import laws
from vibrofriction.oracle import reference
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import FrictionParameters, ParameterError, RigParameters, \
    apply_overrides, default_friction

LEVEL_N = 5.0  # mu 0.5 on 10 N
KNOTS = (0.0, 0.01, 0.025, 0.03, 0.05)
FACTORS = (0.1, -0.2, 0.3, 0.0, -0.1)
COULOMB = FrictionParameters(law="coulomb", friction_coefficient=0.5)


@pytest.mark.parametrize("period", [0.0, 0.06], ids=["natural", "periodic"])
def test_the_position_map_is_the_cubic_spline_through_its_knots(period):
    friction = dataclasses.replace(COULOMB, position_map_knots_m=KNOTS,
                                   position_map_factors=FACTORS, position_map_period_m=period)
    x = np.linspace(-0.02, 0.13, 3001)  # beyond both ends, over two periods
    t = np.arange(x.size) * 1e-3
    run = laws.run_law(friction, t, np.full(x.size, 1e-2), normal_force_N=10.0, position_m=x)
    if period:
        spline = CubicSpline([*KNOTS, KNOTS[0] + period], [*FACTORS, FACTORS[0]],
                             bc_type="periodic")
        s = spline(KNOTS[0] + np.mod(x - KNOTS[0], period))
    else:  # natural, constant beyond the knots
        s = CubicSpline(KNOTS, FACTORS, bc_type="natural")(np.clip(x, KNOTS[0], KNOTS[-1]))
    np.testing.assert_allclose(run.friction_force_N, LEVEL_N * (1 + s), rtol=0, atol=1e-12)


def test_the_velocity_map_is_a_spline_of_the_speed_continued_along_its_end_slopes():
    knots, factors = (0.0, 0.005, 0.02, 0.05), (0.5, 0.0, 0.2, 0.4)
    friction = dataclasses.replace(COULOMB, velocity_map_knots_m_per_s=knots,
                                   velocity_map_factors=factors)
    v = np.linspace(-0.1, 0.1, 4001)
    run = laws.run_law(friction, np.arange(v.size) * 1e-3, v, normal_force_N=10.0)
    spline = CubicSpline(knots, factors, bc_type="natural")
    speed = np.abs(v)
    s = np.where(speed <= knots[-1], spline(np.minimum(speed, knots[-1])),
                 spline(knots[-1]) + spline(knots[-1], 1) * (speed - knots[-1]))
    np.testing.assert_allclose(run.friction_force_N, np.sign(v) * LEVEL_N * (1 + s), rtol=0,
                               atol=1e-12)


def test_a_map_never_makes_the_level_negative():
    friction = dataclasses.replace(COULOMB, position_map_knots_m=(0.0, 1.0, 2.0),
                                   position_map_factors=(-0.99, -0.99, 0.9))
    x = np.linspace(0.0, 2.0, 401)  # the spline dips below -1 between the first knots
    run = laws.run_law(friction, np.arange(x.size) * 1e-3, np.full(x.size, 1.0),
                       normal_force_N=10.0, position_m=x)
    assert run.friction_force_N.min() == 0.0


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
def test_the_rig_with_both_maps_matches_the_reference(law):
    """The slider travels 0.2 mm over the position map's knots on a vibrating table: the MJCF
    rig's drive force against reference.simulate_reference's, which evaluates the maps with
    CubicSpline. Dahl within 2e-3 of the level at every sample, its mean within 1e-4; Coulomb's
    jumps (sliding direction) shift by a step, so its mean within 1e-3."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3,
                        drive_velocity_m_per_s=5e-3)
    friction = dataclasses.replace(
        default_friction(law, rig), position_map_knots_m=(0.0, 5e-5, 1e-4, 1.5e-4),
        position_map_factors=(0.0, 0.3, -0.2, 0.1), velocity_map_knots_m_per_s=(0, 2e-3, 6e-3),
        velocity_map_factors=(0.2, 0.0, 0.1))
    duration = 0.04
    ref = reference.simulate_reference(rig, friction, duration, sample_dt_s=1e-5)
    run = rig_module.simulate(rig, friction, duration_s=duration)
    expected = np.interp(run.time_s, ref.time_s, ref.drive_force_N)
    level = friction.friction_coefficient * rig.normal_force_N
    window = run.time_s > 0.02
    if law == "dahl":
        assert np.max(np.abs(run.drive_force_N - expected)) < 2e-3 * level
    assert run.drive_force_N[window].mean() == pytest.approx(expected[window].mean(),
                                                             rel=1e-4 if law == "dahl" else 1e-3)
    # the maps act: without them the mean differs by more than the agreement
    plain = rig_module.simulate(rig, default_friction(law, rig), duration_s=duration)
    assert abs(plain.drive_force_N[window].mean() - run.drive_force_N[window].mean()) > \
        1e-2 * level


def _compile_error(config: dict[str, str]) -> str:
    spec = rig_module.build_spec(RigParameters(), default_friction("dahl"))
    for plugin in spec.plugins:
        if plugin.name == "friction":
            plugin.config = {**dict(plugin.config), **config}
    with pytest.raises(ValueError) as error:
        spec.compile()
    return str(error.value)


@pytest.mark.parametrize("config, named", [
    ({"position_map_knots": "0 1", "position_map_factors": "0 0 0"},
     "'position_map_knots' has 2 values and 'position_map_factors' 3"),
    ({"position_map_knots": "0 2 1", "position_map_factors": "0 0 0"},
     "the knots of 'position_map_knots' must increase"),
    ({"position_map_knots": "0 1 2", "position_map_factors": "0 -1 0"}, "factor <= -1"),
    ({"position_map_knots": "0 1 2", "position_map_factors": "0 0 0",
      "position_map_period": "1.5"}, "lie within one period"),
    ({"velocity_map_knots": "-1 0", "velocity_map_factors": "0 0"}, "knot < 0"),
    ({"velocity_map_knots": " ".join(str(i) for i in range(17)),
      "velocity_map_factors": " ".join(["0"] * 17)}, "at most 16"),
], ids=["counts", "order", "factor", "period", "negative-speed", "too-many"])
def test_a_bad_map_is_named(config, named):
    assert named in _compile_error(config)


def test_bad_maps_are_named_in_python_and_set_takes_lists():
    with pytest.raises(ParameterError, match="give one factor per knot"):
        dataclasses.replace(COULOMB, position_map_knots_m=(0, 1), position_map_factors=(0,)
                            ).validate()
    with pytest.raises(ParameterError, match="must increase"):
        dataclasses.replace(COULOMB, velocity_map_knots_m_per_s=(0, 2, 1),
                            velocity_map_factors=(0, 0, 0)).validate()
    _, friction = apply_overrides(RigParameters(), COULOMB, {
        "position_map_knots_m": "0,0.01,0.02", "position_map_factors": "0.1 0 -0.1"})
    assert friction.position_map_factors == (0.1, 0.0, -0.1)
    model = rig_module.build_model(RigParameters(), friction)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)  # the MJCF takes the lists as written
