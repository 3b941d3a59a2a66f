"""Steady state detected, not guessed: run each rig case until its mean drive force settles.

After the transient guess of ``rig.default_times`` (two loadings of the drive spring to
breakaway + 30 ms, plus a still stage), the mean drive force is taken over sliding windows of
whole vibration periods, about 40 ms long and a multiple of 48 periods (so that period-2, -3,
-4 and -6 responses average over whole cycles), one quarter of a window apart. Each mean is
Hann-weighted: for a periodic response it equals the plain mean over the whole periods, and
an oscillation that does not fit the window a whole number of times -- the slider ringing on
the drive spring, which nothing damps while it slides -- leaks into it k^2 - 1 times less than
into a plain mean, k the cycles in the window (about 9 for the paper's rig: 80 times less). Window k's mean m_k is compared with the two before it:

* ``relative_change`` = |m_k - m_{k-1}| / |m_k|;
* ``estimated_remaining_error``: the distance to the limit if the means approach it
  geometrically, |d_k| r / (1 - r) with r = d_k / d_{k-1} (Aitken's estimate), |d_k| when
  the differences alternate in sign, infinite when they do not shrink.

A case has converged at the first window where both are within the tolerance (default 0.1 %);
its result is that window's mean. Otherwise it runs on, up to a maximum simulated time, and is
flagged. Each case runs at its own timestep (``rig.recommended_timestep``) and its windows
depend on its own parameters only, so a point's result is the same alone or in any batch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from .. import sim
from . import rig_model
from .rig_model import Convergence
from ..params import FrictionParameters, ParameterError, RigParameters, plain_value
from ..summary import RunSummary

DEFAULT_TOLERANCE = 1e-3
WINDOW_TARGET_S = 0.04
# Periods per window are a multiple of this: whole cycles of period-2, -3, -4, -6 responses,
# also in the quarter window the windows slide by.
SUBHARMONIC_PERIODS = 12
HOPS_PER_WINDOW = 4
MIN_WINDOWS = 3  # non-overlapping windows judged together: a change and its trend
_FIRST_DECISION = (MIN_WINDOWS - 1) * HOPS_PER_WINDOW  # index of the first judged window
_MAX_CHUNK_STEPS = 1 << 20  # rollout returns every step's state: bound its memory
DEFAULT_MAX_DURATION_S = 2.0  # a soft drive spring's slow mode needs about a second

Case = tuple[RigParameters, FrictionParameters]


@dataclass(frozen=True)
class SteadyRun:
    """One case run to steady state: its summary (over the reported window), how it
    converged, and with ``keep_series`` its time series up to that window's end."""

    rig: RigParameters
    friction: FrictionParameters
    timestep_s: float
    summary: RunSummary
    convergence: Convergence
    run: rig_model.RigRun | None = None

    @property
    def mean_drive_force_N(self) -> float:
        return self.summary.mean_drive_force_N


def window_length_s(rig: RigParameters) -> float:
    """Whole periods, a multiple of SUBHARMONIC_PERIODS * HOPS_PER_WINDOW, about
    WINDOW_TARGET_S."""
    f = rig.vibration_frequency_Hz
    if f <= 0 or rig.vibration_velocity_amplitude_m_per_s <= 0:
        return WINDOW_TARGET_S
    block = SUBHARMONIC_PERIODS * HOPS_PER_WINDOW / f
    return max(1, round(WINDOW_TARGET_S / block)) * block


def longest_run_s(rig: RigParameters, friction: FrictionParameters,
                  max_duration_s: float | None = None) -> float:
    """The most a case runs: ``max_duration_s`` (default DEFAULT_MAX_DURATION_S), at least the
    transient guess and MIN_WINDOWS windows."""
    limit = DEFAULT_MAX_DURATION_S if max_duration_s is None else max_duration_s
    return max(limit, rig_model.default_times(rig, friction)[1]
               + MIN_WINDOWS * window_length_s(rig))


def hann_mean(time_s: np.ndarray, y: np.ndarray, start_s: float, end_s: float) -> float:
    """Hann-weighted mean of the samples in [start_s, end_s] (module docstring)."""
    inside = (time_s >= start_s) & (time_s <= end_s)
    weight = 1.0 - np.cos(2.0 * np.pi * (time_s[inside] - start_s) / (end_s - start_s))
    total = weight.sum()
    if not total > 0:
        raise ValueError(f"no samples inside the window [{start_s:g}, {end_s:g}] s")
    return float(np.dot(weight, y[inside]) / total)


def judge(means: Sequence[float], tolerance: float, spacing: int = 1
          ) -> tuple[bool, float, float]:
    """(converged, relative_change, estimated_remaining_error) after the last of ``means``,
    compared with the means ``spacing`` and 2 ``spacing`` before it."""
    if len(means) < 2 * spacing + 1:
        return False, math.inf, math.inf
    m_prev2, m_prev, m_last = means[-1 - 2 * spacing], means[-1 - spacing], means[-1]
    scale = abs(m_last)
    if scale == 0:
        scale = max(abs(m_prev), abs(m_prev2), 1e-300)
    d_prev, d_last = m_prev - m_prev2, m_last - m_prev
    change = abs(d_last) / scale
    if d_last == 0:
        remaining = 0.0
    elif d_prev == 0:
        remaining = math.inf
    else:
        r = d_last / d_prev
        if r <= 0:  # alternating: the limit lies between the last two means
            remaining = abs(d_last) / scale
        elif r < 1:
            remaining = abs(d_last) * r / (1.0 - r) / scale
        else:
            remaining = math.inf
    return bool(change <= tolerance and remaining <= tolerance), float(change), float(remaining)


@dataclass
class _Case:
    """One case's state between rollout calls: the physics state, the samples still needed
    (from the start of the last computed window on) and the window means so far."""

    index: int
    model: mujoco.MjModel
    rig: RigParameters
    friction: FrictionParameters
    timestep_s: float
    first_window_s: float
    window_s: float
    max_duration_s: float
    state: np.ndarray
    forces: np.ndarray  # (samples kept, 2): drive force, friction force
    first_sample: int = 0  # step index of forces[0]
    steps: int = 0
    means: list = field(default_factory=list)
    series: list = field(default_factory=list)  # whole sensordata chunks (keep_series)

    def window(self, k: int) -> tuple[float, float]:
        start = self.first_window_s + k * self.window_s / HOPS_PER_WINDOW
        return start, start + self.window_s


def check_timestep(rig: RigParameters, timestep_s: float) -> None:
    """ParameterError when a run to steady state cannot average at this timestep (either
    route: checked before anything is simulated)."""
    if not (timestep_s > 0 and timestep_s <= window_length_s(rig) / HOPS_PER_WINDOW / 10):
        raise ParameterError(
            f"timestep {plain_value(timestep_s)} s is too coarse to average over windows of "
            f"{window_length_s(rig):.4g} s (at most a tenth of a quarter window); use a "
            "smaller --timestep")


def case_timesteps(cases: Sequence[Case], timesteps: Sequence[float] | None,
                   tolerance: float) -> list[float]:
    """Each case's timestep (the rule's where none is given), every input checked before
    anything is simulated (either route)."""
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ParameterError(f"tolerance {plain_value(tolerance)!r} must be a positive number "
                             "(a relative error, e.g. 1e-3)")
    dts = (list(timesteps) if timesteps is not None
           else [rig_model.recommended_timestep(r) for r, _ in cases])
    if len(dts) != len(cases):
        raise ValueError(f"{len(dts)} timesteps for {len(cases)} cases")
    for (r, _), dt in zip(cases, dts):
        check_timestep(r, dt)
    return dts


def run_until_steady(cases: Sequence[Case], *, timesteps: Sequence[float] | None = None,
                     tolerance: float = DEFAULT_TOLERANCE,
                     max_duration_s: float | None = None, keep_series: bool = False,
                     nthread: int | None = None,
                     progress: Callable[[int, int], None] | None = None) -> list[SteadyRun]:
    """Run every case until its windowed mean drive force has converged (module docstring),
    or until ``max_duration_s`` (default DEFAULT_MAX_DURATION_S; at least the transient
    guess and three windows). Cases run together on rollout threads."""
    dts = case_timesteps(cases, timesteps, tolerance)
    if max_duration_s is not None and not (max_duration_s > 0 and math.isfinite(max_duration_s)):
        raise ParameterError(f"maximum duration {plain_value(max_duration_s)!r} must be a positive "
                             "number of seconds")
    todo: list[_Case] = []
    for i, ((r, f), dt) in enumerate(zip(cases, dts)):
        model = rig_model.build_model(r, f, dt)
        settle = rig_model.default_times(r, f)[1]
        window = window_length_s(r)
        limit = longest_run_s(r, f, max_duration_s)
        todo.append(_Case(index=i, model=model, rig=r, friction=f, timestep_s=dt,
                          first_window_s=settle, window_s=window, max_duration_s=limit,
                          state=sim.initial_state(model), forces=np.empty((0, 2))))
    results: list[SteadyRun | None] = [None] * len(cases)
    # Rollout runs models of one structure for one number of steps together: group by state
    # and sensor sizes and by timestep (a common step count would run a coarse case for as
    # many steps as the finest one needs).
    groups: dict[tuple[int, int, float], list[_Case]] = {}
    for c in todo:
        groups.setdefault((c.state.size, c.model.nsensordata, c.timestep_s), []).append(c)
    finished = 0
    threads = nthread if nthread is not None else sim.cpu_count()
    for group in groups.values():
        # One thread: step in the calling thread (no pool), as a single case does.
        pool_threads = min(threads, len(group)) if len(group) > 1 and threads > 1 else 0
        with mj_rollout.Rollout(nthread=pool_threads) as pool:
            active = list(group)
            first = True
            while active:
                if first:  # straight to every case's first decision (at most _MAX_CHUNK)
                    nstep = min(_MAX_CHUNK_STEPS, max(
                        math.ceil(c.window(_FIRST_DECISION)[1] / c.timestep_s) + 1
                        for c in active))
                    first = False
                else:  # one more window of the case with the most steps per window
                    nstep = max(math.ceil(c.window_s / HOPS_PER_WINDOW / c.timestep_s) + 1
                                for c in active)
                datas = [mujoco.MjData(active[0].model) for _ in range(max(1, pool_threads))]
                states = np.stack([c.state for c in active])
                state_out, sensordata = pool.rollout([c.model for c in active], datas, states,
                                                     nstep=nstep)
                still = []
                for k, c in enumerate(active):
                    _check_finite(c, state_out[k, -1], sensordata[k], nstep)
                    c.state = state_out[k, -1].copy()
                    if keep_series:
                        c.series.append(sensordata[k].copy())
                    c.forces = np.concatenate((c.forces, _force_columns(c.model, c.rig,
                                                                          sensordata[k])))
                    c.steps += nstep
                    result = _advance(c, tolerance)
                    if result is None:
                        still.append(c)
                        continue
                    if keep_series:
                        result = _with_series(result, c)
                    results[c.index] = result
                    finished += 1
                    if progress:
                        progress(finished, len(cases))
                active = still
    return [r for r in results if r is not None]


def _check_finite(c: _Case, last_state: np.ndarray, sensordata: np.ndarray, nstep: int) -> None:
    """A run that diverged (non-finite values, or MuJoCo's reset after a warning, which sets
    the time back) has no steady state: one message, not a number."""
    expected_time = (c.steps + nstep) * c.timestep_s
    if np.all(np.isfinite(sensordata)) and math.isclose(last_state[0], expected_time,
                                                        rel_tol=1e-9, abs_tol=1e-12):
        return
    raise ParameterError(
        f"the run of law {c.friction.law} at vibration_velocity_amplitude_m_per_s="
        f"{plain_value(c.rig.vibration_velocity_amplitude_m_per_s)} diverged within "
        f"{expected_time:.4g} s at timestep {c.timestep_s:.4g} s (MuJoCo warned and reset it, or "
        "a value is not finite); use a smaller --timestep or check the parameters")


def _force_columns(model: mujoco.MjModel, rig: RigParameters,
                   sensordata: np.ndarray) -> np.ndarray:
    """(drive force, friction force) of each step: all a summary needs."""
    s = sim.sensor_slices(model)
    return np.column_stack((rig_model.drive_force_columns(model, rig, sensordata),
                            sensordata[:, s["friction_state"]][:, 4]))


def _advance(c: _Case, tolerance: float) -> SteadyRun | None:
    """Judge every window the samples now cover; the case's result once a window converges
    or the next would end after the maximum time, else None."""
    time_s = (c.first_sample + np.arange(c.forces.shape[0])) * c.timestep_s
    t_last = (c.steps - 1) * c.timestep_s
    verdict = (False, math.inf, math.inf)
    while True:
        start, end = c.window(len(c.means))
        if end > t_last + 1e-12 or end > c.max_duration_s + 1e-12:
            break
        c.means.append(hann_mean(time_s, c.forces[:, 0], start, end))
        verdict = judge(c.means, tolerance, HOPS_PER_WINDOW)
        if verdict[0]:
            return _result(c, time_s, verdict, tolerance)
    if c.window(len(c.means))[1] > c.max_duration_s + 1e-12:
        return _result(c, time_s, judge(c.means, tolerance, HOPS_PER_WINDOW), tolerance)
    # Keep the samples from the last judged window on: the next window and a final summary.
    # (The older means stay: the judgement compares windows a whole window apart.)
    keep_from = c.window(max(0, len(c.means) - 1))[0]
    drop = max(0, int(np.searchsorted(time_s, keep_from, side="right")) - 2)
    c.forces = c.forces[drop:]
    c.first_sample += drop
    return None


def _result(c: _Case, time_s: np.ndarray, verdict: tuple[bool, float, float],
            tolerance: float) -> SteadyRun:
    start, end = c.window(len(c.means) - 1)
    inside = (time_s >= start - 1e-12) & (time_s <= end + 1e-12)
    friction = c.forces[inside, 1]
    vibrating = c.rig.vibration_frequency_Hz > 0 and c.rig.vibration_velocity_amplitude_m_per_s > 0
    summary = RunSummary(
        mean_drive_force_N=float(c.means[-1]),
        mean_friction_force_N=float(hann_mean(time_s, c.forces[:, 1], start, end)),
        friction_min_N=float(friction.min()), friction_max_N=float(friction.max()),
        sign_change=bool(friction.min() < 0 < friction.max()),
        window_start_s=start, window_end_s=end,
        periods_averaged=int(round(c.window_s * c.rig.vibration_frequency_Hz)) if vibrating else 0)
    convergence = Convergence(converged=verdict[0], tolerance=tolerance, window_s=c.window_s,
                              windows=len(c.means), relative_change=verdict[1],
                              estimated_remaining_error=verdict[2], simulated_s=end)
    return SteadyRun(rig=c.rig, friction=c.friction, timestep_s=c.timestep_s, summary=summary,
                     convergence=convergence)


def _with_series(result: SteadyRun, c: _Case) -> SteadyRun:
    """The result with the run's time series up to the reported window's end."""
    data = np.concatenate(c.series)
    keep = np.arange(data.shape[0]) * c.timestep_s <= result.summary.window_end_s + 1e-12
    run = rig_model.runs_from_sensordata(c.model, c.rig, c.friction, data[keep],
                                          result.summary.window_start_s)
    return replace(result, run=run)


def convergence_of_run(run: rig_model.RigRun, settle_time_s: float,
                       tolerance: float = DEFAULT_TOLERANCE) -> Convergence:
    """The same judgement for a run of fixed length: the last MIN_WINDOWS windows that fit
    between ``settle_time_s`` and the run's end (not converged when fewer fit)."""
    window = window_length_s(run.rig)
    end = float(run.time_s[-1])
    fit = int(math.floor((end - settle_time_s) / window + 1e-9))
    count = max(0, min(fit, MIN_WINDOWS))
    means = [hann_mean(run.time_s, run.drive_force_N, end - (j + 1) * window, end - j * window)
             for j in reversed(range(count))]
    converged, change, remaining = judge(means, tolerance)
    return Convergence(converged=converged, tolerance=tolerance, window_s=window,
                       windows=len(means), relative_change=change,
                       estimated_remaining_error=remaining, simulated_s=end)


METHODS = ("auto", "periodic", "transient")


def check_method(method: str) -> str:
    """``method`` if it is one of METHODS, else one clear error."""
    if method not in METHODS:
        raise ParameterError(f"method {method!r} is not one of {', '.join(METHODS)} (auto: the "
                             "periodic orbit where it is found, the transient otherwise)")
    return method


__all__ = ["Convergence", "SteadyRun", "run_until_steady", "check_timestep",
           "case_timesteps", "METHODS",
           "check_method", "window_length_s", "judge",
           "hann_mean", "convergence_of_run", "longest_run_s", "DEFAULT_TOLERANCE",
           "DEFAULT_MAX_DURATION_S"]
