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
import warnings
from dataclasses import replace
from typing import Any, Callable, Sequence

from . import rig as rig_module
from ..errors import InputError
from ..params import FrictionParameters, RigParameters, as_dict
from .steady import (DEFAULT_TOLERANCE, MIN_WINDOWS, Case, Convergence, SteadyRun,
                     check_method, convergence_of_run, run_until_steady)
from ..summary import RunSummary

POINT_KEYS = ("vibration_velocity_amplitude_m_per_s", "kappa", "mean_drive_force_N", "ratio",
              "mean_friction_force_N", "friction_min_N", "friction_max_N", "sign_change")
# After the interface's keys, every point (and "static_convergence") says how it converged.
CONVERGENCE_KEYS = ("converged", "estimated_remaining_error", "relative_change",
                    "window_start_s", "window_end_s", "windows", "window_s", "tolerance",
                    "timestep_s", "method", "method_note")


CONNECT_TIMEOUT_S = 10  # waiting for a --scheduler to answer


class DaskUnavailable(InputError):
    """--scheduler was given but dask.distributed is not installed."""


def run_cases(cases: Sequence[Case], *, timestep_s: float | None = None,
              timesteps: Sequence[float] | None = None, duration_s: float | None = None,
              settle_time_s: float | None = None, tolerance: float = DEFAULT_TOLERANCE,
              max_duration_s: float | None = None, nthread: int | None = None,
              chunk_size: int | None = None, scheduler: Any = None,
              progress: Any = None, keep_series: bool = False,
              method: str = "transient") -> list[SteadyRun]:
    """The one engine of the package's sweeps: each case's summary and convergence, in the
    cases' order.

    Each case runs to steady state (no ``duration_s``) at its timestep (``timesteps``, else
    ``timestep_s`` for all, else its recommended one), or for ``duration_s`` at ``timestep_s``
    (default: the finest the cases recommend). Locally the cases run on rollout threads: all
    together, or with ``chunk_size`` a chunk at a time (coarse timesteps first; the memory of a
    chunk's runs is bounded). With ``scheduler`` (a Dask address or ``Client``) each chunk (one
    case without ``chunk_size``) is a task on that cluster. A case's result depends only on its
    own parameters and timestep, not on the chunks. ``progress(done, total)`` counts cases.

    ``method`` (to steady state only): "transient" (default) runs each from rest until its
    windows settle (``steady``); "periodic" solves for each case's periodic orbit
    (``rigs.periodic``, 10-30x cheaper; a case whose orbit is not found is flagged
    unconverged), "auto" the orbit where it is found and the transient otherwise; each
    result's ``convergence.method`` says which. Where orbits coexist (near the slider's
    contact resonance) the orbit found may not be the one a run from rest reaches: the Fig. 14
    configuration, Dahl at kappa_v 0.75, gives the sliding orbit (F_dv/F_ds 1.000) where the
    run from rest, and the scipy oracle, end vibrating (0.710). A run of fixed ``duration_s``, or one that keeps its time series, is a transient."""
    check_method(method)
    if duration_s is not None and method == "periodic":
        raise InputError("a run of fixed duration is a transient: method 'periodic' solves "
                         "for the steady orbit and takes no duration; drop one of them")
    if not cases:
        return []
    if keep_series:
        method = "transient"  # the time series from rest
    settings = dict(duration_s=duration_s, settle_time_s=settle_time_s, tolerance=tolerance,
                    max_duration_s=max_duration_s, method=method)
    if duration_s is not None:  # one timestep and one averaging window for every case
        if timestep_s is None:
            timestep_s = min(rig_module.recommended_timestep(r) for r, _ in cases)
        if settle_time_s is None:  # (so that no chunk takes its own)
            settings["settle_time_s"] = max(rig_module.default_times(r, f)[1] for r, f in cases)
        dts = [timestep_s] * len(cases)
    elif timesteps is not None:
        dts = list(timesteps)
    elif timestep_s is not None:
        dts = [timestep_s] * len(cases)
    else:
        dts = [rig_module.recommended_timestep(r) for r, _ in cases]
    if scheduler is None and chunk_size is None:
        return _run_chunk((list(cases), dts, dict(settings, nthread=nthread,
                                                  keep_series=keep_series), progress))
    chunks = _chunks(dts, chunk_size or 1)
    jobs = [([cases[i] for i in chunk], [dts[i] for i in chunk],
             dict(settings, nthread=nthread, keep_series=keep_series), None)
            for chunk in chunks]
    if scheduler is None:
        done: list[list[SteadyRun]] = []
        for job in jobs:
            done.append(_run_chunk(job))
            if progress:
                progress(sum(map(len, done)), len(cases))
    else:
        done = dask_map(_run_chunk, jobs, scheduler, sizes=[len(c) for c in chunks],
                        progress=progress)
    out: list[SteadyRun | None] = [None] * len(cases)
    for chunk, results in zip(chunks, done):
        for i, result in zip(chunk, results):
            out[i] = result
    return [r for r in out if r is not None]


def _chunks(dts: Sequence[float], size: int) -> list[list[int]]:
    """The cases' indices in chunks of at most ``size`` sharing a timestep, coarse first."""
    chunks = []
    for dt in sorted(set(dts), reverse=True):
        idx = [i for i, d in enumerate(dts) if d == dt]
        chunks += [idx[start:start + size] for start in range(0, len(idx), size)]
    return chunks


def _run_chunk(job: tuple) -> list[SteadyRun]:
    """One chunk of cases on local rollout threads (also a task on a Dask worker)."""
    cases, dts, settings, progress = job
    settings = dict(settings)
    duration_s, settle_time_s = settings.pop("duration_s"), settings.pop("settle_time_s")
    method = settings.pop("method", "transient")
    if duration_s is None and method != "transient":
        from .periodic import run_periodic
        return run_periodic(cases, timesteps=dts, tolerance=settings["tolerance"],
                            fallback=method == "auto", max_duration_s=settings["max_duration_s"],
                            nthread=settings["nthread"], progress=progress)
    if duration_s is None:
        return run_until_steady(cases, timesteps=dts, progress=progress, **settings)
    tolerance, keep_series = settings["tolerance"], settings["keep_series"]
    runs = rig_module.simulate_many(cases, duration_s=duration_s, timestep_s=dts[0],
                                    settle_time_s=settle_time_s, nthread=settings["nthread"],
                                    progress=progress)
    return [SteadyRun(rig=run.rig, friction=run.friction, timestep_s=dts[0],
                      summary=run.summary(), convergence=convergence_of_run(
                          run, run.settle_time_s, tolerance),
                      run=run if keep_series else None) for run in runs]


def dask_map(function: Callable[[Any], Any], items: Sequence[Any], scheduler: Any,
             sizes: Sequence[int] | None = None, progress: Any = None) -> list:
    """``function`` over ``items`` on a Dask cluster (``scheduler``: an address or a
    ``Client``), the results in the items' order; ``progress(done, total)`` counts ``sizes``
    (default one per item) as items complete."""
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise DaskUnavailable(
            "--scheduler needs dask.distributed; install the extra: pip install "
            "'vibrofriction[dask]' (or pip install 'dask[distributed]')") from exc
    sizes = list(sizes) if sizes is not None else [1] * len(items)
    own_client = not isinstance(scheduler, Client)
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S) if own_client else scheduler
    except (OSError, TimeoutError) as exc:
        raise InputError(f"--scheduler {scheduler}: no Dask scheduler answers there ({exc}); "
                         "start one (dask scheduler) or check the address") from None
    try:
        futures = client.map(function, list(items), pure=False)
        position = {future.key: i for i, future in enumerate(futures)}
        out: list[Any] = [None] * len(futures)
        done = 0
        for future in as_completed(futures):
            i = position[future.key]
            out[i] = future.result()
            done += sizes[i]
            if progress:
                progress(done, sum(sizes))
        return out
    finally:
        if own_client:
            client.close()


def joint_convergence(run: SteadyRun, static: SteadyRun) -> tuple[bool, float]:
    """The convergence of a ratio F_d-v/F_d-s: both runs converged, and the larger estimated
    remaining error of the two."""
    return (bool(run.convergence.converged and static.convergence.converged),
            float(max(run.convergence.estimated_remaining_error,
                      static.convergence.estimated_remaining_error)))


def sweep(rig: RigParameters, friction: FrictionParameters, amplitudes: list[float], *,
          timestep_s: float | None = None, duration_s: float | None = None,
          settle_time_s: float | None = None, tolerance: float = DEFAULT_TOLERANCE,
          max_duration_s: float | None = None, nthread: int | None = None,
          progress: bool = True, scheduler: Any = None, method: str = "transient",
          warn: bool = True) -> dict[str, Any]:
    """Run the sweep; return the docs/interfaces.md JSON object. Local rollout threads, or with
    ``scheduler`` (a Dask address or Client) one task per amplitude on that cluster.
    ``method``: ``run_cases``'s (default transient; each point says which). With ``warn``, a point that did not
    converge raises ``rig.UnconvergedWarning`` (its number is flagged "converged": false)."""
    if nthread is not None and scheduler is not None:
        # a Dask worker runs each amplitude on the threads it was started with
        raise InputError(f"nthread={nthread} sets local rollout threads and cannot be combined "
                         "with a scheduler, whose workers run on their own threads; pass one "
                         "of them (start the workers with 'dask worker --nthreads N')")
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=0.0), friction)]
    cases += [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
              for va in amplitudes]
    report = rig_module.progress_printer("sweep") if progress else None
    results = run_cases(cases, timestep_s=timestep_s, duration_s=duration_s,
                        settle_time_s=settle_time_s, tolerance=tolerance,
                        max_duration_s=max_duration_s, nthread=nthread, scheduler=scheduler,
                        progress=report, method=method)
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
    result = {"law": friction.law, "parameters": as_dict(rig, friction),
              "static_drive_force_N": static, "points": points,
              "static_convergence": convergence_fields(results[0].timestep_s,
                                                       results[0].summary,
                                                       results[0].convergence),
              "all_converged": all(r.convergence.converged for r in results)}
    if warn and not result["all_converged"]:
        warnings.warn("; ".join(unconverged_lines(result, fixed=duration_s is not None)),
                      rig_module.UnconvergedWarning, stacklevel=2)
    return result


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
            "timestep_s": timestep_s, "method": convergence.method,
            "method_note": convergence.note}


def unconverged_line(command: str, label: str, convergence: Convergence, *,
                     fixed: bool = False) -> str:
    """The stderr warning for one run that did not converge (``fixed``: of --duration)."""
    if convergence.method == "periodic":
        return (f"{command}: warning: {label}: its periodic orbit was not found or is "
                f"uncertain ({convergence.note}); it is flagged \"converged\": false. Use "
                "--method auto (the transient where the orbit is not found) or transient")
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
                simulated_s=fields["window_end_s"], method=fields.get("method", "transient"),
                note=fields.get("method_note", "")), fixed=fixed))
    return lines


def _inf(value: float | None) -> float:
    return math.inf if value is None else value
