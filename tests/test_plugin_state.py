"""z lives in mjData.act (and the lagged force in plugin_state), so MuJoCo's state tools work:
continuing from a restored state is bit-identical to continuing the original.

Covered: mj_getState / mj_setState (mjSTATE_FULLPHYSICS), copy.copy(MjData), keyframes,
mujoco.rollout against an mj_step loop, mjd_transitionFD, and rollout with several models
(different law configs) on one MjData.
"""
from __future__ import annotations

import copy
import gc
from dataclasses import replace

import mujoco
import numpy as np
import pytest
from conftest import FULL, initial_state
from mujoco import rollout as mj_rollout

from vibrofriction import sim
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import RigParameters, default_friction

PREFIX_STEPS = 3000  # 30 ms at 1e-5 s: loaded past breakaway, vibrating, sign changes
CONTINUE_STEPS = 400


def _model(law: str = "dahl", **friction_changes) -> mujoco.MjModel:
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    friction = replace(default_friction(law, rig), **friction_changes)
    return rig_module.build_model(rig, friction, 1e-5)


CONFIGS = {
    "dahl": dict(law="dahl"),
    "coulomb": dict(law="coulomb"),
    # a sensor lag puts the lagged force into plugin_state as well
    "lugre_lagged": dict(law="lugre", sensor_lag_s=1e-4),
    "dupont": dict(law="dupont"),
}


def _build(config: str) -> mujoco.MjModel:
    kwargs = dict(CONFIGS[config])
    return _model(kwargs.pop("law"), **kwargs)


def _advanced(model: mujoco.MjModel, steps: int = PREFIX_STEPS) -> mujoco.MjData:
    data = mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return data


def _trajectory(model: mujoco.MjModel, data: mujoco.MjData,
                steps: int = CONTINUE_STEPS) -> np.ndarray:
    """Full state and sensors after each of ``steps`` steps, one row per step."""
    rows = []
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    for _ in range(steps):
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, state, FULL)
        rows.append(np.concatenate([state, data.sensordata, data.actuator_force]))
    return np.array(rows)


def _get_state(model, data) -> np.ndarray:
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, state, FULL)
    return state


@pytest.fixture(scope="module", params=list(CONFIGS))
def advanced(request):
    model = _build(request.param)
    data = _advanced(model)
    assert np.any(data.act != 0) or request.param == "coulomb"
    return request.param, model, data


def test_state_holds_the_deflection(advanced):
    name, model, data = advanced
    assert model.na == 1
    if name == "lugre_lagged":
        friction = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, "friction")
        assert model.plugin_statenum[friction] == 1


def test_get_set_state_round_trip(advanced):
    _, model, data = advanced
    state = _get_state(model, data)
    original = copy.copy(data)
    expected = _trajectory(model, original)
    fresh = mujoco.MjData(model)
    for _ in range(17):  # a fresh MjData that has lived a different life
        mujoco.mj_step(model, fresh)
    mujoco.mj_setState(model, fresh, state, FULL)
    assert np.array_equal(_trajectory(model, fresh), expected)


def test_copy_continues_identically_and_outlives_its_original(advanced):
    _, model, data = advanced
    first = copy.copy(data)
    second = copy.copy(first)
    expected = _trajectory(model, first)
    del first
    gc.collect()  # the copy must not share plugin data with the deleted original
    assert np.array_equal(_trajectory(model, second), expected)


def test_keyframe_round_trip():
    """Keyframes store time, qpos, qvel, act (z), ctrl: enough for the laws without lag."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    spec = rig_module.build_spec(rig, default_friction("dahl", rig), 1e-5)
    spec.add_key(name="loaded")
    model = spec.compile()
    data = _advanced(model)
    mujoco.mj_setKeyframe(model, data, 0)
    assert model.key_act[0, 0] == data.act[0] != 0
    expected = _trajectory(model, copy.copy(data))
    restored = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, restored, 0)
    assert np.array_equal(_trajectory(model, restored), expected)


def test_rollout_equals_step_loop(advanced):
    _, model, data = advanced
    state = _get_state(model, data)
    expected = _trajectory(model, copy.copy(data))
    nstate = state.size
    states, sensors = mj_rollout.rollout(model, mujoco.MjData(model), state[None],
                                         nstep=CONTINUE_STEPS)
    assert np.array_equal(states[0], expected[:, :nstate])
    assert np.array_equal(sensors[0], expected[:, nstate:nstate + model.nsensordata])


def test_transition_fd_leaves_the_state_intact(advanced):
    name, model, data = advanced
    reference = copy.copy(data)
    nx = 2 * model.nv + model.na
    a = np.zeros((nx, nx))
    b = np.zeros((nx, model.nu))
    mujoco.mjd_transitionFD(model, data, 1e-9, True, a, b, None, None)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
    assert np.array_equal(_trajectory(model, data), _trajectory(model, reference))
    if name != "coulomb":
        dz_dz = a[-1, -1]  # d z_{n+1} / d z_n: the closed-form update contracts
        assert 0 < dz_dz <= 1


def test_rollout_with_several_models_uses_each_models_config():
    """One MjData, models with different law configs in one rollout call: each result equals a
    run of that model alone (a plugin caching its first config would fail this)."""
    models = [_model("dahl"), _model("lugre"), _model("dahl", friction_coefficient=0.1),
              _model("dupont"), _model("dahl")]
    state0 = initial_state(models[0])
    nstep = PREFIX_STEPS
    alone = [mj_rollout.rollout(m, mujoco.MjData(m), state0[None], nstep=nstep)[1][0]
             for m in models]
    shared = mujoco.MjData(models[0])
    _, together = mj_rollout.rollout(models, shared, np.stack([state0] * len(models)),
                                     nstep=nstep)
    for k in range(len(models)):
        assert np.array_equal(together[k], alone[k]), k
    assert not np.array_equal(alone[0], alone[2])  # the configs do differ
    assert np.array_equal(alone[0], alone[4])


def _continue(model, data, steps=300):
    rows, state = [], np.empty(mujoco.mj_stateSize(model, FULL))
    for _ in range(steps):
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, state, FULL)
        rows.append(np.concatenate([state, data.actuator_force]))
    return np.array(rows)


@pytest.mark.parametrize("scene", ["emps", "dynamometer"])
def test_plugin_state_round_trips_with_fullphysics_not_physics(scene):
    """The controller's and the dynamometer's state live in plugin_state: FULLPHYSICS restores
    a run bit-identically; PHYSICS, as docs/simulation.md says, does not."""
    from vibrofriction.identify.machine_replay import BUNDLED
    if scene == "emps":
        model = mujoco.MjModel.from_xml_path(str(BUNDLED["emps"]))
        drive = lambda d: d.ctrl.__setitem__(0, 0.05 * np.sin(8 * d.time))  # noqa: E731
    else:
        rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
        spec = rig_module.build_spec(rig, default_friction("dahl", rig), 1e-5)
        sim.set_plugin_config(spec, "dynamometer",
                                     {"tendon": "drive_spring", "time_constant": "2e-4"})
        model = spec.compile()
        drive = lambda d: None  # noqa: E731
    data = mujoco.MjData(model)
    for _ in range(2500):
        drive(data)
        mujoco.mj_step(model, data)
    assert np.any(data.plugin_state != 0)
    saved = {kind: np.empty(mujoco.mj_stateSize(model, kind)) for kind in
             (FULL, mujoco.mjtState.mjSTATE_PHYSICS)}
    for kind, buffer in saved.items():
        mujoco.mj_getState(model, data, buffer, kind)
    ctrl = data.ctrl.copy()
    expected = _continue(model, copy.copy(data))
    restored = {}
    for kind, buffer in saved.items():
        other = mujoco.MjData(model)
        for _ in range(37):  # another life first
            mujoco.mj_step(model, other)
        other.ctrl[:] = ctrl
        mujoco.mj_setState(model, other, buffer, kind)
        restored[kind] = _continue(model, other)
    assert np.array_equal(restored[FULL], expected)
    assert not np.array_equal(restored[mujoco.mjtState.mjSTATE_PHYSICS], expected)
