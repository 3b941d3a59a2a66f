"""Law gms, the generalized Maxwell-slip law (issue 14, item 1): the plugin's one implementation
(friction_law.cc, AdvanceGms) against its closed forms -- the presliding virgin curve, Masing's
rule, the wiping-out of closed inner loops, the Jenkins element, the slip relaxation -- against
the independent scipy reference in the rig, and in the plane against the closed-form rotation of
a slipping element's force. Tolerances: the closed forms are exact for a constant velocity over
each sample, so they hold to rounding (1e-9 of the level); the rig and the plane compare two
discretisations, within the step's error."""
from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from vibrofriction import laws
from vibrofriction.rigs import planar
from vibrofriction.oracle import reference
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import FrictionParameters, ParameterError, RigParameters, \
    apply_overrides, default_friction

NORMAL_N = 55.2
MU = 0.2
LEVEL_N = MU * NORMAL_N
STIFFNESS = (5e7, 2e7, 1e7)
WEIGHTS = (0.2, 0.3, 0.5)
GMS = FrictionParameters(law="gms", friction_coefficient=MU, gms_stiffness_N_per_m=STIFFNESS,
                         gms_weights=WEIGHTS)
TOLERANCE_N = 1e-9 * LEVEL_N


def virgin_curve(x_m: np.ndarray, friction: FrictionParameters = GMS) -> np.ndarray:
    """F(x) = sum_i min(k_i x, w_i F_c) sgn(x): elements slipping one after another."""
    x = np.asarray(x_m, dtype=float)
    total = np.zeros_like(x)
    for k, w in zip(friction.gms_stiffness_N_per_m, friction.gms_element_weights):
        total += np.minimum(k * np.abs(x), w * LEVEL_N)
    return np.sign(x) * total


def run_path(points_m, friction: FrictionParameters = GMS, speed_m_per_s: float = 1e-3,
             step_m: float = 1.7e-9):
    """The law driven through the relative positions ``points_m`` at a constant speed (the same
    step everywhere, the last step of each leg shortened to land on its point)."""
    x = [0.0]
    for target in points_m:
        direction = np.sign(target - x[-1])
        steps = np.arange(x[-1], target, direction * step_m)[1:]
        x.extend(steps.tolist() + [target])
    x = np.array(x)
    dx = np.diff(x)
    dt = np.abs(dx) / speed_m_per_s
    t = np.concatenate([[0.0], np.cumsum(dt)])
    # sample i's velocity is that of the step reaching it: the plugin's order, z_i is advanced
    # with the input at t_i, so force i is the force at x_i
    v = np.concatenate([[0.0], dx / dt])
    run = laws.run_law(friction, t, v, normal_force_N=NORMAL_N)
    return x, run.friction_force_N, run


def test_the_virgin_curve_is_the_elements_slipping_in_turn():
    x, force, _ = run_path([1.5e-6])
    np.testing.assert_allclose(force, virgin_curve(x), rtol=0, atol=TOLERANCE_N)
    assert force[-1] == pytest.approx(LEVEL_N, rel=1e-12)  # every element slips: the full level
    # the initial slope is the total stiffness, the elements' sum
    assert force[1] / x[1] == pytest.approx(sum(STIFFNESS), rel=1e-9)


def test_masing_the_reversal_curve_is_the_virgin_curve_doubled_then_the_virgin_curve():
    """After a reversal at (x_r, F_r) on the virgin curve: F(x) = F_r - 2 F_v((x_r - x) / 2)
    (Masing 1926) down to the mirror point (-x_r, -F_r), and from there on the virgin curve
    again -- the memory rule: the branch rejoins the curve it left."""
    reversal = 0.4e-6  # past the first two elements' slip (0.044, 0.166 um), not the third's
    x, force, _ = run_path([reversal, -1.2e-6])
    back = np.arange(x.size) > np.argmax(x)
    masing = back & (x >= -reversal)
    f_r = virgin_curve(np.array([reversal]))[0]
    expected = f_r - 2 * virgin_curve((reversal - x[masing]) / 2)
    np.testing.assert_allclose(force[masing], expected, rtol=0, atol=TOLERANCE_N)
    beyond = back & (x < -reversal)
    np.testing.assert_allclose(force[beyond], virgin_curve(x[beyond]), rtol=0, atol=TOLERANCE_N)
    # far enough back every element slips the other way: the full level
    assert force[-1] == pytest.approx(-LEVEL_N, rel=1e-12)


def test_a_closed_inner_loop_is_wiped_out_and_the_outer_curve_goes_on():
    """Non-local memory: an inner loop x1 -> x2 -> x1 returns to the force it left at x1, and
    beyond x1 the curve is the virgin curve, as if the loop had not happened; between x2 and
    x1 the force depends on the path (memory of the reversal points)."""
    x1, x2, end = 0.4e-6, 0.1e-6, 1.0e-6  # (the third element still sticks at x1)
    xa, fa, _ = run_path([end])
    xb, fb, _ = run_path([x1, x2, x1, end])
    at_x1 = np.flatnonzero(np.isclose(xb, x1, rtol=0, atol=1e-15))
    assert len(at_x1) == 2
    assert fb[at_x1[1]] == pytest.approx(fb[at_x1[0]], abs=TOLERANCE_N)
    beyond = slice(at_x1[1], None)
    np.testing.assert_allclose(fb[beyond], virgin_curve(xb[beyond]), rtol=0, atol=TOLERANCE_N)
    assert fb[-1] == pytest.approx(fa[-1], abs=TOLERANCE_N)
    # inside the loop the unloading and reloading branches differ (hysteresis)
    middle = 0.35e-6
    down = np.flatnonzero(np.isclose(xb, middle, atol=1e-9))
    forces = fb[down[(down > at_x1[0]) & (down < at_x1[1])]]
    assert forces.max() - forces.min() > 0.05 * LEVEL_N


def test_one_element_with_an_instant_slip_is_the_jenkins_element():
    """gms_relaxation_time 0 (an infinite slip rate): F = clamp(F + k v dt, +-F_c) per step."""
    stiffness = 3e7
    friction = dataclasses.replace(GMS, gms_stiffness_N_per_m=(stiffness,), gms_weights=())
    rng = np.random.default_rng(7)
    t = np.arange(4000) * 2e-6
    v = 2e-2 * np.cos(2 * np.pi * 2e3 * t) + 4e-3 * rng.standard_normal(t.size)  # 1.6 um
    run = laws.run_law(friction, t, v, normal_force_N=NORMAL_N)
    expected = np.empty(t.size)
    force = 0.0
    for i in range(t.size):
        expected[i] = force
        if i + 1 < t.size:
            force = float(np.clip(force + stiffness * v[i + 1] * (t[i + 1] - t[i]), -LEVEL_N,
                                  LEVEL_N))
    np.testing.assert_allclose(run.friction_force_N, expected, rtol=0, atol=TOLERANCE_N)
    assert np.abs(run.friction_force_N).max() == pytest.approx(LEVEL_N)  # it slipped


def test_a_slipping_element_relaxes_to_a_lower_level_with_its_time_constant():
    """Stribeck: slipping near rest at the static level, then fast at the Coulomb level; the
    force falls as F_c + (F_s - F_c) exp(-t / tau)."""
    tau = 2e-4
    friction = dataclasses.replace(GMS, gms_stiffness_N_per_m=(4e7,), gms_weights=(),
                                   static_ratio=1.5, stribeck_velocity_m_per_s=1e-3,
                                   gms_relaxation_time_s=tau)
    slow, fast = 1e-7, 0.1  # m/s: g = F_s (to 1e-8) and g = F_c (exp(-1e4))
    t_slow = np.linspace(0, 10.0, 2001)  # 1 um at 1e-7 m/s, past the slip deflection 0.4 um
    t_fast = t_slow[-1] + np.linspace(0, 5 * tau, 501)[1:]
    t = np.concatenate([t_slow, t_fast])
    v = np.concatenate([np.full(t_slow.size, slow), np.full(t_fast.size, fast)])
    run = laws.run_law(friction, t, v, normal_force_N=NORMAL_N)
    static = LEVEL_N * (1 + 0.5 * np.exp(-(slow / 1e-3) ** 2))
    assert run.friction_force_N[t_slow.size - 1] == pytest.approx(static, rel=1e-12)
    elapsed = t[t_slow.size:] - t_slow[-1]
    # force i is the state reached at t_i (the step ending at sample i)
    expected = LEVEL_N + (static - LEVEL_N) * np.exp(-elapsed / tau)
    np.testing.assert_allclose(run.friction_force_N[t_slow.size:], expected, rtol=1e-9)
    instant = laws.run_law(dataclasses.replace(friction, gms_relaxation_time_s=0.0), t, v,
                           normal_force_N=NORMAL_N)
    assert instant.friction_force_N[t_slow.size] == pytest.approx(LEVEL_N, rel=1e-12)


def test_run_law_reports_each_element_and_the_equivalent_deflection():
    x, force, run = run_path([0.3e-6])
    assert run.element_deflection_m.shape == (x.size, 3)
    limits = np.array(WEIGHTS) * LEVEL_N / np.array(STIFFNESS)
    np.testing.assert_allclose(run.element_deflection_m[-1], np.minimum(x[-1], limits),
                               rtol=1e-9)
    np.testing.assert_allclose(run.deflection_m, force / sum(STIFFNESS), rtol=1e-12)


# ---- the plugin in MuJoCo ----------------------------------------------------------------------


def _simulate_rig(rig: RigParameters, friction: FrictionParameters, duration_s: float):
    dt = rig_module.recommended_timestep(rig)
    model = rig_module.build_model(rig, friction, dt)
    data = mujoco.MjData(model)
    steps = int(round(duration_s / dt))
    times, forces = np.empty(steps), np.empty(steps)
    for i in range(steps):
        mujoco.mj_step(model, data)
        times[i], forces[i] = data.time, data.sensor("drive_force").data[0]
    return times, forces


@pytest.mark.parametrize("amplitude, asymmetry", [(0.0, 0.0), (1.5e-3, 0.0), (1.5e-3, 0.3)],
                         ids=["still", "vibrating", "vibrating-asymmetric"])
def test_the_rig_with_gms_matches_the_independent_reference(amplitude, asymmetry):
    """The MJCF rig with the gms element against reference.simulate_reference's event-driven
    solution: the drive force within 0.1 % of the level at every sample (the step's error at
    the elements' slip kinks), its mean within 1e-3 relative. With a direction asymmetry each
    side has its own level, and a reversal unloads an element across to the other side's."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=amplitude)
    friction = dataclasses.replace(GMS, asymmetry=asymmetry)
    duration = 0.03
    times, forces = _simulate_rig(rig, friction, duration)
    ref = reference.simulate_reference(rig, friction, duration, sample_dt_s=1e-5)
    expected = np.interp(times, ref.time_s, ref.drive_force_N)
    assert np.max(np.abs(forces - expected)) < 1e-3 * LEVEL_N
    window = times > 0.02
    assert forces[window].mean() == pytest.approx(expected[window].mean(), rel=1e-3)
    if amplitude:  # the vibration lowers the drive force (the effect the rig shows)
        assert forces[window].mean() < 0.9 * LEVEL_N * (1 + asymmetry)


def test_the_gms_state_is_in_the_simulation_state():
    """mj_getState / mj_setState of the full physics state carry the elements' deflections (act)
    and slip flags (plugin_state): a run restored from mid-way repeats itself exactly, and one
    restored without its slip flags does not (with a Stribeck peak and a slip relaxation time a
    slipping element and a stuck one at the same deflection move differently)."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3)
    friction = dataclasses.replace(GMS, static_ratio=1.5, stribeck_velocity_m_per_s=1e-3,
                                   gms_relaxation_time_s=2e-4)
    model = rig_module.build_model(rig, friction, rig_module.recommended_timestep(rig))
    data = mujoco.MjData(model)
    for _ in range(3000):
        mujoco.mj_step(model, data)
    assert model.na == 3 and data.plugin_state.size >= 3
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    first = []
    for _ in range(500):
        mujoco.mj_step(model, data)
        first.append(data.sensor("drive_force").data[0])
    def rerun(drop_flags: bool) -> list[float]:
        fresh = mujoco.MjData(model)
        mujoco.mj_setState(model, fresh, state, spec)
        if drop_flags:
            flags = slice(fresh.plugin_state.size - 3, None)  # the friction element's, last
            assert set(fresh.plugin_state[flags]) <= {0.0, 1.0}
            assert fresh.plugin_state[flags].any()  # some element slips here
            fresh.plugin_state[flags] = 0.0
        out = []
        for _ in range(500):
            mujoco.mj_step(model, fresh)
            out.append(fresh.sensor("drive_force").data[0])
        return out

    assert rerun(drop_flags=False) == first
    assert rerun(drop_flags=True) != first


# ---- the plane ---------------------------------------------------------------------------------

PLANE_XML = """
<mujoco>
  <option timestep="{dt}" gravity="0 0 0" integrator="Euler"/>
  <extension>
    <plugin plugin="vibrofriction.planar">
      <instance name="friction">
        <config key="law" value="gms"/>
        <config key="mu" value="{mu}"/>
        <config key="normal" value="{normal}"/>
        <config key="gms_stiffness" value="{stiffness}"/>
        <config key="gms_weight" value="{weights}"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <body name="part">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <geom type="box" size="0.01 0.01 0.01" mass="1e6" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator>
    <plugin name="fx" joint="x" instance="friction" actdim="{count}"/>
    <plugin name="fy" joint="y" instance="friction" actdim="{count}"/>
  </actuator>
</mujoco>
"""


def _plane(friction: FrictionParameters, dt: float) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(PLANE_XML.format(
        dt=dt, mu=friction.friction_coefficient, normal=NORMAL_N,
        stiffness=" ".join(map(str, friction.gms_stiffness_N_per_m)),
        weights=" ".join(map(str, friction.gms_element_weights)),
        count=len(friction.gms_stiffness_N_per_m)))


def test_a_slipping_element_turns_its_force_toward_a_new_direction_of_motion():
    """Each element slipping along x at its level L_i = w_i F_c, then moved along y at a
    constant speed: its force stays on the circle of radius L_i and turns as
    F_y = L_i tanh(y / d_i), d_i = L_i / k_i (the elastic-perfectly-plastic closed form of a
    circular slip limit, which the return mapping approaches to first order in the step)."""
    speed = 1e-3
    model = _plane(GMS, dt=1e-7)  # 440 steps over the smallest slip deflection, 44 nm
    data = mujoco.MjData(model)
    limits = np.array(GMS.gms_element_weights) * LEVEL_N / np.array(STIFFNESS)
    data.act[:3] = limits  # x actuator's elements at their slip deflection
    data.qvel[:] = [0.0, speed]
    steps = 20000  # y = 2 um, past every element's turn
    y, fy, fx = np.empty(steps), np.empty(steps), np.empty(steps)
    for i in range(steps):
        mujoco.mj_step(model, data)
        y[i] = data.qpos[1]
        fx[i], fy[i] = -data.actuator_force[0], -data.actuator_force[1]
    levels = np.array(GMS.gms_element_weights) * LEVEL_N
    expected_y = sum(level * np.tanh(y / d) for level, d in zip(levels, limits))
    expected_x = sum(level / np.cosh(y / d) for level, d in zip(levels, limits))
    # first order in the step: the error scales with speed dt / d_min = 1e-10 / 4.4e-8
    assert np.max(np.abs(fy - expected_y)) < 0.01 * LEVEL_N
    assert np.max(np.abs(fx - expected_x)) < 0.01 * LEVEL_N
    # every element stays on its slip circle
    np.testing.assert_allclose(np.hypot(data.act[:3], data.act[3:]), limits, rtol=1e-9)


# ---- bad input ---------------------------------------------------------------------------------


def _compile_error(config: dict[str, str], actdim: int = 3) -> str:
    spec = rig_module.build_spec(RigParameters(), GMS)
    for plugin in spec.plugins:
        if plugin.name == "friction":
            merged = dict(plugin.config)
            merged.update(config)
            plugin.config = {k: v for k, v in merged.items() if v is not None}
    spec.actuator("friction").actdim = actdim
    with pytest.raises(ValueError) as error:
        spec.compile()
    return str(error.value)


@pytest.mark.parametrize("config, actdim, named", [
    ({"gms_stiffness": None}, 3, "law gms needs 'gms_stiffness'"),
    ({"gms_weight": "0.5 0.5"}, 3, "'gms_weight' has 2 values and 'gms_stiffness' 3"),
    ({"gms_weight": "0.2 0.3 0.4"}, 3, "must sum to 1"),
    ({"gms_stiffness": "5e7 -2e7 1e7"}, 3, "stiffness must be > 0"),
    ({"gms_relaxation_time": "-1"}, 3, "gms_relaxation_time"),
    ({"sigma1": "100"}, 3, "is not a gms parameter"),
    ({}, 1, 'law gms keeps one deflection per element and gms_stiffness names 3: write '
            'actdim="3"'),
    ({"gms_stiffness": " ".join(["1e7"] * 17), "gms_weight": None}, 17, "1 to 16 values"),
], ids=["no-stiffness", "weights-count", "weights-sum", "negative", "relaxation", "sigma1",
        "actdim", "too-many"])
def test_a_bad_gms_config_is_named(config, actdim, named):
    assert named in _compile_error(config, actdim)


def test_the_contact_elements_refuse_gms():
    from vibrofriction.robots import scenes
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("free_part_on_plate")))
    for plugin in spec.plugins:
        if plugin.plugin_name == "vibrofriction.contact":
            plugin.config = {**dict(plugin.config), "law": "gms"}
            break
    else:
        pytest.fail("the scene has no vibrofriction.contact instance")
    with pytest.raises(ValueError, match="law 'gms' .* is taken by vibrofriction.friction and "
                                         "vibrofriction.planar only"):
        spec.compile()


@pytest.mark.parametrize("changes, named", [
    ({"gms_stiffness_N_per_m": ()}, "needs gms_stiffness_N_per_m"),
    ({"gms_weights": (0.5, 0.5)}, "gms_weights has 2 values"),
    ({"gms_weights": (0.2, 0.3, 0.6)}, "must sum to 1"),
    ({"gms_stiffness_N_per_m": (5e7, 0.0, 1e7)}, "finite values > 0"),
    ({"bristle_damping_N_s_per_m": 10.0}, "not a gms parameter"),
])
def test_bad_gms_parameters_are_named_in_python(changes, named):
    with pytest.raises(ParameterError, match=named):
        dataclasses.replace(GMS, **changes).validate()
    with pytest.raises(ParameterError, match="list of numbers"):
        FrictionParameters(law="gms", gms_stiffness_N_per_m="5e7")


def test_set_takes_a_list_and_the_default_gms_is_the_scene():
    _, friction = apply_overrides(RigParameters(), default_friction("gms"),
                                  {"gms_stiffness_N_per_m": "4e7, 4e7", "gms_weights": "0.5 0.5"})
    assert friction.gms_stiffness_N_per_m == (4e7, 4e7) and friction.gms_weights == (0.5, 0.5)
    scene = mujoco.MjModel.from_xml_path(str(rig_module.scene_path("gms")))
    built = rig_module.build_model(RigParameters(), default_friction("gms"))
    assert scene.na == built.na == 3
    with pytest.raises(ParameterError, match="numbers separated by"):
        apply_overrides(RigParameters(), default_friction("gms"), {"gms_weights": "0.5 half"})


def test_the_planar_kinematic_driver_refuses_gms_by_name():
    with pytest.raises(ParameterError, match="law gms has no kinematic planar driver"):
        planar.run_planar_law(GMS, np.arange(3) * 1e-3, np.zeros((3, 2)))


def test_gms_with_a_viscous_term_in_the_line_and_the_plane():
    """The viscous term at the end-of-step velocity (GmsImplicitForce): the 1D rig against the
    reference (which integrates s2 v_r exactly), and the planar rig along x equal to the 1D."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3)
    friction = dataclasses.replace(GMS, viscous_N_s_per_m=300.0)
    dt = rig_module.recommended_timestep(rig)
    times, forces = _simulate_rig(rig, friction, 0.03)
    ref = reference.simulate_reference(rig, friction, 0.03, sample_dt_s=1e-5)
    expected = np.interp(times, ref.time_s, ref.drive_force_N)
    assert np.max(np.abs(forces - expected)) < 2e-3 * LEVEL_N
    line = rig_module.build_model(rig, friction, dt)
    plane = planar.build_rig_spec(rig, friction, timestep_s=dt).compile()
    line_data, plane_data = mujoco.MjData(line), mujoco.MjData(plane)
    for _ in range(3000):
        mujoco.mj_step(line, line_data)
        mujoco.mj_step(plane, plane_data)
    assert -plane_data.actuator("friction_x").force[0] == pytest.approx(
        -line_data.actuator("friction").force[0], rel=1e-9, abs=1e-9 * LEVEL_N)
    assert plane_data.actuator("friction_y").force[0] == pytest.approx(0.0, abs=1e-12)


def test_the_docs_block_with_gms_creeps_far_less_than_with_dahl():
    """docs/simulation.md's block on a vibrating plate, as written (Dahl) and with the gms
    elements its notes give: under the same vibration and pull, Dahl's deflection drifts and
    the block creeps 0.26 mm in 0.2 s; the Jenkins elements do not drift (16 um)."""
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "simulation.md").read_text()
    xml = re.search(r'```xml\n(<mujoco model="block on a vibrating plate">.*?)```', text,
                    re.S).group(1)
    gms_xml = xml.replace('<config key="law" value="dahl"/>',
                          '<config key="law" value="gms"/>'
                          '<config key="gms_stiffness" value="5e7 2e7 1e7"/>'
                          '<config key="gms_weight" value="0.2 0.3 0.5"/>').replace(
        'instance="contact" actdim="1"', 'instance="contact" actdim="3"')
    assert gms_xml != xml
    creep = {}
    for law, scene in (("dahl", xml), ("gms", gms_xml)):
        model = mujoco.MjModel.from_xml_string(scene)
        data = mujoco.MjData(model)
        data.ctrl[model.actuator("pull").id] = 5.0
        for _ in range(20000):
            mujoco.mj_step(model, data)
        creep[law] = data.joint("block_on_plate").qpos[0]
    assert creep["dahl"] == pytest.approx(0.26e-3, rel=0.05)
    assert creep["gms"] == pytest.approx(16e-6, rel=0.1)
