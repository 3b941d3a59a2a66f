"""``vibrofriction.batched``: the robot-timestep elements (contact_averaged, contact_feeder) on
MuJoCo Warp, checked against the C++ plugins on the same scenes (Warp's CPU device).

* step by step: from the same state (the C++ run's, plugin_state included) the batched element
  applies the C++ element's force within float32 rounding (MuJoCo Warp computes in float32);
* the conveying velocity on the feeder and the creep of a pushed part within 0.1 %;
* a batch whose worlds differ in their parameters against separate C++ runs of each.

The MuJoCo Warp tests skip, with the reason, without the optional extra ``batched``.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import vibrofriction
from vibrofriction.batched import unavailable_reason
from vibrofriction.params import ParameterError

REASON = unavailable_reason()
needs_warp = pytest.mark.skipif(REASON is not None, reason=str(REASON))

MU = 0.2
GRAVITY = 9.81


@pytest.fixture(scope="module")
def table():
    """The averaged law of tests/test_contact.py's resolved scene (Dahl, mu 0.2, 1 N/nm) under
    a 1 kHz, 20 mm/s vibration along x."""
    from vibrofriction.params import FrictionParameters
    from vibrofriction.robots.averaged import Vibration, build_table
    friction = FrictionParameters(law="dahl", friction_coefficient=MU,
                                  contact_stiffness_N_per_m=1e9)
    return build_table(friction, Vibration(1000.0, 0.02), GRAVITY)


def _averaged_scene(table, timestep=1e-3, **changes) -> str:
    config = table.contact_config("plate", torsion_radius_m=0.03826)
    config.update({k: str(v) for k, v in changes.items()})
    keys = "\n".join(f'<config key="{k}" value="{v}"/>' for k, v in config.items())
    return f"""
<mujoco>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.contact_averaged">
      <instance name="part_friction">{keys}</instance>
    </plugin>
    <plugin plugin="vibrofriction.contact_sensor"/>
  </extension>
  <worldbody>
    <body name="plate"><geom name="plate" type="plane" size="1 1 0.01" pos="0 0 0.01" condim="1"/></body>
    <body name="part" pos="0 0 0.0599">
      <freejoint/>
      <geom name="part" type="box" size="0.05 0.05 0.05" mass="1" condim="1"/>
      <plugin instance="part_friction"/>
    </body>
  </worldbody>
  <sensor>
    <plugin name="part_sensor" plugin="vibrofriction.contact_sensor">
      <config key="body" value="part"/>
    </plugin>
  </sensor>
</mujoco>"""


def _feeder_path():
    from vibrofriction.robots.scenes import scene_path
    return scene_path("feeder_map")


def _cpp_velocity(xml: str, steps: int, push, body="part", average=100) -> float:
    """The C++ plugin's mean velocity of ``body`` along ``push`` over the last ``average``
    steps (positions' difference)."""
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    part = model.body(body).id
    axis = np.asarray(push, float) / max(np.linalg.norm(push), 1e-300)
    for k in range(steps):
        if k == steps - average:
            start = data.xpos[part].copy()
        data.xfrc_applied[part, :3] = push
        mujoco.mj_step(model, data)
    return float((data.xpos[part] - start) @ axis / (average * model.opt.timestep))


def _twin_velocity(twin, steps: int, body="part", average=100, axis=(1.0, 0.0, 0.0)):
    part = twin.model.body(body).id
    for k in range(steps):
        if k == steps - average:
            start = twin.numpy("xpos")[:, part].copy()
        twin.step()
    end = twin.numpy("xpos")[:, part]
    return (end - start) @ np.asarray(axis) / (average * twin.model.opt.timestep)


def _push(twin, forces, body="part"):
    """xfrc_applied of ``body`` per world: forces (nworld, 3)."""
    import warp as wp
    xfrc = twin.numpy("xfrc_applied")
    xfrc[:, twin.model.body(body).id, :3] = forces
    wp.copy(twin.data.xfrc_applied, wp.array(xfrc, dtype=wp.spatial_vector,
                                              device=twin.device))


# ---- the twin's scene (no Warp needed) -------------------------------------------------------------

def test_the_twin_keeps_the_scene_and_reads_the_plugins_config(table):
    from vibrofriction.batched import twin_scene
    twin = twin_scene(_averaged_scene(table))
    assert twin.model.nplugin == 0 and twin.model.nsensor == 0
    assert twin.model.nbody == 3 and twin.model.body("part").mass[0] == 1.0
    (element,) = twin.elements
    assert element.plugin == "vibrofriction.contact_averaged" and element.body == "part"
    config = table.contact_config("plate")
    np.testing.assert_array_equal(element.xi, np.array(config["table_xi"].split(), float))
    assert element.along.size == table.along.size
    assert element.parameters["velocity_amplitude"] == 0.02
    assert element.parameters["torsion_radius"] == 0.03826
    assert twin.sensors == {"part_sensor": "part_friction"}
    feeder = twin_scene(_feeder_path())
    assert [e.body for e in feeder.elements] == ["part0", "part1", "part2"]
    assert feeder.plugin_stateadr == [0, 16, 32]


def test_a_scene_with_other_plugins_is_refused_by_name():
    from vibrofriction.batched import twin_scene
    from vibrofriction.robots.scenes import scene_path
    with pytest.raises(ParameterError, match="vibrofriction.contact, vibrofriction.motion"):
        twin_scene(scene_path("free_part_on_plate"))


def test_a_bad_config_is_refused_with_the_plugins_own_message(table):
    from vibrofriction.batched import twin_scene
    with pytest.raises(ValueError, match="table_checksum"):
        twin_scene(_averaged_scene(table, table_checksum="0123456789abcdef"))


# ---- against the C++ plugins ------------------------------------------------------------------------

def _step_by_step(path_or_xml, sensors, steps, push=None, samples=None):
    """Largest |batched force - C++ force| over the sampled steps, each taken from the C++ run's
    own state, over mu F_N; and the largest state differences (F_N relative, the other
    forces' acceleration)."""
    from vibrofriction.batched import BatchedTwin
    vibrofriction.load()
    model = (mujoco.MjModel.from_xml_path(str(path_or_xml)) if "<mujoco" not in str(path_or_xml)
             else mujoco.MjModel.from_xml_string(path_or_xml))
    data = mujoco.MjData(model)
    twin = BatchedTwin(path_or_xml, nworld=1, device="cpu")
    samples = set(samples or range(steps))
    worst = {"force": 0.0, "load": 0.0, "other": 0.0, "loaded": 0}
    for k in range(steps):
        if push is not None:
            data.xfrc_applied[model.body("part").id, :3] = push
        if k in samples:
            twin.load_mjdata(data)
            twin.step()
        mujoco.mj_step(model, data)
        if k not in samples:
            continue
        for name in sensors:
            adr = model.sensor(name).adr[0]
            cpp = data.sensordata[adr:adr + 10]
            batched = twin.sensor(name)[0]
            level = MU * max(cpp[8], 1e-300)
            if cpp[8] > 0:
                worst["loaded"] += 1
                worst["force"] = max(worst["force"],
                                     float(np.max(np.abs(batched[:4] - cpp[:4]))) / level)
        state_cpp = np.array([data.plugin_state[a:a + 16] for a in twin.scene.plugin_stateadr])
        state = twin.state[0]
        if np.all(state_cpp[:, 4] > 0):
            worst["load"] = max(worst["load"], float(np.max(
                np.abs(state[:, 4] / state_cpp[:, 4] - 1))))
            worst["other"] = max(worst["other"], float(np.max(np.abs(state[:, 12:15] -
                                                                     state_cpp[:, 12:15]))))
    return worst


@needs_warp
def test_the_feeder_element_applies_the_plugins_force_step_by_step():
    """From the C++ run's state at each sampled step of the parts' start on the feeder (map
    forces up to mu F_N): the batched force within 2e-5 mu F_N (float32); the load summed
    from the step's contacts (MuJoCo Warp's float32 constraint solve) within 3e-5.
    Measured: 2e-8 and 6.3e-6."""
    worst = _step_by_step(_feeder_path(), ["part0_friction", "part1_friction",
                                           "part2_friction"],
                          steps=60, samples=[0, 1, 2, 3, 5, 8, 12, 20, 30, 45, 59])
    assert worst["loaded"] >= 25
    assert worst["force"] < 2e-5
    assert worst["load"] < 3e-5


@needs_warp
def test_the_averaged_element_applies_the_plugins_force_step_by_step(table):
    """A 1 kg box pushed at 0.7 mu m g along x on the averaged plate: from the C++ state at
    each sampled step, the batched force within 2e-5 mu F_N, the load within 3e-5.
    Measured: 1.0e-6 and 1.2e-6."""
    worst = _step_by_step(_averaged_scene(table), ["part_sensor"], steps=40,
                          push=(0.7 * MU * GRAVITY, 0.0, 0.0),
                          samples=[0, 1, 2, 3, 5, 8, 13, 21, 34, 39])
    assert worst["loaded"] >= 8
    assert worst["force"] < 2e-5
    assert worst["load"] < 3e-5


@needs_warp
def test_the_parts_convey_at_the_plugins_velocity_within_0p1_percent():
    """feeder_map.xml from rest, 0.3 s at 1 ms: each part's velocity over the last 0.1 s as
    the C++ plugin's (and the map's conveying velocity) within 0.1 %."""
    from vibrofriction.batched import BatchedTwin
    from vibrofriction.robots.scenes import feeder_map
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_path(str(_feeder_path()))
    data = mujoco.MjData(model)
    twin = BatchedTwin(_feeder_path(), nworld=2, device="cpu")
    parts = ["part0", "part1", "part2"]
    ids = [model.body(p).id for p in parts]
    steps, average = 300, 100
    for k in range(steps):
        if k == steps - average:
            cpp_start = data.xpos[ids, 0].copy()
            twin_start = twin.numpy("xpos")[:, ids, 0].copy()
        mujoco.mj_step(model, data)
        twin.step()
    span = average * model.opt.timestep
    cpp = (data.xpos[ids, 0] - cpp_start) / span
    batched = (twin.numpy("xpos")[:, ids, 0] - twin_start) / span
    np.testing.assert_allclose(batched, np.broadcast_to(cpp, batched.shape), rtol=1e-3)
    np.testing.assert_allclose(cpp, feeder_map().conveying_velocity_m_per_s, rtol=1e-3)


@needs_warp
def test_a_batch_of_differing_parameters_creeps_as_separate_plugin_runs(table):
    """Three worlds of the averaged scene, each with its own mu, vibration amplitude, axis
    and push, against a separate C++ run with that config: creep within 0.1 %."""
    from vibrofriction.batched import BatchedTwin
    cases = [  # mu, v_a, axis, push over mu m g (along x)
        (0.2, 0.02, (1.0, 0.0, 0.0), 0.3),
        (0.25, 0.02, (0.0, 1.0, 0.0), 0.5),
        (0.2, 0.03, (1.0, 1.0, 0.0), 0.7),
    ]
    twin = BatchedTwin(_averaged_scene(table), nworld=len(cases), device="cpu")
    twin.set_parameter("mu", [c[0] for c in cases], "part_friction")
    twin.set_parameter("velocity_amplitude", [c[1] for c in cases], "part_friction")
    twin.set_parameter("axis", [c[2] for c in cases], "part_friction")
    _push(twin, [(c[3] * c[0] * GRAVITY, 0.0, 0.0) for c in cases])
    steps = 250
    batched = _twin_velocity(twin, steps)
    for world, (mu, va, axis, fraction) in enumerate(cases):
        xml = _averaged_scene(table, mu=mu, velocity_amplitude=va,
                              axis=" ".join(str(a) for a in axis))
        cpp = _cpp_velocity(xml, steps, (fraction * mu * GRAVITY, 0.0, 0.0))
        assert cpp > 1e-3  # it creeps
        assert batched[world] == pytest.approx(cpp, rel=1e-3), world


@needs_warp
def test_a_thousand_worlds_step_as_the_plugin_instance_by_instance(table):
    """1000 worlds of the averaged scene, each pushed with its own force (0 to 1.2 mu m g),
    20 steps from the settled C++ state: every world's velocity as a C++ run with that push
    (to 1e-4 relative of mu g dt: float32)."""
    from vibrofriction.batched import BatchedTwin
    vibrofriction.load()
    xml = _averaged_scene(table)
    model = mujoco.MjModel.from_xml_string(xml)
    settled = mujoco.MjData(model)
    for _ in range(30):
        mujoco.mj_step(model, settled)
    nworld, steps = 1000, 20
    fractions = np.linspace(0.0, 1.2, nworld)
    twin = BatchedTwin(xml, nworld=nworld, device="cpu")
    twin.load_mjdata(settled)
    _push(twin, np.outer(fractions * MU * GRAVITY, [1.0, 0.0, 0.0]))
    twin.step(steps)
    batched = twin.numpy("qvel")[:, 0]
    scale = MU * GRAVITY * steps * model.opt.timestep
    part = model.body("part").id
    for world in range(0, nworld, 111):  # instance by instance, a sample of the thousand
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, _full_state(model, settled),
                           mujoco.mjtState.mjSTATE_FULLPHYSICS)
        data.qacc_warmstart[:] = settled.qacc_warmstart
        for _ in range(steps):
            data.xfrc_applied[part, 0] = fractions[world] * MU * GRAVITY
            mujoco.mj_step(model, data)
        assert abs(batched[world] - data.qvel[0]) < 1e-4 * scale, world


def _full_state(model, data):
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data, state, kind)
    return state


@needs_warp
def test_parameters_are_checked():
    from vibrofriction.batched import BatchedTwin
    twin = BatchedTwin(_feeder_path(), nworld=2, device="cpu")
    with pytest.raises(ParameterError, match="unknown batched parameter"):
        twin.set_parameter("law", 1.0)
    with pytest.raises(ParameterError, match="mu must be >= 0"):
        twin.set_parameter("mu", -1.0, "part0")
    twin.set_parameter("mu", [0.3, 0.4], "part1_friction")
    assert twin.parameter("mu")[:, 1].tolist() == pytest.approx([0.3, 0.4])
    assert math.isclose(twin.parameter("mu")[0, 0], 0.3, rel_tol=1e-6)


@needs_warp
def test_a_helical_track_conveys_along_the_plugins_tangent_step_by_step(tmp_path):
    """contact_feeder's helix_pitch (a bowl feeder's spiral track): the feeder scene with its
    parts' maps on a helix of 50 mm pitch about the track's z axis, step by step as above.
    Measured: 2.9e-8 mu F_N."""
    import re
    from vibrofriction.robots.scenes import scene_path
    folder = scene_path("feeder_map").parent
    table = re.sub(r'<config key="axis" value="[^"]*"/>',
                   '<config key="helix_pitch" value="0.05"/>',
                   (folder / "feeder_map_table.xml").read_text())
    (tmp_path / "feeder_map_table.xml").write_text(table)
    (tmp_path / "feeder_map.xml").write_text((folder / "feeder_map.xml").read_text())
    vibrofriction.load()
    try:
        mujoco.MjModel.from_xml_path(str(tmp_path / "feeder_map.xml"))
    except ValueError as error:
        if "helix_pitch" in str(error):
            pytest.skip(f"the installed C++ plugin has no helix_pitch: {error}")
        raise
    worst = _step_by_step(tmp_path / "feeder_map.xml",
                          ["part0_friction", "part1_friction", "part2_friction"], steps=30,
                          samples=[0, 1, 2, 3, 5, 8, 12, 20, 29])
    assert worst["loaded"] >= 20
    assert worst["force"] < 2e-5
