"""``vibrofriction simulate``: one run of the paper's rig.

The time series goes to ``--csv FILE`` in the dataset format (``NAME.csv`` plus the sidecar
``NAME.json``, see docs/dataset-format.md); the summary (parameters, mean drive force over
whole vibration periods after the transient, friction extrema, sign change, and with
``--static`` the static drive force F_d-s and the ratio F_d-v/F_d-s) goes to ``--json FILE``
or, without it, to stdout.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from ..rigs import rig as rig_module
from .common import UsageError, add_common_arguments, parse_overrides, write_json
from ..data.datasets import (MIN_SAMPLE_INTERVAL_S, Dataset, DatasetMetadata, all_or_nothing,
                             sidecar_path, write_dataset)
from ..params import FrictionParameters, RigParameters, apply_overrides, as_dict, default_friction
from ..rigs.steady import DEFAULT_MAX_DURATION_S, DEFAULT_TOLERANCE, SteadyRun, longest_run_s
from ..rigs.sweep import convergence_fields, run_cases, unconverged_line

MAX_STEPS = 5e8  # steps of one run: hours of wall time and gigabytes of recorded series

HELP = ("run the vibrating-support rig once: time series to CSV (dataset format), summary "
        "(mean drive force, friction extrema, sign change) to JSON")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the simulate command's options to its argparse parser."""
    add_common_arguments(parser)
    add_run_arguments(parser)
    parser.add_argument("--csv", dest="csv_path", type=Path, default=None, metavar="FILE",
                        help="write the time series to FILE (NAME.csv or NAME.csv.gz) and its "
                             "sidecar NAME.json, in the dataset format")
    parser.add_argument("--static", action="store_true",
                        help="also run the rig without vibration and report the static drive "
                             "force F_d-s and the ratio F_d-v/F_d-s")


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """--duration, --settle, --tolerance and --max-duration, shared with ``sweep``."""
    parser.add_argument("--duration", type=str, default=None, metavar="S",
                        help="simulated time in seconds; without it each run goes on until "
                             "its mean drive force over windows of whole periods has "
                             "converged (--tolerance), at most --max-duration")
    parser.add_argument("--settle", type=str, default=None, metavar="S",
                        help="with --duration: start of the averaging window in seconds "
                             "(default: two loadings to breakaway + 30 ms, or half of a "
                             "shorter --duration)")
    parser.add_argument("--tolerance", type=str, default=None, metavar="REL",
                        help="relative change of the mean drive force between successive "
                             "windows, and estimated distance to its limit, at which a run "
                             f"has converged (default {DEFAULT_TOLERANCE:g})")
    parser.add_argument("--max-duration", dest="max_duration", type=str, default=None,
                        metavar="S",
                        help="longest simulated time of a run that has not converged "
                             f"(default {DEFAULT_MAX_DURATION_S:g} s; at least the transient "
                             "and three windows); such a run is flagged "
                             '"converged": false')


def positive_seconds(text: str | float | None, option: str,
                     unit: str = "seconds") -> float | None:
    """Parse a positive, finite number (of ``unit``); None stays None."""
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{option} {text!r} is not a number of {unit}") from None
    if not (math.isfinite(value) and value > 0):
        raise UsageError(f"{option} {text!r} must be a finite number of {unit} > 0")
    return value


def parameters_from_args(args: argparse.Namespace) -> tuple[RigParameters, FrictionParameters]:
    """Rig and friction parameters: the law's defaults, then every ``--set``."""
    overrides = parse_overrides(args.overrides)
    law = str(overrides.pop("law", args.law))
    rig = RigParameters()
    rig, _ = apply_overrides(rig, default_friction("dahl"), {
        k: v for k, v in overrides.items() if k in _rig_names()})
    friction = default_friction(law, rig)
    return apply_overrides(rig, friction, overrides)


@dataclass(frozen=True)
class RunSettings:
    """How the runs of one command are timed. ``duration_s`` None: run to steady state."""

    timestep_s: float | None
    duration_s: float | None
    settle_time_s: float | None
    tolerance: float
    max_duration_s: float | None


def run_settings(args: argparse.Namespace, cases: list[tuple[RigParameters, FrictionParameters]]
                 ) -> RunSettings:
    """The run settings from the options and the cases' defaults, checked."""
    timestep = positive_seconds(args.timestep, "--timestep")
    duration = positive_seconds(args.duration, "--duration")
    settle = positive_seconds(args.settle, "--settle")
    tolerance = positive_seconds(args.tolerance, "--tolerance", "relative error")
    max_duration = positive_seconds(args.max_duration, "--max-duration")
    tolerance = DEFAULT_TOLERANCE if tolerance is None else tolerance
    if duration is None:
        if settle is not None:
            raise UsageError("--settle needs --duration: without it each run averages over "
                             "windows after its transient and goes on until they agree")
        for rig, friction in cases:
            dt = timestep if timestep is not None else rig_module.recommended_timestep(rig)
            longest = longest_run_s(rig, friction, max_duration)
            if longest / dt > MAX_STEPS:
                raise UsageError(_too_many_steps(args, [(rig, friction)], longest, dt))
        return RunSettings(timestep, None, None, tolerance, max_duration)
    if args.max_duration is not None:
        raise UsageError("--max-duration applies to runs to steady state; with --duration "
                         "every run is that long")
    if timestep is None:  # the finest the cases recommend (one timestep for a rollout batch)
        timestep = min(rig_module.recommended_timestep(r) for r, _ in cases)
    defaults = [rig_module.default_times(r, f) for r, f in cases]
    if settle is None:
        settle = max(s for _, s in defaults)
        if settle >= duration:  # a short --duration: average over its second half
            settle = 0.5 * duration
    if settle >= duration:
        raise UsageError(f"--settle {_g(settle)} s must be before the end of the run "
                         f"(--duration {_g(duration)} s)")
    periods = [1.0 / r.vibration_frequency_Hz for r, _ in cases
               if r.vibration_frequency_Hz > 0 and r.vibration_velocity_amplitude_m_per_s > 0]
    if periods and duration - settle < max(periods) - 1e-12:
        raise UsageError(f"the averaging window {_g(duration - settle)} s (--duration minus "
                         f"--settle) is shorter than one vibration period {_g(max(periods))} s")
    if duration / timestep > MAX_STEPS:
        raise UsageError(_too_many_steps(args, cases, duration, timestep))
    if timestep > duration:
        raise UsageError(f"--timestep {_g(timestep)} s is longer than --duration "
                         f"{_g(duration)} s")
    return RunSettings(timestep, duration, settle, tolerance, None)


def _too_many_steps(args: argparse.Namespace,
                    cases: list[tuple[RigParameters, FrictionParameters]], duration: float,
                    timestep: float) -> str:
    """The message for a run of more than MAX_STEPS steps: the user's options, or for a
    default the parameter values that made it that long or that fine, and what to change."""
    fixes = []
    if args.duration is not None:
        long_text = f"--duration {_g(duration)} s"
        fixes.append("a shorter --duration")
    else:  # a run to steady state: at most --max-duration, at least the transient + windows
        rig, friction = max(cases, key=lambda c: rig_module.default_times(*c)[0])
        long_text = f"a run to steady state of up to {_g(duration)} s"
        staged = rig.vibration_from_s > 0 and rig.vibration_velocity_amplitude_m_per_s > 0
        transient = rig_module.default_times(rig, friction)[1]
        if staged and rig.vibration_from_s > 0.5 * duration:  # the still stage made it long
            long_text += (f" (the still stage vibration_from_s={_g(rig.vibration_from_s)} s, "
                          "the vibration's build-up, then the transient and the windows)")
            fixes.append("--set a smaller vibration_from_s")
        elif transient > 0.5 * duration:  # the loadings to breakaway made it long
            long_text += (
                " (two loadings of the drive spring to breakaway, 2 friction_coefficient "
                "normal_force_N static_ratio / (drive_stiffness_N_per_m "
                f"drive_velocity_m_per_s) = 2*{_g(friction.friction_coefficient)}*"
                f"{_g(rig.normal_force_N)}*{_g(friction.static_ratio)}/"
                f"({_g(rig.drive_stiffness_N_per_m)}*{_g(abs(rig.drive_velocity_m_per_s))}), "
                "plus 30 ms and the windows" + (
                    f"; first the drive takes up its play, drive_backlash_m="
                    f"{_g(rig.drive_backlash_m)}, and pulls through its faces' stiffness"
                    if rig.drive_backlash_m > 0 else "") + ")")
            fixes.append("--set a smaller normal_force_N or a larger drive_velocity_m_per_s "
                         "or drive_stiffness_N_per_m")
        else:  # the maximum time itself
            fixes.append("a shorter --max-duration" if args.max_duration is not None
                         else "--max-duration S")
    if args.timestep is not None:
        step_text = f"--timestep {_g(timestep)} s"
        fixes.append("a larger --timestep")
    else:  # the finest default: N + 0.382 steps per vibration period
        rig, _ = min(cases, key=lambda c: rig_module.recommended_timestep(c[0]))
        step_text = f"the default timestep {_g(timestep)} s"
        fixes.append("--timestep S")
        n = rig_module.steps_per_period(rig.kappa)
        if timestep < rig_module.DEFAULT_TIMESTEP_S and n > rig_module.BASE_STEPS_PER_PERIOD:
            step_text += (
                f" ({n} steps per period of vibration_frequency_Hz="
                f"{_g(rig.vibration_frequency_Hz)}: {rig_module.BASE_STEPS_PER_PERIOD}, "
                "doubled per doubling above 10 of kappa_v = "
                "vibration_velocity_amplitude_m_per_s / drive_velocity_m_per_s = "
                f"{_g(rig.vibration_velocity_amplitude_m_per_s)}/"
                f"{_g(abs(rig.drive_velocity_m_per_s))})")
            fixes.append("a smaller vibration amplitude (--va or "
                         "vibration_velocity_amplitude_m_per_s) or a larger "
                         "drive_velocity_m_per_s")
    return (f"{long_text} at {step_text} is {duration / timestep:.3g} steps, more than "
            f"{MAX_STEPS:.0e}; give " + ", or ".join(fixes))


def _g(value: float) -> str:
    """A number for a message: 6 significant digits, no float noise (800000.07, not
    800000.0700000001)."""
    return f"{float(value):.6g}"


def summary_fields(result: SteadyRun, static_drive_force_N: float | None) -> dict[str, Any]:
    """The summary of one run under the names of the sweep's points (docs/interfaces.md), with
    its convergence."""
    s = result.summary
    ratio = None
    if static_drive_force_N is not None and static_drive_force_N != 0:
        ratio = s.mean_drive_force_N / static_drive_force_N
    return {
        "vibration_velocity_amplitude_m_per_s": result.rig.vibration_velocity_amplitude_m_per_s,
        "kappa": result.rig.kappa,
        "mean_drive_force_N": s.mean_drive_force_N,
        "ratio": ratio,
        "friction_min_N": s.friction_min_N,
        "friction_max_N": s.friction_max_N,
        "sign_change": s.sign_change,
        "mean_friction_force_N": s.mean_friction_force_N,
        "periods_averaged": s.periods_averaged,
        **convergence_fields(result.timestep_s, s, result.convergence),
    }


def dataset_of(run: rig_module.RigRun, name: str) -> Dataset:
    """The run as a dataset: RigRun.columns() plus the rig's sidecar keys."""
    rig = run.rig
    metadata = DatasetMetadata(
        description=(f"vibrofriction simulate: law {run.friction.law}, v_a = "
                     f"{float(rig.vibration_velocity_amplitude_m_per_s)!r} m/s, dt = "
                     f"{float(run.timestep_s)!r} s" + (
                         f", the table still until {float(rig.vibration_from_s)!r} s"
                         if rig.vibration_from_s > 0 else "")),
        mass_kg=rig.mass_kg,
        drive_stiffness_N_per_m=rig.drive_stiffness_N_per_m,
        drive_velocity_m_per_s=rig.drive_velocity_m_per_s,
        vibration_frequency_Hz=rig.vibration_frequency_Hz if rig.vibration_frequency_Hz > 0
        else None,
        normal_force_N=rig.normal_force_N,
        sample_rate_Hz=float(f"{1.0 / run.timestep_s:.12g}"),
        source="vibrofriction simulate (MuJoCo rig, mjcf_models/rig)",
        simulation_timestep_s=run.timestep_s,
    )
    return Dataset(name=name, columns=run.columns(), metadata=metadata)


def run(args: argparse.Namespace) -> int:
    """Run the simulate command on parsed arguments; return the exit status."""
    rig, friction = parameters_from_args(args)
    if args.csv_path is not None:
        sidecar = sidecar_path(args.csv_path)  # checks the name before simulating
        if args.json_path is not None and Path(args.json_path).resolve() == sidecar.resolve():
            raise UsageError(f"--json {args.json_path} would overwrite the CSV's sidecar; "
                             "choose another name")
    cases = [(rig, friction)]
    if args.static:
        cases.append((replace(rig, vibration_velocity_amplitude_m_per_s=0.0), friction))
    settings = run_settings(args, cases)
    # A run to steady state without --timestep uses the rig's recommended one.
    timestep = (settings.timestep_s if settings.timestep_s is not None
                else rig_module.recommended_timestep(rig))
    if args.csv_path is not None and timestep < MIN_SAMPLE_INTERVAL_S:
        raise UsageError(f"--csv {args.csv_path}: a record sampled every {_g(timestep)} s "
                         f"(the timestep) is finer than the {MIN_SAMPLE_INTERVAL_S:g} s a "
                         "dataset accepts; use a larger --timestep or leave out --csv")
    results = run_cases(cases, timestep_s=settings.timestep_s, duration_s=settings.duration_s,
                        settle_time_s=settings.settle_time_s, tolerance=settings.tolerance,
                        max_duration_s=settings.max_duration_s,
                        keep_series=args.csv_path is not None)
    main = results[0]
    static = results[1].summary.mean_drive_force_N if args.static else None
    payload: dict[str, Any] = {
        "law": friction.law,
        "parameters": as_dict(rig, friction),
        "timestep_s": main.timestep_s,
        "duration_s": (main.convergence.simulated_s if settings.duration_s is None
                       else settings.duration_s),
        "settle_time_s": (main.summary.window_start_s if settings.settle_time_s is None
                          else settings.settle_time_s),
        "static_drive_force_N": static,
        **summary_fields(main, static),
        "static_convergence": (None if not args.static else convergence_fields(
            results[1].timestep_s, results[1].summary, results[1].convergence)),
        "csv": None if args.csv_path is None else str(args.csv_path),
    }
    with all_or_nothing():  # the CSV, its sidecar and the JSON: all of them or none
        if args.csv_path is not None:
            name = sidecar_path(args.csv_path).stem
            write_dataset(dataset_of(main.run, name), args.csv_path)
        if args.json_path is not None:
            write_json(args.json_path, payload)
    if args.json_path is None:
        write_json(None, payload)
    for result, label in zip(results, ("the run", "the static run")):
        if not result.convergence.converged:
            print(unconverged_line("simulate", label, result.convergence,
                                   fixed=settings.duration_s is not None), file=sys.stderr)
    return 0


def _rig_names() -> set[str]:
    return set(asdict(RigParameters()))
