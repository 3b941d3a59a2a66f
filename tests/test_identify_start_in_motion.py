"""A record that starts in motion (a held-out part cut mid-push, another lab's record) starts
every state law at its steady sliding state, on the inverse path and in a replayed scene.

At z = 0 a LuGre contact sliding at 0.6 m/s loads its bristles with a damping force sigma1 v
far above the friction level (the issue: a 1.9-4.7 kN one-sample spike, 500-970 % held out).
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

import vibrofriction
from conftest import carriage_scene_xml
from vibrofriction.data.datasets import Dataset, DatasetMetadata
from vibrofriction.identify import identify
from vibrofriction.identify.model import Model, Scales
from vibrofriction.identify.record import prepare
from vibrofriction.identify.replay import Replayer
from vibrofriction.identify.replays import prepare_replay
from vibrofriction.identify.simulation import identify_by_simulation
from vibrofriction.identify.start import starts_in_motion
from vibrofriction.laws import run_law, steady_deflection_m
from vibrofriction.params import FrictionParameters, default_friction

NORMAL_N = 1.0  # the friction coefficient is the level in N
LEVEL_N = 38.0
MASS_KG = 24.7
RATE_HZ = 1500.0


def _law(law: str) -> FrictionParameters:
    """A machine's guide: presliding resolved at 1.5 kHz (2e5 N/m: 0.19 mm of deflection)."""
    friction = replace(default_friction(law), friction_coefficient=LEVEL_N,
                       contact_stiffness_N_per_m=2e5, viscous_N_s_per_m=45.0)
    if law == "lugre":
        friction = replace(friction, bristle_damping_N_s_per_m=2e3, static_ratio=1.3,
                           stribeck_velocity_m_per_s=0.02)
    if law == "gms":
        friction = replace(friction, gms_stiffness_N_per_m=(2e5, 1e5, 5e4),
                           gms_weights=(0.2, 0.3, 0.5))
    return friction.validate()


@pytest.mark.parametrize("law,alpha", [("lugre", 1.0), ("dahl", 1.0), ("dahl", 0.5),
                                       ("dupont", 1.0)])
def test_steady_deflection_is_the_laws_sliding_state(law, alpha):
    """z_ss = sgn(v) g(v) / sigma0 (the level g with its Stribeck curve), from either side."""
    friction = replace(_law(law), alpha=alpha)
    for v in (0.3, -0.004, 2.0):
        g = LEVEL_N * NORMAL_N
        if law == "lugre":
            g *= 1.0 + (friction.static_ratio - 1.0) * math.exp(
                -(v / friction.stribeck_velocity_m_per_s) ** 2)
        z = steady_deflection_m(friction, v, normal_force_N=NORMAL_N)
        assert z == pytest.approx(math.copysign(g, v) / friction.contact_stiffness_N_per_m,
                                  rel=1e-9)
    assert steady_deflection_m(friction, 0.0, normal_force_N=NORMAL_N) == 0.0
    assert steady_deflection_m(_law("coulomb"), 0.5, normal_force_N=NORMAL_N) == 0.0


def test_gms_elements_start_at_their_sliding_deflections():
    friction = _law("gms")
    z = steady_deflection_m(friction, -0.2, normal_force_N=NORMAL_N)
    expected = [-w * LEVEL_N / k for w, k in zip(friction.gms_weights,
                                                 friction.gms_stiffness_N_per_m)]
    assert z == pytest.approx(expected, rel=1e-9)


def _push_velocity(t: np.ndarray) -> np.ndarray:
    """A push: accelerate from rest to 0.85 m/s, brake to rest (smooth)."""
    return 0.85 * np.sin(np.pi * np.clip(t / 1.2, 0.0, 1.0)) ** 2


def test_start_in_motion_is_told_from_a_start_at_rest():
    rng = np.random.default_rng(4)
    t = np.arange(1500) / RATE_HZ
    v = _push_velocity(t)
    noise = 2e-4 * rng.standard_normal(t.size)
    x = np.cumsum(v) / RATE_HZ
    assert not starts_in_motion(t, x, v + noise)  # at rest, sensor noise only
    assert not starts_in_motion(t, x, None)  # the same from the position
    cut = 900  # decelerating through ~0.5 m/s
    assert starts_in_motion(t[cut:], x[cut:], v[cut:] + noise[cut:])
    assert starts_in_motion(t[cut:], x[cut:], None)


@pytest.mark.parametrize("law", ["lugre", "dahl", "dupont"])
def test_inverse_prediction_of_a_record_cut_mid_motion(law):
    """The friction the law makes over a whole push, cut mid-motion: predicted on the cut part
    alone (its state not in the record), it follows the whole push's own from the first
    sample; started at z = 0 it would not (LuGre: its damping's spike)."""
    friction = _law(law)
    t = np.arange(int(1.3 * RATE_HZ)) / RATE_HZ
    v = _push_velocity(t)
    whole = run_law(friction, t, v, normal_force_N=NORMAL_N).friction_force_N
    cut = int(0.85 * RATE_HZ)
    part = t[cut:] - t[cut]
    dataset = Dataset(name="cut", columns={
        "time_s": part, "velocity_m_per_s": v[cut:], "position_m": np.cumsum(v[cut:]) / RATE_HZ,
        "friction_force_N": whole[cut:]}, metadata=DatasetMetadata(normal_force_N=NORMAL_N))
    record = prepare(dataset, substeps=4)
    assert record.starts_in_motion
    model = Model.build(law, [], False, Scales.of(record, LEVEL_N), base=friction)
    values = {name: getattr(friction, name) for name in model.names}
    predicted = model.predict_values(record, values)
    # the law's step is first order in the grid spacing along a slowly varying speed
    assert np.max(np.abs(predicted - whole[cut:])) < 2e-2 * LEVEL_N
    at_rest = run_law(friction, record.grid_time_s, record.grid_velocity_m_per_s,
                      normal_force_N=NORMAL_N).friction_force_N[::record.stride]
    if law == "lugre":  # what the fix removes: sigma1 v at the first sample
        assert np.max(np.abs(at_rest - whole[cut:])) > 10 * LEVEL_N


def _scene_xml(friction: FrictionParameters) -> str:
    """The 24.7 kg carriage with this friction, its velocity measured, at 4 steps a sample."""
    return carriage_scene_xml(friction, mass_kg=MASS_KG, timestep_s=1 / RATE_HZ / 4,
                              measured="velocity_m_per_s", normal_N=NORMAL_N)


def _push(scene: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time, force, velocity) of a push from rest to rest, run in the scene at 1.5 kHz."""
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_path(str(scene))
    data = mujoco.MjData(model)
    t = np.arange(int(1.6 * RATE_HZ)) / RATE_HZ
    force = np.interp(t, [0, .2, .5, .9, 1.1, 1.3, 1.6], [0, 60, 95, 95, -20, -10, 0])
    velocity = np.empty_like(t)
    for i in range(t.size):
        velocity[i] = data.qvel[0]
        data.ctrl[0] = force[i]
        mujoco.mj_step(model, data, 4)
    return t, force, velocity


def _cut_push(law: str, tmp_path: Path, rng) -> tuple[Path, Dataset, Dataset]:
    """The push with sensor noise on force and velocity: train on rest and the push, hold out
    the braking, which starts at 0.64 m/s (as the issue's record)."""
    scene = tmp_path / f"carriage_{law}.xml"
    scene.write_text(_scene_xml(_law(law)))
    t, force, velocity = _push(scene)
    peak = int(np.argmax(velocity))
    cut = peak + int(np.argmax(velocity[peak:] < 0.64))
    noisy_force = force + 0.3 * rng.standard_normal(t.size)
    noisy_velocity = velocity + 2e-4 * rng.standard_normal(t.size)
    position = np.cumsum(velocity) / RATE_HZ
    meta = DatasetMetadata(mass_kg=MASS_KG, sample_rate_Hz=RATE_HZ)
    parts = []
    for name, rows in (("push", slice(0, cut)), ("braking", slice(cut, None))):
        parts.append(Dataset(name=name, metadata=meta, columns={
            "time_s": t[rows] - t[rows][0], "drive_force_N": noisy_force[rows],
            "velocity_m_per_s": noisy_velocity[rows], "position_m": position[rows]}))
    return scene, parts[0], parts[1]


@pytest.mark.parametrize("law", ["lugre", "dahl", "dupont"])
def test_held_out_from_mid_motion_is_no_worse_than_a_rigid_fit(law, tmp_path):
    """The issue's situation, end to end on the inverse path: the law + viscous, held out on
    the braking that starts at 0.64 m/s, is no worse than rigid Coulomb + viscous on the same
    split (here far better: the inverse Coulomb cannot hold the load at rest)."""
    _, train, held = _cut_push(law, tmp_path, np.random.default_rng(7))
    fitted = identify(train, [held], law=law, declared=["viscous"])
    rigid = identify(train, [held], law="coulomb", declared=["viscous"])
    assert fitted.validation[0].starts_in_motion
    assert fitted.final.validation[0].relerr_pct <= rigid.final.validation[0].relerr_pct
    # no single sample dominates the held-out error (the spike at the start did)
    record = fitted.validation[0]
    residual = record.target_N - fitted.final.model.predict_values(record, fitted.final.values)
    assert np.max(residual ** 2) < 0.05 * np.sum(residual ** 2)


def test_a_scene_replay_cut_mid_motion_starts_sliding(tmp_path):
    """The simulation path: the carriage scene at the true LuGre values, replaying the braking
    part alone, follows the whole push's velocity from its first sample."""
    scene = tmp_path / "carriage.xml"
    scene.write_text(_scene_xml(_law("lugre")))
    t, force, velocity = _push(scene)
    peak = int(np.argmax(velocity))
    cut = peak + int(np.argmax(velocity[peak:] < 0.64))
    part = Dataset(name="braking", metadata=DatasetMetadata(
        model=str(scene), mass_kg=MASS_KG, simulation_timestep_s=1 / RATE_HZ / 4), columns={
        "time_s": t[cut:] - t[cut], "drive_force_N": force[cut:],
        "velocity_m_per_s": velocity[cut:], "position_m": np.zeros(t.size - cut)})
    replay = prepare_replay(part)
    assert replay.starts_in_motion
    with Replayer(replay) as runner:
        out = runner.run([(replay.rig, _law("lugre"))])[0]["velocity_m_per_s"]
    # the same scene at the same step from the record's first state: only the start differs
    assert np.max(np.abs(out - velocity[cut:])) < 1e-3 * velocity[cut]


def test_identify_by_simulation_holds_out_from_mid_motion(tmp_path):
    """The default path on the scene: LuGre + viscous fitted on the push, held out on the
    braking, lands near the held-out record's noise (a start at z = 0 left sigma1 v)."""
    scene, train, held = _cut_push("lugre", tmp_path, np.random.default_rng(8))
    train, held = (replace(d, metadata=replace(d.metadata, model=str(scene),
                                               simulation_timestep_s=1 / RATE_HZ / 4))
                   for d in (train, held))
    result = identify_by_simulation(train, [held], law="lugre", declared=["viscous"])
    assert result.validation[0].starts_in_motion
    velocity_noise = 2e-4 / np.sqrt(np.mean(held.columns["velocity_m_per_s"] ** 2))
    assert result.final.validation[0].relerr_pct < 100 * 5 * velocity_noise
