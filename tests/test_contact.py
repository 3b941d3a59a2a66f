"""``vibrofriction.contact``: the drop-in element for free bodies on MuJoCo's own contacts.

Checked against the heavy-body kinematic limits (docs/physics.md: a body much heavier than
the friction impulse of one vibration period creeps at the rigid-Coulomb value), the Coulomb
torsional rate of a spinning disc, lift-off and set-down, the state round trip, and against the
slide-joint planar element on the same motion.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

import vibrofriction
from vibrofriction.oracle import analytic

MU = 0.2
GRAVITY = 9.81
STATE_SIZE = 16  # z_t (3), theta, F_N, point (3), normal (3), rho, coulomb's (4)


def _scene(*, law="dahl", frequency_Hz=1000.0, amplitude_m_per_s=0.02, stiffness=1e9,
           part_geom='type="box" size="0.05 0.05 0.05"', part_condim=1, extra="",
           timestep=1e-5, part_z=0.06):
    return f"""
<mujoco>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.contact">
      <instance name="part_friction">
        <config key="law" value="{law}"/>
        <config key="mu" value="{MU}"/>
        <config key="stiffness" value="{stiffness}"/>
        <config key="support" value="plate"/>
        {extra}
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.motion">
      <instance name="shaker">
        <config key="frequency" value="{frequency_Hz}"/>
        <config key="velocity_amplitude" value="{amplitude_m_per_s}"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <body name="plate">
      <joint name="plate_x" type="slide" axis="1 0 0"/>
      <geom name="plate" type="box" size="1 1 0.01" mass="10" condim="1"/>
    </body>
    <body name="part" pos="0 0 {part_z}">
      <freejoint/>
      <geom name="part" {part_geom} mass="1" condim="{part_condim}"/>
      <plugin instance="part_friction"/>
    </body>
  </worldbody>
  <actuator>
    <plugin name="shaker" joint="plate_x" instance="shaker"/>
  </actuator>
</mujoco>"""


def _model(**kwargs) -> mujoco.MjModel:
    vibrofriction.load()
    return mujoco.MjModel.from_xml_string(_scene(**kwargs))


def _push(model, data, steps, force=(0.0, 0.0, 0.0), record=None):
    part = model.body("part").id
    out = []
    for _ in range(steps):
        data.xfrc_applied[part, :3] = force
        mujoco.mj_step(model, data)
        if record is not None:
            out.append(record(data))
    return np.array(out)


def _mean_velocity(model, data, steps, force, axis):
    """Mean velocity of the part along `axis` over the second half of `steps`."""
    positions = _push(model, data, steps, force, lambda d: d.body("part").xpos[axis].copy())
    time = np.arange(1, steps + 1) * model.opt.timestep
    half = steps // 2
    return np.polyfit(time[half:], positions[half:], 1)[0]


@pytest.mark.parametrize("law, fraction, timestep", [
    ("dahl", 0.3, 1e-5), ("dahl", 0.7, 1e-5),
    # rigid Coulomb switches direction inside a step: it converges with dt (measured -3.6 % at
    # 1e-5 s, -1.3 % at 5e-6 s, -0.09 % at 2.5e-6 s; the planar element's is -4.7 % at 1e-5 s)
    ("coulomb", 0.3, 2.5e-6)])
def test_a_free_box_pushed_below_mu_mg_creeps_at_the_longitudinal_kinematic_value(
        law, fraction, timestep):
    """Pushed along the vibration at F = f mu m g, the heavy body creeps at v = v_a sin(pi f/2)
    (f = (2/pi) arcsin(v/v_a)). Measured: Dahl within 0.02 %, Coulomb -0.09 %."""
    model = _model(law=law, timestep=timestep)
    data = mujoco.MjData(model)
    v = _mean_velocity(model, data, round(0.4 / timestep), (fraction * MU * GRAVITY, 0, 0),
                       axis=0)
    expected = 0.02 * math.sin(math.pi * fraction / 2)
    assert analytic.coulomb_kinematic_ratio(expected / 0.02) == pytest.approx(fraction)
    assert v == pytest.approx(expected, rel=0.02)


def test_pushed_across_the_vibration_it_creeps_at_the_transverse_elliptic_value():
    fraction = 0.5
    model = _model()
    data = mujoco.MjData(model)
    v = _mean_velocity(model, data, 40000, (0, fraction * MU * GRAVITY, 0), axis=1)
    xi = brentq(lambda x: float(analytic.transverse_kinematic_ratio(x)) - fraction, 1e-6, 100)
    assert v == pytest.approx(xi * 0.02, rel=0.02)


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
def test_without_vibration_it_holds_below_mu_mg_and_slides_above(law):
    model = _model(law=law, amplitude_m_per_s=0.0)
    data = mujoco.MjData(model)
    _push(model, data, 3000)  # settle on the plate: the load builds up in MuJoCo's contact
    x = _push(model, data, 20000, (0.7 * MU * GRAVITY, 0, 0),
              lambda d: d.body("part").xpos[0].copy())
    # It leans into the push on MuJoCo's soft normal contact (16 um at the centre of mass) and
    # comes to rest there: over the last 0.05 s it moves by under 0.2 um, where sliding at even
    # a tenth of the vibrated creep speed would take 0.7 mm.
    assert abs(x[-1] - x[-5000]) < 2e-7
    # Pushed at 1.5 mu m g it accelerates at (F - mu m g)/m.
    v = _push(model, data, 20000, (1.5 * MU * GRAVITY, 0, 0),
              lambda d: d.qvel[model.jnt_dofadr[model.joint(1).id]].copy())
    time = np.arange(1, len(v) + 1) * model.opt.timestep
    acceleration = np.polyfit(time[5000:], v[5000:], 1)[0]
    assert acceleration == pytest.approx(0.5 * MU * GRAVITY, rel=0.01)


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
def test_a_spinning_disc_decays_at_the_coulomb_torsional_rate(law):
    """Uniform pressure over a disc of radius R: M = (2/3) mu F_N R (torsion_radius = 2R/3), so
    omega falls linearly at M / I_z, I_z = m R^2 / 2. Measured: within 0.001 % (both laws)."""
    radius = 0.05
    model = _model(law=law, amplitude_m_per_s=0.0, part_geom=f'type="cylinder" size="{radius} 0.01"',
                   part_z=0.02, extra=f'<config key="torsion_radius" value="{2 * radius / 3}"/>')
    data = mujoco.MjData(model)
    _push(model, data, 20000)  # settle on the plate (MuJoCo's contact: time constant 0.02 s)
    dof = model.jnt_dofadr[model.joint(1).id]
    data.qvel[dof + 5] = 3.0  # rad/s about z
    spin = _push(model, data, 20000, record=lambda d: d.qvel[dof + 5].copy())
    time = np.arange(1, len(spin) + 1) * model.opt.timestep
    moving = spin > 0.5
    rate = -np.polyfit(time[moving][100:], spin[moving][100:], 1)[0]
    inertia = model.body_inertia[model.body("part").id][2]
    assert inertia == pytest.approx(0.5 * radius**2, rel=1e-6)
    expected = MU * GRAVITY * (2 * radius / 3) / inertia
    assert rate == pytest.approx(expected, rel=0.02)
    # and it stops (held by the torsional deflection), rather than turning back
    assert abs(spin[-1]) < 1e-3


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
def test_lift_off_leaves_no_force_and_no_state_and_set_down_starts_fresh(law):
    model = _model(law=law)
    data = mujoco.MjData(model)
    part = model.body("part").id
    adr = model.plugin_stateadr[0]
    _push(model, data, 5000, (0.5 * MU * GRAVITY, 0, 0))
    assert data.plugin_state[adr + 4] == pytest.approx(GRAVITY, rel=1e-2)  # F_N = m g
    # Lifted: 2 m g upwards. Once airborne, no friction: a side push accelerates it freely.
    _push(model, data, 3000, (0, 0, 2 * GRAVITY))
    assert data.body("part").xpos[2] > 0.061
    assert np.all(data.plugin_state[adr:adr + STATE_SIZE] == 0)
    dof = model.jnt_dofadr[model.joint(1).id]
    before = data.qvel[dof].copy()
    _push(model, data, 100, (1.0, 0, 2 * GRAVITY))
    assert (data.qvel[dof] - before) == pytest.approx(1.0 * 100 * model.opt.timestep, rel=1e-6)
    # Set down again: the load comes back, the deflection starts from zero and stays bounded.
    _push(model, data, 30000, (0, 0, 0))
    assert data.plugin_state[adr + 4] == pytest.approx(GRAVITY, rel=1e-2)
    z = data.plugin_state[adr:adr + 3]
    assert np.linalg.norm(z) <= MU * GRAVITY / 1e9 * 1.001


@pytest.mark.parametrize("law", ["dahl", "coulomb"])
def test_the_state_round_trips_through_mj_get_and_set_state(law):
    model = _model(law=law)
    data = mujoco.MjData(model)
    _push(model, data, 3000, (0.5 * MU * GRAVITY, 0, 0))
    spec = mujoco.mjtState.mjSTATE_INTEGRATION  # with the warm start: bitwise
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    copy = mujoco.MjData(model)
    mujoco.mj_setState(model, copy, state, spec)
    a = _push(model, data, 500, (0.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel.copy())
    b = _push(model, copy, 500, (0.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel.copy())
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("change, message", [
    ({"part_condim": 3}, "condim 3, so MuJoCo adds its own friction"),
    ({"law": "stick"}, "is not a friction law"),
    ({"extra": '<config key="torsion_radius" value="-1"/>'}, "torsion_radius"),
])
def test_bad_configs_are_refused_naming_the_fix(change, message):
    with pytest.raises(ValueError, match=message):
        _model(**change)


def test_a_missing_or_unknown_support_is_refused():
    vibrofriction.load()
    text = _scene()
    with pytest.raises(ValueError, match="names no body"):
        mujoco.MjModel.from_xml_string(text.replace('value="plate"/>', 'value="table"/>'))
    with pytest.raises(ValueError, match="'support' is required"):
        mujoco.MjModel.from_xml_string(
            text.replace('<config key="support" value="plate"/>', ""))


def _planar_scene(stiffness=1e9):
    """The same part and plate with the slide-joint planar element (the part a child of the
    plate, x and y slides, the normal load m g given)."""
    return f"""
<mujoco>
  <option timestep="1e-5" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.planar">
      <instance name="part_friction">
        <config key="law" value="dahl"/>
        <config key="mu" value="{MU}"/>
        <config key="stiffness" value="{stiffness}"/>
        <config key="normal" value="{GRAVITY}"/>
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.motion">
      <instance name="shaker">
        <config key="frequency" value="1000"/>
        <config key="velocity_amplitude" value="0.02"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <body name="plate">
      <joint name="plate_x" type="slide" axis="1 0 0"/>
      <geom type="box" size="1 1 0.01" mass="10" contype="0" conaffinity="0"/>
      <body name="part" pos="0 0 0.06">
        <joint name="part_x" type="slide" axis="1 0 0"/>
        <joint name="part_y" type="slide" axis="0 1 0"/>
        <geom type="box" size="0.05 0.05 0.05" mass="1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <plugin name="shaker" joint="plate_x" instance="shaker"/>
    <plugin joint="part_x" instance="part_friction" actdim="1"/>
    <plugin joint="part_y" instance="part_friction" actdim="1"/>
  </actuator>
</mujoco>"""


def test_the_drop_in_element_equals_the_slide_joint_planar_element():
    """Pushed obliquely at 0.6 mu m g over the vibrating plate: the free part on MuJoCo's
    contacts creeps as the part on slide joints with the planar element (the same law)."""
    vibrofriction.load()
    push = 0.6 * MU * GRAVITY * np.array([math.cos(0.5), math.sin(0.5), 0.0])
    free = _model()
    free_data = mujoco.MjData(free)
    _push(free, free_data, 3000)  # settle
    def on_plate(data):  # the part's position relative to the (vibrating) plate
        return data.body("part").xpos[:2] - [data.qpos[0], 0.0]
    start = on_plate(free_data)
    _push(free, free_data, 30000, push)
    planar = mujoco.MjModel.from_xml_string(_planar_scene())
    planar_data = mujoco.MjData(planar)
    _push(planar, planar_data, 30000, push)
    free_travel = on_plate(free_data) - start
    # the planar part's travel relative to the plate: its slide joints
    planar_travel = planar_data.qpos[1:3]
    np.testing.assert_allclose(free_travel, planar_travel,
                               rtol=0.005, atol=0.005 * np.linalg.norm(planar_travel))


def test_the_bundled_drop_in_scene_steps_without_warnings_and_creeps():
    vibrofriction.load()
    from vibrofriction.robots import scenes
    model = mujoco.MjModel.from_xml_path(str(scenes.scene_path("free_part_on_plate")))
    data = mujoco.MjData(model)
    _push(model, data, 3000)
    start = data.body("part").xpos[0]
    v = _mean_velocity(model, data, 20000, (0.5 * MU * GRAVITY, 0, 0), axis=0)
    assert v == pytest.approx(0.02 * math.sin(math.pi * 0.5 / 2), rel=0.02)
    assert data.body("part").xpos[0] > start
    assert all(w.number == 0 for w in data.warning)


def test_rollout_keeps_the_state_as_stepping_does():
    """mujoco.rollout starts from the full physics state (plugin_state included) and steps as
    mj_step does."""
    from mujoco import rollout as mj_rollout
    model = _model()
    data = mujoco.MjData(model)
    _push(model, data, 2000, (0.5 * MU * GRAVITY, 0, 0))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    start = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, start, spec)
    assert np.any(start != 0)
    data.xfrc_applied[:] = 0
    stepped = np.array([(mujoco.mj_step(model, data), data.qpos.copy())[1] for _ in range(300)])
    state, _ = mj_rollout.rollout(model, mujoco.MjData(model), start, nstep=300)
    qpos = state[0, :, 1:1 + model.nq]
    np.testing.assert_allclose(qpos, stepped, rtol=0, atol=1e-12)


def test_the_contact_sensor_reports_the_force_the_element_applies():
    """vibrofriction.contact_sensor (velocity stage): the force on the part, its spin moment, the
    deflection, F_N and the sliding speed. Held without vibration below mu m g, the friction
    force balances the push."""
    vibrofriction.load()
    text = _scene(amplitude_m_per_s=0.0).replace(
        "</mujoco>", '<sensor><plugin name="part_friction" plugin="vibrofriction.contact_sensor">'
        '<config key="body" value="part"/></plugin></sensor></mujoco>')
    text = text.replace("<extension>", '<extension><plugin plugin="vibrofriction.contact_sensor"/>')
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    _push(model, data, 3000)
    _push(model, data, 10000, (0.5 * MU * GRAVITY, 0, 0))
    sensor = data.sensor("part_friction").data
    assert sensor.shape == (10,)
    # within the lean's decaying rock on MuJoCo's soft normal contact (0.2 % at 0.1 s)
    assert sensor[0] == pytest.approx(-0.5 * MU * GRAVITY, rel=1e-2)
    assert abs(sensor[1]) < 1e-9 and abs(sensor[3]) < 1e-9
    # Dahl without damping: the force is k_t z of the step's start (the sensor runs before
    # advance updates the state)
    np.testing.assert_allclose(-sensor[0:3], 1e9 * sensor[4:7], rtol=1e-9, atol=1e-15)
    assert sensor[8] == pytest.approx(GRAVITY, rel=1e-2)
    assert sensor[9] < 1e-6  # held: no sliding
    with pytest.raises(ValueError,
                       match="has no vibrofriction.contact, contact_averaged or contact_feeder"):
        mujoco.MjModel.from_xml_string(text.replace('value="part"/></plugin></sensor>',
                                                    'value="plate"/></plugin></sensor>'))


# ---- vibrofriction.contact_averaged: the same drop-in at robot timesteps -------------------------

@pytest.fixture(scope="module")
def dahl_table():
    """The averaged law of the resolved scene's contact (Dahl, mu 0.2, 1 N/nm, F_N = m g) under
    its plate's vibration (1 kHz, 20 mm/s along x)."""
    from vibrofriction.robots.averaged import Vibration, build_table
    from vibrofriction.params import FrictionParameters
    friction = FrictionParameters(law="dahl", friction_coefficient=MU,
                                  contact_stiffness_N_per_m=1e9)
    return build_table(friction, Vibration(1000.0, 0.02), GRAVITY)


def _averaged_model(table, timestep, **changes):
    vibrofriction.load()
    config = table.contact_config("plate")
    config.update(changes)
    keys = "\n".join(f'<config key="{k}" value="{v}"/>' for k, v in config.items())
    return mujoco.MjModel.from_xml_string(f"""
<mujoco>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.contact_averaged">
      <instance name="part_friction">{keys}</instance>
    </plugin>
  </extension>
  <worldbody>
    <body name="plate">
      <geom name="plate" type="box" size="1 1 0.01" mass="10" condim="1"/>
    </body>
    <body name="part" pos="0 0 0.06">
      <freejoint/>
      <geom name="part" type="box" size="0.05 0.05 0.05" mass="1" condim="1"/>
      <plugin instance="part_friction"/>
    </body>
  </worldbody>
</mujoco>""")


@pytest.mark.parametrize("timestep", [1e-3, 2e-3])
@pytest.mark.parametrize("fraction, axis", [(0.3, 0), (0.7, 0), (0.5, 1)])
def test_the_averaged_drop_in_at_robot_timesteps_creeps_as_the_resolved_element(
        dahl_table, timestep, fraction, axis):
    """At 1 and 2 ms (the plate does not vibrate: the table holds the vibration) the part creeps
    as the resolved element on the vibrating plate at 10 us, along and across the vibration.
    Measured: within 0.4 %."""
    force = [0.0, 0.0, 0.0]
    force[axis] = fraction * MU * GRAVITY
    averaged = _averaged_model(dahl_table, timestep)
    data = mujoco.MjData(averaged)
    _push(averaged, data, round(0.05 / timestep))  # settle on the plate
    v_averaged = _mean_velocity(averaged, data, round(1.0 / timestep), tuple(force), axis=axis)
    resolved = _model()
    data = mujoco.MjData(resolved)
    v_resolved = _mean_velocity(resolved, data, 40000, tuple(force), axis=axis)
    assert v_averaged == pytest.approx(v_resolved, rel=0.03)


def test_the_averaged_drop_in_without_vibration_holds_and_slides_at_1_ms(dahl_table):
    model = _averaged_model(dahl_table, 1e-3, velocity_amplitude="0")
    data = mujoco.MjData(model)
    _push(model, data, 100)
    x = _push(model, data, 1000, (0.7 * MU * GRAVITY, 0, 0),
              lambda d: d.body("part").xpos[0].copy())
    assert abs(x[-1] - x[-200]) < 1e-9
    dof = model.jnt_dofadr[0]
    v = _push(model, data, 1000, (1.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel[dof].copy())
    acceleration = np.polyfit(np.arange(len(v)) * 1e-3, v, 1)[0]
    assert acceleration == pytest.approx(0.5 * MU * GRAVITY, rel=0.01)


@pytest.mark.parametrize("change, message", [
    ({"axis": "0 0 0"}, "'axis' needs 3 numbers"),
    ({"stribeck_velocity": "0"}, "stribeck_velocity.*must be > 0"),
])
def test_the_averaged_drop_in_refuses_bad_attributes(dahl_table, change, message):
    with pytest.raises(ValueError, match=message):
        _averaged_model(dahl_table, 1e-3, **change)


def test_a_ball_on_one_contact_point_keeps_a_steady_coulomb_force():
    """One contact point: the torsion radius is exactly 0 (not the rounding noise of the
    contact centre, which made a spin axis with no response and dropped the tangential force to
    0 in about half the steps). A ball (anisotropic inertia) on the ground pushed obliquely at its
    centre rolls without slipping: the friction force is steady and never vanishes."""
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_string(f"""
<mujoco>
  <option timestep="1e-4" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.contact">
      <instance name="ball_friction">
        <config key="law" value="coulomb"/> <config key="mu" value="0.5"/>
        <config key="support" value="world"/>
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.contact_sensor"/>
  </extension>
  <worldbody>
    <geom type="plane" size="1 1 0.1" condim="1"/>
    <body name="ball" pos="0 0 0.05">
      <freejoint/>
      <inertial pos="0 0 0" mass="1" fullinertia="0.001 0.002 0.0015 0.0005 0 0"/>
      <geom type="sphere" size="0.05" condim="1"/>
      <plugin instance="ball_friction"/>
    </body>
  </worldbody>
  <sensor>
    <plugin name="friction" plugin="vibrofriction.contact_sensor">
      <config key="body" value="ball"/>
    </plugin>
  </sensor>
</mujoco>""")
    data = mujoco.MjData(model)
    for _ in range(2000):
        mujoco.mj_step(model, data)
    forces = []
    for _ in range(3000):
        data.xfrc_applied[1, :3] = [0.5, 0.3, 0.0]
        mujoco.mj_step(model, data)
        forces.append(data.sensor("friction").data[:2].copy())
    forces = np.array(forces)[1000:]
    assert data.plugin_state[model.plugin_stateadr[0] + 11] == 0  # rho: a point
    magnitude = np.linalg.norm(forces, axis=1)
    assert magnitude.min() > 0.5 * magnitude.mean() > 0
    assert forces[:, 0].std() < 0.02 * magnitude.mean()


def test_the_support_can_be_the_world():
    """support="world": the part on the ground (a geom of the world body) holds and slides."""
    vibrofriction.load()
    text = _scene(law="coulomb", amplitude_m_per_s=0.0).replace(
        'value="plate"/>', 'value="world"/>').replace(
        '<body name="plate">', '<geom name="ground" type="plane" size="2 2 0.1" condim="1"/>'
        '<body name="plate" pos="5 0 0">')
    model = mujoco.MjModel.from_xml_string(text.replace('pos="0 0 0.06"', 'pos="0 0 0.05"'))
    data = mujoco.MjData(model)
    _push(model, data, 3000)
    x = _push(model, data, 20000, (0.7 * MU * GRAVITY, 0, 0),
              lambda d: d.body("part").xpos[0].copy())
    assert abs(x[-1] - x[-5000]) < 2e-7  # leaned into the push on the soft normal contact
    dof = model.jnt_dofadr[model.joint(1).id]
    v = _push(model, data, 5000, (1.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel[dof].copy())
    acceleration = np.polyfit(np.arange(len(v)) * model.opt.timestep, v, 1)[0]
    assert acceleration == pytest.approx(0.5 * MU * GRAVITY, rel=0.01)


@pytest.mark.parametrize("element", ["contact", "contact_averaged"])
def test_a_part_on_an_oblique_slide_joint_holds_below_mu_mg(element, dahl_table):
    """A part that moves along one combination of the tangent directions only (a slide joint at
    45 degrees): the response is singular and coupled, and the stick force its pseudo-inverse.
    Pushed along the joint at half its friction level it holds; the friction balances the push.
    (A per-axis stick force was twice too large and the part crept backwards.)"""
    vibrofriction.load()
    if element == "contact":
        keys = ('<config key="law" value="coulomb"/><config key="mu" value="0.2"/>'
                '<config key="support" value="world"/>')
    else:
        config = dahl_table.contact_config("world")
        config["velocity_amplitude"] = "0"
        keys = "".join(f'<config key="{k}" value="{v}"/>' for k, v in config.items())
    model = mujoco.MjModel.from_xml_string(f"""
<mujoco>
  <option timestep="1e-3" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.{element}"><instance name="pf">{keys}</instance></plugin>
    <plugin plugin="vibrofriction.contact_sensor"/>
  </extension>
  <worldbody>
    <geom type="plane" size="2 2 0.1" condim="1"/>
    <body name="part" pos="0 0 0.05">
      <joint type="slide" axis="0 0 1"/>
      <joint name="along" type="slide" axis="1 1 0"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1" condim="1"/>
      <plugin instance="pf"/>
    </body>
  </worldbody>
  <sensor>
    <plugin name="friction" plugin="vibrofriction.contact_sensor">
      <config key="body" value="part"/>
    </plugin>
  </sensor>
</mujoco>""")
    data = mujoco.MjData(model)
    _push(model, data, 300)
    direction = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    push = 0.5 * MU * GRAVITY
    start = data.qpos[1]
    _push(model, data, 400, tuple(push * direction))
    assert abs(data.qpos[1] - start) < 1e-5  # the first step's settling, then at rest
    assert data.sensor("friction").data[:3] @ direction == pytest.approx(-push, rel=1e-6)
    assert abs(data.qvel[1]) < 1e-12


def test_the_averaged_drop_in_reads_the_table_at_the_in_plane_amplitude(dahl_table):
    """A vibration at 45 degrees to the plate (axis "1 0 1") dithers the contact at v_a/sqrt 2:
    the part creeps at (v_a/sqrt 2) sin(pi f/2), the heavy-body value at that amplitude."""
    model = _averaged_model(dahl_table, 1e-3, axis="1 0 1")
    data = mujoco.MjData(model)
    _push(model, data, 50)
    v = _mean_velocity(model, data, 1000, (0.5 * MU * GRAVITY, 0, 0), axis=0)
    assert v == pytest.approx(0.02 / math.sqrt(2) * math.sin(math.pi / 4), rel=0.03)


def test_the_averaged_drop_in_round_trips_its_state(dahl_table):
    model = _averaged_model(dahl_table, 1e-3)
    data = mujoco.MjData(model)
    _push(model, data, 300, (0.5 * MU * GRAVITY, 0, 0))
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    copy = mujoco.MjData(model)
    mujoco.mj_setState(model, copy, state, spec)
    a = _push(model, data, 100, (0.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel.copy())
    b = _push(model, copy, 100, (0.5 * MU * GRAVITY, 0, 0), lambda d: d.qvel.copy())
    np.testing.assert_array_equal(a, b)


def test_contact_config_takes_the_tables_vibration_axis():
    from vibrofriction.robots.averaged import Vibration, build_table
    from vibrofriction.params import FrictionParameters
    table = build_table(FrictionParameters(law="coulomb", friction_coefficient=MU),
                        Vibration(1000.0, 0.02, axis_angle_rad=math.pi / 2), GRAVITY,
                        xi=[0.0, 0.5, 1.0, 2.0], angle_rad=[0.0, math.pi / 2, math.pi])
    axis = [float(a) for a in table.contact_config("plate")["axis"].split()]
    np.testing.assert_allclose(axis, [0.0, 1.0, 0.0], atol=1e-15)
    assert table.contact_config("plate", axis=(1, 0, 0))["axis"] == "1.0 0.0 0.0"


def test_one_data_stepped_with_another_model_uses_that_models_bodies() -> None:
    """One MjData may be stepped with models of equal sizes whose trees differ (a rollout over
    several models does so): the element
    re-reads its config (its body, support and chain ids) for each model, even when the config
    text is the same. Model 2 lists the part before the plate, so their ids and dofs swap; a
    part sliding obliquely with mu 0.5 must stop where it does with its own data."""
    head = """<mujoco><option timestep="1e-3" integrator="implicitfast"/>
<extension><plugin plugin="vibrofriction.contact"><instance name="pf">
<config key="support" value="plate"/><config key="law" value="coulomb"/><config key="mu" value="0.5"/>
</instance></plugin></extension><worldbody>"""
    part = ('<body name="part" pos="0 0 0.0199"><freejoint name="part"/><geom type="box" '
            'size="0.02 0.02 0.01" mass="0.1" condim="1"/><plugin instance="pf"/></body>')
    plate = ('<body name="plate"><joint name="plate" type="slide" axis="1 0 0"/><geom '
             'type="box" size="0.3 0.3 0.01" mass="5" condim="1"/></body>')
    vibrofriction.load()
    models = [mujoco.MjModel.from_xml_string(head + a + b + "</worldbody></mujoco>")
              for a, b in ((plate, part), (part, plate))]
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS

    def start(m):
        d = mujoco.MjData(m)
        dof = m.joint("part").dofadr[0]
        d.qvel[dof:dof + 2] = 0.2, 0.1  # the part slides obliquely
        state = np.empty(mujoco.mj_stateSize(m, kind))
        mujoco.mj_getState(m, d, state, kind)
        return state

    def run(m, data):
        mujoco.mj_setState(m, data, start(m), kind)
        mujoco.mj_step(m, data, nstep=200)
        adr = m.joint("part").qposadr[0]
        return data.qpos[adr:adr + 2].copy()
    shared = mujoco.MjData(models[0])
    for m in models:
        alone = run(m, mujoco.MjData(m))
        assert alone[0] < 0.2 * 0.2 / 2  # friction stopped it (frictionless: 40 mm)
        np.testing.assert_allclose(run(m, shared), alone, rtol=0, atol=1e-12)


@pytest.mark.parametrize("layout,fix", [
    ('<body name="plate"><geom name="plate" type="box" size="1 1 0.01" condim="1"/>'
     '<body name="part" pos="0 0 0.06"><geom name="part" type="box" size="0.05 0.05 0.05" '
     'mass="1" condim="1"/><plugin instance="part_friction"/></body></body>', "welded together"),
    ('<body name="plate"><joint type="slide" axis="1 0 0"/><geom name="plate" type="box" '
     'size="1 1 0.01" mass="10" condim="1"/><body name="part" pos="0 0 0.06"><joint '
     'type="slide" axis="0 1 0"/><geom name="part" type="box" size="0.05 0.05 0.05" mass="1" '
     'condim="1"/><plugin instance="part_friction"/></body></body>', "filterparent"),
])
def test_a_part_that_mujoco_never_collides_with_its_support_is_refused(layout, fix) -> None:
    """MuJoCo's body-pair filter: one weld group, or parent and child with filterparent on."""
    vibrofriction.load()
    xml = f"""<mujoco><extension><plugin plugin="vibrofriction.contact">
<instance name="part_friction"><config key="law" value="coulomb"/>
<config key="support" value="plate"/></instance></plugin></extension>
<worldbody>{layout}</worldbody></mujoco>"""
    with pytest.raises(ValueError, match=fix):
        mujoco.MjModel.from_xml_string(xml)
    # with filterparent off the parent-child layout compiles
    if fix == "filterparent":
        mujoco.MjModel.from_xml_string(xml.replace(
            "<mujoco>", '<mujoco><option><flag filterparent="disable"/></option>'))
