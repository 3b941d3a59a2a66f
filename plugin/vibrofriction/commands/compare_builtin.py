"""``vibrofriction compare-builtin``: the rig with MuJoCo's built-in friction vs the plugin."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco

from .common import add_common_arguments, check_replaceable_folder, parse_overrides, write_json
from .sweep import add_method_argument
from ..data.datasets import all_or_nothing, stage_folder
from ..provenance import json_text
from ..params import PAPER_CONTACT_STIFFNESS_N_PER_M, FrictionParameters, ParameterError, \
    apply_overrides
from ..study import builtin
from ..study.config import PAPER_RIG
from ..study.output import StageLog
from ..study.reproduce import comparison_config, comparison_json, study_config

HELP = ("the paper's rig with MuJoCo's own friction (joint frictionloss, box-on-box contact, "
        "dcmotor LuGre, springyield) against the plugin: master curves, traces, the timestep "
        "each needs for 1 % in the mean drive force and its wall time")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the compare-builtin command's options to its argparse parser."""
    parser.add_argument("--out", type=Path, default=Path("vibrofriction-builtin"),
                        metavar="DIR",
                        help="output folder (default ./vibrofriction-builtin: reproduce's "
                             "folder holds its own comparison); written beside it and put in "
                             "place at the end, so an existing DIR (empty or an earlier "
                             "comparison: it holds builtin.json) is replaced as a whole")
    parser.add_argument("--quick", action="store_true",
                        help="short timestep ladder and master grid")
    parser.add_argument("--variants", default=None, metavar="A,B,...",
                        help="variants to run (default: all the installed MuJoCo can build): "
                             + ", ".join(builtin.VARIANTS))
    parser.add_argument("--ladder", default=None, metavar="N1,N2,...",
                        help="steps per vibration period of the timestep ladder "
                             "(dt = T/(N + 0.382)); the finest is the reference")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_method_argument(parser, default="auto")  # (the converged curve's cost: the product's route)
    # No --timestep: the ladder and the master grid set every timestep.
    add_common_arguments(parser, law=False, timestep=False)


def run(args: argparse.Namespace) -> int:
    """Run the compare-builtin command on parsed arguments; return the exit status."""
    overrides = parse_overrides(args.overrides)
    changes = {}
    if "vibration_from_s" in overrides:
        raise ParameterError("compare-builtin compares steady vibration; --set "
                             "vibration_from_s=... is not accepted (use simulate for a stage "
                             "without vibration)")
    if overrides:
        rig, friction = apply_overrides(PAPER_RIG, FrictionParameters(
            contact_stiffness_N_per_m=PAPER_CONTACT_STIFFNESS_N_PER_M), overrides)
        changes.update(rig=rig, friction=friction)
    config = study_config(args.quick, **changes)
    if args.variants is None:  # all this MuJoCo can build; the others are named later
        names = list(builtin.available_variants(builtin.VARIANTS))
        left_out = builtin.unavailable_variants()
    else:
        names = [v.strip() for v in args.variants.split(",") if v.strip()]
        left_out = {}
    unknown = [v for v in names if v not in builtin.VARIANTS]
    if unknown:
        raise ParameterError(f"unknown variant(s) {', '.join(unknown)}; use: "
                             + ", ".join(builtin.VARIANTS))
    # The targets are needed as references.
    needed = list(dict.fromkeys(names + [builtin.VARIANTS[v].target for v in names]))
    cmp_config = comparison_config(args.quick, costs=True)
    cmp_changes = {"variants": tuple(needed), "method": args.method}
    if args.ladder:
        try:
            steps = tuple(sorted({int(x) for x in args.ladder.split(",")}))
        except ValueError:
            raise ParameterError(f"--ladder expects integers, got {args.ladder!r}") from None
        if len(steps) < 2 or steps[0] < 4:
            raise ParameterError("--ladder needs at least two values >= 4")
        cmp_changes["ladder_steps"] = steps
    from dataclasses import replace
    cmp_config = replace(cmp_config, **cmp_changes)
    check_replaceable_folder(args.out, "--out", "builtin.json",
                             foreign={"claims.json": "vibrofriction reproduce"})
    for name, why in left_out.items():  # after every check: a bad input is one line
        print(f"compare-builtin: {name} left out: MuJoCo {mujoco.__version__} lacks {why}",
              file=sys.stderr)
    log = StageLog(1, quiet=args.quiet)
    log.stage(f"{len(needed)} variants, ladder {list(cmp_config.ladder_steps)} steps per period")
    result = builtin.compare(config, cmp_config, progress=log.progress)
    payload = comparison_json(result)

    def write(folder: Path) -> None:
        builtin.write_comparison(result, folder)
        (folder / "builtin.json").write_text(json_text(payload))

    with all_or_nothing():  # DIR and --json FILE: both or neither
        stage_folder(args.out, write)
        if args.json_path is not None:
            write_json(args.json_path, payload)
    print(builtin.comparison_table(result))
    if result.costs:
        print()
        print(builtin.converged_costs_table(result.costs))
    print(f"wrote {args.out / 'builtin.md'}, {args.out / 'builtin_comparison.png'} and CSV "
          "tables")
    return 0
