"""Batched simulation: the robot-timestep elements (``vibrofriction.contact_averaged``,
``vibrofriction.contact_feeder``) for MuJoCo Warp, thousands of worlds at once.

MuJoCo Warp runs no engine plugin, so :class:`BatchedTwin` turns a scene that uses the
plugins into its batched twin: the same MJCF with the plugin instances removed, their configs
(the same tables, the same keys) read into Warp kernels that apply each element through MuJoCo
Warp's passive-force hook and carry its state per world (docs/batched.md)::

    from vibrofriction.batched import BatchedTwin
    twin = BatchedTwin("feeder_map.xml", nworld=1000)
    twin.step(1000)                      # 1 s at 1 ms, every world
    qpos = twin.numpy("qpos")            # (1000, nq)

Needs the optional extra ``batched`` (``pip install vibrofriction[batched]``: mujoco-warp and
warp-lang); :func:`available` says whether it is installed and, if not, why.
"""
from __future__ import annotations

from .scene import (AVERAGED, FEEDER, PARAMETERS, SENSOR_SIZE, STATE_SIZE, Element, TwinScene,
                    twin_scene)

INSTALL_HINT = "pip install 'vibrofriction[batched]' (mujoco-warp and warp-lang)"


def unavailable_reason() -> str | None:
    """None when MuJoCo Warp can be imported; else why not, with the fix."""
    try:
        import warp  # noqa: F401
        import mujoco_warp  # noqa: F401
    except Exception as error:  # noqa: BLE001 - any import failure means the same here
        return f"MuJoCo Warp is not installed ({error}); {INSTALL_HINT}"
    return None


def available() -> bool:
    """Whether MuJoCo Warp and Warp can be imported, so that ``BatchedTwin`` works
    (``unavailable_reason`` says why not)."""
    return unavailable_reason() is None


def __getattr__(name: str):
    if name == "BatchedTwin":
        reason = unavailable_reason()
        if reason is not None:
            raise ImportError(f"vibrofriction.batched.BatchedTwin: {reason}")
        from .twin import BatchedTwin
        return BatchedTwin
    raise AttributeError(name)


__all__ = ["AVERAGED", "BatchedTwin", "Element", "FEEDER", "INSTALL_HINT", "PARAMETERS",
           "SENSOR_SIZE", "STATE_SIZE", "TwinScene", "available", "twin_scene",
           "unavailable_reason"]
