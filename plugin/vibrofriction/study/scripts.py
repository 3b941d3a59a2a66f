"""What every ``scripts/fig_*.py`` shares: argparse (--out, --quick), the Agg backend, and the
study configuration. Paths live here, in one place."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence

from .config import StudyConfig
from .output import StageLog
from .reproduce import DEFAULT_OUT, study_config


def parse(description: str, argv: Sequence[str] | None = None,
          extra: Callable[[argparse.ArgumentParser], None] | None = None) -> argparse.Namespace:
    import matplotlib
    matplotlib.use("Agg")
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                        help=f"output folder (default ./{DEFAULT_OUT})")
    parser.add_argument("--quick", action="store_true", help="small grids, a smoke run")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def config(args: argparse.Namespace) -> StudyConfig:
    return study_config(args.quick)


def log(stages: int = 1) -> StageLog:
    return StageLog(stages)


def done(*paths: Path) -> int:
    for path in paths:
        print(f"wrote {path}", file=sys.stdout)
    return 0
