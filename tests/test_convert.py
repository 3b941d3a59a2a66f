"""Converters of the real friction records (../shared/data) and ``vibrofriction convert``."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.data.convert import (PNEUMATIC_PISTON_AREA_M2, convert_emps,
                                        convert_friction_damper, convert_pneumatic_seal)
from vibrofriction.data.datasets import DatasetError, read_dataset

DATA_DIR = Path(__file__).resolve().parents[2] / "shared" / "data"
EMPS_MAT = DATA_DIR / "emps" / "DATA_EMPS.mat"
DAMPER_1HZ = DATA_DIR / "friction_damper" / "dataset-2_char_1Hz30lbtension1amplitude.json"
DAMPER_2HZ = DATA_DIR / "friction_damper" / "dataset-2_char_2Hz30lbtension0.5amplitude.json"
SEALS = [DATA_DIR / "pneumatic_seal" / name
         for name in ("NAPN_3bar.csv", "O-ring_1bar.csv", "O-ring_5bar.csv")]


def _need(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"real data not found at {path} (the shared data folder is absent)")
    return path


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# ------------------------------------------------------------------------------------- EMPS

@pytest.fixture(scope="module")
def emps():
    return convert_emps(_need(EMPS_MAT))


def test_emps_shape_units_and_metadata(emps) -> None:
    assert list(emps.columns) == ["time_s", "position_m", "drive_force_N",
                                  "reference_position_m"]
    assert emps.metadata.model == "emps"  # identification replays the closed loop
    assert emps.n_rows == 24841 and emps.duration_s == pytest.approx(24.84)
    assert np.all(np.abs(emps.position_m) < 0.3) and np.ptp(emps.position_m) > 0.2
    assert np.abs(emps.columns["drive_force_N"]).max() == pytest.approx(152.0, abs=1.0)
    assert emps.metadata.mass_kg is None  # identified, not given
    assert emps.metadata.sample_rate_Hz == 1000.0
    assert "95.1089" in emps.metadata.description and "Janot" in emps.metadata.source


def test_emps_reproduces_the_reference_idim_fit(emps) -> None:
    # Inverse model of the description, eq. (1): F = M a + Fv v + Fc sign(v) + offset. Least
    # squares on our SI columns and derivatives must land near the published IDIM-LS values.
    v = emps.velocity_m_per_s
    basis = np.column_stack([emps.acceleration_m_per_s2, v, np.sign(v), np.ones_like(v)])
    force_N = emps.columns["drive_force_N"]
    (mass_kg, fv, fc, offset), *_ = np.linalg.lstsq(basis, force_N, rcond=None)
    assert mass_kg == pytest.approx(95.1089, rel=0.05)
    assert fv == pytest.approx(203.5034, rel=0.05)
    assert fc == pytest.approx(20.3935, rel=0.10)
    assert offset == pytest.approx(-3.1648, abs=0.5)
    relerr_pct = 100 * np.linalg.norm(force_N - basis @ [mass_kg, fv, fc, offset]) \
        / np.linalg.norm(force_N)
    assert relerr_pct < 6.0  # reference: 4.08 % (filtered, decimated), 5.85 % (simulation)


def test_emps_friction_with_the_reference_mass_resists_motion(emps) -> None:
    from dataclasses import replace
    with_mass = replace(emps, metadata=replace(emps.metadata, mass_kg=95.1089))
    friction_N = with_mass.friction_force_N
    assert np.corrcoef(friction_N, with_mass.relative_velocity_m_per_s)[0, 1] > 0.9


# -------------------------------------------------------------------------- friction damper

@pytest.mark.parametrize("path, amplitude_m, rows", [(DAMPER_1HZ, 0.0254, 7169),
                                                     (DAMPER_2HZ, 0.0127, 3585)])
def test_friction_damper_units_and_sign(path: Path, amplitude_m: float, rows: int) -> None:
    data = convert_friction_damper(_need(path))
    assert list(data.columns) == ["time_s", "position_m", "velocity_m_per_s", "friction_force_N"]
    assert data.n_rows == rows and data.metadata.sample_rate_Hz == 1024.0
    assert np.abs(data.position_m).max() == pytest.approx(amplitude_m, rel=0.03)
    # The in/s velocity column agrees with the derivative of the in displacement column.
    derived = np.gradient(data.position_m, data.time_s)
    assert np.polyfit(derived, data.velocity_m_per_s, 1)[0] == pytest.approx(1.0, rel=0.03)
    # 2-4 kip peaks: 9-18 kN.
    assert 9e3 < np.abs(data.friction_force_N).max() < 18e3
    assert np.corrcoef(data.friction_force_N, data.relative_velocity_m_per_s)[0, 1] > 0.5
    assert "normal_force_N" not in data.columns  # band forces are friction reactions


# --------------------------------------------------------------------------- pneumatic seal

@pytest.mark.parametrize("path", SEALS, ids=lambda p: p.stem)
def test_pneumatic_seal_units_and_sign(path: Path) -> None:
    data = convert_pneumatic_seal(_need(path))
    assert list(data.columns) == ["time_s", "position_m", "friction_force_N"]
    assert 60 < data.duration_s < 120 and data.metadata.sample_rate_Hz == pytest.approx(100.0)
    assert -0.005 < data.position_m.min() < 0.0 and 0.035 < data.position_m.max() < 0.040
    first = np.loadtxt(path, max_rows=1)  # force [N] - p [bar] * 1e5 * A
    assert data.friction_force_N[0] == pytest.approx(first[6] - first[5] * 1e5 *
                                                     PNEUMATIC_PISTON_AREA_M2)
    assert np.abs(data.friction_force_N).max() < 15.0
    assert np.corrcoef(data.friction_force_N, data.relative_velocity_m_per_s)[0, 1] > 0.9


# -------------------------------------------------------------------- malformed source files

def test_pneumatic_bad_cell_names_line_and_column(tmp_path: Path) -> None:
    bad = tmp_path / "seal.csv"
    bad.write_text("0.0\t3.4\t1.5\t3.2\t0.01\t3.0\t151.0\r\n"
                   "10.0\t3.4\t1.5\t3.2\toops\t3.0\t151.0\r\n")
    with pytest.raises(DatasetError, match=r"seal.csv: line 2, column 'displacement \[mm\]'"):
        convert_pneumatic_seal(bad)


SEAL_ROWS = "".join(f"{10 * i:.3f}\t3.474\t1.499\t3.248\t{0.01 * i:.3f}\t2.997\t151.092\r\n"
                    for i in range(3))


@pytest.mark.parametrize("last", ["30.000\t3.474\t1.499\t3.248\t0.030\t2.997\t151.0",
                                  "30.000\t3.474\t1.499\t3.248\t0.030\t2.997\t15",
                                  "30.000\t3.474\t1.4"])
def test_pneumatic_file_cut_inside_its_last_row_is_refused(tmp_path: Path, last: str) -> None:
    cut = tmp_path / "seal.txt"
    cut.write_text(SEAL_ROWS + last, newline="")
    with pytest.raises(DatasetError, match=r"seal.txt: line 4 .*without a line break.*cut off"):
        convert_pneumatic_seal(cut)


def test_pneumatic_file_complete_but_without_the_last_line_break_converts(tmp_path: Path) -> None:
    whole = tmp_path / "seal.txt"
    whole.write_text(SEAL_ROWS + "30.000\t3.474\t1.499\t3.248\t0.030\t2.997\t151.092",
                     newline="")
    assert convert_pneumatic_seal(whole).n_rows == 4


def test_pneumatic_repeated_time_names_the_line(tmp_path: Path) -> None:
    bad = tmp_path / "seal.txt"
    bad.write_text("0 1 1 1 0 1 1\n10 1 1 1 0 1 1\n10 1 1 1 0 1 1\n")
    with pytest.raises(DatasetError, match=r"line 3, column 'time \[ms\]'.*strictly increase"):
        convert_pneumatic_seal(bad)


@pytest.mark.parametrize("rows, words", [
    ([[0.0, 0.0, 0.0, 0.0, 1.0, 1.0], [0.001, 0.0, 0.0, 0.0, 1.0]], "data[1]: expected a row"),
    ([[0.0, 0.0, 0.0, 0.0, 1.0, 1.0], [0.001, "x", 0.0, 0.0, 1.0, 1.0]],
     "data[1], column 'displacement [in]'"),
])
def test_friction_damper_bad_rows(tmp_path: Path, rows: list, words: str) -> None:
    bad = tmp_path / "damper.json"
    bad.write_text(json.dumps({"data": rows}))
    with pytest.raises(DatasetError) as info:
        convert_friction_damper(bad)
    assert "damper.json" in str(info.value) and words in str(info.value)


def test_emps_missing_variable(tmp_path: Path) -> None:
    from scipy.io import savemat
    bad = tmp_path / "emps.mat"
    savemat(bad, {"t": np.arange(3.0), "qm": np.zeros(3), "qg": np.zeros(3), "gtau": 35.15})
    with pytest.raises(DatasetError, match="emps.mat: missing variable 'vir'"):
        convert_emps(bad)


# ---------------------------------------------------------------------------------- command

def test_cli_convert_writes_a_readable_dataset(tmp_path: Path,
                                               capsys: pytest.CaptureFixture) -> None:
    source = _need(SEALS[1])
    out = tmp_path / "seal.csv.gz"
    assert cli.main(["convert", "auto", str(source), "--out", str(out)]) == 0
    summary = capsys.readouterr().out.strip()
    assert "7139 rows" in summary and "73.508 s" in summary and "friction_force_N" in summary
    back = read_dataset(out)
    expected = convert_pneumatic_seal(source)
    for name, values in expected.columns.items():
        np.testing.assert_array_equal(back.columns[name], values)
    assert back.metadata == expected.metadata


@pytest.mark.parametrize("make_input, words", [
    (lambda d: d / "absent.mat", "no such file"),
    (lambda d: _text(d / "fake.mat", "not a MATLAB file"), "not a readable MATLAB file"),
    (lambda d: _text(d / "bad.json", "{\"data\": 1}"), "key 'data'"),
])
def test_cli_convert_bad_input_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture,
                                       make_input, words: str) -> None:
    source = make_input(tmp_path)
    before = _snapshot(tmp_path)
    code = cli.main(["convert", "auto", str(source), "--out", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("vibrofriction convert: error:") and words in err
    assert len(err.strip().splitlines()) == 1
    assert _snapshot(tmp_path) == before  # nothing written


def test_cli_convert_refuses_to_overwrite_its_input(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    source = _text(tmp_path / "run.json", json.dumps({"data": [[0, 0, 0, 0, 0, 0]]}))
    code = cli.main(["convert", "friction-damper", str(source), "--out", str(tmp_path / "run.csv")])
    assert code == 2 and "overwrite the input" in capsys.readouterr().err
    assert _snapshot(tmp_path) == {"run.json": source.read_bytes()}


def _text(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
