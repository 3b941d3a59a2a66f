"""A model's state as ``mujoco.rollout`` starts from it, and its sensors' columns."""
from __future__ import annotations

import mujoco
import numpy as np


def full_state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """``data``'s state as mujoco.rollout starts from it (mjSTATE_FULLPHYSICS: time, qpos,
    qvel, act, plugin state...)."""
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data, state, kind)
    return state


def initial_state(model: mujoco.MjModel, data: mujoco.MjData | None = None) -> np.ndarray:
    """The model's reset state (``full_state``), e.g. for mujoco.rollout; ``data`` is reset
    and reused when given."""
    data = data if data is not None else mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    return full_state(model, data)


def sensor_slices(model: mujoco.MjModel) -> dict[str, slice]:
    """Columns of each named sensor in sensordata (and in rollout's nstep x nsensordata)."""
    out = {}
    for i in range(model.nsensor):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i)
        adr, dim = model.sensor_adr[i], model.sensor_dim[i]
        out[name] = slice(adr, adr + dim)
    return out


def sensor_columns(model: mujoco.MjModel, sensordata: np.ndarray, name: str) -> np.ndarray:
    """Rollout sensordata (nstep x nsensordata) of sensor ``name``: (nstep,) for a scalar
    sensor, (nstep, dim) otherwise. KeyError when the model has no such sensor."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
    if i < 0:
        raise KeyError(name)
    adr, dim = model.sensor_adr[i], model.sensor_dim[i]
    out = sensordata[:, adr:adr + dim]
    return out[:, 0] if dim == 1 else out
