"""Sweeps of the rig over the vibration velocity amplitude: the master curve F_d-v/F_d-s.

Every amplitude and the static run (v_a = 0, giving F_d-s) are simulated in parallel on MuJoCo
rollout threads (one model per case, ``rig.simulate_many``). The result is the JSON object of
``vibrofriction sweep`` (interfaces.md).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

from . import rig as rig_module
from .params import FrictionParameters, RigParameters, as_dict

POINT_KEYS = ("vibration_velocity_amplitude_m_per_s", "kappa", "mean_drive_force_N", "ratio",
              "friction_min_N", "friction_max_N", "sign_change")


def sweep(rig: RigParameters, friction: FrictionParameters, amplitudes: list[float], *,
          timestep_s: float, duration_s: float, settle_time_s: float,
          nthread: int | None = None, progress: bool = True) -> dict[str, Any]:
    """Run the sweep; return the interfaces.md JSON object."""
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=0.0), friction)]
    cases += [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
              for va in amplitudes]
    runs = rig_module.simulate_many(
        cases, duration_s=duration_s, timestep_s=timestep_s, settle_time_s=settle_time_s,
        nthread=nthread, progress=rig_module.progress_printer("sweep") if progress else None)
    static = runs[0].summary(settle_time_s).mean_drive_force_N
    points = []
    for run in runs[1:]:
        s = run.summary(settle_time_s)
        points.append({
            "vibration_velocity_amplitude_m_per_s": run.rig.vibration_velocity_amplitude_m_per_s,
            "kappa": run.rig.kappa,
            "mean_drive_force_N": s.mean_drive_force_N,
            "ratio": s.mean_drive_force_N / static if static != 0 else None,
            "friction_min_N": s.friction_min_N,
            "friction_max_N": s.friction_max_N,
            "sign_change": s.sign_change,
        })
    return {"law": friction.law, "parameters": as_dict(rig, friction),
            "static_drive_force_N": static, "points": points}
