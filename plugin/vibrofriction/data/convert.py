"""Converters from the real friction records in ../shared/data to the dataset format.

Each ``convert_*`` reads one original file (never modifying it) and returns a :class:`Dataset`
in SI units with friction "positive when it resists motion in +x". Malformed input raises
:class:`DatasetError` naming the file, the key or column, and the row.
"""
from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .datasets import (Dataset, DatasetError, DatasetMetadata, check_finite, check_increasing,
                       parse_numeric_table)

# Unit conversions (exact by definition of the inch and the pound-force).
M_PER_IN = 0.0254
N_PER_LBF = 4.4482216152605
N_PER_KIP = 1000.0 * N_PER_LBF
M_PER_MM = 1.0e-3
S_PER_MS = 1.0e-3
PA_PER_BAR = 1.0e5

EMPS_SAMPLE_RATE_HZ = 1000.0  # EMPS description, section 2.2
EMPS_SOURCE = (
    "EMPS benchmark, DATA_EMPS.mat: Janot, Gautier, Brunot, 'Data Set and Reference Models of "
    "EMPS', Nonlinear System Identification Benchmarks workshop, 2019 (cite when used)")
EMPS_DESCRIPTION = (
    "EMPS prismatic joint (DC motor + ball screw), closed-loop PD, bang-bang motion. "
    "position_m = qm (motor position on the load side), reference_position_m = qg; "
    "drive_force_N = gtau*vir. Controller: kp = 160.18 1/s, kv = 243.45 V s/m, 1 kHz. "
    "Friction = drive force - M*a with the mass M to identify. Reference IDIM-LS values "
    "(description, section 3): M = 95.1089 kg, Fv = 203.5034 N s/m, Fc = 20.3935 N, "
    "offset = -3.1648 N; force relative error 4.08 % (inverse model), 5.85 % (direct "
    "simulation). The friction is asymmetric and a flexibility is not modelled.")

DAMPER_SAMPLE_RATE_HZ = 1024.0
DAMPER_SOURCE = (
    "Coble, Huggins, Cao, Ricles, Downey, 'Dataset-Friction-Damper-with-Backlash' (ARTS Lab), "
    "CC BY-SA 4.0")
# Source columns of the JSON 'data' rows; datasets 1-3 have 6 columns, dataset 4 has 8
# (actuator positions inserted before the forces). Only the first four are converted.
DAMPER_COLUMNS = ("time [s]", "displacement [in]", "friction force [kip]", "velocity [in/s]")
DAMPER_ROW_LENGTHS = (6, 8)
DAMPER_UNITS = {"time units": "s", "displacement units": "in", "friction force units": "kip"}

PNEUMATIC_PISTON_AREA_M2 = math.pi * (0.025 / 2) ** 2  # 25 mm bore (data README)
PNEUMATIC_SOURCE = "Zillen (TU Delft) thesis data, pneumatic piston seals, CC0 1.0"
# Whitespace text, no header; the .csv files in the folder are this text too.
PNEUMATIC_COLUMNS = ("time [ms]", "laser [V]", "pressure [V]", "force [V]",
                     "displacement [mm]", "pressure [bar]", "force [N]")


# ------------------------------------------------------------------------------------- EMPS

def convert_emps(mat_path: str | os.PathLike) -> Dataset:
    """``DATA_EMPS.mat`` (or ``DATA_EMPS_PULSES.mat``) -> a record of the EMPS closed loop.

    position_m = qm, reference_position_m = qg (the controller's input), drive_force_N =
    gtau * vir (the total motor force), and for the validation run feedforward_force_N, the
    pulses as a force at the drive (added to the controller's command, so already inside vir;
    their unit, V or N, read from the data: ``_emps_pulse_force``). The sidecar names the
    model (``"model": "emps"``): identification simulates the closed loop of
    ``mjcf_models/emps`` driven by the reference.
    """
    from scipy.io import loadmat  # scipy only for this converter

    path = _existing_file(mat_path)
    try:
        mat = loadmat(path)
    except Exception as exc:  # scipy raises several types for a non-MAT file
        raise DatasetError(f"{path}: not a readable MATLAB file: {exc}") from None
    time_s = _mat_vector(mat, "t", path)
    raw = {"t": time_s, "qm": _mat_vector(mat, "qm", path), "qg": _mat_vector(mat, "qg", path),
           "vir": _mat_vector(mat, "vir", path)}
    if "pulses_N" in mat:
        raw["pulses_N"] = _mat_vector(mat, "pulses_N", path)
    gtau_N_per_V = _mat_scalar(mat, "gtau", path)
    _check_source_table(raw, "t", path, lambda i: f"sample {i + 1}")
    columns = {"time_s": time_s, "position_m": raw["qm"], "reference_position_m": raw["qg"],
               "drive_force_N": gtau_N_per_V * raw["vir"]}
    if "pulses_N" in raw:
        columns["feedforward_force_N"] = _emps_pulse_force(mat, raw, gtau_N_per_V, path)
    metadata = DatasetMetadata(description=EMPS_DESCRIPTION, sample_rate_Hz=EMPS_SAMPLE_RATE_HZ,
                               source=EMPS_SOURCE, model="emps")
    return Dataset(name=path.stem, columns=columns, metadata=metadata, source_path=path)


def _emps_pulse_force(mat: dict[str, Any], raw: dict[str, np.ndarray], gtau_N_per_V: float,
                      path: Path) -> np.ndarray:
    """The pulses as a force at the drive. The logged command is the controller's law plus the
    pulses, so the data say their unit: volts (a 0/5 V square wave, force g_tau pulses) or
    newtons (force = pulses). The unit whose pulses leave the smaller remainder of
    vir - law(qm, qg) is taken; neither explaining it is an error."""
    kp, kv = _mat_scalar(mat, "kp", path), _mat_scalar(mat, "kv", path)
    t, q, r, vir = raw["t"], raw["qm"], raw["qg"], raw["vir"]
    T = float((t[-1] - t[0]) / (len(t) - 1))
    filtered = np.r_[q[0], 0.5 * (q[1:] + q[:-1])]
    law = kv * (kp * (r - q) - np.r_[0.0, np.diff(filtered) / T])
    added = (vir - law)[10:]
    pulses = raw["pulses_N"][10:]
    volts = float(np.sqrt(np.mean((added - pulses) ** 2)))
    newtons = float(np.sqrt(np.mean((added - pulses / gtau_N_per_V) ** 2)))
    if min(volts, newtons) > 0.5 * float(np.sqrt(np.mean(added ** 2))):
        raise DatasetError(f"{path}: pulses_N does not explain the command beyond the "
                           f"controller law (rms remainder {min(volts, newtons):.3g} V); "
                           "the record is not the EMPS closed loop this converter knows")
    return gtau_N_per_V * raw["pulses_N"] if volts <= newtons else raw["pulses_N"].copy()


def _mat_value(mat: dict[str, Any], key: str, path: Path) -> np.ndarray:
    if key not in mat:
        found = ", ".join(k for k in mat if not k.startswith("__"))
        raise DatasetError(f"{path}: missing variable '{key}' (variables: {found})")
    try:
        return np.asarray(mat[key], dtype=float)
    except (TypeError, ValueError):
        raise DatasetError(f"{path}: variable '{key}' is not numeric") from None


def _mat_vector(mat: dict[str, Any], key: str, path: Path) -> np.ndarray:
    value = _mat_value(mat, key, path)
    if value.ndim != 2 or min(value.shape) != 1:
        raise DatasetError(f"{path}: variable '{key}' must be a vector, got shape {value.shape}")
    return value.ravel()


def _mat_scalar(mat: dict[str, Any], key: str, path: Path) -> float:
    value = _mat_value(mat, key, path)
    if value.size != 1 or not np.isfinite(value).all():
        raise DatasetError(f"{path}: variable '{key}' must be one finite number, "
                           f"got shape {value.shape}")
    return float(value.ravel()[0])


# -------------------------------------------------------------------------- friction damper

def convert_friction_damper(json_path: str | os.PathLike) -> Dataset:
    """Banded rotary friction damper test (ARTS Lab JSON) -> measured friction and motion.

    Displacement [in] -> position_m, velocity [in/s] -> velocity_m_per_s, friction [kip] ->
    friction_force_N. The load-cell force is already "positive when resisting +x": it rises
    with the velocity (correlation +0.76 in the 1 Hz run, +0.64 in the 2 Hz run), so it is
    kept as recorded. The support is fixed (the actuator moves the body).

    No normal_force_N: the two band actuator forces are not an independent normal load. They
    switch with the sliding direction (tight side ~1100 lb, slack side ~5 lb) and their sum
    tracks |friction| (correlation 0.94): they are the band-end reactions that carry the
    friction itself (self-energizing band, T_tight - T_slack). Used as F_N they would let an
    identified law "explain" friction by itself. The nominal band tension is in the description.
    """
    path = _existing_file(json_path)
    obj = _load_json(path)
    rows = obj.get("data") if isinstance(obj, dict) else None
    if not isinstance(rows, list) or not rows:
        raise DatasetError(f"{path}: key 'data' must be a non-empty list of rows")
    _check_damper_units(obj, path)
    table = _damper_table(rows, path)
    raw = dict(zip(DAMPER_COLUMNS, table.T))
    _check_source_table(raw, DAMPER_COLUMNS[0], path, lambda i: f"data[{i}]")
    columns = {
        "time_s": raw["time [s]"],
        "position_m": raw["displacement [in]"] * M_PER_IN,
        "velocity_m_per_s": raw["velocity [in/s]"] * M_PER_IN,
        "friction_force_N": raw["friction force [kip]"] * N_PER_KIP,
    }
    metadata = DatasetMetadata(description=_damper_description(path),
                               sample_rate_Hz=_damper_sample_rate_Hz(obj, path),
                               source=f"{DAMPER_SOURCE}; file {path.name}")
    return Dataset(name=path.stem, columns=columns, metadata=metadata, source_path=path)


def _check_damper_units(obj: dict[str, Any], path: Path) -> None:
    for key, unit in DAMPER_UNITS.items():
        if key in obj and obj[key] != unit:
            raise DatasetError(f"{path}: key '{key}' is {obj[key]!r}, expected {unit!r}")


def _damper_sample_rate_Hz(obj: dict[str, Any], path: Path) -> float:
    rate = obj.get("sampling freq", DAMPER_SAMPLE_RATE_HZ)
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0:
        raise DatasetError(f"{path}: key 'sampling freq' must be a positive number, got {rate!r}")
    return float(rate)


def _damper_table(rows: list[Any], path: Path) -> np.ndarray:
    """The first four columns of the 'data' rows as floats; bad rows named as data[i]."""
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) not in DAMPER_ROW_LENGTHS:
            size = len(row) if isinstance(row, list) else type(row).__name__
            raise DatasetError(f"{path}: key 'data', data[{i}]: expected a row of "
                               f"{' or '.join(map(str, DAMPER_ROW_LENGTHS))} numbers, got {size}")
        if len(row) != len(rows[0]):
            raise DatasetError(f"{path}: key 'data', data[{i}] has {len(row)} values but "
                               f"data[0] has {len(rows[0])}")
    table = np.array([row[:len(DAMPER_COLUMNS)] for row in rows], dtype=object)
    for j, name in enumerate(DAMPER_COLUMNS):
        for i, cell in enumerate(table[:, j]):
            if isinstance(cell, bool) or not isinstance(cell, (int, float)):
                raise DatasetError(f"{path}: key 'data', data[{i}], column '{name}': "
                                   f"expected a number, got {cell!r}")
    return table.astype(float)


def _damper_description(path: Path) -> str:
    text = "Banded rotary friction damper, displacement imposed by a hydraulic actuator"
    match = re.search(r"([\d.]+)Hz([\d.]+)lbtension([\d.]+)amplitude", path.stem)
    if match:
        frequency, tension, amplitude = match.groups()
        text += (f"; characterization test: sinusoid {frequency} Hz, amplitude {amplitude} in, "
                 f"nominal band tension {tension} lb (from the file name)")
    return text + ". Friction force from a load cell; band actuator forces not converted."


def _load_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{path}: line {exc.lineno}: not valid JSON: {exc.msg}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: cannot read: {exc}") from None


# --------------------------------------------------------------------------- pneumatic seal

def convert_pneumatic_seal(txt_path: str | os.PathLike) -> Dataset:
    """Pneumatic piston-seal record (whitespace text, no header, 7 columns) -> friction.

    friction_force_N = force - p*A with p [bar] -> Pa and A = pi*(0.025/2)^2 m^2. It already
    follows the convention (correlation with the smoothed velocity +0.99 in all three files), so
    it is kept as computed; its +1 to +4 N mean at rest is left in (a sensor or pressure offset
    for identification to find). position_m = displacement [mm] -> m. Velocity is not stored:
    the sampling is irregular (10-24 ms steps, a few gaps of ~0.3 s), and the reader's smoothed
    derivative (Dataset.velocity_m_per_s) handles that in one place.
    """
    path = _existing_file(txt_path)
    try:
        text = path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: cannot read: {exc}") from None
    lines = text.splitlines()
    _check_not_cut_off(text, lines, path)
    raw, line_numbers = parse_numeric_table(
        lines, source=str(path), first_line=1, delimiter=None, n_cells=len(PNEUMATIC_COLUMNS),
        wanted={name: j for j, name in enumerate(PNEUMATIC_COLUMNS)})
    _check_source_table(raw, "time [ms]", path, lambda i: f"line {line_numbers[i]}")
    time_s = raw["time [ms]"] * S_PER_MS
    pressure_force_N = raw["pressure [bar]"] * PA_PER_BAR * PNEUMATIC_PISTON_AREA_M2
    columns = {
        "time_s": time_s,
        "position_m": raw["displacement [mm]"] * M_PER_MM,
        "friction_force_N": raw["force [N]"] - pressure_force_N,
    }
    mean_pressure_bar = float(np.mean(raw["pressure [bar]"]))
    metadata = DatasetMetadata(
        description=(f"Pneumatic cylinder piston seal '{path.stem}', 25 mm bore, mean pressure "
                     f"{mean_pressure_bar:.2f} bar; friction = load-cell force - p*A."),
        sample_rate_Hz=round(float(1.0 / np.median(np.diff(time_s))), 6),
        source=f"{PNEUMATIC_SOURCE}; file {path.name}")
    return Dataset(name=path.stem, columns=columns, metadata=metadata, source_path=path)


def _check_not_cut_off(text: str, lines: list[str], path: Path) -> None:
    """Refuse a text table cut off inside its last row (a truncated copy or download). The
    recorder ends every line with a line break and writes each column with fixed decimals
    (all three files: 3), so a last line without a line break whose cells differ from the
    line before in number or in decimals is a cut, not data."""
    if not text or text.endswith(("\n", "\r")):
        return
    rows = [(number, line) for number, line in enumerate(lines, start=1) if line.strip()]
    if len(rows) < 2:
        return
    (last_number, last), (previous_number, previous) = rows[-1], rows[-2]

    def decimals(line: str) -> list[int]:
        return [len(cell.partition(".")[2]) if "." in cell else -1 for cell in line.split()]

    if decimals(last) != decimals(previous):
        raise DatasetError(f"{path}: line {last_number} ({last.strip()!r}) ends the file "
                           "without a line break and its cells differ from line "
                           f"{previous_number}'s in number or decimals: the file is cut off; "
                           "use the complete file, or delete its last line")


# ---------------------------------------------------------------------------------- shared

CONVERTERS: dict[str, Callable[[str | os.PathLike], Dataset]] = {
    "emps": convert_emps,
    "friction-damper": convert_friction_damper,
    "pneumatic-seal": convert_pneumatic_seal,
}
_SOURCE_BY_SUFFIX = {".mat": "emps", ".json": "friction-damper", ".csv": "pneumatic-seal",
                     ".txt": "pneumatic-seal"}


def detect_source(path: str | os.PathLike) -> str:
    """Source name from the file suffix (.mat, .json, .csv/.txt)."""
    suffix = Path(path).suffix.lower()
    if suffix not in _SOURCE_BY_SUFFIX:
        raise DatasetError(f"{path}: cannot tell the source from the suffix {suffix!r}; "
                           f"name it: {', '.join(CONVERTERS)}")
    return _SOURCE_BY_SUFFIX[suffix]


def convert(source: str, path: str | os.PathLike) -> Dataset:
    """Convert ``path`` with the converter named ``source`` ("auto": from the suffix)."""
    if source == "auto":
        source = detect_source(path)
    if source not in CONVERTERS:
        raise DatasetError(f"unknown source {source!r}; use one of: auto, {', '.join(CONVERTERS)}")
    return CONVERTERS[source](path)


def _existing_file(path: str | os.PathLike) -> Path:
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: no such file")
    return path


def _check_source_table(raw: dict[str, np.ndarray], time_key: str, path: Path,
                        row_label: Callable[[int], str]) -> None:
    """Equal lengths, finite values and increasing time, named by the source's own columns."""
    lengths = {key: len(values) for key, values in raw.items()}
    if len(set(lengths.values())) > 1:
        raise DatasetError(f"{path}: variables differ in length: {lengths}")
    check_finite(raw, str(path), row_label)
    check_increasing(raw[time_key], str(path), row_label, name=time_key)


__all__ = [
    "CONVERTERS",
    "convert",
    "convert_emps",
    "convert_friction_damper",
    "convert_pneumatic_seal",
    "detect_source",
]
