"""``vibrofriction sweep --va V1,V2,...``: the master curve F_d-v/F_d-s over v_a.

Every amplitude and the static run (v_a = 0, giving F_d-s) are simulated in parallel on
MuJoCo rollout threads (one model per case) with a progress bar on stderr. The JSON is
docs/interfaces.md's: ``{"law", "parameters", "static_drive_force_N", "points": [...]}``.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace

from .common import UsageError, add_common_arguments, write_json
from ..rigs.steady import METHODS
from ..rigs.sweep import sweep, unconverged_lines
from .simulate import add_run_arguments, parameters_from_args, run_settings

HELP = ("master curve: mean drive force over the vibration velocity amplitudes --va "
        "V1,V2,... (m/s), relative to the static drive force; runs in parallel")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the sweep command's options to its argparse parser."""
    parser.add_argument("--va", required=True, metavar="V1,V2,...",
                        help="vibration velocity amplitudes v_a in m/s, comma-separated, each "
                             ">= 0, e.g. --va 0.75e-3,3e-3,20e-3")
    add_common_arguments(parser)
    add_run_arguments(parser)
    add_method_argument(parser)
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="local rollout threads (default: one per CPU core, at most one "
                             "per run); not with --scheduler")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the amplitudes on this Dask scheduler (HOST:PORT; needs the "
                             "extra 'dask' and vibrofriction installed on the workers) instead "
                             "of local rollout threads; not with --threads (the workers' own "
                             "threads run the tasks: dask worker --nthreads N)")


def add_method_argument(parser: argparse.ArgumentParser, default: str = "transient") -> None:
    """--method periodic|transient|auto (shared by sweep, reproduce and compare-builtin)."""
    parser.add_argument("--method", choices=METHODS, default=default,
                        help="how each run reaches its steady state: transient (run from rest "
                             "until the windowed mean settles), periodic (solve for the "
                             "periodic orbit by shooting, rigs.periodic, 10-30x cheaper; a "
                             "point whose orbit is not found is flagged; where orbits coexist "
                             "it may find another than the one reached from rest), auto "
                             "(periodic where the orbit is found, transient otherwise); "
                             f"default {default}; each point's \"method\" says which. Not "
                             "with --duration, which runs fixed-length transients")


def parse_amplitudes(text: str) -> list[float]:
    """'0.75e-3,3e-3' -> [0.00075, 0.003]; each finite and >= 0."""
    values = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            raise UsageError(f"--va {text!r} has an empty entry; write V1,V2,... in m/s")
        try:
            value = float(item)
        except ValueError:
            raise UsageError(f"--va entry {item!r} is not a number (m/s)") from None
        if not math.isfinite(value) or value < 0:
            raise UsageError(f"--va entry {item!r} must be a finite velocity amplitude >= 0 "
                             "(m/s)")
        values.append(value)
    return values


def run(args: argparse.Namespace) -> int:
    """Run the sweep command on parsed arguments; return the exit status."""
    # Before anything else, so the refusal needs no cluster: a Dask task runs one amplitude on
    # its worker, whose thread count the worker sets, so --threads could not apply there.
    if args.threads is not None and args.scheduler is not None:
        raise UsageError(f"--threads {args.threads} sets local rollout threads and cannot be "
                         f"combined with --scheduler {args.scheduler}, where each Dask worker "
                         "runs the amplitudes on its own threads; drop --threads (set the "
                         "workers' threads with 'dask worker --nthreads N') or drop "
                         "--scheduler to run locally")
    amplitudes = parse_amplitudes(args.va)
    rig, friction = parameters_from_args(args)
    if args.threads is not None and args.threads < 1:
        raise UsageError(f"--threads {args.threads} must be >= 1")
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
             for va in [0.0, *amplitudes]]
    for case_rig, _ in cases:
        case_rig.validate()
    settings = run_settings(args, cases)
    if settings.duration_s is not None and args.method == "periodic":
        raise UsageError("--method periodic solves for the steady orbit and takes no "
                         "--duration (a fixed-length run is a transient); drop one of them")
    result = sweep(rig, friction, amplitudes, timestep_s=settings.timestep_s,
                   duration_s=settings.duration_s, settle_time_s=settings.settle_time_s,
                   tolerance=settings.tolerance, max_duration_s=settings.max_duration_s,
                   nthread=args.threads, scheduler=args.scheduler,
                   method="transient" if settings.duration_s is not None else args.method,
                   warn=False)
    write_json(args.json_path, result)
    for line in unconverged_lines(result, fixed=settings.duration_s is not None):
        print(line, file=sys.stderr)
    return 0
