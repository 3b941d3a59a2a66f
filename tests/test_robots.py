"""The robot scenes (mjcf_models/robots/): every scene loads and steps without MuJoCo warnings;
the plate push at the robot's timestep matches the resolved scene and is stable at 1-2 ms; the
averaged table file is the one the resolved law gives; the feeder conveys only with vibration;
offscreen rendering works where a GL context can be made."""
from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest

import vibrofriction
from vibrofriction.robots import averaged, scenes
from vibrofriction.robots.averaged import Vibration
from vibrofriction.params import ParameterError

WEIGHT_N = scenes.PART_MASS_KG * scenes.GRAVITY_M_PER_S2
BOUND_N = scenes.PLATE_PART_FRICTION.friction_coefficient * WEIGHT_N


@pytest.mark.parametrize("name", sorted(scenes.SCENES))
def test_every_scene_loads_and_steps_without_warnings(name):
    model = scenes.load_model(name)
    data = mujoco.MjData(model)
    data.ctrl[:] = 1.0 if name != "plate_push_averaged" else 0.0
    nstep = 2000 if model.opt.timestep < 1e-4 else 300
    mujoco.mj_step(model, data, nstep)
    assert all(w.number == 0 for w in data.warning), [w.number for w in data.warning]
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))


@pytest.fixture(scope="module")
def averaged_push():
    return {v: scenes.run_push("averaged", vibration=v) for v in (True, False)}


def _push_window(run: scenes.SceneRun, start: float, end: float) -> np.ndarray:
    return (run.time_s >= start) & (run.time_s < end)


def test_push_needs_less_force_with_vibration(averaged_push):
    plan = scenes.PushPlan()
    mask = _push_window(averaged_push[True], plan.push_start_s + 0.3, plan.push_end_s)
    on = averaged_push[True].sensor("push_force")[mask].mean()
    off = averaged_push[False].sensor("push_force")[mask].mean()
    assert off == pytest.approx(BOUND_N, rel=0.01)  # Coulomb: the part slides at mu m g
    assert on < 0.5 * off  # xi = 0.6 along the vibration
    for run in averaged_push.values():
        assert not run.warnings
        # The normal load comes from the contact: m g.
        assert run.sensor("part_friction")[mask, 6].mean() == pytest.approx(WEIGHT_N, rel=2e-3)
        # The part ends where the pusher left it (60 mm along x, within a millimetre).
        end = run.sensor("part_position")[-1]
        assert end[0] == pytest.approx(plan.part_xy_m[0] + plan.distance_m, abs=1.5e-3)


def test_resolved_push_matches_the_averaged_one(averaged_push):
    """The resolved scene (2 kHz resolved, dt = 10 us) over the first 1.2 s: mean push force
    in 0.8-1.2 s within 3 % of the averaged scene's (dt = 1 ms)."""
    run = scenes.run_push("resolved", vibration=True, duration_s=1.2)
    assert not run.warnings
    mask = _push_window(run, 0.8, 1.2)
    resolved = run.sensor("push_force")[mask].mean()
    fast = averaged_push[True]
    averaged = fast.sensor("push_force")[_push_window(fast, 0.8, 1.2)].mean()
    assert averaged == pytest.approx(resolved, rel=0.03)


def test_averaged_push_is_stable_at_2_ms():
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("plate_push_averaged")))
    spec.option.timestep = 2e-3
    model = spec.compile()
    plan = scenes.PushPlan()
    ctrl = scenes.push_controls(model, plan, int(round(plan.duration_s / 2e-3)), 1.0)
    x, y, quill = plan.pusher(0.0)
    q1, q2 = scenes.scara_ik(x, y)
    state0 = scenes.initial_state(model, ctrl[0], {"shoulder": q1, "elbow": q2, "quill": quill})
    run = scenes.run_scene(model, ctrl, state0)
    assert not run.warnings
    assert np.all(np.isfinite(run.sensordata))
    assert np.max(np.linalg.norm(run.sensor("part_friction")[:, :2], axis=1)) <= BOUND_N * 1.01
    end = run.sensor("part_position")[-1]
    assert end[0] == pytest.approx(plan.part_xy_m[0] + plan.distance_m, abs=1.5e-3)


def test_the_table_file_is_made_from_the_resolved_scene():
    """plate_push_table.xml is what scripts/robot_tables.py makes now, and the law/vibration it
    was made from are those of plate_push_resolved.xml."""
    text = scenes.table_files()["plate_push_table.xml"]
    committed = (scenes.ROBOTS_DIR / "plate_push_table.xml").read_text()
    fresh_config, committed_config = _table_config(text), _table_config(committed)
    assert fresh_config and "table_along" in fresh_config
    assert fresh_config.keys() == committed_config.keys()
    for key, fresh in fresh_config.items():
        if key == "table_checksum":
            # the hash of the lists' last digits, which another machine changes: the committed
            # one must be its own lists' (the element refuses a table edited by hand)
            assert committed_config[key] == averaged.table_checksum(*(
                committed_config[k] for k in ("table_xi", "table_angle", "table_along",
                                              "table_across"))), key
            continue
        try:
            a = np.array(fresh.split(), dtype=float)
        except ValueError:  # a name or a flag
            assert committed_config[key] == fresh, key
            continue
        # The table entries are period means of a simulated law; a new machine or library
        # version changes their last digits, a change of the scene or the law the third.
        b = np.array(committed_config[key].split(), dtype=float)
        assert a.shape == b.shape, key
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-7 * max(1.0, float(np.max(np.abs(a)))),
                                   err_msg=key)
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("plate_push_resolved")))
    configs = {p.name: dict(p.config) for p in spec.plugins}
    friction = configs["part_friction"]
    assert friction["law"] == scenes.PLATE_PART_FRICTION.law
    assert float(friction["mu"]) == scenes.PLATE_PART_FRICTION.friction_coefficient
    assert float(friction["stiffness"]) == scenes.PLATE_PART_FRICTION.contact_stiffness_N_per_m
    shaker = configs["plate_shaker"]
    assert Vibration(float(shaker["frequency"]), float(shaker["velocity_amplitude"])) == \
        scenes.PLATE_VIBRATION


def _table_config(text: str) -> dict[str, str]:
    """Config of the averaged instance in a generated table file."""
    return dict(re.findall(r'<config key="([^"]+)" value="([^"]*)"/>', text))


def test_scara_ik_reaches_its_targets():
    for x, y in ((0.25, 0.0), (0.3, 0.1), (0.2, -0.15)):
        q1, q2 = scenes.scara_ik(x, y)
        ex = scenes.SCARA_L1_M * math.cos(q1) + scenes.SCARA_L2_M * math.cos(q1 + q2)
        ey = scenes.SCARA_L1_M * math.sin(q1) + scenes.SCARA_L2_M * math.sin(q1 + q2)
        assert (ex, ey) == pytest.approx((x, y), abs=1e-12)


def test_feeder_conveys_only_with_vibration():
    on = scenes.run_feeder(vibration=True, duration_s=1.0)
    off = scenes.run_feeder(vibration=False, duration_s=0.3)
    assert not on.warnings and not off.warnings
    t = on.time_s
    for part in scenes.FEEDER_PARTS:
        x = on.sensor(f"{part}_position")[:, 0]
        speed = np.polyfit(t[t > 0.5], x[t > 0.5], 1)[0]
        assert 3e-3 < speed < 20e-3  # mm/s to cm/s: the sliding regime of a feeder
        still = off.sensor(f"{part}_position")[:, 0]
        assert np.max(np.abs(still - still[0])) < 1e-9  # rigid Coulomb sticks: no creep
        state = on.sensor(f"{part}_friction")
        weight = scenes.FEEDER_PART_MASS_KG * scenes.GRAVITY_M_PER_S2
        assert state[t > 0.5, 6].mean() == pytest.approx(weight, rel=0.01)
        assert state[t > 0.5, 6].max() > 1.5 * weight  # the normal load follows the throw


def test_the_feeder_map_file_is_made_from_the_feeder_scene():
    """feeder_map_table.xml is what scripts/robot_tables.py makes now, from the track motion and
    friction of feeder.xml."""
    fresh = _instances(scenes.table_files()["feeder_map_table.xml"])
    committed = _instances((scenes.ROBOTS_DIR / "feeder_map_table.xml").read_text())
    assert list(fresh) == list(committed) == [f"{p}_friction" for p in scenes.FEEDER_PARTS]
    for name, config in fresh.items():
        assert config.keys() == committed[name].keys()
        for key in ("mu", "support", "axis", "torsion_radius"):
            assert config[key] == committed[name][key], key
        for key in ("map_velocity", "map_force"):
            # reference means over whole periods, switching times to 1e-15 s: a new machine
            # changes the last digits only
            a, b = (np.array(c[key].split(), dtype=float) for c in (config, committed[name]))
            assert a.shape == b.shape, key
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * np.max(np.abs(a)), err_msg=key)
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("feeder")))
    configs = {p.name: dict(p.config) for p in spec.plugins}
    feeder = scenes.FEEDER
    along = float(configs["shaker_x"]["velocity_amplitude"])
    normal = float(configs["shaker_z"]["velocity_amplitude"])
    assert math.hypot(along, normal) == pytest.approx(feeder.amplitude_m * feeder.omega,
                                                      rel=1e-4)
    assert math.atan2(normal, along) == pytest.approx(feeder.throw_angle_rad, rel=1e-4)
    assert float(configs["shaker_x"]["frequency"]) == feeder.frequency_Hz
    assert float(configs["part0_friction"]["mu"]) == feeder.friction_coefficient


def _instances(text: str) -> dict[str, dict[str, str]]:
    return {name: dict(re.findall(r'<config key="([^"]+)" value="([^"]*)"/>', body))
            for name, body in re.findall(r'<instance name="([^"]+)">(.*?)</instance>', text,
                                         re.S)}


def test_the_feeder_at_robot_timesteps_conveys_at_the_exact_velocity():
    """feeder_map.xml (free parts, still track, 1 ms) against the exact reference; feeder.xml's
    resolved run approaches it as its step shrinks (MuJoCo's soft contact keeps it about 2 %
    off at 10 us, docs/physics.md)."""
    exact = scenes.feeder_map().conveying_velocity_m_per_s
    mapped = scenes.run_feeder(mode="map", duration_s=1.0)
    assert not mapped.warnings
    late = mapped.time_s > 0.5
    for part in scenes.FEEDER_PARTS:
        x = mapped.sensor(f"{part}_position")[:, 0]
        assert np.polyfit(mapped.time_s[late], x[late], 1)[0] == pytest.approx(exact, rel=1e-3)
    errors = {}
    for timestep in (1e-4, 1e-5):
        spec = mujoco.MjSpec.from_file(str(scenes.scene_path("feeder")))
        spec.option.timestep = timestep
        model = spec.compile()
        nstep = int(round(0.6 / timestep))
        ctrl = np.ones((nstep, model.nu)) * [model.actuator(i).name.startswith("shaker")
                                             for i in range(model.nu)]
        run = scenes.run_scene(model, ctrl)
        late = run.time_s > 0.3
        x = run.sensor("part1_position")[:, 0]
        errors[timestep] = np.polyfit(run.time_s[late], x[late], 1)[0] / exact - 1
    assert abs(errors[1e-5]) < 0.03
    assert abs(errors[1e-5]) < abs(errors[1e-4]) / 3


def test_the_flexible_feeder_plate_scene_in_both_modes():
    """robots.feeder_plate_scene (scripts/bench_robots.py): the map mode's parts convey at the
    exact velocity; the resolved mode steps without warnings (its speed is the benchmark's)."""
    vibrofriction.load()
    exact = scenes.feeder_map().conveying_velocity_m_per_s
    model = mujoco.MjModel.from_xml_string(scenes.feeder_plate_scene(4, mode="map"))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=300)
    before = data.qpos.copy()
    mujoco.mj_step(model, data, nstep=200)
    assert not any(w.number for w in data.warning)
    for k in range(4):
        adr = model.joint(model.body(f"part{k}").jntadr[0]).qposadr[0]
        assert (data.qpos[adr] - before[adr]) / 0.2 == pytest.approx(exact, rel=1e-3)
    resolved = mujoco.MjModel.from_xml_string(scenes.feeder_plate_scene(2, mode="resolved"))
    assert resolved.opt.timestep == 1e-5
    data = mujoco.MjData(resolved)
    mujoco.mj_step(resolved, data, nstep=1000)
    assert not any(w.number for w in data.warning)
    with pytest.raises(ParameterError, match="unknown feeder mode"):
        scenes.feeder_plate_scene(1, mode="fast")


def test_a_chunked_run_is_the_same_run_with_fewer_states_kept():
    """run_scene(chunk_steps=...) carries the state and the warm start from chunk to chunk: the
    same sensors and, at the kept rows, the same states as one rollout."""
    model = scenes.load_model("feeder_map")
    ctrl = np.zeros((250, model.nu))
    whole = scenes.run_scene(model, ctrl, keep_every=5)
    chunked = scenes.run_scene(model, ctrl, keep_every=5, chunk_steps=50)
    np.testing.assert_array_equal(chunked.sensordata, whole.sensordata)
    np.testing.assert_array_equal(chunked.time_s, whole.time_s)
    np.testing.assert_array_equal(chunked.state, whole.state[4::5])
    dt = model.opt.timestep
    for steps in (0, 3, 12, 200, 250):  # the last kept state at or before each time
        kept = steps // 5 * 5
        np.testing.assert_array_equal(chunked.state_at(steps * dt), whole.state_at(kept * dt))
    for bad in (0, -5, 12):
        with pytest.raises(ParameterError, match="chunk_steps"):
            scenes.run_scene(model, ctrl, keep_every=5, chunk_steps=bad)


_RENDER = """
import sys
from vibrofriction.robots import scenes
run = scenes.run_push("averaged", vibration=True, duration_s=0.05)
try:
    frame = scenes.render_frames(run, [0.02], height=48, width=64)[0]
except scenes.RenderingUnavailable as reason:
    print(reason)
    sys.exit(3)
assert frame.shape == (48, 64, 3) and frame.std() > 0, frame.shape
"""


def test_offscreen_rendering_where_available():
    """MUJOCO_GL is read when mujoco is imported: try EGL, then OSMesa, in a fresh process."""
    import os
    import subprocess
    import sys
    reasons = []
    for backend in ("egl", "osmesa"):
        env = dict(os.environ, MUJOCO_GL=backend)
        result = subprocess.run([sys.executable, "-c", _RENDER], env=env, capture_output=True,
                                text=True, timeout=120)
        if result.returncode == 0:
            return
        assert result.returncode == 3, result.stderr[-2000:]
        reasons.append(result.stdout.strip())
    pytest.skip("; ".join(reasons))
