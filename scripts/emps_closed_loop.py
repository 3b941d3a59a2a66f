"""The EMPS benchmark identified in closed loop, with a held-out half: the table in
docs/identification.md.

Converts ``DATA_EMPS.mat`` with ``vibrofriction convert`` (the record names its model, so
``identify`` simulates mjcf_models/emps in closed loop), cuts it at half time into a training
record and a held-out one (the benchmark's validation run, DATA_EMPS_PULSES.mat, is not in the
shared data; where it is, pass it with --validate), runs ``vibrofriction identify`` for each law
asked, and prints the closed-loop errors as the benchmark defines them beside the published
ones, with the time each identification took.

    python scripts/emps_closed_loop.py [--data DATA_EMPS.mat] [--laws coulomb,lugre]
        [--with viscous,force_offset] [--out DIR] [--validate DATA_EMPS_PULSES.mat]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from vibrofriction import cli
from vibrofriction.data.convert import convert_emps
from vibrofriction.data.datasets import Dataset, write_dataset
from vibrofriction.identify.simulation_report import PUBLISHED_CLOSED_LOOP

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared/data/emps/DATA_EMPS.mat"


def halves(record: Dataset) -> tuple[Dataset, Dataset]:
    n = record.n_rows // 2
    first = Dataset(name=f"{record.name}_first_half", metadata=record.metadata,
                    columns={c: np.asarray(v)[:n] for c, v in record.columns.items()})
    second = Dataset(name=f"{record.name}_second_half", metadata=record.metadata,
                     columns={c: np.asarray(v)[n:] for c, v in record.columns.items()})
    return first, second


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--laws", default="coulomb")
    parser.add_argument("--with", dest="declared", default="",
                        help="effects declared in advance (identify --with), e.g. "
                             "viscous,force_offset: the benchmark's IDIM-LS structure")
    parser.add_argument("--out", type=Path, default=Path("emps_closed_loop"))
    parser.add_argument("--validate", type=Path, action="append", default=[],
                        help="a further held-out .mat (e.g. DATA_EMPS_PULSES.mat)")
    args = parser.parse_args(argv)
    if not args.data.is_file():
        print(f"EMPS data not found at {args.data}; pass --data DATA_EMPS.mat", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    first, second = halves(convert_emps(args.data))
    paths = []
    for part in (first, second):
        path = args.out / f"{part.name}.csv"
        write_dataset(part, path)
        paths.append(path)
    for extra in args.validate:
        held = convert_emps(extra)
        path = args.out / f"{held.name}.csv"
        write_dataset(held, path)
        paths.append(path)
    rows = []
    for law in [s.strip() for s in args.laws.split(",") if s.strip()]:
        report = args.out / f"identify_{law}"
        started = time.monotonic()
        argv = ["identify", str(paths[0]), "--law", law, "--out", str(report)]
        if args.declared:
            argv += ["--with", args.declared]
        for held in paths[1:]:
            argv += ["--validate", str(held)]
        code = cli.main(argv)
        seconds = time.monotonic() - started
        if code != 0:
            return code
        result = json.loads((report / "report.json").read_text())
        rows.append((law, result, seconds))
    print("\nclosed-loop simulation errors, relerr from the 50th sample (force | position | "
          "velocity)")
    for law, result, seconds in rows:
        loop = result["closed_loop"]
        for label in ("baseline", "final"):
            for record, e in loop[label].items():
                print(f"  {law:<8s} {label:<8s} {record:<28s} {e['force_relerr_pct']:7.3f} % | "
                      f"{e['position_relerr_pct']:8.4f} % | {e['velocity_relerr_pct']:7.3f} %")
        print(f"  {law:<8s} selected: {', '.join(result['selected_effects']) or 'nothing'}; "
              f"{seconds:.0f} s, {result['settings']['substeps']} step(s) a sample")
    for record, e in PUBLISHED_CLOSED_LOOP["emps"].items():
        print(f"  published IDIM-LS {record:<34s} {e['force_relerr_pct']:7.3f} % | "
              f"{e['position_relerr_pct']:8.4f} % | {e['velocity_relerr_pct']:7.3f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
