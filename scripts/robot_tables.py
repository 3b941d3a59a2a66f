#!/usr/bin/env python3
"""Make the averaged-friction tables of the robot scenes (mjcf_models/robots/*_table.xml).

Source: vibrofriction.averaged.build_table, i.e. the resolved planar law of each scene's
vibrofriction.planar instance driven kinematically over the scene's vibration. Run it after
changing a scene's friction or vibration parameters, then scripts/dev_install.sh.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from vibrofriction import robots

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "mjcf_models" / "robots",
                        help="folder of the scene files (default: the source tree's)")
    args = parser.parse_args(argv)
    for name, text in robots.table_files().items():
        path = args.out / name
        path.write_text(text)
        print(f"wrote {path} ({len(text) / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
