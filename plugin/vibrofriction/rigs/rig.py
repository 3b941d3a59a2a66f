"""The paper's rig in MuJoCo: run it from parameters and summarize it.

Its model (scene files, parameters set through MjSpec, timestep rule, sensors read as a
``RigRun``) is ``rig_model.py``; its names are exported here too, so ``rig.build_spec``,
``rig.RigRun`` and ``rig.simulate`` are one import. A run to steady state is ``steady.py``'s.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from ..params import FrictionParameters, ParameterError, RigParameters, plain_value
from ..sim import cpu_count, initial_state
from .rig_model import (BASE_STEPS_PER_PERIOD, DEFAULT_TIMESTEP_S, MJCF_KEYS, RIG_DIR,
                        STEP_PHASE_SLIDE, STEPS_DOUBLING_KAPPA, VIBRATION_RAMP_PERIODS, RigRun,
                        UnconvergedWarning, build_model, build_spec, default_times,
                        drive_force_columns, dynamometer_config, friction_config,
                        period_timestep, recommended_timestep, runs_from_sensordata,
                        scene_path, steps_per_period)
from .steady import run_until_steady

__all__ = [
    "simulate", "simulate_many", "static_drive_force", "progress_printer",
    # the model (rig_model.py)
    "BASE_STEPS_PER_PERIOD", "DEFAULT_TIMESTEP_S", "MJCF_KEYS", "RIG_DIR", "STEP_PHASE_SLIDE",
    "STEPS_DOUBLING_KAPPA", "VIBRATION_RAMP_PERIODS", "RigRun", "UnconvergedWarning",
    "build_model", "build_spec", "default_times", "drive_force_columns", "dynamometer_config",
    "friction_config", "period_timestep", "recommended_timestep", "runs_from_sensordata",
    "scene_path", "steps_per_period"]


def simulate(rig: RigParameters, friction: FrictionParameters, *,
             duration_s: float | None = None, timestep_s: float = DEFAULT_TIMESTEP_S,
             settle_time_s: float | None = None) -> RigRun:
    """One run of the rig from rest (spring unloaded, z = 0): until its mean drive force has
    converged (``steady.run_until_steady``; ``convergence`` says how), or ``duration_s``."""
    return simulate_many([(rig, friction)], duration_s=duration_s, timestep_s=timestep_s,
                         settle_time_s=settle_time_s)[0]


def simulate_many(cases: Sequence[tuple[RigParameters, FrictionParameters]], *,
                  duration_s: float | None = None, timestep_s: float = DEFAULT_TIMESTEP_S,
                  settle_time_s: float | None = None, nthread: int | None = None,
                  progress: Callable[[int, int], None] | None = None) -> list[RigRun]:
    """Run several rigs in parallel on rollout threads (one model per case, same structure).

    Without ``duration_s`` each case runs until its own mean drive force has converged
    (``steady.run_until_steady``), so its result does not depend on the batch. With it, every
    case runs that long and is averaged after ``settle_time_s`` (default: the longest transient
    guess of ``default_times``); cases are run in groups so that ``progress(done, total)`` can
    report.
    """
    if not cases:
        return []
    if duration_s is None:
        if settle_time_s is not None:
            raise ParameterError("settle_time_s needs duration_s: a run to steady state "
                                 "averages over windows after its own transient")
        results = run_until_steady(cases, timesteps=[timestep_s] * len(cases),
                                   keep_series=True, nthread=nthread, progress=progress)
        return [replace(r.run, convergence=r.convergence, steady_summary=r.summary)
                for r in results]
    times = [default_times(r, f) for r, f in cases]
    duration = duration_s
    settle = settle_time_s if settle_time_s is not None else max(t[1] for t in times)
    if not (duration > 0 and math.isfinite(duration)):
        raise ParameterError(f"duration {plain_value(duration)!r} must be a positive number of "
                             "seconds")
    nstep = int(round(duration / timestep_s))
    models = [build_model(r, f, timestep_s) for r, f in cases]
    nthread = nthread if nthread is not None else min(len(cases), cpu_count())
    group = max(1, nthread)
    runs: list[RigRun] = []
    pool_threads = nthread if len(cases) > 1 else 0
    with mj_rollout.Rollout(nthread=pool_threads) as pool:
        for start in range(0, len(cases), group):
            chunk_models = models[start:start + group]
            # Rollout wants exactly one MjData per thread, also for a short last chunk.
            datas = [mujoco.MjData(chunk_models[0]) for _ in range(max(1, pool_threads))]
            states = np.stack([initial_state(mm, datas[0]) for mm in chunk_models])
            _, sensordata = pool.rollout(chunk_models, datas, states, nstep=nstep)
            for k, mm in enumerate(chunk_models):
                r, f = cases[start + k]
                runs.append(runs_from_sensordata(mm, r, f, sensordata[k], settle))
            if progress:
                progress(len(runs), len(cases))
    return runs


def static_drive_force(rig: RigParameters, friction: FrictionParameters, *,
                       timestep_s: float = DEFAULT_TIMESTEP_S) -> float:
    """F_d-s: mean drive force of the same rig without vibration."""
    still = replace(rig, vibration_velocity_amplitude_m_per_s=0.0)
    return simulate(still, friction, timestep_s=timestep_s).summary().mean_drive_force_N


def progress_printer(label: str) -> Callable[[int, int], None]:
    """A progress report on stderr (``progress.progress_bar``)."""
    from ..progress import progress_bar
    return progress_bar(label)
