"""Law gms is identifiable like the others (issue 39): fitted as a total stiffness and the
spread of its elements' break-away deflections (``model.gms_elements``), on the inverse path
and in a replayed scene."""
from __future__ import annotations

import json
from functools import partial

import mujoco
import numpy as np
import pytest

import vibrofriction
from conftest import carriage_scene_xml
from vibrofriction import cli
from vibrofriction.data.datasets import Dataset, DatasetMetadata, write_dataset
from vibrofriction.identify import identify
from vibrofriction.identify.model import gms_elements
from vibrofriction.identify.replay import Replayer
from vibrofriction.identify.replays import prepare_replay
from vibrofriction.laws import run_law
from vibrofriction.params import FrictionParameters

LEVEL_N = 38.0
TOTAL_STIFFNESS = 2e5
SPREAD = 20.0


def _truth() -> FrictionParameters:
    stiffness, weights = gms_elements(TOTAL_STIFFNESS, SPREAD)
    return FrictionParameters(law="gms", friction_coefficient=LEVEL_N,
                              gms_stiffness_N_per_m=stiffness, gms_weights=weights).validate()


def test_the_elements_have_the_total_stiffness_and_the_spread():
    stiffness, weights = gms_elements(TOTAL_STIFFNESS, SPREAD)
    assert sum(stiffness) == pytest.approx(TOTAL_STIFFNESS, rel=1e-12)
    breakaway = [w * LEVEL_N / k for w, k in zip(weights, stiffness)]
    assert breakaway[-1] / breakaway[0] == pytest.approx(SPREAD, rel=1e-12)
    assert sum(weights) == pytest.approx(1.0)
    # spread 1: every element lets go at once (one deflection, the elasto-plastic limit)
    assert np.ptp([w / k for w, k in zip(*gms_elements(TOTAL_STIFFNESS, 1.0))]) == 0.0


def _strokes(tmp_path=None) -> Dataset:
    """Strokes with small reversals (presliding loops) at 2 kHz, friction measured with
    0.1 N of noise, made by the law itself."""
    rate = 2000.0
    t = np.arange(4000) / rate
    v = 0.02 * np.sin(2 * np.pi * 0.5 * t) + 0.004 * np.sin(2 * np.pi * 3.1 * t)
    force = run_law(_truth(), t, v, normal_force_N=1.0).friction_force_N
    noise = 0.1 * np.random.default_rng(2).standard_normal(t.size)
    return Dataset(name="gms_strokes", metadata=DatasetMetadata(), columns={
        "time_s": t, "velocity_m_per_s": v, "position_m": np.cumsum(v) / rate,
        "friction_force_N": force + noise})


def test_inverse_path_gives_back_the_level_stiffness_and_spread():
    result = identify(_strokes(), law="gms")
    values = result.final.values
    # noise 0.1 N on a 38 N level over 4000 samples: the values within a few of their SE
    assert values["friction_coefficient"] == pytest.approx(LEVEL_N, rel=2e-3)
    assert values["contact_stiffness_N_per_m"] == pytest.approx(TOTAL_STIFFNESS, rel=3e-2)
    assert values["gms_spread"] == pytest.approx(SPREAD, rel=5e-2)
    assert result.selected == []


def test_cli_takes_law_gms_and_reports_the_elements(tmp_path, capsys):
    path = tmp_path / "strokes.csv"
    write_dataset(_strokes(), path)
    code = cli.main(["identify", str(path), "--law", "gms", "--method", "inverse",
                     "--out", str(tmp_path / "out"), "--no-figures"])
    assert code == 0, capsys.readouterr().err
    parameters = json.loads((tmp_path / "out" / "report.json").read_text())["final"][
        "parameters"]
    assert len(parameters["gms_stiffness_N_per_m"]) == 3
    assert sum(parameters["gms_stiffness_N_per_m"]) == pytest.approx(
        parameters["contact_stiffness_N_per_m"], rel=1e-9)
    assert parameters["gms_spread"] > 1.0


def test_a_scene_with_one_deflection_replays_law_gms(tmp_path):
    """A user's scene declares one deflection (Coulomb, actdim 1): the replay of law gms gives
    its friction actuator one per element, and at the true values follows a record the gms
    scene made."""
    vibrofriction.load()
    truth = _truth()
    scene_xml = partial(carriage_scene_xml, mass_kg=5.0, timestep_s=2.5e-4,
                        measured="position_m")
    model = mujoco.MjModel.from_xml_string(scene_xml(truth, actdim=3))
    data = mujoco.MjData(model)
    t = np.arange(1500) * 1e-3
    push = 45 * np.sin(2 * np.pi * 1.0 * t) + 8 * np.sin(2 * np.pi * 3.7 * t)
    x = np.empty_like(t)
    for i in range(t.size):
        x[i] = data.qpos[0]
        data.ctrl[0] = push[i]
        mujoco.mj_step(model, data, 4)
    scene = tmp_path / "carriage.xml"
    scene.write_text(scene_xml(FrictionParameters(law="coulomb", friction_coefficient=LEVEL_N)))
    record = Dataset(name="pushed", columns={"time_s": t, "position_m": x, "drive_force_N": push},
                     metadata=DatasetMetadata(model=str(scene), mass_kg=5.0,
                                              simulation_timestep_s=2.5e-4))
    replay = prepare_replay(record)
    assert replay.model(replay.rig, truth).actuator("friction").actnum[0] == 3
    with Replayer(replay) as runner:
        out = runner.run([(replay.rig, truth)])[0]["position_m"]
    # the same scene and step; only the replay's start (its estimated first velocity) differs
    assert np.sqrt(np.mean((out - x) ** 2)) < 1e-3 * np.ptp(x)
