"""Running many rig cases for the study: timestep rule, runs to steady state, summaries only.

Each case runs at its timestep (``StudyConfig.timestep``) to its steady state: by default from
rest until its mean drive force has converged (``steady.run_until_steady``: Hann-weighted
windows of whole periods after the transient, within 0.1 %); ``StudyConfig.method`` may ask for
the periodic orbit (``rigs.periodic``) instead. A number does not depend on which cases
happened to run beside it. Cases are run by the package's one engine (``rigs.sweep.run_cases``): together on MuJoCo's
rollout threads, a few at a time, or chunk by chunk on a Dask cluster.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

import numpy as np

from ..params import FrictionParameters, RigParameters
from ..rigs.steady import Case, SteadyRun
from ..rigs.sweep import run_cases
from ..summary import RunSummary
from .config import STATIC_TIMESTEP_S, StudyConfig

Progress = Callable[[int, int], None]
# Cases a chunk: runs held in memory at once (a 1 us run keeps ~11 MB of time series), and a
# task on a Dask cluster (enough to keep its rollout threads busy, few enough to spread work).
DEFAULT_CHUNK_SIZE = 8


# A study point is one case run to steady state: the engine's record (rigs.steady.SteadyRun).
Point = SteadyRun


def run_points(cases: Sequence[Case], config: StudyConfig, *,
               timesteps: Sequence[float] | None = None, scheduler: Any = None,
               chunk_size: int = DEFAULT_CHUNK_SIZE, progress: Progress | None = None) -> list[Point]:
    """Summaries of ``cases`` (in order), each at its timestep (the study's rule, or
    ``timesteps``), run by the package's one engine (``rigs.sweep.run_cases``) a chunk at a
    time, locally or on the Dask cluster ``scheduler``."""
    dts = list(timesteps) if timesteps is not None else [config.timestep(r) for r, _ in cases]
    return run_cases(cases, timesteps=dts, chunk_size=chunk_size, scheduler=scheduler,
                     progress=progress, method=config.method)


def static_cases(cases: Sequence[Case]) -> list[Case]:
    """The same rigs without vibration (F_d-s)."""
    return [(replace(r, vibration_velocity_amplitude_m_per_s=0.0), f) for r, f in cases]


def static_points(cases: Sequence[Case], config: StudyConfig, *, scheduler: Any = None,
                  chunk_size: int = DEFAULT_CHUNK_SIZE, progress: Progress | None = None) -> list[Point]:
    """The run without vibration of each case (F_d-s and its convergence).

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
                        scheduler=scheduler, chunk_size=chunk_size, progress=progress)
    return [points[unique[(r, f)]] for r, f in statics]


def static_forces(cases: Sequence[Case], config: StudyConfig, *,
                  progress: Progress | None = None) -> list[float]:
    """F_d-s of each case: mean drive force of the same rig without vibration."""
    return [p.mean_drive_force_N for p in static_points(cases, config, progress=progress)]


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
    """Runs of ``cases`` to steady state keeping the last ``periods`` vibration periods of
    their time series (those of the reported window's end)."""
    statics = static_forces(cases, config)
    out: list[Trace] = []
    for k, ((r, f), fds) in enumerate(zip(cases, statics)):
        dt = config.timestep(r)
        result = run_cases([(r, f)], timesteps=[dt], keep_series=True)[0]
        run = result.run
        t = run.time_s
        period = run.period_s if run.period_s > 0 else 2.5e-4
        keep = t >= t[-1] - periods * period - 0.5 * dt
        out.append(Trace(
            rig=r, friction=f, timestep_s=dt, summary=result.summary,
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


__all__ = ["Point", "Trace", "run_points", "run_traces", "static_forces", "static_points",
           "static_cases"]
