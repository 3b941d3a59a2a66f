#!/usr/bin/env python3
"""Assemble README.md from docs/readme_template.md and the section files docs/readme_*.md.

The sections are written by the runs that produce their numbers (scripts/fig_readme.py writes
docs/readme_study.md from a `vibrofriction reproduce` folder; the others are edited by hand from
scripts/bench_plugin.py, scripts/bench_averaged.py and scripts/identify_real_data.py runs), so
the README is never edited directly: change a section, then run this script.

    python scripts/build_readme.py
"""
from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SECTIONS = ("readme_core.md", "readme_study.md", "readme_identify.md", "readme_robots.md")
FIGURE = ("![Master curves: drive-force ratio F_d-v/F_d-s against kappa_v = v_a/v_d for the four "
          "laws, with their kinematic limits](docs/figures/master_curves.png)")


def section(name: str) -> str:
    text = (DOCS / name).read_text()
    # Drop leading HTML comments; figure links are relative to docs/.
    while text.lstrip().startswith("<!--"):
        text = text.lstrip()
        text = text[text.index("-->") + 3:]
    return text.strip().replace("](figures/", "](docs/figures/") + "\n"


def build() -> str:
    template = (DOCS / "readme_template.md").read_text()
    body = "\n".join(section(name) for name in SECTIONS)
    return template.replace("<!-- FIGURE -->", FIGURE).replace("<!-- SECTIONS -->", body.strip())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if README.md is not what the sections assemble to")
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
