#!/usr/bin/env python3
"""Identify the three real friction records in ../shared/data and tabulate before/after.

Sources (see ../shared/data/README.md; cite them when you use the numbers):
  EMPS benchmark, DATA_EMPS.mat: Janot, Gautier, Brunot, "Data Set and Reference Models of
    EMPS", Nonlinear System Identification Benchmarks workshop, 2019.
  Friction damper: Coble, Huggins, Cao, Ricles, Downey, "Dataset-Friction-Damper-with-Backlash"
    (ARTS Lab), CC BY-SA 4.0.
  Pneumatic seals: Zillen (TU Delft) thesis data, CC0 1.0.

What runs (each one `vibrofriction identify`, reports under OUT/<case>/):
  EMPS: the whole 24.8 s record (4 identical cycles) is split in two halves, the first
    trains and the second is held out. Coulomb baseline -> traced; the benchmark's IDIM-LS
    model (Coulomb + viscous + offset, --with viscous,force_offset) -> traced, raw and with the
    IDIM practice of a 100 Hz zero-phase low-pass (the benchmark's 4.08 % is of filtered and
    decimated data); and LuGre with the same declared effects.
  Friction damper: fit the 1 Hz run, validate on the 2 Hz run (and the reverse).
  Pneumatic seals: each file holds 10 strokes; the first five train, the last five are held
    out (the three files differ in seal and pressure, with no normal-force signal to carry a
    model from one pressure to another).

Usage:  .venv/bin/python scripts/identify_real_data.py [--out DIR] [--figures DIR]
Writes OUT/summary.md (the before/after table) and prints it; --figures copies the EMPS figure
into DIR as identify_emps_fit.png (the figure in docs/identification.md).
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from vibrofriction import cli
from vibrofriction.data.convert import convert_emps, convert_friction_damper, convert_pneumatic_seal
from vibrofriction.data.datasets import Dataset, write_dataset

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
EMPS = DATA / "emps" / "DATA_EMPS.mat"
DAMPER = {"1Hz": DATA / "friction_damper" / "dataset-2_char_1Hz30lbtension1amplitude.json",
          "2Hz": DATA / "friction_damper" / "dataset-2_char_2Hz30lbtension0.5amplitude.json"}
SEALS = {name: DATA / "pneumatic_seal" / f"{name}.csv"
         for name in ("O-ring_1bar", "O-ring_5bar", "NAPN_3bar")}
IDIM_LS_RELERR_PCT = 4.08  # EMPS description, section 3.4 (filtered, decimated data)


def split(dataset: Dataset, at: int, names: tuple[str, str]) -> tuple[Dataset, Dataset]:
    """Two records: samples [0, at] and [at, end] (the split sample is in both)."""
    parts = []
    for name, part in zip(names, (slice(0, at + 1), slice(at, None))):
        columns = {k: v[part] for k, v in dataset.columns.items()}
        parts.append(Dataset(name=name, columns=columns, metadata=dataset.metadata))
    return parts[0], parts[1]


def stroke_split(dataset: Dataset) -> int:
    """Index of the stroke start (position near its minimum) closest to the record's middle."""
    x, t = np.asarray(dataset.position_m), np.asarray(dataset.time_s)
    low = np.flatnonzero(x < x.min() + 0.05 * np.ptp(x))
    return int(low[np.argmin(np.abs(t[low] - 0.5 * (t[0] + t[-1])))])


def prepare(work: Path) -> dict[str, Path]:
    """Convert the originals (never modified) and write the training / held-out records."""
    paths: dict[str, Path] = {}
    emps = convert_emps(EMPS)
    half = int(np.searchsorted(emps.time_s, 0.5 * emps.time_s[-1]))
    for part in split(emps, half, ("emps_first_half", "emps_second_half")):
        paths[part.name] = write_dataset(part, work / f"{part.name}.csv")[0]
    for label, source in DAMPER.items():
        d = convert_friction_damper(source)
        d = Dataset(name=f"damper_{label}", columns=d.columns, metadata=d.metadata)
        paths[d.name] = write_dataset(d, work / f"{d.name}.csv")[0]
    for label, source in SEALS.items():
        d = convert_pneumatic_seal(source)
        for part in split(d, stroke_split(d), (f"seal_{label}_strokes1-5",
                                               f"seal_{label}_strokes6-10")):
            paths[part.name] = write_dataset(part, work / f"{part.name}.csv")[0]
    return paths


def cases(paths: dict[str, Path]) -> list[dict]:
    e1, e2 = paths["emps_first_half"], paths["emps_second_half"]
    # The EMPS records name their model, so identify would simulate the closed loop
    # (scripts/emps_closed_loop.py); this table is the inverse path's.
    inverse = ["--method", "inverse"]
    out = [
        dict(case="emps_coulomb", source="EMPS", train=e1, held=[e2], law="coulomb",
             args=inverse, baseline="Coulomb"),
        dict(case="emps_idim", source="EMPS", train=e1, held=[e2], law="coulomb",
             args=[*inverse, "--with", "viscous,force_offset"],
             baseline="IDIM-LS: Coulomb + viscous + offset"),
        dict(case="emps_idim_lowpass", source="EMPS", train=e1, held=[e2], law="coulomb",
             args=[*inverse, "--with", "viscous,force_offset", "--lowpass", "100"],
             baseline="IDIM-LS, 100 Hz low-pass"),
        dict(case="emps_lugre", source="EMPS", train=e1, held=[e2], law="lugre",
             args=[*inverse, "--with", "viscous,force_offset"],
             baseline="LuGre + viscous + offset"),
        dict(case="damper_1Hz", source="friction damper", train=paths["damper_1Hz"],
             held=[paths["damper_2Hz"]], law="lugre", args=[], baseline="LuGre"),
        dict(case="damper_2Hz", source="friction damper", train=paths["damper_2Hz"],
             held=[paths["damper_1Hz"]], law="lugre", args=[], baseline="LuGre"),
    ]
    for label in SEALS:
        out.append(dict(case=f"seal_{label}", source=f"pneumatic seal {label}",
                        train=paths[f"seal_{label}_strokes1-5"],
                        held=[paths[f"seal_{label}_strokes6-10"]], law="lugre", args=[],
                        baseline="LuGre"))
    return out


def run_case(case: dict, out: Path) -> dict:
    argv = ["identify", str(case["train"]), "--law", case["law"], "--out",
            str(out / case["case"]), *case["args"]]
    for held in case["held"]:
        argv += ["--validate", str(held)]
    started = time.monotonic()
    code = cli.main(argv)
    if code != 0:
        raise SystemExit(f"{case['case']}: vibrofriction {' '.join(argv)} failed ({code})")
    report = json.loads((out / case["case"] / "report.json").read_text())
    return {**case, "report": report, "seconds": time.monotonic() - started}


def table(results: list[dict]) -> str:
    lines = ["| record (train -> held out) | law, baseline | baseline: train / held out | "
             "selected effects | final: train / held out | time |",
             "|---|---|---|---|---|---|"]
    for r in results:
        rep = r["report"]

        def cell(block: dict) -> str:
            held = " / ".join(f"{v['relerr_pct']:.2f} %" for v in block["validation"])
            return f"{block['train']['relerr_pct']:.2f} % / {held}"

        names = f"{r['train'].stem} -> {', '.join(p.stem for p in r['held'])}"
        lines.append(f"| {r['source']}: {names} | {rep['law']}, {r['baseline']} | "
                     f"{cell(rep['baseline'])} | {', '.join(rep['selected_effects']) or 'none'} "
                     f"| {cell(rep['final'])} | {r['seconds']:.0f} s |")
    lines += ["", "Relative error 100 ||y - y_hat|| / ||y|| of the measured force (EMPS: motor "
              "force; damper, seals: friction force). EMPS reference: IDIM-LS "
              f"{IDIM_LS_RELERR_PCT} % on filtered and decimated data (benchmark description)."]
    peaks = [f"{r['case']}: {', '.join(f'{f:.3g}' for f in r['report']['residual_peaks_Hz'])} Hz"
             for r in results if r["report"]["residual_peaks_Hz"]]
    if peaks:
        lines += ["", "Unexplained residual peaks (`residual_peaks_Hz`): " + "; ".join(peaks) + "."]
    ringing = [f"{r['case']}: {g['frequency_Hz']:.3g} Hz, damping ratio {g['damping_ratio']:.2g}, "
               f"{g['amplitude_N']:.3g} N ({100 * g['explained']:.0f} % of the residual after "
               f"{g['reversals']} reversals)"
               for r in results if (g := r["report"].get("ringing_after_reversals"))]
    if ringing:
        lines += ["", "Ringing after the reversals (`ringing_after_reversals`): " +
                  "; ".join(ringing) + "."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("identify_real"), metavar="DIR")
    parser.add_argument("--figures", type=Path, default=None, metavar="DIR",
                        help="copy the EMPS fit figure here as identify_emps_fit.png")
    parser.add_argument("--only", default=None, metavar="PREFIX",
                        help="run only the cases whose name starts with PREFIX")
    args = parser.parse_args(argv)
    missing = [p for p in (EMPS, *DAMPER.values(), *SEALS.values()) if not p.is_file()]
    if missing:
        print(f"real data not found: {', '.join(map(str, missing))}", file=sys.stderr)
        return 2
    work = args.out / "datasets"
    work.mkdir(parents=True, exist_ok=True)
    paths = prepare(work)
    todo = [c for c in cases(paths) if not args.only or c["case"].startswith(args.only)]
    results = []
    for case in todo:
        print(f"== {case['case']}", file=sys.stderr, flush=True)
        results.append(run_case(case, args.out))
    text = table(results)
    (args.out / "summary.md").write_text(text + "\n")
    print(text)
    if args.figures is not None and (args.out / "emps_coulomb" / "fit.png").is_file():
        args.figures.mkdir(parents=True, exist_ok=True)
        for name in ("fit", "residual_vs_regressor", "spectrum"):
            shutil.copy(args.out / "emps_coulomb" / f"{name}.png",
                        args.figures / f"identify_emps_{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
