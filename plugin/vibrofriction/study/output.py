"""Writing the study's outputs: CSV tables, PNG figures (matplotlib, no pyplot), progress."""
from __future__ import annotations

import csv
import sys
import time
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

# Small figures for the README: 6.4 x 4 in at 110 dpi stays well under 150 kB.
FIGURE_DPI = 110
LAW_COLORS = {"coulomb": "tab:gray", "dahl": "tab:blue", "dupont": "tab:green",
              "lugre": "tab:orange"}
LAW_LABELS = {"coulomb": "Coulomb", "dahl": "Dahl", "dupont": "Dupont", "lugre": "LuGre"}


def new_figure(width_in: float = 6.4, height_in: float = 4.0):
    """A matplotlib Figure drawn by the Agg canvas, independent of pyplot and its backend."""
    from matplotlib.figure import Figure
    return Figure(figsize=(width_in, height_in), layout="constrained")


def save_figure(fig, path: Path) -> Path:
    """Save a matplotlib figure to ``path`` at FIGURE_DPI, making its folder; return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=FIGURE_DPI)
    return path


def write_csv(path: Path, columns: Mapping[str, Sequence] | None = None, *,
              rows: Iterable[Mapping[str, object]] | None = None) -> Path:
    """Write columns (equal-length arrays) or rows (dicts with the same keys) as CSV."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        if columns is not None:
            names = list(columns)
            writer.writerow(names)
            data = [np.asarray(columns[n]) for n in names]
            for i in range(len(data[0]) if data else 0):
                writer.writerow([_fmt(col[i]) for col in data])
        else:
            rows = list(rows or [])
            if rows:
                names = list(rows[0])
                writer.writerow(names)
                for row in rows:
                    writer.writerow([_fmt(row[n]) for n in names])
    return path


def _fmt(value: object) -> object:
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.10g}"
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    return value


def read_csv(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV file with a header row, as dicts of strings (the reverse of
    ``write_csv``, without converting the values)."""
    with Path(path).open(newline="") as fh:
        return list(csv.DictReader(fh))


class StageLog:
    """Stage headers and progress bars on stderr (quiet=True: nothing)."""

    def __init__(self, total_stages: int, *, quiet: bool = False, stream=None):
        self.total = total_stages
        self.index = 0
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self._start = time.monotonic()

    def stage(self, title: str) -> None:
        self.index += 1
        if not self.quiet:
            elapsed = time.monotonic() - self._start
            print(f"[{self.index}/{self.total}] {title}  ({elapsed:.0f} s elapsed)",
                  file=self.stream, flush=True)

    def progress(self, label: str):
        """A ``progress(done, total)`` callback drawing one bar per call site, or None."""
        if self.quiet:
            return None
        from ..progress import progress_bar
        return progress_bar(label, self.stream, indent="    ")

    def note(self, text: str) -> None:
        if not self.quiet:
            print(f"    {text}", file=self.stream, flush=True)
