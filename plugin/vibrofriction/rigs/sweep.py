"""Sweeps of the rig over the vibration velocity amplitude: the master curve F_d-v/F_d-s.

Every amplitude and the static run (v_a = 0, giving F_d-s) are simulated in parallel on MuJoCo
rollout threads (one model per case). By default each case runs at its own recommended
timestep until its mean drive force has converged (``steady.run_until_steady``), so a point is
the same alone or in any sweep; with ``duration_s`` every case runs that long at one timestep
and the convergence of its last windows is reported. The result is the JSON object of
``vibrofriction sweep`` (docs/interfaces.md), each point with its convergence.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from . import rig as rig_module
from ..errors import InputError
from ..params import FrictionParameters, RigParameters, as_dict
from .steady import (DEFAULT_TOLERANCE, MIN_WINDOWS, Convergence, SteadyRun, convergence_of_run,
                     run_until_steady)
from ..summary import RunSummary

POINT_KEYS = ("vibration_velocity_amplitude_m_per_s", "kappa", "mean_drive_force_N", "ratio",
              "mean_friction_force_N", "friction_min_N", "friction_max_N", "sign_change")
# After the interface's keys, every point (and "static_convergence") says how it converged.
CONVERGENCE_KEYS = ("converged", "estimated_remaining_error", "relative_change",
                    "window_start_s", "window_end_s", "windows", "window_s", "tolerance",
                    "timestep_s")


def run_cases(cases: list[tuple[RigParameters, FrictionParameters]], *,
              timestep_s: float | None = None, duration_s: float | None = None,
              settle_time_s: float | None = None, tolerance: float = DEFAULT_TOLERANCE,
              max_duration_s: float | None = None, nthread: int | None = None,
              progress: Any = None, keep_series: bool = False) -> list[SteadyRun]:
    """Each case's summary and convergence: run to steady state (no ``duration_s``), or for
    ``duration_s`` at ``timestep_s`` (default: the finest the cases recommend)."""
    if duration_s is None:
        timesteps = None if timestep_s is None else [timestep_s] * len(cases)
        return run_until_steady(cases, timesteps=timesteps, tolerance=tolerance,
                                max_duration_s=max_duration_s, nthread=nthread,
                                progress=progress, keep_series=keep_series)
    if timestep_s is None:
        timestep_s = min(rig_module.recommended_timestep(r) for r, _ in cases)
    runs = rig_module.simulate_many(cases, duration_s=duration_s, timestep_s=timestep_s,
                                    settle_time_s=settle_time_s, nthread=nthread,
                                    progress=progress)
    return [SteadyRun(rig=run.rig, friction=run.friction, timestep_s=timestep_s,
                      summary=run.summary(), convergence=convergence_of_run(
                          run, run.settle_time_s, tolerance),
                      run=run if keep_series else None) for run in runs]


def sweep(rig: RigParameters, friction: FrictionParameters, amplitudes: list[float], *,
          timestep_s: float | None = None, duration_s: float | None = None,
          settle_time_s: float | None = None, tolerance: float = DEFAULT_TOLERANCE,
          max_duration_s: float | None = None, nthread: int | None = None,
          progress: bool = True, scheduler: Any = None) -> dict[str, Any]:
    """Run the sweep; return the docs/interfaces.md JSON object. Local rollout threads, or with
    ``scheduler`` (a Dask address or Client) one task per amplitude on that cluster."""
    if nthread is not None and scheduler is not None:
        # a Dask worker runs each amplitude on the threads it was started with
        raise InputError(f"nthread={nthread} sets local rollout threads and cannot be combined "
                         "with a scheduler, whose workers run on their own threads; pass one "
                         "of them (start the workers with 'dask worker --nthreads N')")
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=0.0), friction)]
    cases += [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
              for va in amplitudes]
    report = rig_module.progress_printer("sweep") if progress else None
    settings = dict(timestep_s=timestep_s, duration_s=duration_s, settle_time_s=settle_time_s,
                    tolerance=tolerance, max_duration_s=max_duration_s)
    if scheduler is None:
        results = run_cases(cases, nthread=nthread, progress=report, **settings)
    else:
        from ..study.sweep import dask_map
        if duration_s is not None:  # one timestep and window for all, as locally
            if timestep_s is None:
                settings["timestep_s"] = min(rig_module.recommended_timestep(r)
                                             for r, _ in cases)
            if settle_time_s is None:
                settings["settle_time_s"] = max(rig_module.default_times(r, f)[1]
                                                for r, f in cases)
        results = dask_map(_case_result, [(r, f, settings) for r, f in cases], scheduler,
                           progress=report)
    static = results[0].summary.mean_drive_force_N
    points = []
    for (case_rig, _), result in zip(cases[1:], results[1:]):
        s = result.summary
        points.append({
            "vibration_velocity_amplitude_m_per_s": case_rig.vibration_velocity_amplitude_m_per_s,
            "kappa": case_rig.kappa,
            "mean_drive_force_N": s.mean_drive_force_N,
            "ratio": s.mean_drive_force_N / static if static != 0 else None,
            "mean_friction_force_N": s.mean_friction_force_N,
            "friction_min_N": s.friction_min_N,
            "friction_max_N": s.friction_max_N,
            "sign_change": s.sign_change,
            **convergence_fields(result.timestep_s, s, result.convergence),
        })
    return {"law": friction.law, "parameters": as_dict(rig, friction),
            "static_drive_force_N": static, "points": points,
            "static_convergence": convergence_fields(results[0].timestep_s, results[0].summary,
                                                     results[0].convergence),
            "all_converged": all(r.convergence.converged for r in results)}


def convergence_fields(timestep_s: float, summary: RunSummary,
                       convergence: Convergence) -> dict[str, Any]:
    """A point's convergence in its JSON: flagged, with the window and the error estimate."""
    as_json = convergence.as_dict()  # infinities as null
    return {"converged": convergence.converged,
            "estimated_remaining_error": as_json["estimated_remaining_error"],
            "relative_change": as_json["relative_change"],
            "window_start_s": summary.window_start_s, "window_end_s": summary.window_end_s,
            "windows": convergence.windows, "window_s": convergence.window_s,
            "tolerance": convergence.tolerance,
            "timestep_s": timestep_s}


def unconverged_line(command: str, label: str, convergence: Convergence, *,
                     fixed: bool = False) -> str:
    """The stderr warning for one run that did not converge (``fixed``: of --duration)."""
    if convergence.windows < MIN_WINDOWS:
        return (f"{command}: warning: {label} is too short to judge its convergence: "
                f"{convergence.windows} averaging window(s) of {convergence.window_s:.4g} s fit "
                f"after the settle time, {MIN_WINDOWS} are needed; it is flagged "
                "\"converged\": false. Give a longer --duration, or leave it out to run "
                "until the mean drive force converges")
    remaining = convergence.estimated_remaining_error
    estimate = (f"estimated remaining error {remaining:.2g}" if math.isfinite(remaining)
                else "no estimate of the remaining error (the windows are not settling)")
    fix = "a longer --duration" if fixed else "a longer --max-duration"
    return (f"{command}: warning: {label} did not converge to {convergence.tolerance:g} "
            f"within {convergence.simulated_s:.4g} s (last change {convergence.relative_change:.2g}"
            f", {estimate}); it is flagged \"converged\": false. Give {fix} or a looser "
            "--tolerance, or look for stick-slip")


def unconverged_lines(result: dict[str, Any], *, fixed: bool = False) -> list[str]:
    """The warnings for the sweep's runs that did not converge (none when all did)."""
    lines = []
    runs = [("the static run (v_a = 0)", result["static_convergence"])] + [
        (f"v_a = {p['vibration_velocity_amplitude_m_per_s']:g} m/s", p)
        for p in result["points"]]
    for label, fields in runs:
        if not fields["converged"]:
            lines.append(unconverged_line("sweep", label, Convergence(
                converged=False, tolerance=fields["tolerance"], window_s=fields["window_s"],
                windows=fields["windows"],
                relative_change=_inf(fields["relative_change"]),
                estimated_remaining_error=_inf(fields["estimated_remaining_error"]),
                simulated_s=fields["window_end_s"]), fixed=fixed))
    return lines


def _inf(value: float | None) -> float:
    return math.inf if value is None else value


def _case_result(job: tuple) -> SteadyRun:
    """One case of a sweep on a Dask worker: its summary and convergence (no time series)."""
    rig, friction, settings = job
    return run_cases([(rig, friction)], **settings)[0]
