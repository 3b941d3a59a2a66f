#!/usr/bin/env python3
"""A grid sweep of the rig (Dahl) over v_a x f x k_t x F_N: F_d-v/F_d-s against kappa_v for
every combination. Local rollout threads by default; --scheduler ADDRESS runs it on an existing
Dask cluster (needs the 'dask' extra)."""
from __future__ import annotations

import sys

from vibrofriction.study import scripts
from vibrofriction.study.output import write_csv
from vibrofriction.study.sweep import SweepGrid, plot_sweep, run_sweep


def _extra(parser) -> None:
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="Dask scheduler address, e.g. tcp://127.0.0.1:8786")


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv, extra=_extra)
    config = scripts.config(args)
    grid = SweepGrid.from_config(config)
    log = scripts.log()
    log.stage(f"grid sweep: {grid.size} runs")
    result = run_sweep(grid, config, scheduler=args.scheduler, progress=log.progress("runs"))
    write_csv(args.out / "grid_sweep.csv", rows=[r.row() for r in result.records])
    return scripts.done(plot_sweep(result, args.out / "grid_sweep.png"),
                        args.out / "grid_sweep.csv")


if __name__ == "__main__":
    sys.exit(main())
