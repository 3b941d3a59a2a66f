#!/usr/bin/env python3
"""The study's page: key figures (small palette PNGs in docs/figures/) and docs/study.md with
the claims and built-in comparison tables, all taken from the output folder of one
``vibrofriction reproduce`` run (run that first, without --no-builtin)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from vibrofriction.study.readme import write_study_page
from vibrofriction.study.reproduce import DEFAULT_OUT

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None) -> int:
    import matplotlib
    matplotlib.use("Agg")
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--results", type=Path, default=DEFAULT_OUT, metavar="DIR",
                        help=f"reproduce output folder (default ./{DEFAULT_OUT})")
    parser.add_argument("--out", type=Path, default=ROOT / "docs", metavar="DOCS",
                        help="docs folder (default the repository's docs/)")
    parser.add_argument("--quick", action="store_true", help="accepted for uniformity; unused")
    parser.add_argument("--costs", type=Path, default=None, metavar="DIR",
                        help="a `vibrofriction compare-builtin` output folder: its converged "
                             "master curve's cost by each route goes on the page")
    args = parser.parse_args(argv)
    path = write_study_page(args.results, args.out, costs_from=args.costs)
    print(f"wrote {path} and figures in {args.out / 'figures'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
