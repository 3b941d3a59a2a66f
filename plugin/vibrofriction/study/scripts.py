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
    """Parse a figure script's command line (``--out DIR``, ``--quick``); selects matplotlib's
    Agg backend and makes the output folder.

    Parameters
    ----------
    description : str
        The script's description for ``--help``.
    argv : sequence of str, optional
        The arguments (default ``sys.argv[1:]``).
    extra : callable, optional
        Adds the script's own options to the parser.

    Returns
    -------
    argparse.Namespace
        The parsed arguments; ``out`` is a Path to an existing folder.
    """
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
    """The study configuration the script's arguments ask for (quick or full)."""
    return study_config(args.quick)


def log(stages: int = 1) -> StageLog:
    """A progress log on stderr for a script of ``stages`` stages."""
    return StageLog(stages)


def done(*paths: Path) -> int:
    """Print "wrote PATH" for each file written; return 0, the script's exit status."""
    for path in paths:
        print(f"wrote {path}", file=sys.stdout)
    return 0
