"""``vibrofriction convert SOURCE INPUT --out OUTPUT.csv``: a real record -> dataset format."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..data.convert import CONVERTERS, convert
from ..data.datasets import DatasetError, sidecar_path, write_dataset

HELP = ("convert a real friction record (EMPS .mat, friction-damper .json, pneumatic-seal "
        "text) to the dataset format: OUTPUT.csv (or .csv.gz) plus OUTPUT.json")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the convert command's options to its argparse parser."""
    parser.add_argument("source", choices=["auto", *CONVERTERS], metavar="SOURCE",
                        help=f"which recording INPUT is: auto, {', '.join(CONVERTERS)}; 'auto' "
                             "tells it from the suffix (.mat emps, .json friction-damper, "
                             ".csv/.txt pneumatic-seal)")
    parser.add_argument("input", type=Path, metavar="INPUT",
                        help="the original file (never modified)")
    parser.add_argument("--out", type=Path, required=True, metavar="OUTPUT.csv",
                        help="dataset to write: OUTPUT.csv or OUTPUT.csv.gz, and OUTPUT.json")


def run(args: argparse.Namespace) -> int:
    """Run the convert command on parsed arguments; return the exit status."""
    outputs = (args.out, sidecar_path(args.out))  # checks the name before converting
    _refuse_overwriting_input(args.input, outputs)
    dataset = convert(args.source, args.input)
    csv_path, json_path = write_dataset(dataset, args.out)
    print(f"wrote {csv_path} and {json_path}: {dataset.n_rows} rows, "
          f"{dataset.duration_s:.3f} s, columns {', '.join(dataset.columns)}")
    return 0


def _refuse_overwriting_input(input_path: Path, outputs: tuple[Path, ...]) -> None:
    # e.g. "convert friction-damper x.json --out x.csv" would replace x.json with the sidecar.
    for output in outputs:
        if output.resolve() == input_path.resolve():
            raise DatasetError(f"{output}: this would overwrite the input {input_path}; "
                               "choose another --out")
