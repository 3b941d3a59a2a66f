"""Misuse of the plugins is one clear compile error: the message names the element (its plugin
instance, actuators and sensors) and the attribute or option, says how to fix it, and appears
once; integrator="RK4" is refused (Euler, implicit and implicitfast take the step the plugins
assume); value="" is MuJoCo's absent key."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from vibrofriction import sim
import vibrofriction
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import RigParameters, default_friction


def _rig_spec(law: str = "dahl") -> mujoco.MjSpec:
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    return rig_module.build_spec(rig, default_friction(law, rig), 1e-5)


def _error(compile_) -> str:
    with pytest.raises(ValueError) as info:
        compile_()
    return str(info.value)


# ---- one message, naming the element ---------------------------------------------------------

def test_an_invalid_attribute_is_one_message_naming_the_element():
    spec = _rig_spec()
    sim.set_plugin_config(spec, "friction", {**dict(next(
        p for p in spec.plugins if p.name == "friction").config), "mu": "-0.1"})
    for message in (_error(spec.compile), _error(lambda: mujoco.MjModel.from_xml_string(
            spec.to_xml()))):
        # MuJoCo's "plugin->init failed" line and the warning repeated twice are gone
        assert "plugin->init failed" not in message
        assert message.count("attribute 'mu'") == 1
        assert len(message.splitlines()) == 1
        assert ("vibrofriction.friction (instance 'friction', actuator 'friction'): "
                "attribute 'mu'=\"-0.1\" must be >= 0") in message


INLINE = """
<mujoco>
  <extension>
    <plugin plugin="vibrofriction.friction"/>
    <plugin plugin="vibrofriction.friction_sensor"/>
  </extension>
  <worldbody>
    <body><joint name="j" type="slide" axis="1 0 0"/><geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator>
    <plugin name="slip" plugin="vibrofriction.friction" joint="j" actdim="1">
      <config key="law" value="dahl"/><config key="normal" value="{normal}"/>
    </plugin>
  </actuator>
  <sensor>
    <plugin name="slip_state" plugin="vibrofriction.friction_sensor">
      <config key="actuator" value="{actuator}"/>
    </plugin>
  </sensor>
</mujoco>"""


def test_an_inline_element_is_named_by_its_actuator_or_sensor():
    vibrofriction.load()
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        INLINE.format(normal="1e10", actuator="slip")))
    assert "vibrofriction.friction (actuator 'slip'): attribute 'normal'=\"1e10\"" in message
    assert "within +-1e+09" in message and len(message.splitlines()) == 1
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        INLINE.format(normal="10", actuator="nothing")))
    assert ("vibrofriction.friction_sensor (sensor 'slip_state'): attribute 'actuator'="
            "\"nothing\" names no actuator") in message
    assert len(message.splitlines()) == 1
    mujoco.MjModel.from_xml_string(INLINE.format(normal="10", actuator="slip"))


def test_a_structural_error_names_the_element():
    """A transmission is only known once the model is complete (plugin init): the message names
    the element too. MuJoCo prefixes "plugin->init failed" and repeats a plugin's warning there
    (its compiler appends the warnings to the error twice); see plugin/cpp/README.md."""
    spec = _rig_spec()
    spec.actuator("friction").actdim = 2
    message = _error(spec.compile)
    assert ("vibrofriction.friction (instance 'friction', actuator 'friction'): "
            'actdim="2"; the element keeps one deflection z: write actdim="1"') in message


def test_failed_compiles_do_not_leak():
    """The attribute check raises its error before MuJoCo makes any mjData (an mju_error from
    init would leak the mjData being made, ~13 MB of address space a failure)."""
    spec = _rig_spec()
    config = dict(next(p for p in spec.plugins if p.name == "friction").config)
    sim.set_plugin_config(spec, "friction", {**config, "mu": "-1"})

    def vm_size_kb() -> int:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmSize"))

    for _ in range(20):  # warm up the allocator
        _error(spec.compile)
    before = vm_size_kb()
    for _ in range(200):
        _error(spec.compile)
    assert vm_size_kb() - before < 50_000  # the leaking way: 200 x 13 MB


# ---- integrators -----------------------------------------------------------------------------

def _single_element_scene(element: str, integrator: str, law: str = "coulomb") -> str:
    """A body on slide joints with one plugin element (and nothing else that could refuse)."""
    planar = element in ("vibrofriction.planar", "vibrofriction.averaged")
    config = {
        "vibrofriction.friction": f'<config key="law" value="{law}"/>',
        "vibrofriction.planar": f'<config key="law" value="{law}"/>',
        "vibrofriction.averaged": "",
        "vibrofriction.motion": '<config key="velocity" value="0.01"/>',
    }[element]
    if element != "vibrofriction.motion":
        config += '<config key="mu" value="0.5"/><config key="normal" value="10"/>'
    actdim = "" if element in ("vibrofriction.motion", "vibrofriction.averaged") else 'actdim="1"'
    actuators = (f'<plugin name="x" joint="x" instance="e" {actdim}/>'
                 + (f'<plugin name="y" joint="y" instance="e" {actdim}/>' if planar else ""))
    return f"""
<mujoco>
  <option timestep="1e-4" integrator="{integrator}"/>
  <extension><plugin plugin="{element}"><instance name="e">{config}</instance></plugin></extension>
  <worldbody>
    <body><joint name="x" type="slide" axis="1 0 0"/><joint name="y" type="slide" axis="0 1 0"/>
      <geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator>{actuators}<motor name="push" joint="x"/></actuator>
</mujoco>"""


ELEMENTS = ["vibrofriction.friction", "vibrofriction.planar", "vibrofriction.averaged",
            "vibrofriction.motion"]


@pytest.mark.parametrize("element", ELEMENTS)
def test_rk4_is_refused_naming_the_option_and_the_fix(element):
    vibrofriction.load()
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        _single_element_scene(element, "RK4")))
    assert f"{element} (instance 'e', actuator 'x'" in message
    assert 'integrator="RK4" is not supported' in message
    assert '<option integrator="Euler"/>' in message
    assert len(message.splitlines()) == 1
    for integrator in ("Euler", "implicit", "implicitfast"):
        model = mujoco.MjModel.from_xml_string(_single_element_scene(element, integrator))
        data = mujoco.MjData(model)
        data.ctrl[model.actuator("push").id] = 20.0
        for _ in range(100):
            mujoco.mj_step(model, data)
        assert np.all(np.isfinite(data.qvel))


@pytest.mark.parametrize("law", ["coulomb", "dahl"])
def test_implicit_integrators_take_the_euler_step_without_damping(law):
    """Evidence that implicit and implicitfast are correct: they integrate the velocity by the
    semi-implicit Euler step the stick solve and the deflection update assume, treating only
    velocity-dependent forces (damping) implicitly. Without damping the rig steps bitwise as
    with Euler under implicitfast, and within rounding under implicit (its LU factorization of
    M - dt D, D = 0, rounds differently from M's)."""
    runs = {}
    for integrator in ("Euler", "implicit", "implicitfast"):
        spec = _rig_spec(law)
        spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
        model = spec.compile()
        data = mujoco.MjData(model)
        rows = []
        for _ in range(3000):
            mujoco.mj_step(model, data)
            rows.append(np.concatenate([data.qpos, data.qvel, data.act, data.sensordata]))
        runs[integrator] = np.array(rows)
    assert np.array_equal(runs["implicitfast"], runs["Euler"])
    assert np.allclose(runs["implicit"], runs["Euler"], rtol=1e-9, atol=1e-15)


DAMPED = """
<mujoco>
  <option timestep="1e-4" integrator="{integrator}"/>
  <extension>
    <plugin plugin="vibrofriction.motion"><instance name="drive">
      <config key="velocity" value="0.01"/></instance></plugin>
    <plugin plugin="vibrofriction.friction"><instance name="stick">
      <config key="law" value="coulomb"/><config key="mu" value="1"/>
      <config key="normal" value="100"/></instance></plugin>
  </extension>
  <worldbody>
    <body><joint name="block" type="slide" axis="1 0 0" damping="30"/>
      <geom size="0.1" mass="1"/></body>
    <body pos="0 1 0"><joint name="end" type="slide" axis="1 0 0"/><geom size="0.1" mass="1"/>
    </body>
  </worldbody>
  <tendon><fixed name="damper" damping="1000" stiffness="1000">
    <joint joint="end" coef="1"/><joint joint="block" coef="-1"/></fixed></tendon>
  <actuator><plugin name="drive" joint="end" instance="drive"/>
    <plugin name="stick" joint="block" instance="stick" actdim="1"/></actuator>
</mujoco>"""


@pytest.mark.parametrize("integrator", ["Euler", "implicit", "implicitfast"])
def test_coulomb_stick_stays_exact_with_damping_under_each_accepted_integrator(integrator):
    """A block held by Coulomb friction (100 N) against a spring-damper tendon (15 N) to a
    driven end, the block's joint damped too: the implicit integrators treat the damping
    implicitly and the stick solve still stops the block exactly."""
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_string(DAMPED.format(integrator=integrator))
    data = mujoco.MjData(model)
    block = model.joint("block").dofadr[0]
    largest = 0.0
    for _ in range(5000):
        mujoco.mj_step(model, data)
        largest = max(largest, abs(data.qvel[block]))
    assert largest < 1e-15
    assert abs(data.actuator_force[model.actuator("stick").id]) == pytest.approx(15.0, rel=1e-3)


# ---- value="" ---------------------------------------------------------------------------------

def test_an_empty_value_is_stored_as_an_absent_key():
    """MuJoCo stores value="" exactly as a key that is not given (an empty string in
    plugin_attr, via MJCF and via MjSpec): the plugin cannot tell them apart, so value=""
    reads as the default (plugin/cpp/README.md)."""
    base = _rig_spec()
    friction = dict(next(p for p in base.plugins if p.name == "friction").config)
    absent = {k: v for k, v in friction.items() if k != "stiffness"}
    attrs = []
    for config in (absent, {**absent, "stiffness": ""}):
        spec = _rig_spec()
        sim.set_plugin_config(spec, "friction", config)
        via_spec = spec.compile()
        via_xml = mujoco.MjModel.from_xml_string(spec.to_xml())
        attrs += [bytes(m.plugin_attr) for m in (via_spec, via_xml)]
    assert len(set(attrs)) == 1


# ---- structural misuse of the normal load and the planar element's state (issue 35) ------------

PLANAR_ACTDIM = """
<mujoco>
  <extension><plugin plugin="vibrofriction.planar"><instance name="e">
    <config key="law" value="{law}"/><config key="mu" value="0.5"/><config key="normal" value="10"/>
  </instance></plugin></extension>
  <worldbody>
    <body><joint name="x" type="slide" axis="1 0 0"/><joint name="y" type="slide" axis="0 1 0"/>
      <geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator><plugin name="x" joint="x" instance="e" actdim="{actdim}"/>
    <plugin name="y" joint="y" instance="e" actdim="{actdim}"/></actuator>
</mujoco>"""


@pytest.mark.parametrize("law, keeps", [("dahl", "one deflection per axis, (z_x, z_y) in act"),
                                        ("coulomb", "one (unused) state per axis")])
def test_the_planar_element_refuses_two_states_for_a_one_state_law(law, keeps):
    """As the 1D element: actdim="2" on both actuators of a one-state law is refused, naming
    the actuator, its actdim and the fix (it compiled before, with act[1] never used). Checked
    in init, where MuJoCo repeats the message (plugin/cpp/README.md, Errors)."""
    vibrofriction.load()
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        PLANAR_ACTDIM.format(law=law, actdim=2)))
    assert (f"vibrofriction.planar (instance 'e', actuator 'x', actuator 'y'): the x actuator "
            f'has actdim="2"; law {law} keeps {keeps}: write actdim="1" on both actuators'
            ) in message
    mujoco.MjModel.from_xml_string(PLANAR_ACTDIM.format(law=law, actdim=1))


TOUCH_LOAD = """
<mujoco>
  <extension><plugin plugin="vibrofriction.{element}"><instance name="e">
    {law}<config key="mu" value="0.5"/><config key="normal" value="{normal}"/>
    <config key="normal_sensor" value="touch"/><config key="normal_gain" value="{gain}"/>
  </instance></plugin></extension>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.1"><joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/><joint name="z" type="slide" axis="0 0 1"/>
      <geom size="0.1" mass="1" condim="1"/><site name="pad" size="0.11"/></body>
  </worldbody>
  <actuator><plugin name="x" joint="x" instance="e" {actdim}/>{second}</actuator>
  <sensor><touch name="touch" site="pad"/></sensor>
</mujoco>"""


@pytest.mark.parametrize("element", ["friction", "planar", "averaged"])
def test_a_negative_gain_on_a_sensor_that_never_reads_below_zero_is_refused(element):
    """A touch sensor reads >= 0: with normal="0" a negative gain makes F_N <= 0 at every step
    (a contact that never carries friction), as the contact geoms' rule. With a constant
    normal the same gain is a load the sensor's reading lowers: accepted."""
    vibrofriction.load()
    planar = element != "friction"
    fields = dict(element=element, law="" if element == "averaged"
                  else '<config key="law" value="dahl"/>',
                  actdim="" if element == "averaged" else 'actdim="1"',
                  second=('<plugin name="y" joint="y" instance="e" '
                          + ("" if element == "averaged" else 'actdim="1"') + "/>")
                  if planar else "")
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        TOUCH_LOAD.format(normal=0, gain=-1, **fields)))
    assert ("attribute 'normal_gain'=\"-1\" with normal=\"0\" makes the load negative at every "
            "step: normal_sensor 'touch' is a touch sensor, never below 0; the gain must be > 0"
            ) in message
    assert f"vibrofriction.{element} (instance 'e'" in message
    mujoco.MjModel.from_xml_string(TOUCH_LOAD.format(normal=0, gain=1, **fields))
    mujoco.MjModel.from_xml_string(TOUCH_LOAD.format(normal=20, gain=-1, **fields))


CTRL_LOAD = """
<mujoco>
  <extension><plugin plugin="vibrofriction.friction"><instance name="e">
    <config key="law" value="coulomb"/><config key="normal" value="{normal}"/>
    <config key="normal_gain" value="{gain}"/><config key="normal_from_ctrl" value="true"/>
  </instance></plugin></extension>
  <worldbody><body><joint name="x" type="slide" axis="1 0 0"/><geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator><plugin name="x" joint="x" instance="e" actdim="1" ctrlrange="{range}"/></actuator>
</mujoco>"""


def test_a_load_from_ctrl_that_its_ctrlrange_keeps_at_or_below_zero_is_refused():
    vibrofriction.load()
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        CTRL_LOAD.format(normal=0, gain=-1, range="0 10")))
    assert ("attribute 'normal_gain'=\"-1\" with normal=\"0\" and the actuator's ctrlrange "
            "[0, 10] makes the load 0 N at most, <= 0 at every step") in message
    message = _error(lambda: mujoco.MjModel.from_xml_string(
        CTRL_LOAD.format(normal=5, gain=2, range="-10 -3")))
    assert "makes the load -1 N at most" in message
    for normal, gain, range_ in ((0, 1, "0 10"), (5, -1, "0 10"), (0, -1, "-10 0")):
        mujoco.MjModel.from_xml_string(CTRL_LOAD.format(normal=normal, gain=gain, range=range_))
