#!/usr/bin/env python3
"""Build README.md, the front page, from docs/readme_template.md.

The README is the template with the figure link put in at `<!-- FIGURE -->`; the detailed
material lives in pages under docs/ that the README links (docs/simulation.md, docs/study.md,
docs/identification.md, docs/robots.md, ...). docs/study.md is written by the run that produces
its numbers (scripts/fig_readme.py, from a `vibrofriction reproduce` folder); the other pages
are edited by hand from scripts/bench_plugin.py, scripts/bench_averaged.py and
scripts/identify_real_data.py runs. The README is never edited directly: change the template,
then run this script.

    python scripts/build_readme.py
"""
from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FIGURE = ("![Master curves: drive-force ratio F_d-v/F_d-s against kappa_v = v_a/v_d for the four "
          "laws, with their kinematic limits](docs/figures/master_curves.png)")


def build() -> str:
    template = (DOCS / "readme_template.md").read_text()
    return template.replace("<!-- FIGURE -->", FIGURE)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if README.md is not what the template builds")
    args = parser.parse_args(argv)
    text = build()
    readme = ROOT / "README.md"
    if args.check:
        return 0 if readme.exists() and readme.read_text() == text else 1
    readme.write_text(text)
    print(f"wrote {readme}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
