"""``vibrofriction.robots.vibrate``: any body of any scene made to vibrate along an axis.

On a scene with dm_control's defaults (``<general ctrllimited="true" .../>``, ``<joint
armature="0"/>``) and a plate welded to the world, the plate's velocity along the axis is the
asked sine to the step's own discretisation (the shaker puts the position on (v_a/w) sin(w t)
at every step, so the velocity after a semi-implicit Euler step is the step mean
v_a sinc(w dt/2) cos(w (t - dt/2)), within v_a (w dt/2 + (w dt)^2/24) of v_a cos(w t)); a free
box with vibrofriction.contact creeps on it at the heavy-body value and holds without the
vibration, as on the bundled free_part_on_plate scene, which vibrate rebuilds bit for bit.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import vibrofriction
from vibrofriction.errors import InputError
from vibrofriction.robots import scenes, vibrate

MU = 0.2
GRAVITY = 9.81
FREQUENCY_HZ = 1000.0
VA = 0.02
TIMESTEP = 1e-5

DM_CONTROL_DEFAULTS = '<general ctrllimited="true" ctrlrange="-1 1"/><joint armature="0"/>'
# every default that silently changed or broke the bare shaker line (measured): a force range
# clips it to standing still, a gear scales the amplitude, dynamics add state, a joint's
# actuator force range clips it, ctrllimited without a range does not compile
HOSTILE_DEFAULTS = ('<general ctrllimited="true" forcelimited="true" forcerange="-1 1" gear="3" '
                    'dyntype="filter" dynprm="0.01" actdim="1"/>'
                    '<joint armature="0" damping="50" limited="true" range="-1e-6 1e-6" '
                    'frictionloss="5" actuatorfrclimited="true" actuatorfrcrange="-1 1"/>')


def _scene(defaults: str = DM_CONTROL_DEFAULTS, extra_world: str = "", keyframe: str = "") -> str:
    """A plain scene: a plate welded to the world on the floor, a free box on it with the
    drop-in element (free_part_on_plate.xml without its shaker)."""
    return f"""
<mujoco>
  <option timestep="{TIMESTEP}" integrator="implicitfast"/>
  <default>{defaults}</default>
  <extension>
    <plugin plugin="vibrofriction.contact">
      <instance name="part_friction">
        <config key="law" value="dahl"/>
        <config key="mu" value="{MU}"/>
        <config key="stiffness" value="1e9"/>
        <config key="support" value="plate"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="plate" pos="0 0 0.01">
      <geom name="plate" type="box" size="0.4 0.4 0.01" mass="10"/>
    </body>
    <body name="part" pos="0 0 0.07">
      <freejoint/>
      <geom name="part" type="box" size="0.05 0.05 0.05" mass="1" condim="1" priority="1"/>
      <plugin instance="part_friction"/>
    </body>
    {extra_world}
  </worldbody>
  {keyframe}
</mujoco>"""


def _spec(**kwargs) -> mujoco.MjSpec:
    vibrofriction.load()
    return mujoco.MjSpec.from_string(_scene(**kwargs))


def _push(model, data, steps, force=(0.0, 0.0, 0.0), record=None):
    part = model.body("part").id
    out = []
    for _ in range(steps):
        data.xfrc_applied[part, :3] = force
        mujoco.mj_step(model, data)
        if record is not None:
            out.append(record(data))
    return np.array(out)


def _plate_motion(model, data):
    """The plate's world position and linear velocity at the end of the step (mj_step leaves
    the kinematics of its start)."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)
    velocity = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, model.body("plate").id,
                             velocity, 0)
    return np.concatenate([data.body("plate").xpos, velocity[3:]])


@pytest.mark.parametrize("defaults", [DM_CONTROL_DEFAULTS, HOSTILE_DEFAULTS],
                         ids=["dm_control", "hostile"])
@pytest.mark.parametrize("axis", [(1.0, 0.0, 0.0), (1.0, 2.0, 0.0)])
def test_the_plate_moves_on_the_asked_sine_to_the_steps_discretisation(defaults, axis):
    spec = _spec(defaults=defaults)
    added = vibrate(spec, "plate", axis=axis, frequency_Hz=FREQUENCY_HZ,
                    velocity_amplitude_m_per_s=VA)
    assert (added.joint, added.actuator, added.instance) == (
        "plate_vibration", "plate_shaker", "plate_shaker")
    assert added.joint_added and added.excludes == (("plate", "world"),)
    model = spec.compile()
    assert model.na == 0 and model.actuator_gear[0, 0] == 1.0
    data = mujoco.MjData(model)
    steps = round(2 / FREQUENCY_HZ / TIMESTEP)  # two periods, the part resting on the plate
    motion = _push(model, data, steps, record=lambda d: _plate_motion(model, d))
    time = np.arange(1, steps + 1) * TIMESTEP
    unit = np.asarray(axis) / np.linalg.norm(axis)
    omega = 2 * math.pi * FREQUENCY_HZ
    half = omega * TIMESTEP / 2
    along = motion[:, 3:] @ unit
    across = motion[:, 3:] - np.outer(along, unit)
    # the step mean of the sine, to the friction's reaction on the 1e5 kg apparent mass
    step_mean = VA * math.sin(half) / half * np.cos(omega * (time - TIMESTEP / 2))
    np.testing.assert_allclose(along, step_mean, rtol=0, atol=1e-6 * VA)
    # ... which is the sine within its discretisation bound
    bound = VA * (half + (omega * TIMESTEP) ** 2 / 24)
    assert np.max(np.abs(along - VA * np.cos(omega * time))) < 1.01 * bound
    assert np.max(np.abs(across)) < 1e-9 * VA
    # the position is on (v_a / w) sin(w t) along the axis at every step
    displacement = (motion[:, :3] - [0.0, 0.0, 0.01]) @ unit
    np.testing.assert_allclose(displacement, VA / omega * np.sin(omega * time),
                               rtol=0, atol=1e-6 * VA / omega)
    assert all(w.number == 0 for w in data.warning)


def test_the_part_creeps_below_mu_mg_with_the_vibration_on_and_holds_with_it_off():
    """use_ctrl: ctrl 1 vibrates, 0 keeps the plate still. Pushed at mu m g / 2 the heavy
    body creeps at v_a sin(pi/4) (within 2 %, as on the bundled scene, tests/test_contact.py)
    and holds without the vibration."""
    spec = _spec()
    added = vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA,
                    use_ctrl=True)
    model = spec.compile()
    shaker = model.actuator(added.actuator).id
    assert tuple(model.actuator_ctrlrange[shaker]) == (0.0, 1.0)
    push = (0.5 * MU * GRAVITY, 0.0, 0.0)
    x_of = lambda d: d.body("part").xpos[0].copy()  # noqa: E731
    for ctrl in (1.0, 0.0):
        data = mujoco.MjData(model)
        data.ctrl[shaker] = ctrl
        _push(model, data, 3000)  # settle: the load builds up in MuJoCo's contact
        x = _push(model, data, 20000, push, x_of)
        time = np.arange(1, len(x) + 1) * TIMESTEP
        if ctrl:
            creep = np.polyfit(time[10000:], x[10000:], 1)[0]
            assert creep == pytest.approx(VA * math.sin(math.pi / 4), rel=0.02)
        else:  # at rest after leaning into the push: under 0.2 um over the last 0.05 s
            assert abs(x[-1] - x[-5000]) < 2e-7
        assert all(w.number == 0 for w in data.warning)


def _bundled_without_its_shaker(keep_joint: bool) -> mujoco.MjSpec:
    vibrofriction.load()
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("free_part_on_plate")))
    spec.delete(spec.actuator("plate_shaker"))  # (MjSpec deletes its instance with it)
    assert [p.name for p in spec.plugins] == ["part_friction"]
    if not keep_joint:
        spec.delete(spec.joint("plate_x"))  # the plate welded to the world, as a user's
    return spec


@pytest.mark.parametrize("keep_joint", [False, True])
def test_a_scene_built_from_the_bundled_one_steps_bit_for_bit_as_the_bundled_scene(keep_joint):
    """The bundled scene without its shaker (and without the plate's joint, or with it: then
    vibrate drives that joint) vibrated by vibrate: the same model, the same trajectory."""
    spec = _bundled_without_its_shaker(keep_joint)
    added = vibrate(spec, "plate", frequency_Hz=1000.0, velocity_amplitude_m_per_s=0.02)
    assert added.joint_added is not keep_joint
    assert added.joint == ("plate_x" if keep_joint else "plate_vibration")
    assert added.notes == () and added.excludes == ()
    bundled = scenes.load_model("free_part_on_plate")
    record = lambda d: np.concatenate([d.qpos, d.qvel])  # noqa: E731
    push = (0.5 * MU * GRAVITY, 0.0, 0.0)
    models = (bundled, spec.compile())
    runs = [_push(m, mujoco.MjData(m), 2000, push, record) for m in models]
    np.testing.assert_array_equal(runs[1], runs[0])


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_a_body_on_a_slide_joint_along_the_axis_keeps_it_with_the_advised_armature(sense):
    """dm_control's <joint armature="0"/> left the plate's own joint light: vibrate raises its
    armature and says so; a joint along -axis is driven through gear -1."""
    spec = _spec()
    spec.body("plate").add_joint(name="plate_x", type=mujoco.mjtJoint.mjJNT_SLIDE,
                                 axis=[sense, 0.0, 0.0])
    added = vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
    assert (added.joint, added.joint_added, added.excludes) == ("plate_x", False, ())
    assert added.notes == ("raised joint 'plate_x''s armature from 0 to 100000",)
    model = spec.compile()
    assert model.dof_armature[model.joint("plate_x").dofadr[0]] == 1e5
    assert model.actuator_gear[model.actuator("plate_shaker").id, 0] == sense
    data = mujoco.MjData(model)
    _push(model, data, 50)  # half a period: at full speed backwards along the axis
    assert sense * data.joint("plate_x").qvel[0] == pytest.approx(-VA, rel=1e-3)


def test_the_bundled_scene_is_not_vibrated_twice():
    vibrofriction.load()
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("free_part_on_plate")))
    with pytest.raises(InputError, match="already has an actuator named 'plate_shaker'"):
        vibrate(spec, "plate", frequency_Hz=1000.0, velocity_amplitude_m_per_s=0.02)
    with pytest.raises(InputError, match="already driven by actuator 'plate_shaker'.*delete"):
        vibrate(spec, "plate", frequency_Hz=1000.0, velocity_amplitude_m_per_s=0.02,
                name="second")


SHAKER = '<plugin name="plate_shaker" joint="plate_x" instance="plate_shaker"{}/>'
ROBUST = ' ctrllimited="true" ctrlrange="0 1" forcelimited="false" gear="1"'


def _with_shaker_line(defaults: str, attributes: str) -> str:
    """The scene with the plate on a slide joint and the MJCF shaker of docs/robots.md."""
    xml = _scene(defaults=defaults)
    xml = xml.replace('<geom name="plate"', '<joint name="plate_x" type="slide" axis="1 0 0" '
                      'armature="1e5" limited="false" actuatorfrclimited="false"/>\n'
                      '      <geom name="plate"')
    xml = xml.replace("  </extension>", '    <plugin plugin="vibrofriction.motion"><instance '
                      'name="plate_shaker"><config key="frequency" value="1000"/><config '
                      'key="velocity_amplitude" value="0.02"/></instance></plugin>\n'
                      "  </extension>")
    return xml.replace("</mujoco>", f"<actuator>{SHAKER.format(attributes)}</actuator></mujoco>")


def test_dm_controls_ctrllimited_default_breaks_the_bare_shaker_line_but_not_vibrate():
    vibrofriction.load()
    defaults = '<general ctrllimited="true"/>'
    with pytest.raises(ValueError, match="invalid control range"):
        mujoco.MjModel.from_xml_string(_with_shaker_line(defaults, ""))
    # a default force range clips the bare line's force: the plate stands still, silently
    clipped = mujoco.MjModel.from_xml_string(
        _with_shaker_line('<general forcelimited="true" forcerange="-1 1"/>', ""))
    data = mujoco.MjData(clipped)
    _push(clipped, data, 50)
    assert abs(data.joint("plate_x").qvel[0]) < 1e-6 * VA
    # the documented line with its own limits compiles under every hostile default
    for hostile in (defaults, HOSTILE_DEFAULTS):
        model = mujoco.MjModel.from_xml_string(_with_shaker_line(hostile, ROBUST))
        data = mujoco.MjData(model)
        _push(model, data, 50)  # half a period: the plate at full speed backwards
        assert data.joint("plate_x").qvel[0] == pytest.approx(-VA, rel=1e-3)
    spec = _spec(defaults=defaults)
    vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
    spec.compile()


@pytest.mark.parametrize("change, error, message", [
    ({"body": "plat"}, InputError, "no body named 'plat'; its bodies: part, plate"),
    ({"axis": (0, 0, 0)}, ValueError, r"axis=\(0, 0, 0\) has no direction"),
    ({"axis": (1, 0)}, ValueError, "axis=.* must be three finite numbers"),
    ({"frequency_Hz": 0.0}, ValueError, "frequency_Hz=0.0 must be > 0"),
    ({"velocity_amplitude_m_per_s": -1.0}, ValueError, "must be >= 0"),
    ({"body": "part"}, InputError, "has a free joint.*delete it"),
    ({"body": "world"}, InputError, "is the world"),
])
def test_a_bad_call_is_one_clear_error(change, error, message):
    spec = _spec()
    arguments = {"body": "plate", "frequency_Hz": FREQUENCY_HZ, "velocity_amplitude_m_per_s": VA,
                 **change}
    body = arguments.pop("body")
    with pytest.raises(error, match=message) as raised:
        vibrate(spec, body, **arguments)
    assert "\n" not in str(raised.value)
    assert spec.joint("plate_vibration") is None and not spec.actuators  # nothing added


def test_a_free_body_fixed_by_deleting_its_free_joint_vibrates_where_it_was():
    """The free-joint refusal's fix: delete the joint, then vibrate."""
    tray = ('<body name="tray" pos="1 1 0.05"><freejoint/>'
            '<geom type="box" size="0.1 0.1 0.05" mass="2"/></body>')
    spec = _spec(extra_world=tray)
    with pytest.raises(InputError, match="free joint"):
        vibrate(spec, "tray", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
    spec.delete(spec.body("tray").first_joint())
    added = vibrate(spec, "tray", axis=(0, 1, 0), frequency_Hz=FREQUENCY_HZ,
                    velocity_amplitude_m_per_s=VA)
    # welded to the floor and the plate before: it stays out of contact with them
    assert set(added.excludes) == {("tray", "world"), ("tray", "plate")}
    model = spec.compile()
    data = mujoco.MjData(model)
    _push(model, data, 50)  # half a period: at full speed backwards
    assert data.joint("tray_vibration").qvel[0] == pytest.approx(-VA, rel=1e-3)
    assert data.joint("tray_vibration").qpos[0] == pytest.approx(0.0, abs=1e-12)


def test_keyframes_get_the_new_coordinate_and_welded_neighbours_stay_out_of_contact():
    """A static block next to the plate (touching it) and a keyframe: the plate and the block
    were welded together and never collided; vibrated, they still do not; the key keeps the
    part where it put it."""
    block = '<body name="block" pos="0.45 0 0.01"><geom type="box" size="0.05 0.05 0.01"/></body>'
    key = '<keyframe><key name="home" qpos="0.1 0 0.07 1 0 0 0"/></keyframe>'
    spec = _spec(extra_world=block, keyframe=key)
    added = vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
    assert set(added.excludes) == {("plate", "world"), ("plate", "block")}
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    assert data.joint("plate_vibration").qpos[0] == 0.0
    np.testing.assert_array_equal(data.body("part").xpos, [0.1, 0.0, 0.07])
    _push(model, data, 200)
    plate = model.body("plate").id
    touching = {(model.geom_bodyid[c.geom[0]], model.geom_bodyid[c.geom[1]])
                for c in data.contact[:data.ncon]}
    assert all(plate in pair and model.body("part").id in pair for pair in touching)


def test_the_actuator_elements_are_declared_after_the_shaker():
    """Plugins compute in declaration order; a planar friction instance declared before is
    declared again after the motion (its actuators keep it)."""
    spec = _spec()
    spec.activate_plugin("vibrofriction.friction")
    friction = spec.add_plugin(name="element", plugin_name="vibrofriction.friction", active=True)
    friction.config = {"law": "coulomb", "normal": "1"}
    inner = spec.body("plate").add_body(name="slider", pos=[0, 0, 0.5])
    inner.add_joint(name="slider_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    inner.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0, 0], contype=0,
                   conaffinity=0)
    element = spec.add_actuator(name="element", target="slider_x",
                                trntype=mujoco.mjtTrn.mjTRN_JOINT, actdim=1)
    element.plugin = friction
    added = vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
    assert added.notes == ("declared vibrofriction.friction instance 'element' after the shaker "
                           "(plugins compute in declaration order)",)
    model = spec.compile()
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, i) for i in range(model.nplugin)]
    assert names == ["part_friction", "plate_shaker", "element"]
    assert model.actuator_plugin[model.actuator("element").id] == 2


def test_a_timestep_that_does_not_resolve_the_vibration_is_warned_about():
    spec = _spec()
    spec.option.timestep = 1e-3
    with pytest.warns(RuntimeWarning, match="1 steps a period"):
        vibrate(spec, "plate", frequency_Hz=FREQUENCY_HZ, velocity_amplitude_m_per_s=VA)
