"""A machine in closed loop: the vibrofriction.sampled_pd controller, the EMPS scene, its records
and their identification by simulation (issue 17, item 5)."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

import vibrofriction
from vibrofriction import cli
from vibrofriction.data.convert import convert_emps
from vibrofriction.data.datasets import Dataset, DatasetMetadata, write_dataset
from vibrofriction.errors import InputError
from vibrofriction.identify.machine_replay import BUNDLED, closed_loop_errors
from vibrofriction.identify.replay import Replayer
from vibrofriction.identify.replays import prepare_replay
from vibrofriction.identify.simulation import identify_by_simulation
from vibrofriction.params import FrictionParameters

EMPS_MAT = Path(__file__).resolve().parents[2] / "shared" / "data" / "emps" / "DATA_EMPS.mat"
EMPS_XML = BUNDLED["emps"]
CONTROLLER = {"position_gain": 160.18, "velocity_gain": 243.45, "drive_gain": 35.15,
              "saturation": 10.0, "sample_period": 1e-3}


def _need_emps() -> Path:
    if not EMPS_MAT.is_file():
        pytest.skip(f"EMPS data not found at {EMPS_MAT} (the shared data folder is absent)")
    return EMPS_MAT


def _controller_spec(substeps: int = 4, **config) -> mujoco.MjSpec:
    """A 2 kg carriage, no friction, under the sampled PD (EMPS gains unless overridden)."""
    vibrofriction.load()
    values = {**CONTROLLER, **config}
    spec = mujoco.MjSpec.from_string(f"""
<mujoco>
  <option timestep="{values['sample_period'] / substeps!r}" integrator="Euler"/>
  <extension><plugin plugin="vibrofriction.sampled_pd"><instance name="pd">
    {''.join(f'<config key="{k}" value="{v!r}"/>' for k, v in values.items())}
  </instance></plugin></extension>
  <worldbody><body name="b"><joint name="x" type="slide" axis="1 0 0"/>
    <inertial pos="0 0 0" mass="2" diaginertia="1 1 1"/></body></worldbody>
  <actuator><plugin name="motor" joint="x" instance="pd"/></actuator>
</mujoco>""")
    return spec


def _run_controller(model: mujoco.MjModel, substeps: int, reference: np.ndarray):
    """Positions and forces at every sample's first step."""
    data = mujoco.MjData(model)
    q, force = [], []
    for r in reference:
        data.ctrl[0] = r
        q.append(float(data.qpos[0]))
        mujoco.mj_step(model, data)
        force.append(float(data.actuator_force[0]))
        for _ in range(substeps - 1):
            mujoco.mj_step(model, data)
            assert data.actuator_force[0] == force[-1]  # held between samples
    return np.array(q), np.array(force)


@pytest.mark.parametrize("delay", [0, 1])
def test_sampled_pd_applies_its_documented_law_held_over_each_sample(delay):
    substeps = 4
    model = _controller_spec(substeps, command_delay=delay).compile()
    n = 400
    reference = 0.02 * np.sin(np.linspace(0, 6, n)) ** 2
    q, force = _run_controller(model, substeps, reference)
    T = CONTROLLER["sample_period"]
    filtered = 0.5 * (q + np.r_[q[0], q[:-1]])  # at rest before the first sample
    velocity = np.diff(np.r_[filtered[0], filtered]) / T
    law = CONTROLLER["velocity_gain"] * (CONTROLLER["position_gain"] * (reference - q) -
                                         velocity)
    applied = law if delay == 0 else np.r_[0.0, law[:-1]]
    expected = CONTROLLER["drive_gain"] * np.clip(applied, -10, 10)
    assert np.max(np.abs(force - expected)) <= 1e-9 * np.max(np.abs(expected))
    assert np.any(np.abs(applied) > 10)  # the saturation was exercised


@pytest.mark.parametrize("changes, attribute, fix", [
    ({"velocity_gain": 0.0}, "velocity_gain", "must be > 0"),
    ({"command_delay": 2.0}, "command_delay", "0 or 1"),
    ({"sample_period": 1e-6}, "sample_period", "at least the model's timestep"),
    ({"saturation": -1.0}, "saturation", ">= 0"),
])
def test_sampled_pd_bad_config_is_named(changes, attribute, fix):
    spec = _controller_spec(4, **{k: v for k, v in changes.items() if k != "sample_period"})
    if "sample_period" in changes:
        spec.option.timestep = 1e-4
        plugin = spec.plugins[0]
        plugin.config = {**dict(plugin.config), "sample_period": "1e-6"}
    with pytest.raises(ValueError) as info:
        spec.compile()
    message = str(info.value)
    assert "vibrofriction.sampled_pd" in message and attribute in message and fix in message


def test_the_emps_scene_compiles_alone_and_holds_still_at_its_reference():
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_path(str(EMPS_XML))
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("motor").id] = 0.0
    mujoco.mj_step(model, data, 2000)
    assert abs(data.qpos[0]) < 1e-6 and abs(data.qvel[0]) < 1e-6


# ----------------------------------------------------------------------------------- EMPS data

@pytest.fixture(scope="module")
def emps():
    return convert_emps(_need_emps())


def test_convert_keeps_the_reference_and_names_the_model(emps):
    assert {"reference_position_m", "position_m", "drive_force_N"} <= set(emps.columns)
    assert emps.metadata.model == "emps"
    # the controller tracks its reference to well under a millimetre
    error = emps.columns["reference_position_m"] - emps.columns["position_m"]
    assert np.max(np.abs(error)) < 1e-3


def test_the_published_emps_model_in_closed_loop_beats_its_published_simulation(emps):
    # IDIM-LS values simulated in the scene with the plugin, the controller on the record's
    # clock: the description's own simulation reaches 5.85 % (force), 0.0138 % (position).
    replay = prepare_replay(emps, substeps=2)
    friction = FrictionParameters(law="coulomb", friction_coefficient=20.3935,
                                  viscous_N_s_per_m=203.5034, force_offset_N=-3.1648)
    with Replayer(replay) as runner:
        predicted = runner.run([(replace(replay.rig, mass_kg=95.1089), friction)],
                               ("velocity_m_per_s",))[0]
    errors = closed_loop_errors(replay, predicted)
    assert errors["force_relerr_pct"] < 5.85
    assert errors["position_relerr_pct"] < 0.0138
    assert errors["velocity_relerr_pct"] < 1.0


# ------------------------------------------------------------------------ identification

def _synthetic_emps_record(tmp_path: Path, seconds: float = 4.0) -> tuple[Path, dict]:
    """The EMPS scene with known values, driven by a bang-bang-like reference, sampled at 1 kHz
    with position quantization and force noise."""
    truth = {"mass_kg": 80.0, "friction_coefficient": 25.0, "viscous_N_s_per_m": 150.0}
    t = np.arange(int(seconds * 1000)) * 1e-3
    # from rest, within the controller's range (a jump saturates it for a while)
    reference = 0.1 * (1 - np.cos(2 * np.pi * t / 2.0)) + \
        0.02 * (1 - np.cos(2 * np.pi * 1.3 * t))
    record = Dataset(name="synthetic_emps", columns={
        "time_s": t, "position_m": np.zeros_like(t), "drive_force_N": np.zeros_like(t),
        "reference_position_m": reference}, metadata=DatasetMetadata(model="emps"))
    replay = prepare_replay(record, substeps=4)
    friction = FrictionParameters(law="coulomb",
                                  friction_coefficient=truth["friction_coefficient"],
                                  viscous_N_s_per_m=truth["viscous_N_s_per_m"])
    with Replayer(replay) as runner:
        out = runner.run([(replace(replay.rig, mass_kg=truth["mass_kg"]), friction)])[0]
    rng = np.random.default_rng(7)
    columns = {"time_s": t, "position_m": np.round(out["position_m"] / 5e-8) * 5e-8,
               "drive_force_N": out["drive_force_N"] + 0.3 * rng.standard_normal(len(t)),
               "reference_position_m": reference}
    meta = DatasetMetadata(model="emps", simulation_timestep_s=1e-3 / 4)
    path = tmp_path / "synthetic_emps.csv"
    write_dataset(Dataset(name="synthetic_emps", columns=columns, metadata=meta), path)
    return path, truth


def test_a_machine_record_round_trips_through_its_closed_loop(tmp_path):
    from vibrofriction.data.datasets import read_dataset
    from vibrofriction.identify import simulation_report
    path, truth = _synthetic_emps_record(tmp_path)
    result = identify_by_simulation(read_dataset(path), law="coulomb", declared=["viscous"])
    for name, value in truth.items():
        assert result.final.values[name] == pytest.approx(value, rel=0.01), name
    assert result.selected == []
    assert result.closed_loop["final"]["train"]["force_relerr_pct"] < 1.0
    # the fitted scene written with the report loads and runs the fitted values
    out = simulation_report.write_report(result, tmp_path / "report", figures=False)
    model = mujoco.MjModel.from_xml_path(str(out / "fitted_model.xml"))
    assert model.body("carriage").mass[0] == pytest.approx(result.final.values["mass_kg"])
    report = json.loads((out / "report.json").read_text())
    assert report["closed_loop"]["model"] == "emps"


def test_a_fitted_scene_at_one_step_a_sample_loads(emps):
    # MJCF keeps 6 digits of the timestep: 0.00099998... may be written rounded up past the
    # controller's sample period, which must still load
    from vibrofriction.identify.machine_replay import MachineReplay
    replay = prepare_replay(emps, substeps=1)
    assert isinstance(replay, MachineReplay)
    xml = replay.spec(replace(replay.rig, mass_kg=95.0),
                      FrictionParameters(law="coulomb", friction_coefficient=20.0)).to_xml()
    mujoco.MjModel.from_xml_string(xml)


def test_machine_record_errors_are_clear_and_write_nothing(tmp_path, capsys):
    t = np.arange(100) * 1e-3
    columns = {"time_s": t, "position_m": np.zeros_like(t), "drive_force_N": np.zeros_like(t)}
    unknown = Dataset(name="r", columns={**columns, "reference_position_m": np.zeros_like(t)},
                      metadata=DatasetMetadata(model="lathe"))
    with pytest.raises(InputError, match=r"model 'lathe' names no bundled model and no .xml"):
        prepare_replay(unknown)
    no_reference = Dataset(name="r", columns=columns, metadata=DatasetMetadata(model="emps"))
    with pytest.raises(InputError, match="needs reference_position_m"):
        prepare_replay(no_reference)
    velocity_only = Dataset(name="r", metadata=DatasetMetadata(model="emps"), columns={
        "time_s": t, "velocity_m_per_s": np.zeros_like(t), "drive_force_N": np.zeros_like(t),
        "reference_position_m": np.zeros_like(t)})
    with pytest.raises(InputError, match="needs position_m"):
        prepare_replay(velocity_only)
    moving = {"time_s": t, "position_m": 1e-3 * np.sin(20 * t),
              "drive_force_N": np.sin(50 * t), "reference_position_m": 1e-3 * np.sin(20 * t)}
    machine = Dataset(name="m", metadata=DatasetMetadata(model="emps"), columns=moving)
    with pytest.raises(InputError, match="drive_damping: not an effect of this record's model"):
        identify_by_simulation(machine, law="coulomb", declared=["drive_damping"])
    rig_record = Dataset(name="rig", columns={c: moving[c] for c in columns},
                         metadata=DatasetMetadata(
        model="rig", drive_stiffness_N_per_m=1e6, drive_velocity_m_per_s=5e-4))
    assert type(prepare_replay(rig_record)).__name__ == "RigReplay"  # "rig" is the default
    with pytest.raises(InputError, match=r"must be of the training record's model \(emps\)"):
        identify_by_simulation(machine, [rig_record], law="coulomb")
    path = tmp_path / "no_reference.csv"
    write_dataset(Dataset(name="r", metadata=DatasetMetadata(model="emps"), columns={
        c: v for c, v in moving.items() if c != "reference_position_m"}), path)
    before = sorted(p.name for p in tmp_path.iterdir())
    code = cli.main(["identify", str(path), "--out", str(tmp_path / "out")])
    assert code == 2
    err = capsys.readouterr().err
    assert "reference_position_m" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("unit", ["V", "N"])
def test_emps_pulses_become_the_force_the_command_shows(tmp_path, unit):
    """A validation-style .mat: the logged command is the controller law plus pulses; the
    converter reads their unit from the data."""
    from scipy.io import savemat
    from vibrofriction.data.convert import convert_emps as convert
    n, T, gtau = 2000, 1e-3, 35.15
    t = np.arange(n) * T
    rng = np.random.default_rng(3)
    q = 0.1 * (1 - np.cos(2 * np.pi * t)) + 1e-6 * rng.standard_normal(n)
    r = q + 1e-4 * np.sin(2 * np.pi * 3 * t)
    filtered = np.r_[q[0], 0.5 * (q[1:] + q[:-1])]
    law = 243.45 * (160.18 * (r - q) - np.r_[0.0, np.diff(filtered) / T])
    pulses_V = 5.0 * (np.sin(2 * np.pi * 2 * t) > 0)
    pulses = pulses_V if unit == "V" else gtau * pulses_V
    path = tmp_path / "pulses.mat"
    savemat(path, {"t": t[:, None], "qm": q[:, None], "qg": r[:, None],
                   "vir": (law + pulses_V)[:, None], "pulses_N": pulses[:, None],
                   "gtau": gtau, "kp": 160.18, "kv": 243.45})
    record = convert(path)
    np.testing.assert_allclose(record.columns["feedforward_force_N"], gtau * pulses_V)


def test_a_record_starting_in_motion_starts_its_controller_in_motion(emps):
    # the second half of the record starts at -43 mm/s: a controller filter started at rest
    # would command hundreds of N for a sample or two
    n = emps.n_rows // 2
    half = Dataset(name="second_half", metadata=emps.metadata,
                   columns={c: np.asarray(v)[n:] for c, v in emps.columns.items()})
    replay = prepare_replay(half, substeps=2)
    assert abs(replay.initial_velocity_m_per_s) > 0.02
    friction = FrictionParameters(law="coulomb", friction_coefficient=20.3935,
                                  viscous_N_s_per_m=203.5034, force_offset_N=-3.1648)
    with Replayer(replay) as runner:
        out = runner.run([(replace(replay.rig, mass_kg=95.1089), friction)])[0]
    error = out["drive_force_N"] - replay.measured["drive_force_N"]
    first, rest = (float(np.sqrt(np.mean(e ** 2))) for e in (error[:50], error[50:]))
    assert first < 4 * rest


USER_SCENE = """
<mujoco model="pushed block">
  <option timestep="2.5e-4" integrator="Euler"/>
  <extension><plugin plugin="vibrofriction.friction"><instance name="guide_friction">
    <config key="law" value="coulomb"/><config key="normal" value="1"/>
    <config key="mu" value="1"/>
  </instance></plugin></extension>
  <custom>
    <text name="vibrofriction:joint" data="slide"/>
    <text name="vibrofriction:body" data="block"/>
    <text name="vibrofriction:input:drive_force_N" data="push"/>
    <text name="vibrofriction:output:position_m" data="x"/>
  </custom>
  <worldbody><body name="block"><joint name="slide" type="slide" axis="1 0 0"/>
    <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody>
  <actuator>
    <motor name="push" joint="slide"/>
    <plugin name="friction" joint="slide" instance="guide_friction" actdim="1"/>
  </actuator>
  <sensor><jointpos name="x" joint="slide"/></sensor>
</mujoco>
"""


def test_identify_against_a_users_scene_driven_by_its_measured_force(tmp_path, capsys):
    """--model SCENE.xml: a block pushed by a measured force (an input of the scene), its
    position measured; mass, Coulomb level and viscous come back from the position alone."""
    from vibrofriction.identify.machine_replay import MachineScene
    scene = tmp_path / "pushed_block.xml"
    scene.write_text(USER_SCENE)
    truth = {"mass_kg": 2.0, "friction_coefficient": 3.0, "viscous_N_s_per_m": 4.0}
    t = np.arange(3000) * 1e-3
    push = 5.0 * np.sin(2 * np.pi * 1.0 * t) + 1.0 * np.sin(2 * np.pi * 3.7 * t)
    columns = {"time_s": t, "position_m": np.zeros_like(t), "drive_force_N": push}
    meta = DatasetMetadata(model=str(scene), simulation_timestep_s=2.5e-4)
    replay = prepare_replay(Dataset(name="b", columns=columns, metadata=meta))
    assert replay.scene == MachineScene.from_file(scene) and replay.channels == ("position_m",)
    friction = FrictionParameters(law="coulomb",
                                  friction_coefficient=truth["friction_coefficient"],
                                  viscous_N_s_per_m=truth["viscous_N_s_per_m"])
    with Replayer(replay) as runner:
        out = runner.run([(replace(replay.rig, mass_kg=truth["mass_kg"]), friction)])[0]
    assert np.ptp(out["position_m"]) > 0.02  # it slides, and sticks at the reversals
    rng = np.random.default_rng(11)
    columns["position_m"] = out["position_m"] + 1e-6 * rng.standard_normal(len(t))
    path = tmp_path / "pushed.csv"
    write_dataset(Dataset(name="pushed", columns=columns, metadata=DatasetMetadata(
        simulation_timestep_s=2.5e-4)), path)
    code = cli.main(["identify", str(path), "--model", str(scene), "--law", "coulomb",
                     "--with", "viscous", "--out", str(tmp_path / "out"), "--no-figures"])
    assert code == 0, capsys.readouterr().err
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    fitted = report["final"]["parameters"]
    for name, value in truth.items():
        assert fitted[name] == pytest.approx(value, rel=0.01), name
    assert report["selected_effects"] == []
    # the fitted scene is the user's, values changed, no probe sensors added
    xml = (tmp_path / "out" / "fitted_model.xml").read_text()
    assert "vibrofriction_position" not in xml and "guide_friction" in xml


def test_a_users_scene_without_its_mapping_is_a_clear_error(tmp_path):
    from vibrofriction.identify.machine_replay import machine
    scene = tmp_path / "bare.xml"
    scene.write_text(USER_SCENE.replace('<text name="vibrofriction:joint" data="slide"/>', ""))
    with pytest.raises(InputError, match='say which joint.*vibrofriction:joint'):
        machine(str(scene))
    scene.write_text(USER_SCENE.replace('data="push"', 'data="no_such_actuator"'))
    with pytest.raises(InputError, match="'no_such_actuator', which is no actuator"):
        machine(str(scene))
    with pytest.raises(InputError, match="does not exist"):
        machine(str(tmp_path / "missing.xml"))
    t = np.arange(100) * 1e-3
    scene.write_text(USER_SCENE)
    record = Dataset(name="r", metadata=DatasetMetadata(model=str(scene)), columns={
        "time_s": t, "position_m": np.zeros_like(t), "drive_force_N": np.zeros_like(t),
        "reference_position_m": np.zeros_like(t)})
    with pytest.raises(InputError, match="has reference_position_m, which the model"):
        prepare_replay(record)


def test_a_scene_keeps_its_own_normal_load_and_needs_named_plugins(tmp_path):
    from vibrofriction.identify.machine_replay import machine
    scene = tmp_path / "loaded.xml"
    scene.write_text(USER_SCENE.replace('<config key="normal" value="1"/>',
                                        '<config key="normal" value="40"/>'))
    t = np.arange(100) * 1e-3
    record = Dataset(name="r", metadata=DatasetMetadata(model="loaded.xml"), columns={
        "time_s": t, "position_m": 1e-3 * np.sin(20 * t), "drive_force_N": np.sin(50 * t)})
    path = tmp_path / "r.csv"
    write_dataset(record, path)
    from vibrofriction.data.datasets import read_dataset
    replay = prepare_replay(read_dataset(path))  # the sidecar's path is the record's folder's
    assert replay.scene.path == scene.resolve() and replay.rig.normal_force_N == 40.0
    spec = replay.spec(replace(replay.rig, mass_kg=1.0),
                       FrictionParameters(law="coulomb", friction_coefficient=0.1),
                       probes=False)
    config = dict(next(p for p in spec.plugins if p.name == "guide_friction").config)
    assert float(config["normal"]) == 40.0 and float(config["mu"]) == 0.1
    inline = tmp_path / "inline.xml"
    bare = USER_SCENE[:USER_SCENE.index("  <extension>")] + \
        '  <extension><plugin plugin="vibrofriction.friction"/></extension>\n' + \
        USER_SCENE[USER_SCENE.index("  <custom>"):]
    inline.write_text(bare.replace(
        '<plugin name="friction" joint="slide" instance="guide_friction" actdim="1"/>',
        '<plugin name="friction" joint="slide" plugin="vibrofriction.friction" actdim="1">'
        '<config key="law" value="coulomb"/><config key="mu" value="1"/></plugin>'))
    with pytest.raises(InputError, match="has no instance name"):
        machine(str(inline))
    typo = tmp_path / "typo.xml"
    typo.write_text(USER_SCENE.replace("vibrofriction:body", "vibrofriction:bdy"))
    with pytest.raises(InputError, match="vibrofriction:bdy is not a key"):
        machine(str(typo))


def test_the_friction_actuator_must_be_a_friction_element(tmp_path):
    from vibrofriction.identify.machine_replay import machine
    scene = tmp_path / "wrong.xml"
    scene.write_text(USER_SCENE.replace(
        '<plugin plugin="vibrofriction.friction"><instance name="guide_friction">',
        '<plugin plugin="vibrofriction.motion"><instance name="guide_friction">').replace(
        '<config key="law" value="coulomb"/><config key="normal" value="1"/>\n'
        '    <config key="mu" value="1"/>', '').replace(' actdim="1"', ""))
    with pytest.raises(InputError, match="must be backed by a named vibrofriction.friction"):
        machine(str(scene))


def test_fitted_values_never_leave_the_vocabulary_limits():
    from vibrofriction.identify.model import Scales, parameter_table
    from vibrofriction.params import LIMITS
    # a few um of travel at 10 N: the stiffness bound is the vocabulary's limit, 1e18 N/m
    scales = Scales(force_N=10.0, velocity_m_per_s=1e-3, normal_force_N=1.0, dt_s=1e-5,
                    travel_m=1e-6)
    for param in parameter_table("dahl", [], True, scales):
        lo, hi = param.internal_bounds()
        for q in (lo, hi, hi + 1.0):
            value = param.from_internal(q)
            if param.name in LIMITS:
                assert abs(value) <= LIMITS[param.name][1], param.name
            assert param.lower <= value <= param.upper, param.name


def test_a_users_scene_gives_back_a_joint_damping_it_names(tmp_path, capsys):
    """vibrofriction:damping names a slide joint whose damping is fitted with the friction and
    the mass (a named value of the scene, written into fitted_model.xml); the friction
    element's viscous candidate, the same force, is then not selected."""
    import xml.etree.ElementTree as ET
    scene = tmp_path / "damped_block.xml"
    scene.write_text(USER_SCENE.replace(
        '<text name="vibrofriction:body" data="block"/>',
        '<text name="vibrofriction:body" data="block"/>\n'
        '    <text name="vibrofriction:damping" data="slide"/>'))
    truth = {"mass_kg": 2.0, "friction_coefficient": 3.0, "joint_damping_N_s_per_m": 4.0}
    t = np.arange(3000) * 1e-3
    push = 5.0 * np.sin(2 * np.pi * 1.0 * t) + 1.0 * np.sin(2 * np.pi * 3.7 * t)
    columns = {"time_s": t, "position_m": np.zeros_like(t), "drive_force_N": push}
    meta = DatasetMetadata(model=str(scene), simulation_timestep_s=2.5e-4)
    replay = prepare_replay(Dataset(name="b", columns=columns, metadata=meta))
    assert replay.fitted_scene_values == ("joint_damping_N_s_per_m",)
    friction = FrictionParameters(law="coulomb",
                                  friction_coefficient=truth["friction_coefficient"])
    with Replayer(replay) as runner:
        out = runner.run([(replace(replay.rig, mass_kg=truth["mass_kg"]), friction, {},
                           {"joint_damping_N_s_per_m": 4.0})])[0]
    rng = np.random.default_rng(12)
    columns["position_m"] = out["position_m"] + 1e-6 * rng.standard_normal(len(t))
    path = tmp_path / "damped.csv"
    write_dataset(Dataset(name="damped", columns=columns, metadata=DatasetMetadata(
        simulation_timestep_s=2.5e-4)), path)
    code = cli.main(["identify", str(path), "--model", str(scene), "--law", "coulomb",
                     "--out", str(tmp_path / "out"), "--no-figures"])
    assert code == 0, capsys.readouterr().err
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    fitted = report["final"]["parameters"]
    for name, value in truth.items():
        assert fitted[name] == pytest.approx(value, rel=0.01), name
    assert report["selected_effects"] == []
    joint = ET.parse(tmp_path / "out" / "fitted_model.xml").find(".//joint[@name='slide']")
    linear = float(joint.get("damping").split()[0])  # (MuJoCo 4: linear, then higher orders)
    assert linear == pytest.approx(fitted["joint_damping_N_s_per_m"])


def test_a_damping_that_names_no_slide_joint_is_refused(tmp_path):
    from vibrofriction.identify.machine_replay import MachineScene
    scene = tmp_path / "hinge.xml"
    scene.write_text(USER_SCENE.replace(
        '<text name="vibrofriction:body" data="block"/>',
        '<text name="vibrofriction:body" data="block"/>\n'
        '    <text name="vibrofriction:damping" data="turn"/>').replace(
        '<inertial', '<joint name="turn" type="hinge" axis="0 0 1"/><inertial'))
    with pytest.raises(InputError, match="'turn', which is not a slide joint"):
        MachineScene.from_file(scene)
