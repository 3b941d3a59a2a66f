"""Running many rig cases for the study: timestep rule, shared durations, summaries only.

Cases are grouped by timestep (``StudyConfig.timestep``) and run together on MuJoCo's rollout
threads (``rig.simulate_many``). Every case of one call gets the same duration and averaging
window -- the longest default over the cases (``rig.default_times``) -- so a number does not
depend on which cases happened to run beside it.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from .. import rig as rig_module
from ..params import FrictionParameters, RigParameters
from ..summary import RunSummary
from .config import STATIC_TIMESTEP_S, StudyConfig

Progress = Callable[[int, int], None]
Case = tuple[RigParameters, FrictionParameters]
# Runs held in memory at once (a 1 us run keeps ~11 MB of time series).
_CHUNK = 8


@dataclass(frozen=True)
class Point:
    """Summary of one run, with what defines it."""

    rig: RigParameters
    friction: FrictionParameters
    timestep_s: float
    summary: RunSummary

    @property
    def mean_drive_force_N(self) -> float:
        return self.summary.mean_drive_force_N


def shared_times(cases: Sequence[Case]) -> tuple[float, float]:
    """(duration_s, settle_time_s) shared by ``cases``: the longest defaults."""
    times = [rig_module.default_times(r, f) for r, f in cases]
    return max(t[0] for t in times), max(t[1] for t in times)


def run_points(cases: Sequence[Case], config: StudyConfig, *,
               timesteps: Sequence[float] | None = None,
               times: tuple[float, float] | None = None,
               progress: Progress | None = None) -> list[Point]:
    """Summaries of ``cases`` (in order), each at its timestep (rule or ``timesteps``)."""
    if not cases:
        return []
    dts = list(timesteps) if timesteps is not None else [config.timestep(r) for r, _ in cases]
    duration, settle = times if times is not None else shared_times(cases)
    order = sorted(range(len(cases)), key=lambda i: -dts[i])  # coarse (fast) runs first
    out: list[Point | None] = [None] * len(cases)
    done = 0
    start = 0
    while start < len(order):
        dt = dts[order[start]]
        stop = start
        while stop < len(order) and stop - start < _CHUNK and dts[order[stop]] == dt:
            stop += 1
        idx = order[start:stop]
        runs = rig_module.simulate_many([cases[i] for i in idx], duration_s=duration,
                                        timestep_s=dt, settle_time_s=settle)
        for i, run in zip(idx, runs):
            out[i] = Point(rig=run.rig, friction=run.friction, timestep_s=dt,
                           summary=run.summary())
        done += len(idx)
        if progress:
            progress(done, len(cases))
        start = stop
    return [p for p in out if p is not None]


def static_cases(cases: Sequence[Case]) -> list[Case]:
    """The same rigs without vibration (F_d-s)."""
    return [(replace(r, vibration_velocity_amplitude_m_per_s=0.0), f) for r, f in cases]


def static_forces(cases: Sequence[Case], config: StudyConfig, *,
                  progress: Progress | None = None) -> list[float]:
    """F_d-s of each case: mean drive force of the same rig without vibration.

    Identical static rigs are run once.
    """
    statics = static_cases(cases)
    unique: dict[tuple, int] = {}
    todo: list[Case] = []
    for r, f in statics:
        key = (r, f)
        if key not in unique:
            unique[key] = len(todo)
            todo.append((r, f))
    points = run_points(todo, config, timesteps=[STATIC_TIMESTEP_S] * len(todo),
                        progress=progress)
    return [points[unique[(r, f)]].mean_drive_force_N for r, f in statics]


@dataclass(frozen=True)
class Trace:
    """The last whole periods of one run (what the time-trace figures show)."""

    rig: RigParameters
    friction: FrictionParameters
    timestep_s: float
    summary: RunSummary
    static_drive_force_N: float
    time_s: np.ndarray
    slider_position_m: np.ndarray
    slider_velocity_m_per_s: np.ndarray
    support_position_m: np.ndarray
    support_velocity_m_per_s: np.ndarray
    relative_velocity_m_per_s: np.ndarray
    deflection_m: np.ndarray
    friction_force_N: np.ndarray
    drive_force_N: np.ndarray

    @property
    def ratio(self) -> float:
        return self.summary.mean_drive_force_N / self.static_drive_force_N

    @property
    def relative_oscillation_m(self) -> np.ndarray:
        """x - u with the mean sliding v_d t and the mean removed: the slider's displacement
        on the support within the periods (closes into a loop in steady state)."""
        rel = self.slider_position_m - self.support_position_m
        rel = rel - self.rig.drive_velocity_m_per_s * self.time_s
        return rel - rel.mean()

    def columns(self) -> dict[str, np.ndarray]:
        n = self.time_s.shape[0]
        return {
            "time_s": self.time_s,
            "slider_position_m": self.slider_position_m,
            "slider_velocity_m_per_s": self.slider_velocity_m_per_s,
            "drive_velocity_m_per_s": np.full(n, self.rig.drive_velocity_m_per_s),
            "support_position_m": self.support_position_m,
            "support_velocity_m_per_s": self.support_velocity_m_per_s,
            "relative_velocity_m_per_s": self.relative_velocity_m_per_s,
            "deflection_m": self.deflection_m,
            "friction_force_N": self.friction_force_N,
            "drive_force_N": self.drive_force_N,
        }


def run_traces(cases: Sequence[Case], config: StudyConfig, *, periods: int,
               progress: Progress | None = None) -> list[Trace]:
    """Runs of ``cases`` keeping the last ``periods`` vibration periods of their time series."""
    duration, settle = shared_times(cases)
    statics = static_forces(cases, config)
    out: list[Trace] = []
    for k, ((r, f), fds) in enumerate(zip(cases, statics)):
        dt = config.timestep(r)
        run = rig_module.simulate_many([(r, f)], duration_s=duration, timestep_s=dt,
                                       settle_time_s=settle)[0]
        t = run.time_s
        period = run.period_s if run.period_s > 0 else 2.5e-4
        keep = t >= t[-1] - periods * period - 0.5 * dt
        out.append(Trace(
            rig=r, friction=f, timestep_s=dt, summary=run.summary(),
            static_drive_force_N=fds,
            time_s=t[keep] - t[keep][0],
            slider_position_m=run.slider_position_m[keep],
            slider_velocity_m_per_s=run.slider_velocity_m_per_s[keep],
            support_position_m=run.support_position_m[keep],
            support_velocity_m_per_s=run.support_velocity_m_per_s[keep],
            relative_velocity_m_per_s=run.relative_velocity_m_per_s[keep],
            deflection_m=run.deflection_m[keep],
            friction_force_N=run.friction_force_N[keep],
            drive_force_N=run.drive_force_N[keep]))
        if progress:
            progress(k + 1, len(cases))
    return out


__all__ = ["Point", "Trace", "run_points", "run_traces", "static_forces", "static_cases",
           "shared_times"]
