"""The robot-timestep mode vibrofriction.averaged: the table reproduces the analytic kinematic
limits for rigid Coulomb, the averaged rig at dt = 1 ms matches the resolved rig (dt = 10 us)
within 3 % in mean force, it is stable at dt = 1-2 ms even for light bodies, and without
vibration it is rigid Coulomb with stick."""
from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from vibrofriction.robots import averaged
from vibrofriction.rigs import planar
from vibrofriction.params import FrictionParameters, ParameterError, RigParameters

# A 0.2 kg part on a plate vibrating at 2 kHz with v_a = 50 mm/s (u0 = 4 um), mu = 0.3,
# Dahl with k_t = 1 N/um: eps = k_t u0 / (mu F_N) = 6.8, m omega^2 / k_t = 32 (heavy body).
MASS_KG = 0.2
NORMAL_N = MASS_KG * 9.81
PART = FrictionParameters(law="dahl", friction_coefficient=0.3, contact_stiffness_N_per_m=1e6)
VIBRATION = averaged.Vibration(frequency_Hz=2000.0, velocity_amplitude_m_per_s=0.05)
ANGLES = np.array([0.0, math.pi / 2, math.pi])  # along and across the vibration only


def _rig(xi: float, mass: float = MASS_KG, drive_stiffness: float = 2e3,
         va: float = VIBRATION.velocity_amplitude_m_per_s) -> RigParameters:
    return RigParameters(mass_kg=mass, drive_stiffness_N_per_m=drive_stiffness,
                         drive_damping_N_s_per_m=2 * math.sqrt(drive_stiffness * mass),
                         drive_velocity_m_per_s=xi * va,
                         vibration_frequency_Hz=VIBRATION.frequency_Hz,
                         vibration_velocity_amplitude_m_per_s=va, normal_force_N=NORMAL_N)


@pytest.fixture(scope="module")
def dahl_table() -> averaged.AveragedTable:
    return averaged.build_table(PART, VIBRATION, NORMAL_N, angle_rad=ANGLES)


def test_coulomb_table_is_the_analytic_kinematic_limit():
    friction = FrictionParameters(law="coulomb", friction_coefficient=0.3)
    table = averaged.build_table(friction, VIBRATION, NORMAL_N, angle_rad=ANGLES)
    assert np.allclose(table.along[:, 0], planar.longitudinal_coulomb_ratio(table.xi), atol=4e-3)
    assert np.allclose(table.across[:, 1], planar.transverse_coulomb_ratio(table.xi), atol=4e-3)
    assert np.allclose(table.along[:, 2], -table.along[:, 0])  # odd along the axis
    assert np.all(table.along[:, 1] == pytest.approx(0, abs=1e-9))


XIS = (0.1, 0.4, 1.0)


@pytest.mark.parametrize("angle", (0.0, math.pi / 2), ids=("along", "across"))
def test_averaged_matches_the_resolved_simulation(dahl_table, angle):
    """Mean drive force of the resolved rig (dt = 10 us, the 2 kHz vibration resolved) and of
    the averaged rig (dt = 1 ms, implicitfast, table at rest) within 3 %."""
    cases = [(_rig(xi), PART, 0.0, angle) for xi in XIS]
    resolved = planar.simulate_rigs(cases, duration_s=0.25, settle_time_s=0.15, timestep_s=1e-5)
    fast = planar.simulate_rigs(cases, duration_s=0.25, settle_time_s=0.15, timestep_s=1e-3,
                                averaged_config=dahl_table.config())
    for xi, slow, quick in zip(XIS, resolved, fast):
        a, b = slow.mean_drive_force_N(), quick.mean_drive_force_N()
        assert np.linalg.norm(b - a) <= 0.03 * np.linalg.norm(a), (xi, a, b)
        # Vibration lowers friction below mu F_N (xi < 1) along and across.
        if xi < 1:
            assert np.linalg.norm(a) < 0.97 * PART.friction_coefficient * NORMAL_N


@pytest.mark.parametrize("dt", (1e-3, 2e-3))
def test_averaged_is_stable_at_robot_timesteps(dt):
    """A light body (20 g) on a weakly vibrating plate: the averaged law's slope at V = 0,
    ~ mu F_N / v_a, is far above m / dt. The implicit solve keeps it stable and settles at the
    drive velocity; the force never exceeds the table's bound."""
    weak = averaged.Vibration(2000.0, 2e-3)
    friction = FrictionParameters(law="coulomb", friction_coefficient=0.3)
    table = averaged.build_table(friction, weak, NORMAL_N, angle_rad=ANGLES)
    slope = 2 / math.pi * 0.3 * NORMAL_N / weak.velocity_amplitude_m_per_s
    assert slope * dt / 0.02 > 4  # an explicit force would diverge (> 2)
    cases = [(_rig(xi, mass=0.02, drive_stiffness=5e3, va=2e-3), friction, 0.0, angle)
             for xi in (0.05, 0.5, 3.0) for angle in (0.0, math.pi / 2)]
    runs = planar.simulate_rigs(cases, duration_s=2.0, settle_time_s=1.5, timestep_s=dt,
                                averaged_config=table.config())
    for (r, _, _, angle), run in zip(cases, runs):
        assert np.all(np.isfinite(run.friction_force_N))
        assert np.max(np.linalg.norm(run.friction_force_N, axis=1)) <= 0.3 * NORMAL_N * 1.001
        v = run.mean(run.slider_velocity_m_per_s)
        want = r.drive_velocity_m_per_s * np.array([math.cos(angle), math.sin(angle)])
        assert np.allclose(v, want, rtol=0, atol=0.01 * r.drive_velocity_m_per_s)
        tail = run.slider_velocity_m_per_s[-100:]  # settled, no oscillation
        assert np.max(np.abs(tail - want)) < 0.02 * r.drive_velocity_m_per_s


def test_without_vibration_it_is_coulomb_with_stick():
    """velocity_amplitude = 0: rigid Coulomb with the planar stick solve at dt = 2 ms. While the
    drive spring (k_d = 2 kN/m, end moving at 1 mm/s along 40 deg) pulls below mu F_N the body
    does not move at all (no creep); past it, it slides with |F| = mu F_N."""
    friction = FrictionParameters(law="coulomb", friction_coefficient=0.3)
    config = {"mu": "0.3", "normal": repr(NORMAL_N)}
    rig = _rig(1.0, va=1e-3)
    model = planar.build_rig_spec(rig, friction, drive_angle_rad=math.radians(40),
                                  timestep_s=2e-3, averaged_config=config).compile()
    data = mujoco.MjData(model)
    bound = 0.3 * NORMAL_N
    t_break = bound / (rig.drive_stiffness_N_per_m * rig.drive_velocity_m_per_s)  # 0.29 s
    while data.time < 0.9 * t_break:
        mujoco.mj_step(model, data)
        assert np.all(np.abs(data.qpos[2:4]) < 1e-9), data.time  # stuck (no creep)
    while data.time < 0.8:
        mujoco.mj_step(model, data)
    friction_state = data.sensordata[2:9]  # F_x, F_y, z_x, z_y, v_x, v_y, F_N
    assert np.linalg.norm(data.qvel[2:4]) > 0.5 * rig.drive_velocity_m_per_s
    assert np.linalg.norm(friction_state[:2]) == pytest.approx(bound, rel=1e-9)
    direction = friction_state[:2] / np.linalg.norm(friction_state[:2])
    assert direction == pytest.approx([math.cos(math.radians(40)), math.sin(math.radians(40))],
                                      abs=1e-3)
    assert all(w.number == 0 for w in data.warning)



def _slider_path(spec: mujoco.MjSpec, duration_s: float = 1.0) -> np.ndarray:
    model = spec.compile()
    data = mujoco.MjData(model)
    rows = []
    while data.time < duration_s:
        mujoco.mj_step(model, data)
        rows.append(data.qpos[2:4].copy())
    return np.array(rows)


def test_without_vibration_its_stribeck_curve_is_the_planar_coulomb_elements():
    """velocity_amplitude = 0 with static_ratio > 1: the averaged element is vibrofriction.planar
    with law="coulomb", Stribeck curve (stribeck_velocity) included, step for step; leaving
    stribeck_velocity out means its default, 1e-3 m/s, and another path."""
    rig = replace(_rig(1.0, va=0.0), drive_velocity_m_per_s=3e-3)  # sliding near v_s
    friction = FrictionParameters(law="coulomb", friction_coefficient=0.3, static_ratio=1.5,
                                  stribeck_velocity_m_per_s=4e-3)
    angle = math.radians(40)
    resolved = planar.build_rig_spec(rig, friction, drive_angle_rad=angle, timestep_s=2e-3)
    resolved.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST  # as the averaged scene
    config = {"mu": "0.3", "normal": repr(NORMAL_N), "static_ratio": "1.5",
              "stribeck_velocity": "0.004"}
    averaged_spec = planar.build_rig_spec(rig, friction, drive_angle_rad=angle, timestep_s=2e-3,
                                          averaged_config=config)
    path = _slider_path(averaged_spec)
    assert np.max(np.abs(path)) > 1e-3  # it slid
    assert np.array_equal(path, _slider_path(resolved))
    del config["stribeck_velocity"]
    default_path = _slider_path(planar.build_rig_spec(
        rig, friction, drive_angle_rad=angle, timestep_s=2e-3, averaged_config=config))
    assert np.max(np.abs(default_path - path)) > 1e-5


def test_the_table_config_carries_the_no_vibration_stribeck_curve(dahl_table):
    config = dahl_table.config()
    assert config["static_ratio"] == repr(PART.static_ratio)
    assert config["stribeck_velocity"] == repr(PART.stribeck_velocity_m_per_s)


def test_a_bad_stribeck_velocity_is_named():
    config = {"mu": "0.3", "normal": repr(NORMAL_N), "stribeck_velocity": "0"}
    spec = planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3, averaged_config=config)
    with pytest.raises(ValueError, match=r"vibrofriction.averaged .*attribute "
                                         r"'stribeck_velocity'=\"0\" must be > 0 \(m/s\)"):
        spec.compile()


@pytest.mark.parametrize("key, value", [("law", "dahl"), ("stiffness", "1e6")])
def test_a_law_key_of_the_resolved_element_is_refused_by_name(key, value):
    """The law's shape is in the table: the resolved element's law keys are not attributes of
    the averaged one. Set from Python, the key is named against the table before MuJoCo
    compiles; written in MJCF, MuJoCo names it."""
    config = {"mu": "0.3", "normal": repr(NORMAL_N), key: value}
    with pytest.raises(ParameterError, match=f"vibrofriction.averaged has no config key "
                                             f"'{key}'; its keys are mu, viscous"):
        planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3, averaged_config=config)
    spec = planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3,
                                 averaged_config={"mu": "0.3", "normal": repr(NORMAL_N)})
    text = spec.to_xml().replace('<config key="mu" value="0.3"/>',
                                 f'<config key="mu" value="0.3"/><config key="{key}" '
                                 f'value="{value}"/>', 1)
    assert f'key="{key}"' in text
    with pytest.raises(ValueError, match=f"unrecognized attribute 'plugin:{key}' for plugin "
                                         "vibrofriction.averaged"):
        mujoco.MjModel.from_xml_string(text)

def test_invalid_table_is_named(dahl_table):
    config = dahl_table.config()
    config["table_along"] = " ".join(config["table_along"].split()[:-1])
    spec = planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3, averaged_config=config)
    with pytest.raises(ValueError, match="table_along"):
        spec.compile()
    config = dahl_table.config()
    config["table_angle"] = "0 1 2"
    spec = planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3, averaged_config=config)
    with pytest.raises(ValueError, match="table_angle"):
        spec.compile()


@pytest.mark.parametrize("bad, named", [
    ("0x10", "table_along' has a non-number at position 0"),
    ("inf", "table_along' has a non-number at position 0"),
    ("1e300", "table_along'=.* holds 1e\\+300, out of its physical range")])
def test_a_table_number_that_is_not_a_plain_decimal_is_named(dahl_table, bad, named):
    config = dahl_table.config()
    values = config["table_along"].split()
    config["table_along"] = " ".join([bad] + values[1:])
    spec = planar.build_rig_spec(_rig(0.5), PART, timestep_s=1e-3, averaged_config=config)
    with pytest.raises(ValueError, match=named):
        spec.compile()


def _synthetic_table_config(scale_middle: float = 1.0, checksum: bool = False) -> dict[str, str]:
    """An averaged config with fixed-width numbers: scaling the middle of the table keeps the
    config's length and its first and last bytes (and, with its checksum, the checksum's
    length: the element then compares the bytes around the table each step, not the table)."""
    xi = np.array([0.0, 0.25, 0.5, 1.0, 2.0, 4.0])
    angle = np.array([0.0, math.pi / 2, math.pi])
    level = xi / (xi + 0.3)  # along the velocity, rising to 1 past xi ~ 1
    along = np.outer(level, np.cos(angle))
    across = np.outer(level, np.sin(angle))
    middle = slice(6, along.size - 6)
    along.ravel()[middle] *= scale_middle
    across.ravel()[middle] *= scale_middle
    fixed = lambda values: " ".join(f"{v:.6f}" for v in values.ravel())  # noqa: E731
    config = {"mu": "0.3", "normal": repr(NORMAL_N), "velocity_amplitude": "0.05",
              "table_xi": fixed(xi), "table_angle": repr(0.0) + " " + repr(math.pi / 2) + " "
              + repr(math.pi), "table_along": fixed(along), "table_across": fixed(across)}
    if checksum:
        config["table_checksum"] = averaged.table_checksum(*(config[key] for key in TABLE_KEYS))
    return config


def _spec_with(config: dict[str, str]) -> mujoco.MjSpec:
    return planar.build_rig_spec(_rig(0.4), PART, timestep_s=1e-3, averaged_config=config)


def _config_bytes(model: mujoco.MjModel) -> np.ndarray:
    """The averaged element's config as the plugin sees it (a view into the model)."""
    instance = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, "friction")
    end = model.plugin_attradr[instance + 1] if instance + 1 < model.nplugin else None
    return model.plugin_attr[model.plugin_attradr[instance]:end]


def _forces(model: mujoco.MjModel, data: mujoco.MjData, steps: int = 50) -> np.ndarray:
    rows = []
    for _ in range(steps):
        mujoco.mj_step(model, data)
        rows.append(data.actuator_force.copy())
    return np.array(rows)


FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, state, FULL)
    return state


def _run_from(model: mujoco.MjModel, state: np.ndarray) -> np.ndarray:
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, FULL)
    return _forces(model, data)


TABLE_KEYS = ("table_xi", "table_angle", "table_along", "table_across")


@pytest.mark.parametrize("checksum", [False, True])
def test_two_tables_differ_only_in_the_middle_at_the_same_length(checksum):
    bytes_a = bytes(_config_bytes(_spec_with(_synthetic_table_config(1.0, checksum)).compile()))
    bytes_b = bytes(_config_bytes(_spec_with(_synthetic_table_config(0.5, checksum)).compile()))
    assert len(bytes_a) == len(bytes_b) and bytes_a != bytes_b
    assert bytes_a[:40] == bytes_b[:40]
    if not checksum:  # with one, the checksum (16 hex digits) ends the config and differs
        assert bytes_a[-40:] == bytes_b[-40:]


@pytest.mark.parametrize("checksum, named", [
    ("0" * 16, "'table_checksum'=\"0000000000000000\" is not the checksum of the table's values"),
    ("xyz", "'table_checksum'=\"xyz\" is not the checksum"),
    ("0x" + "1" * 14, "is not the checksum")])
def test_a_table_edited_after_its_checksum_was_made_is_refused(checksum, named):
    config = _synthetic_table_config(1.0, checksum=True)
    assert averaged.table_checksum(*(config[key] for key in TABLE_KEYS)) == config["table_checksum"]
    _spec_with(config).compile()  # the stated checksum is the plugin's
    config["table_checksum"] = checksum
    with pytest.raises(ValueError, match=named + ".*make it again with vibrofriction.robots.averaged"
                       ".build_table, or remove 'table_checksum'"):
        _spec_with(config).compile()


def test_a_checksum_with_a_0x_prefix_is_refused_even_when_its_value_matches():
    """strtoull would read "0x" + the last 14 digits of a checksum starting "00" as its value:
    the format is 16 hex digits exactly (a table whose checksum starts "00" is searched for)."""
    for k in range(4096):
        config = _synthetic_table_config(1.0 + 1e-3 * k, checksum=True)
        if config["table_checksum"].startswith("00"):
            break
    else:  # pragma: no cover - 1 in 256 a try
        pytest.fail("no table with a checksum starting 00 in 4096 tries")
    _spec_with(config).compile()
    config["table_checksum"] = "0x" + config["table_checksum"][2:]
    with pytest.raises(ValueError, match="is not the checksum"):
        _spec_with(config).compile()


def test_the_tables_build_table_writes_carry_their_checksum(dahl_table):
    config = dahl_table.config()
    assert len(config["table_checksum"]) == 16  # (the plugin's verdict: every compile here)
    edited = dict(config, table_along=config["table_along"].replace(" ", "  ", 1))
    assert averaged.table_checksum(*(edited[key] for key in TABLE_KEYS)) == \
        config["table_checksum"]  # the numbers, not their spelling


@pytest.mark.parametrize("checksum", [False, True])
def test_a_model_compiled_where_a_freed_one_lived_runs_its_own_table(checksum):
    """One MjData stepped with model A, A freed, B compiled (sometimes at A's address)
    differing only in the middle of its table at the same config length: B's table drives the
    run (the config cache compares the whole config -- or, with a table_checksum, everything
    but the table, the checksum included -- not the pointer or the edges)."""
    config_a = _synthetic_table_config(1.0, checksum)
    config_b = _synthetic_table_config(0.5, checksum)
    base = _spec_with(config_a).compile()  # the MjData's own model (MjData keeps it alive)
    rounds, reused = 5, 0
    for _ in range(rounds):
        data = mujoco.MjData(base)
        model_a = _spec_with(config_a).compile()
        _forces(model_a, data, 100)  # sliding: the table's middle is in use; A's config cached
        state = _state(base, data)
        address_a, spec_b = model_a._address, _spec_with(config_b)
        del model_a  # freed: B may be allocated at its address
        model_b = spec_b.compile()
        reused += model_b._address == address_a
        expected = _run_from(model_b, state)
        assert np.array_equal(_forces(model_b, data), expected)
        assert not np.array_equal(_run_from(base, state), expected)  # the tables matter here
    print(f"model B at freed model A's address in {reused} of {rounds} rounds")


@pytest.mark.parametrize("checksum", [False, True])
def test_a_table_changed_in_place_at_the_same_address_is_read_again(checksum):
    """The same-address case made certain: A's config bytes are overwritten with B's (same
    length, same edges) in the model the MjData was just stepped with. A cache keyed on the
    model pointer, or on a spot check of the edges, would keep running A's table."""
    model = _spec_with(_synthetic_table_config(1.0, checksum)).compile()
    data = mujoco.MjData(model)
    _forces(model, data, 100)
    state = _state(model, data)
    with_a = _run_from(model, state)
    model_b = _spec_with(_synthetic_table_config(0.5, checksum)).compile()
    _config_bytes(model)[:] = _config_bytes(model_b)
    expected = _run_from(model_b, state)
    assert not np.array_equal(with_a, expected)
    assert np.array_equal(_forces(model, data), expected)
