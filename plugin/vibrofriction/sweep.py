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
          nthread: int | None = None, progress: bool = True,
          scheduler: Any = None) -> dict[str, Any]:
    """Run the sweep; return the interfaces.md JSON object. Local rollout threads, or with
    ``scheduler`` (a Dask address or Client) one task per amplitude on that cluster."""
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=0.0), friction)]
    cases += [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
              for va in amplitudes]
    report = rig_module.progress_printer("sweep") if progress else None
    if scheduler is None:
        runs = rig_module.simulate_many(
            cases, duration_s=duration_s, timestep_s=timestep_s,
            settle_time_s=settle_time_s, nthread=nthread, progress=report)
        summaries = [run.summary(settle_time_s) for run in runs]
    else:
        from .study.sweep import dask_map
        summaries = dask_map(_case_summary, [(r, f, timestep_s, duration_s, settle_time_s)
                                             for r, f in cases], scheduler, progress=report)
    static = summaries[0].mean_drive_force_N
    points = []
    for (case_rig, _), s in zip(cases[1:], summaries[1:]):
        points.append({
            "vibration_velocity_amplitude_m_per_s": case_rig.vibration_velocity_amplitude_m_per_s,
            "kappa": case_rig.kappa,
            "mean_drive_force_N": s.mean_drive_force_N,
            "ratio": s.mean_drive_force_N / static if static != 0 else None,
            "friction_min_N": s.friction_min_N,
            "friction_max_N": s.friction_max_N,
            "sign_change": s.sign_change,
        })
    return {"law": friction.law, "parameters": as_dict(rig, friction),
            "static_drive_force_N": static, "points": points}


def _case_summary(job: tuple) -> Any:
    """One case of a sweep on a Dask worker: its summary (not its time series)."""
    rig, friction, timestep_s, duration_s, settle_time_s = job
    run = rig_module.simulate(rig, friction, duration_s=duration_s, timestep_s=timestep_s,
                              settle_time_s=settle_time_s)
    return run.summary(settle_time_s)
