"""Measured or simulated friction data in the dataset format (docs/dataset-format.md).

One measurement is ``NAME.csv`` (or ``NAME.csv.gz``) plus the sidecar ``NAME.json``. Columns are
SI with the unit in the name; ``read_dataset`` validates everything and reports the first bad
cell by file, column and ``line N`` (1-based line of the file, the header is line 1);
``write_dataset`` writes both files atomically. Derived signals (velocity, acceleration,
friction from Newton's law) come from the :class:`Dataset` properties, computed in one place.
"""
from __future__ import annotations

import contextlib
import contextvars
import gzip
import json
import math
import os
import secrets
import shutil
import signal
import sys
import tempfile
import threading
from dataclasses import asdict, dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, NoReturn, Sequence

import numpy as np

from ..errors import InputError

# Known columns, in the order they are written.
COLUMNS = (
    "time_s",
    "position_m",
    "velocity_m_per_s",
    "acceleration_m_per_s2",
    "drive_force_N",
    "friction_force_N",
    "support_velocity_m_per_s",
    "support_position_m",
    "normal_force_N",
    # inputs of a machine model (sidecar "model"): what drives it besides the friction
    "reference_position_m",  # the position controller's reference
    "feedforward_force_N",  # a known force added at the drive (part of drive_force_N)
    "external_force_N",  # a measured force on the body that does not pass through the drive
)
# Columns that drive a machine model (sidecar "model"), not written by the rig's simulate.
MACHINE_INPUT_COLUMNS = ("reference_position_m", "feedforward_force_N", "external_force_N")
# Each group needs at least one of its columns.
REQUIRED_GROUPS = (
    ("time_s",),
    ("position_m", "velocity_m_per_s"),
    ("drive_force_N", "friction_force_N"),
)
# Half-width (samples) of the local parabola fitted to differentiate: an 11-sample window,
# 11 ms at 1 kHz, passes the ~20 Hz motion of the real rigs and damps sample noise.
DERIVATIVE_HALF_WINDOW_SAMPLES = 5

RowLabel = Callable[[int], str]


class DatasetError(InputError):
    """A dataset or source file is malformed; the message names file, column/key and row."""


class OutputError(DatasetError):
    """An output file or folder cannot be written; the message names the user's path."""


def data_row_label(index: int) -> str:
    """Label of a 0-based sample index as a 1-based data row (the header is not counted)."""
    return f"data row {index + 1}"


# ---------------------------------------------------------------------------------- metadata

_TEXT_KEYS = ("description", "source", "model")
# Numeric keys and the range each must lie in (name of the rule, test).
_NUMBER_RULES: dict[str, tuple[str, Callable[[float], bool]]] = {
    "mass_kg": ("> 0", lambda x: x > 0),
    "drive_stiffness_N_per_m": (">= 0", lambda x: x >= 0),
    "drive_velocity_m_per_s": ("finite", lambda x: True),
    "vibration_frequency_Hz": ("> 0", lambda x: x > 0),
    "normal_force_N": (">= 0", lambda x: x >= 0),
    "sample_rate_Hz": ("> 0", lambda x: x > 0),
    "simulation_timestep_s": ("> 0", lambda x: x > 0),
}


@dataclass(frozen=True)
class DatasetMetadata:
    """The sidecar ``NAME.json``; every key optional (None = absent)."""

    description: str | None = None
    mass_kg: float | None = None
    drive_stiffness_N_per_m: float | None = None
    drive_velocity_m_per_s: float | None = None
    vibration_frequency_Hz: float | None = None
    normal_force_N: float | None = None
    sample_rate_Hz: float | None = None
    source: str | None = None
    # A record made by a simulator: its timestep (identification replays it at that step).
    simulation_timestep_s: float | None = None
    # The MJCF model that made or explains the record: a bundled machine ("emps"); absent:
    # the vibrating rig (identification replays the record in that model).
    model: str | None = None

    def __post_init__(self) -> None:
        for key in _TEXT_KEYS:
            value = getattr(self, key)
            if value is not None and not isinstance(value, str):
                raise DatasetError(f"key '{key}' must be text, got {_show(value)}")
        for key, (rule, ok) in _NUMBER_RULES.items():
            value = getattr(self, key)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise DatasetError(f"key '{key}' must be a number, got {_show(value)}")
            if not math.isfinite(value) or not ok(value):
                raise DatasetError(f"key '{key}' must be finite and {rule}, got "
                                   f"{_plain(value)!r}")
            object.__setattr__(self, key, float(value))

    @classmethod
    def from_json_object(cls, obj: Any, source: str) -> "DatasetMetadata":
        """Build from a parsed sidecar; unknown keys are ignored with a notice."""
        if not isinstance(obj, dict):
            raise DatasetError(f"{source}: the sidecar must be a JSON object, got {_show(obj)}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(obj) - known)
        if unknown:
            _notice(f"{source}: ignoring unknown keys {_quoted(unknown)}")
        try:
            return cls(**{key: value for key, value in obj.items() if key in known})
        except DatasetError as exc:
            raise DatasetError(f"{source}: {exc}") from None

    def to_json_object(self) -> dict[str, Any]:
        return {key: value for key, value in asdict(self).items() if value is not None}


# ----------------------------------------------------------------------------------- dataset

@dataclass(frozen=True, eq=False)
class Dataset:
    """One measurement: SI columns keyed by the dataset-format names, plus its sidecar.

    Columns are validated on construction (required columns, equal lengths, finite values,
    strictly increasing time) and stored as read-only float arrays.

    Derived signals, used wherever a column is absent:

    * velocity: the ``velocity_m_per_s`` column, else :func:`smoothed_derivative` of position;
    * acceleration: the ``acceleration_m_per_s2`` column, else the smoothed derivative of that
      velocity (so twice-differentiated position when only position is measured);
    * friction: the ``friction_force_N`` column, else ``drive_force_N - mass_kg * acceleration``
      (Newton's law, needs ``mass_kg`` in the sidecar).
    """

    name: str
    columns: Mapping[str, np.ndarray]
    metadata: DatasetMetadata = field(default_factory=DatasetMetadata)
    source_path: Path | None = None

    def __post_init__(self) -> None:
        where = str(self.source_path or self.name)
        if not isinstance(self.metadata, DatasetMetadata):
            raise DatasetError(f"{where}: metadata must be a DatasetMetadata")
        unknown = sorted(set(self.columns) - set(COLUMNS))
        if unknown:
            raise DatasetError(f"{where}: unknown columns {_quoted(unknown)}; "
                               f"known columns are {', '.join(COLUMNS)}")
        columns = {name: _frozen_array(self.columns[name], name, where)
                   for name in COLUMNS if name in self.columns}
        validate_columns(columns, where, data_row_label)
        object.__setattr__(self, "columns", columns)
        if self.source_path is not None:
            object.__setattr__(self, "source_path", Path(self.source_path))

    @property
    def n_rows(self) -> int:
        return len(self.time_s)

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def time_s(self) -> np.ndarray:
        return self.columns["time_s"]

    @cached_property
    def position_m(self) -> np.ndarray:
        """The column, else velocity integrated (trapezoid) from position 0 at the first sample."""
        if "position_m" in self.columns:
            return self.columns["position_m"]
        return _frozen(cumulative_trapezoid(self.columns["velocity_m_per_s"], self.time_s))

    @cached_property
    def velocity_m_per_s(self) -> np.ndarray:
        """The column, else the smoothed derivative of position."""
        if "velocity_m_per_s" in self.columns:
            return self.columns["velocity_m_per_s"]
        return _frozen(smoothed_derivative(self.columns["position_m"], self.time_s))

    @cached_property
    def acceleration_m_per_s2(self) -> np.ndarray:
        """The column, else the smoothed derivative of :attr:`velocity_m_per_s`."""
        if "acceleration_m_per_s2" in self.columns:
            return self.columns["acceleration_m_per_s2"]
        return _frozen(smoothed_derivative(self.velocity_m_per_s, self.time_s))

    @cached_property
    def support_velocity_m_per_s(self) -> np.ndarray:
        """The column, else the derivative of support position, else 0 (fixed support)."""
        if "support_velocity_m_per_s" in self.columns:
            return self.columns["support_velocity_m_per_s"]
        if "support_position_m" in self.columns:
            return _frozen(smoothed_derivative(self.columns["support_position_m"], self.time_s))
        return _frozen(np.zeros_like(self.time_s))

    @cached_property
    def relative_velocity_m_per_s(self) -> np.ndarray:
        """Body velocity minus support velocity (the sliding velocity)."""
        return _frozen(self.velocity_m_per_s - self.support_velocity_m_per_s)

    @cached_property
    def friction_force_N(self) -> np.ndarray:
        """Friction, positive when it resists motion in +x.

        The measured column when there is one; otherwise Newton's law for the body,
        ``m a = F_drive - F_friction``, i.e. ``drive_force_N - mass_kg * acceleration`` with
        the acceleration of :attr:`acceleration_m_per_s2` (column or smoothed derivative).
        """
        if "friction_force_N" in self.columns:
            return self.columns["friction_force_N"]
        mass_kg = self.metadata.mass_kg
        if mass_kg is None:
            raise DatasetError(
                f"{self.source_path or self.name}: no 'friction_force_N' column and no "
                "'mass_kg' in the sidecar, so friction cannot follow from the drive force; "
                "add mass_kg or identify the mass together with the friction law")
        return _frozen(self.columns["drive_force_N"] - mass_kg * self.acceleration_m_per_s2)

    @cached_property
    def normal_force_N(self) -> np.ndarray | None:
        """The column, else the sidecar's constant for every sample, else None (unknown)."""
        if "normal_force_N" in self.columns:
            return self.columns["normal_force_N"]
        if self.metadata.normal_force_N is None:
            return None
        return _frozen(np.full_like(self.time_s, self.metadata.normal_force_N))


# ---------------------------------------------------------------------------------- numerics

def white_noise_sd(values: np.ndarray) -> float:
    """White-noise standard deviation from the median absolute third difference (0 for a
    noise-free smooth signal): the third difference of white noise has variance 20 sigma^2,
    a signal smooth on the sample scale adds little, the median ignores sharp transitions."""
    d3 = np.diff(np.asarray(values, dtype=float), 3)
    return 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0)


def smoothed_derivative(values: np.ndarray, time_s: np.ndarray,
                        half_window: int = DERIVATIVE_HALF_WINDOW_SAMPLES) -> np.ndarray:
    """d(values)/dt from a least-squares parabola through 2*half_window+1 samples.

    The parabola is fitted around each sample and differentiated at that sample's own time, so
    irregular sampling adds no bias; on a uniform grid this is the Savitzky-Golay first
    derivative (order 2). Near the ends the nearest full window is used.
    """
    values = np.asarray(values, dtype=float)
    time_s = np.asarray(time_s, dtype=float)
    n = len(values)
    width = min(2 * int(half_window) + 1, n)
    if width < 3:
        return np.gradient(values, time_s)
    first = np.clip(np.arange(n) - width // 2, 0, n - width)
    window = first[:, None] + np.arange(width)
    offset_s = time_s[window] - time_s[:, None]
    scale_s = np.abs(offset_s).max(axis=1, keepdims=True)  # unit-free offsets: well conditioned
    u = offset_s / scale_s
    powers = u[:, :, None] ** np.arange(3)  # columns 1, u, u^2
    normal = np.einsum("nwi,nwj->nij", powers, powers)
    rhs = np.einsum("nwi,nw->ni", powers, values[window])
    coefficients = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
    return coefficients[:, 1] / scale_s[:, 0]


def cumulative_trapezoid(values: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """Integral of values over time, 0 at the first sample."""
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(time_s)
    return np.concatenate([[0.0], np.cumsum(increments)])


# -------------------------------------------------------------------------------- validation

def check_required(names: Sequence[str], where: str) -> None:
    """Raise when a required column (or a whole one-of group) is missing."""
    for group in REQUIRED_GROUPS:
        if not any(name in names for name in group):
            need = " or ".join(f"'{name}'" for name in group)
            found = ", ".join(names) or "none"
            raise DatasetError(f"{where}: missing required column {need} (columns: {found})")


def check_finite(columns: Mapping[str, np.ndarray], where: str, row_label: RowLabel) -> None:
    """Raise on the earliest NaN or inf in any column, naming its row and column."""
    first: tuple[int, str] | None = None
    for name, values in columns.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size and (first is None or bad[0] < first[0]):
            first = (int(bad[0]), name)
    if first is not None:
        index, name = first
        raise DatasetError(f"{where}: {row_label(index)}, column '{name}': value is "
                           f"{float(columns[name][index])!r}; every value must be a finite "
                           "number")


def check_increasing(time_s: np.ndarray, where: str, row_label: RowLabel,
                     name: str = "time_s") -> None:
    """Raise at the first sample whose time is not after the previous one."""
    bad = np.flatnonzero(np.diff(time_s) <= 0)
    if bad.size:
        index = int(bad[0]) + 1
        raise DatasetError(f"{where}: {row_label(index)}, column '{name}': "
                           f"{float(time_s[index])!r} is not after the previous row's "
                           f"{float(time_s[index - 1])!r}; time must strictly increase")


# The closest two samples may be: a sample rate of 1 GHz, far beyond any friction measurement
# (and any simulation timestep this package uses); closer samples are a unit or a glitch.
MIN_SAMPLE_INTERVAL_S = 1e-9


def check_sample_interval(time_s: np.ndarray, where: str, row_label: RowLabel,
                          name: str = "time_s") -> None:
    """Raise at the first sample closer than MIN_SAMPLE_INTERVAL_S to the previous one."""
    steps = np.diff(time_s)
    # (with a relative tolerance: t = k * 1e-9 rounds some steps a few ulps below 1e-9)
    bad = np.flatnonzero((steps > 0) & (steps < MIN_SAMPLE_INTERVAL_S * (1 - 1e-6)))
    if bad.size:
        index = int(bad[0]) + 1
        raise DatasetError(f"{where}: {row_label(index)}, column '{name}': "
                           f"{float(steps[index - 1]):.3g} s after the previous row; samples "
                           f"closer than {MIN_SAMPLE_INTERVAL_S:g} s (above 1 GHz) are not a "
                           "friction record: check that the time is in seconds")


# The largest magnitude a column may hold: far beyond any friction experiment (a kilometre, a
# kilometre a second, a giganewton), low enough that squares and sums of them stay finite.
# (time is not limited: absolute clocks such as Unix time are fine)
COLUMN_LIMITS = {
    "position_m": 1e3, "support_position_m": 1e3, "reference_position_m": 1e3,
    "velocity_m_per_s": 1e3, "support_velocity_m_per_s": 1e3,
    "acceleration_m_per_s2": 1e9,
    "drive_force_N": 1e9, "friction_force_N": 1e9, "normal_force_N": 1e9,
    "feedforward_force_N": 1e9, "external_force_N": 1e9,
}


def check_ranges(columns: Mapping[str, np.ndarray], where: str, row_label: RowLabel) -> None:
    """Raise on the earliest value beyond its column's limit (a unit or a glitch)."""
    for name, values in columns.items():
        limit = COLUMN_LIMITS.get(name)
        if limit is None:
            continue
        bad = np.flatnonzero(np.abs(values) > limit)
        if bad.size:
            index = int(bad[0])
            raise DatasetError(f"{where}: {row_label(index)}, column '{name}': "
                               f"{float(values[index])!r} is beyond +-{limit:g} (SI units); check "
                               "the unit of the column or the sample")


def validate_columns(columns: Mapping[str, np.ndarray], where: str,
                     row_label: RowLabel = data_row_label) -> None:
    """All of docs/dataset-format.md's rules on named SI columns."""
    check_required(list(columns), where)
    lengths = {name: len(values) for name, values in columns.items()}
    if len(set(lengths.values())) > 1:
        raise DatasetError(f"{where}: columns differ in length: {lengths}")
    if lengths["time_s"] < 2:
        raise DatasetError(f"{where}: needs at least 2 rows, got {lengths['time_s']}")
    check_finite(columns, where, row_label)
    check_ranges(columns, where, row_label)
    check_increasing(columns["time_s"], where, row_label)
    check_sample_interval(columns["time_s"], where, row_label)


# ----------------------------------------------------------------------------------- parsing

def parse_numeric_table(lines: Sequence[str], *, source: str, first_line: int,
                        delimiter: str | None, n_cells: int,
                        wanted: Mapping[str, int]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Parse text rows of numbers (blank lines skipped) into named float columns.

    ``wanted`` maps a column name to its 0-based cell index; other cells are not parsed.
    ``delimiter`` None means whitespace. Returns the columns and the 1-based file line number
    of each row. Fast path: one numpy call; on failure the rows are scanned to name the line
    and column of the first bad cell.
    """
    numbered = [(number, line) for number, line in enumerate(lines, start=first_line)
                if line.strip()]
    if not numbered:
        raise DatasetError(f"{source}: no data rows")
    line_numbers = np.array([number for number, _ in numbered], dtype=np.int64)
    rows = [line for _, line in numbered]
    _check_cell_counts(rows, line_numbers, source, delimiter, n_cells)
    try:
        values = np.loadtxt(rows, delimiter=delimiter, usecols=list(wanted.values()),
                            comments=None, dtype=float, ndmin=2)
    except ValueError as exc:
        _raise_first_bad_cell(rows, line_numbers, source, delimiter, wanted, exc)
    columns = {name: values[:, j] for j, name in enumerate(wanted)}
    return columns, line_numbers


def _split(line: str, delimiter: str | None) -> list[str]:
    return line.split(delimiter)


def _check_cell_counts(rows: list[str], line_numbers: np.ndarray, source: str,
                       delimiter: str | None, n_cells: int) -> None:
    counts = np.array([len(_split(row, delimiter)) for row in rows])
    bad = np.flatnonzero(counts != n_cells)
    if bad.size:
        i = int(bad[0])
        raise DatasetError(f"{source}: line {line_numbers[i]} has {counts[i]} cells, "
                           f"expected {n_cells}")


def _raise_first_bad_cell(rows: list[str], line_numbers: np.ndarray, source: str,
                          delimiter: str | None, wanted: Mapping[str, int],
                          exc: ValueError) -> NoReturn:
    for number, row in zip(line_numbers, rows):
        cells = _split(row, delimiter)
        for name, index in wanted.items():
            cell = cells[index].strip()
            try:
                float(cell)
            except ValueError:
                raise DatasetError(f"{source}: line {number}, column '{name}': cannot parse "
                                   f"{cell!r} as a number") from None
    raise DatasetError(f"{source}: cannot parse the table: {exc}") from None


# ------------------------------------------------------------------------------ read / write

def sidecar_path(csv_path: str | os.PathLike) -> Path:
    """``NAME.json`` for ``NAME.csv`` or ``NAME.csv.gz``; other names are an error."""
    path = Path(csv_path)
    for suffix in (".csv", ".csv.gz"):
        if path.name.endswith(suffix) and len(path.name) > len(suffix):
            return path.with_name(path.name[: -len(suffix)] + ".json")
    raise DatasetError(f"{path}: a dataset file must be named NAME.csv or NAME.csv.gz")


def dataset_name(csv_path: str | os.PathLike) -> str:
    """The dataset's NAME: ``NAME.csv`` or ``NAME.csv.gz`` without the suffix (DatasetError for
    another file name)."""
    return sidecar_path(csv_path).stem


def read_dataset(path: str | os.PathLike) -> Dataset:
    """Read ``NAME.csv`` / ``NAME.csv.gz`` and its sidecar; raise DatasetError on bad input.

    Errors name the file, the column (or sidecar key) and ``line N`` of the file (1-based; the
    header is line 1, so the first data row is line 2). Unknown columns and keys are ignored with
    a one-line notice on stderr; a missing sidecar means empty metadata (also noticed).
    """
    path = Path(path)
    json_path = sidecar_path(path)
    lines = _read_text(path).splitlines()
    if not lines or not lines[0].strip():
        raise DatasetError(f"{path}: line 1: missing header row (e.g. time_s,position_m,...)")
    header = [cell.strip().strip('"') for cell in lines[0].split(",")]
    wanted = _header_columns(header, path)
    columns, line_numbers = parse_numeric_table(
        lines[1:], source=str(path), first_line=2, delimiter=",", n_cells=len(header),
        wanted=wanted)
    validate_columns(columns, str(path), lambda i: f"line {line_numbers[i]}")
    return Dataset(name=dataset_name(path), columns=columns,
                   metadata=_read_metadata(json_path), source_path=path)


def _header_columns(header: list[str], path: Path) -> dict[str, int]:
    """Known column name -> cell index; duplicates and missing required columns are errors."""
    duplicates = sorted({name for name in header if header.count(name) > 1})
    if duplicates:
        raise DatasetError(f"{path}: line 1: duplicate columns {_quoted(duplicates)}")
    check_required(header, str(path))
    unknown = [name for name in header if name not in COLUMNS]
    if unknown:
        _notice(f"{path}: ignoring unknown columns {_quoted(unknown)}")
    return {name: index for index, name in enumerate(header) if name in COLUMNS}


def _read_text(path: Path) -> str:
    try:
        raw = path.read_bytes()
        if path.name.endswith(".gz"):
            raw = gzip.decompress(raw)
        return raw.decode("utf-8-sig")
    except FileNotFoundError:
        raise DatasetError(f"{path}: no such file") from None
    except (OSError, EOFError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: cannot read: {exc}") from None


def _read_metadata(json_path: Path) -> DatasetMetadata:
    if not json_path.exists():
        _notice(f"{json_path}: no sidecar; using empty metadata")
        return DatasetMetadata()
    text = _read_text(json_path)
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{json_path}: line {exc.lineno}: not valid JSON: {exc.msg}") from None
    return DatasetMetadata.from_json_object(obj, str(json_path))


def write_dataset(dataset: Dataset, path: str | os.PathLike) -> tuple[Path, Path]:
    """Write ``NAME.csv`` (or ``.csv.gz``) and ``NAME.json``; return both paths.

    Both files are written to temporary files in the target folder and renamed into place
    only when both are complete; on any error neither is left behind and files already there
    are kept as they were (inside :func:`all_or_nothing`, together with the block's other
    outputs). Numbers are written with Python's shortest round-trip repr, so reading gives
    back exactly the same values.
    """
    path = Path(path)
    json_path = sidecar_path(path)
    csv_bytes = _csv_text(dataset).encode("utf-8")
    if path.name.endswith(".gz"):
        csv_bytes = gzip.compress(csv_bytes, mtime=0)  # mtime 0: same data, same bytes
    json_bytes = (json.dumps(dataset.metadata.to_json_object(), indent=2) + "\n").encode()
    with all_or_nothing():
        stage_file(path, csv_bytes)
        stage_file(json_path, json_bytes)
    return path, json_path


def _csv_text(dataset: Dataset) -> str:
    names = list(dataset.columns)  # canonical order, fixed by Dataset
    rows = np.column_stack([dataset.columns[name] for name in names]).tolist()
    body = "\n".join(",".join(map(repr, row)) for row in rows)
    return ",".join(names) + "\n" + body + "\n"


# ------------------------------------------------------------------------ all-or-nothing writes

class _Outputs:
    """Files and folders staged beside their targets, put in place together by commit()."""

    def __init__(self) -> None:
        self.staged: list[tuple[Path, Path]] = []  # (temporary, target)
        self.created: list[Path] = []  # parent folders made for the targets

    def folder_of(self, target: Path) -> Path:
        missing = [p for p in (target.parent, *target.parent.parents) if not p.exists()]
        for folder in reversed(missing):
            folder.mkdir()
            self.created.append(folder)
        return target.parent

    def file(self, target: Path, data: bytes) -> None:
        fd, tmp = tempfile.mkstemp(dir=self.folder_of(target), prefix=f".{target.name}.",
                                   suffix=".tmp")
        self.staged.append((Path(tmp), target))
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give a normal file's mode

    def folder(self, target: Path, write: Callable[[Path], None]) -> None:
        def make() -> Path:
            made = Path(tempfile.mkdtemp(dir=self.folder_of(target), prefix=f".{target.name}.",
                                         suffix=".tmp"))
            self.staged.append((made, target))
            os.chmod(made, 0o777 & ~_umask())  # mkdtemp makes 0700; a normal folder's mode
            return made

        # only making the folder is a write error of the target: an OSError of the work
        # inside (a missing input, a refused connection) is reported as itself
        write(_on(target, make))

    def commit(self) -> None:
        """Every target checked first; then each old one renamed aside and the new one renamed
        in; on any error every target is restored; the old ones are deleted at the end."""
        for tmp, target in self.staged:
            if target.exists() and target.is_dir() != tmp.is_dir():
                kind = "a folder" if target.is_dir() else "a file"
                raise OutputError(f"{target}: cannot write: it is {kind}; name another "
                                  "path or remove it")
        swapped: list[tuple[Path, Path, Path | None]] = []  # (temporary, target, old one)
        try:
            for tmp, target in self.staged:
                aside = None
                if os.path.lexists(target):
                    aside = target.with_name(f".{target.name}.{secrets.token_hex(4)}.old")
                swapped.append((tmp, target, aside))
                if aside is not None:
                    _on(target, os.rename, target, aside)
                _on(target, os.rename, tmp, target)
        except BaseException:
            for tmp, target, aside in reversed(swapped):
                if not os.path.lexists(tmp):  # placed: take the new one out again
                    _remove(target)
                if aside is not None and os.path.lexists(aside):
                    os.rename(aside, target)
            raise
        for _, _, aside in swapped:
            if aside is not None:
                _remove(aside)

    def discard(self) -> None:
        for tmp, _ in self.staged:
            _remove(tmp)
        for folder in reversed(self.created):
            with contextlib.suppress(OSError):
                folder.rmdir()


_OUTPUTS: contextvars.ContextVar[_Outputs | None] = contextvars.ContextVar(
    "vibrofriction_outputs", default=None)


@contextlib.contextmanager
def all_or_nothing() -> Iterator[None]:
    """Outputs written in the block (write_dataset, commands.common.write_json, report.write_folder) are
    staged beside their targets and put in place together when the block ends: all of them,
    or on any error none, with every file and folder that was there kept as it was. An
    existing folder target is replaced as a whole. SIGTERM meanwhile raises SystemExit, so
    the staged files are removed before the process ends. Nested blocks join the outer one.
    """
    if _OUTPUTS.get() is not None:
        yield
        return
    outputs = _Outputs()
    token = _OUTPUTS.set(outputs)
    try:
        with _sigterm_raises():
            try:
                yield
                outputs.commit()
            except BaseException:
                outputs.discard()
                raise
    finally:
        _OUTPUTS.reset(token)


def stage_file(target: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``target`` (inside :func:`all_or_nothing`: when the block ends)."""
    target = Path(target)
    with all_or_nothing():
        _on(target, _OUTPUTS.get().file, target, data)


def stage_folder(target: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Run ``write(tmp)`` on a new folder beside ``target``, which then replaces ``target`` as
    a whole (inside :func:`all_or_nothing`: when the block ends)."""
    target = Path(os.path.abspath(target))
    with all_or_nothing():
        _OUTPUTS.get().folder(target, write)
    return target


def _on(target: Path, action: Callable[..., Any], *args: Any) -> Any:
    """``action(*args)``; an OSError becomes an OutputError naming ``target``."""
    try:
        return action(*args)
    except OSError as exc:
        raise OutputError(f"{target}: cannot write: {exc.strerror or exc}") from None


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """SIGTERM raises SystemExit(143) (once) so the cleanup of a write runs; restored after."""
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGTERM) == signal.SIG_IGN):
        yield  # (handlers belong to the main thread; an ignored SIGTERM stays ignored)
        return

    def terminate(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the cleanup runs undisturbed
        raise SystemExit(128 + signum)

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)


# ----------------------------------------------------------------------------------- helpers

def _frozen_array(values: Any, name: str, where: str) -> np.ndarray:
    try:
        array = np.array(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DatasetError(f"{where}: column '{name}' is not numeric: {exc}") from None
    if array.ndim != 1:
        raise DatasetError(f"{where}: column '{name}' must be 1-D, got shape {array.shape}")
    return _frozen(array)


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _notice(message: str) -> None:
    print(f"notice: {message}", file=sys.stderr)


def _quoted(names: Sequence[str]) -> str:
    return ", ".join(f"'{name}'" for name in names)


def _show(value: Any) -> str:
    return f"{_plain(value)!r} ({type(_plain(value)).__name__})"


def _plain(value: Any) -> Any:
    """A numpy scalar as the Python number it holds (its repr is then a plain number)."""
    return value.item() if isinstance(value, np.generic) else value


__all__ = [
    "COLUMNS",
    "MACHINE_INPUT_COLUMNS",
    "Dataset",
    "DatasetError",
    "DatasetMetadata",
    "MIN_SAMPLE_INTERVAL_S",
    "OutputError",
    "all_or_nothing",
    "check_finite",
    "check_increasing",
    "check_sample_interval",
    "cumulative_trapezoid",
    "parse_numeric_table",
    "read_dataset",
    "sidecar_path",
    "smoothed_derivative",
    "stage_file",
    "stage_folder",
    "validate_columns",
    "write_dataset",
]
