#!/usr/bin/env python3
"""Make the generated include files of the robot scenes (mjcf_models/robots/*_table.xml).

Sources: plate_push_table.xml from vibrofriction.robots.averaged.build_table (the resolved planar law of
plate_push_resolved.xml's vibrofriction.planar instance driven kinematically over its
vibration); feeder_map_table.xml from vibrofriction.robots.feeder_map.build_map (the exact feeder
reference, vibrofriction.oracle.feeder_reference, for scenes.FEEDER, the track and parts of
feeder.xml). Run it after changing a scene's friction, vibration or feeder, then
scripts/dev_install.sh.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from vibrofriction.robots import scenes

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "mjcf_models" / "robots",
                        help="folder of the scene files (default: the source tree's)")
    args = parser.parse_args(argv)
    for name, text in scenes.table_files().items():
        path = args.out / name
        path.write_text(text)
        print(f"wrote {path} ({len(text) / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
