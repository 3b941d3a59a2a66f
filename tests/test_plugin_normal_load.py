"""Normal load of vibrofriction.friction: config, sensor, or the contact force between geoms."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

import vibrofriction

BLOCK_KG = 2.0
GRAVITY = 9.81

SCENE = """
<mujoco>
  <option timestep="1e-4" integrator="Euler"/>
  <extension>
    <plugin plugin="vibrofriction.friction">
      <instance name="contact">
        <config key="law" value="dahl"/>
        <config key="mu" value="0.3"/>
        <config key="stiffness" value="1e6"/>
        {normal}
        <config key="ripple" value="0.5"/>
        <config key="ripple_wavelength" value="1e-3"/>
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.friction_sensor"/>
  </extension>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="block" pos="0 0 0.05">
      <joint name="slide_x" type="slide" axis="1 0 0"/>
      <joint name="lift_z" type="slide" axis="0 0 1"/>
      <geom name="block" type="box" size="0.05 0.05 0.05" mass="{mass}" friction="0 0 0"
            condim="1"/>
    </body>
  </worldbody>
  <actuator>
    <plugin name="contact" joint="slide_x" instance="contact" actdim="1"/>
    <motor name="lift" joint="lift_z"/>
  </actuator>
  <sensor>
    <plugin name="contact_state" plugin="vibrofriction.friction_sensor">
      <config key="actuator" value="contact"/>
    </plugin>
    <actuatorfrc name="lift_force" actuator="lift"/>
  </sensor>
</mujoco>
"""


def _model(normal: str) -> mujoco.MjModel:
    vibrofriction.load()
    return mujoco.MjModel.from_xml_string(SCENE.format(normal=normal, mass=BLOCK_KG))


def _settle(model: mujoco.MjModel, steps: int = 3000, lift_N: float = 0.0) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("lift").id] = lift_N
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return data


def test_constant_normal_force_is_reported_without_effect_factors():
    # ripple multiplies the friction level, not the normal force the sensor reports
    data = _settle(_model('<config key="normal" value="55.2"/>'), steps=10)
    assert data.sensor("contact_state").data[3] == pytest.approx(55.2, rel=1e-12)


def test_normal_force_from_a_sensor_with_gain():
    # F_N = normal + gain * sensor: a 10 N upward lift read through its force sensor
    model = _model('<config key="normal" value="30"/><config key="normal_sensor" '
                   'value="lift_force"/><config key="normal_gain" value="-1"/>')
    data = _settle(model, steps=10, lift_N=10.0)
    assert data.sensor("contact_state").data[3] == pytest.approx(20.0, rel=1e-9)


def test_normal_force_from_the_contact_between_two_geoms():
    # the block rests on the floor: the contact carries m g (previous step's value)
    model = _model('<config key="contact_geom1" value="block"/>'
                   '<config key="contact_geom2" value="floor"/>')
    data = _settle(model)
    normal = data.sensor("contact_state").data[3]
    assert normal == pytest.approx(BLOCK_KG * GRAVITY, rel=0.02)
    # lifting with half the weight halves the contact force
    data = _settle(model, lift_N=0.5 * BLOCK_KG * GRAVITY)
    assert data.sensor("contact_state").data[3] == pytest.approx(0.5 * BLOCK_KG * GRAVITY, rel=0.02)
    assert np.isfinite(data.qpos).all()


def test_normal_force_from_the_elements_own_ctrl_with_another_actuator_first():
    # the element reads ctrl[its actuator id], not of its plugin instance or of actuator 0
    scene = SCENE.replace('<plugin name="contact" joint="slide_x" instance="contact" '
                          'actdim="1"/>\n    <motor name="lift" joint="lift_z"/>',
                          '<motor name="lift" joint="lift_z" ctrlrange="-50 50"/>\n    '
                          '<plugin name="contact" joint="slide_x" instance="contact" '
                          'actdim="1" ctrlrange="0 30"/>')
    assert scene != SCENE
    model = mujoco.MjModel.from_xml_string(scene.format(
        normal='<config key="normal_from_ctrl" value="true"/>', mass=BLOCK_KG))
    data = mujoco.MjData(model)
    assert model.actuator("contact").id == 1
    data.ctrl[:] = [7.0, 12.0]
    mujoco.mj_step(model, data)
    assert data.sensor("contact_state").data[3] == pytest.approx(12.0, rel=1e-12)
    data.ctrl[1] = 100.0  # past its ctrlrange: held at 30, as MuJoCo holds a ctrl
    mujoco.mj_step(model, data)
    assert data.sensor("contact_state").data[3] == pytest.approx(30.0, rel=1e-12)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL  # MuJoCo clamps no ctrl
    mujoco.mj_step(model, data)
    assert data.sensor("contact_state").data[3] == pytest.approx(100.0, rel=1e-12)


def test_normal_force_from_ctrl_after_an_actuator_of_several_controls():
    # an orientation servo (4 controls, a quaternion) first: the element's ctrl is at its
    # actuator's ctrladr (4), not at its actuator id (1)
    scene = SCENE.format(normal='<config key="normal_from_ctrl" value="true"/>',
                         mass=BLOCK_KG).replace(
        '<worldbody>', '<worldbody><body name="wrist" pos="1 0 1"><joint name="ball" '
        'type="ball"/><geom size=".05" contype="0" conaffinity="0"/></body>').replace(
        '<actuator>', '<actuator><general name="servo" joint="ball" gaintype="so3" '
        'input="quat" biastype="so3" biasprm="0 -1 -1"/>')
    vibrofriction.load()
    try:
        model = mujoco.MjModel.from_xml_string(scene)
    except ValueError as error:
        if "gaintype" in str(error) or "input" in str(error):
            pytest.skip(f"this MuJoCo has no actuator with several controls ({error})")
        raise
    element = model.actuator("contact").id
    assert model.actuator_ctrladr[element] != element  # the case this test is about
    data = mujoco.MjData(model)
    data.ctrl[:] = 99.0
    data.ctrl[model.actuator_ctrladr[element]] = 12.0
    mujoco.mj_step(model, data)
    assert data.sensor("contact_state").data[3] == pytest.approx(12.0, rel=1e-12)


def test_normal_force_from_the_elements_own_ctrl_this_step():
    # F_N = normal + gain * ctrl[the element's actuator], read in the same step (no sensor
    # stage between): a measured load replayed step by step
    model = _model('<config key="normal" value="5"/><config key="normal_gain" value="2"/>'
                   '<config key="normal_from_ctrl" value="true"/>')
    data = mujoco.MjData(model)
    for load in (10.0, 25.0, 0.0):
        data.ctrl[model.actuator("contact").id] = load
        mujoco.mj_step(model, data)
        assert data.sensor("contact_state").data[3] == pytest.approx(5 + 2 * load, rel=1e-12)


@pytest.mark.parametrize("normal, attribute", [
    ('<config key="normal_from_ctrl" value="true"/><config key="normal_sensor" '
     'value="lift_force"/>', "'normal_from_ctrl' and 'normal_sensor' are both set"),
    ('<config key="normal_from_ctrl" value="yes"/>', "normal_from_ctrl"),
    ('<config key="normal_sensor" value="no_such_sensor"/>', "normal_sensor"),
    ('<config key="contact_geom1" value="block"/>', "contact_geom"),
    ('<config key="contact_geom1" value="block"/><config key="contact_geom2" value="nowhere"/>',
     "contact_geom2"),
    ('<config key="normal_sensor" value="lift_force"/><config key="contact_geom1" value="block"/>'
     '<config key="contact_geom2" value="floor"/>', "normal_sensor"),
])
def test_bad_normal_load_sources_are_named(normal, attribute):
    with pytest.raises(ValueError, match=attribute):
        _model(normal)


@pytest.mark.parametrize("actuator, message", [
    ("", "attribute 'actuator' is missing"),
    ("no_such_actuator", "names no actuator"),
    ("lift", "is not backed by vibrofriction.friction"),
])
def test_state_sensor_names_a_friction_element_actuator(actuator, message):
    vibrofriction.load()
    xml = SCENE.format(normal='<config key="normal" value="10"/>', mass=BLOCK_KG)
    xml = xml.replace('<config key="actuator" value="contact"/>',
                      f'<config key="actuator" value="{actuator}"/>' if actuator else "")
    with pytest.raises(ValueError, match=message):
        mujoco.MjModel.from_xml_string(xml)


def test_an_element_without_its_sensor_adds_no_acceleration_stage_work():
    # MuJoCo runs mj_rnePostConstraint for every plugin with an acceleration-stage sensor
    # capability; the element has none, so without its sensor nothing forces it.
    vibrofriction.load()
    spec = mujoco.MjSpec.from_string(SCENE.format(normal='<config key="normal" value="10"/>',
                                                  mass=BLOCK_KG))
    spec.delete(spec.sensor("contact_state"))
    spec.delete(spec.sensor("lift_force"))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.flg_rnepost == 0
    with_sensor = _model('<config key="normal" value="10"/>')
    data = mujoco.MjData(with_sensor)
    mujoco.mj_forward(with_sensor, data)
    assert data.flg_rnepost == 1  # the state sensor is an acceleration-stage plugin sensor


# ---- lift-off: a negative load is clamped (the contact opens), and the sensors show it -------

def test_a_load_pulled_below_zero_is_reported_and_carries_no_friction():
    # F_N = 30 - 50 N: the lift exceeds the load; the law uses 0, the sensor shows -20 N
    model = _model('<config key="normal" value="30"/><config key="normal_sensor" '
                   'value="lift_force"/><config key="normal_gain" value="-1"/>')
    data = _settle(model, steps=10, lift_N=50.0)
    state = data.sensor("contact_state").data
    assert state[3] == pytest.approx(-20.0, rel=1e-9)
    assert state[0] == 0.0 and state[1] == 0.0  # no friction force, no deflection


PLANAR_SCENE = """
<mujoco>
  <option timestep="1e-4"/>
  <extension>
    <plugin plugin="{element}">
      <instance name="contact">
        {law}<config key="mu" value="0.3"/><config key="normal" value="30"/>
        <config key="normal_sensor" value="lift_force"/><config key="normal_gain" value="-1"/>
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.planar_sensor"/>
  </extension>
  <worldbody>
    <body name="block">
      <joint name="x" type="slide" axis="1 0 0"/><joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom type="box" size="0.05 0.05 0.05" mass="2"/>
    </body>
  </worldbody>
  <actuator>
    <plugin name="cx" joint="x" instance="contact" {actdim}/>
    <plugin name="cy" joint="y" instance="contact" {actdim}/>
    <motor name="lift" joint="z"/>
    <motor name="push" joint="x"/>
  </actuator>
  <sensor>
    <plugin name="state" plugin="vibrofriction.planar_sensor">
      <config key="actuator" value="cx"/>
    </plugin>
    <actuatorfrc name="lift_force" actuator="lift"/>
  </sensor>
</mujoco>"""


@pytest.mark.parametrize("element", ["vibrofriction.planar", "vibrofriction.averaged"])
def test_planar_sensors_report_the_unclamped_load(element):
    vibrofriction.load()
    planar = element == "vibrofriction.planar"
    model = mujoco.MjModel.from_xml_string(PLANAR_SCENE.format(
        element=element, law='<config key="law" value="coulomb"/>' if planar else "",
        actdim='actdim="1"' if planar else ""))
    for lift, load in ((10.0, 20.0), (50.0, -20.0)):
        data = mujoco.MjData(model)
        data.ctrl[model.actuator("lift").id] = lift
        data.ctrl[model.actuator("push").id] = 1.0
        for _ in range(10):
            mujoco.mj_step(model, data)
        state = data.sensor("state").data
        assert state[6] == pytest.approx(load, rel=1e-9)
        if load < 0:  # lifted off: no friction, the push accelerates the block freely
            assert state[0] == 0.0 and state[1] == 0.0
            assert data.qacc[model.joint("x").dofadr[0]] == pytest.approx(0.5, rel=1e-9)
        else:  # held: 1 N push below mu F_N = 6 N
            assert state[0] == pytest.approx(1.0, rel=1e-9)


def test_a_contact_load_that_is_never_positive_is_refused():
    # the contact force is >= 0: with normal = 0 a negative gain gives F_N <= 0 at every step
    contact = ('<config key="contact_geom1" value="block"/>'
               '<config key="contact_geom2" value="floor"/><config key="normal_gain" value="-1"/>')
    with pytest.raises(ValueError, match=r"attribute 'normal_gain'=\"-1\" with normal=\"0\""):
        _model(contact)
    _model(contact + '<config key="normal" value="50"/>')  # 50 N less the contact: can be > 0
