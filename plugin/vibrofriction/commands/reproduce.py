"""``vibrofriction reproduce [--quick] [--out DIR]``: every figure of the paper's simulation
study, the built-in comparison, a grid sweep, and the claims summary."""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from .common import add_common_arguments, check_replaceable_folder, parse_overrides, write_json
from .sweep import add_method_argument
from ..data.datasets import all_or_nothing, stage_folder
from ..params import PAPER_CONTACT_STIFFNESS_N_PER_M, ParameterError, apply_overrides
from ..study.claims import json_ready, summary_json
from ..study.config import PAPER_RIG, StudyConfig
from ..study.reproduce import DEFAULT_OUT, reproduce, study_config

HELP = ("regenerate the paper's figures (Figs. 7-14, master curves), the built-in friction "
        "comparison, a grid sweep and summary.md/claims.json with every claim's number")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the reproduce command's options to its argparse parser."""
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                        help=f"output folder (default ./{DEFAULT_OUT}); written beside it and "
                             "put in place when the run ends, so an existing DIR (empty or an "
                             "earlier output: it holds claims.json) is replaced as a whole")
    parser.add_argument("--quick", action="store_true",
                        help="small grids (a smoke run of every figure, about a minute)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the grid sweep on an existing Dask cluster at ADDRESS "
                             "(e.g. tcp://host:8786; needs the 'dask' extra)")
    parser.add_argument("--no-builtin", dest="builtin", action="store_false",
                        help="skip the built-in friction comparison (compare-builtin)")
    parser.add_argument("--no-sweep", dest="sweep", action="store_false",
                        help="skip the grid sweep")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_method_argument(parser)
    add_common_arguments(parser, law=False)
    parser.epilog = ("--set NAME=VALUE changes the base parameters of every figure (e.g. "
                     "--set alpha=2); what a figure takes from the paper (v_a, and f, v_d, "
                     "F_N, k_t, m in Figs. 13/14) is still set by the figure. --timestep S "
                     "replaces the timestep rule by a fixed step. --json FILE writes claims.json "
                     "also to FILE.")


def config_from_args(args: argparse.Namespace) -> StudyConfig:
    """The study configuration from the options: quick or full, the ``--set`` overrides of the
    paper's rig and friction, ``--timestep`` and ``--method``; ParameterError for what
    reproduce does not accept (``law``, ``vibration_from_s``, a timestep <= 0)."""
    overrides = parse_overrides(args.overrides)
    changes = {}
    if overrides:
        from ..params import FrictionParameters
        rig, friction = apply_overrides(PAPER_RIG, FrictionParameters(
            contact_stiffness_N_per_m=PAPER_CONTACT_STIFFNESS_N_PER_M), overrides)
        if "law" in overrides:
            raise ParameterError("reproduce runs every law; --set law=... is not accepted")
        if "vibration_from_s" in overrides:
            raise ParameterError("reproduce averages over steady vibration, as the paper's "
                                 "study does; --set vibration_from_s=... is not accepted (use "
                                 "simulate for a stage without vibration)")
        changes["rig"] = rig
        changes["friction"] = friction
    if args.timestep is not None:
        if not args.timestep > 0:
            raise ParameterError(f"--timestep {args.timestep} must be > 0")
        changes["timestep_s"] = args.timestep
    changes["method"] = getattr(args, "method", "transient")
    return study_config(args.quick, **changes)


def run(args: argparse.Namespace) -> int:
    """Run the reproduce command on parsed arguments; return the exit status."""
    config = config_from_args(args)
    check_replaceable_folder(args.out, "--out", "claims.json")
    command = "vibrofriction " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
        if sys.argv and sys.argv[0].endswith("vibrofriction") else \
        f"vibrofriction reproduce{' --quick' if args.quick else ''} --out {args.out}"
    made = {}

    def write(folder: Path) -> None:
        made["results"], made["claims"] = reproduce(
            folder, config=config, scheduler=args.scheduler, with_builtin=args.builtin,
            with_sweep=args.sweep, quiet=args.quiet, command=command)

    with all_or_nothing():  # DIR and --json FILE: both or neither, DIR only when complete
        stage_folder(args.out, write)
        results, claims = made["results"], made["claims"]
        if args.json_path is not None:
            write_json(args.json_path, json_ready(summary_json(results, claims)))
    held = sum(1 for c in claims if c.holds == "yes")
    print(f"wrote {args.out}/summary.md, claims.json and {len(results.files)} files; "
          f"{held} of {len(claims)} claims hold in this run ({results.wall_s:.0f} s)")
    return 0
