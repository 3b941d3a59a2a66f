"""Dataset format (docs/dataset-format.md): round trip, derived signals, bad input."""
from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from vibrofriction.data.datasets import (Dataset, DatasetError, DatasetMetadata, read_dataset,
                                         smoothed_derivative, write_dataset)

GOOD_CSV = ("time_s,position_m,drive_force_N\n"
            "0.0,0.0,1.0\n"
            "0.1,0.001,1.5\n"
            "0.2,0.002,2.0\n"
            "0.3,0.004,2.5\n")


def _dataset(n_rows: int = 200) -> Dataset:
    t = np.linspace(0.0, 1.0, n_rows)
    columns = {
        "time_s": t,
        "position_m": 1e-3 * np.sin(2 * np.pi * t) + 1e-17,  # a value that needs 17 digits
        "velocity_m_per_s": 2e-3 * np.pi * np.cos(2 * np.pi * t),
        "friction_force_N": np.tanh(50 * np.cos(2 * np.pi * t)) / 3.0,
        "normal_force_N": np.full(n_rows, 55.2),
    }
    metadata = DatasetMetadata(description="synthetic", mass_kg=0.5, sample_rate_Hz=199.0,
                               source="test_datasets.py")
    return Dataset(name="synthetic", columns=columns, metadata=metadata)


def _put(folder: Path, csv_text: str, sidecar: object | None = None,
         name: str = "run.csv") -> Path:
    path = folder / name
    path.write_text(csv_text)
    if sidecar is not None:
        (folder / "run.json").write_text(json.dumps(sidecar))
    return path


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _read_fails(path: Path) -> str:
    """Read must fail, leave the folder exactly as it was, and return the message."""
    before = _snapshot(path.parent)
    with pytest.raises(DatasetError) as info:
        read_dataset(path)
    assert _snapshot(path.parent) == before
    message = str(info.value)
    assert "\n" not in message and str(path.parent) in message
    return message


# ---------------------------------------------------------------------------------- round trip

@pytest.mark.parametrize("name", ["run.csv", "run.csv.gz"])
def test_round_trip_is_exact(tmp_path: Path, name: str) -> None:
    original = _dataset()
    csv_path, json_path = write_dataset(original, tmp_path / name)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "run.json"])
    assert json_path == tmp_path / "run.json"
    back = read_dataset(csv_path)
    assert back.name == "run" and back.source_path == csv_path
    assert list(back.columns) == list(original.columns)
    for column, values in original.columns.items():
        np.testing.assert_array_equal(back.columns[column], values)
    assert back.metadata == original.metadata


def test_gzip_output_is_gzip_and_reproducible(tmp_path: Path) -> None:
    write_dataset(_dataset(), tmp_path / "a.csv.gz")
    write_dataset(_dataset(), tmp_path / "b.csv.gz")
    first = (tmp_path / "a.csv.gz").read_bytes()
    assert gzip.decompress(first).startswith(b"time_s,position_m,")
    assert first == (tmp_path / "b.csv.gz").read_bytes()


def test_columns_in_any_order_and_sidecar_types(tmp_path: Path) -> None:
    path = _put(tmp_path, "drive_force_N, time_s ,position_m\r\n1,0,0\r\n2,1,0.5\r\n\r\n",
                {"mass_kg": 2, "description": "x", "normal_force_N": 55.2})
    data = read_dataset(path)
    np.testing.assert_array_equal(data.time_s, [0.0, 1.0])
    np.testing.assert_array_equal(data.columns["drive_force_N"], [1.0, 2.0])
    assert data.metadata.mass_kg == 2.0 and isinstance(data.metadata.mass_kg, float)
    np.testing.assert_array_equal(data.normal_force_N, [55.2, 55.2])


def test_columns_are_read_only() -> None:
    data = _dataset()
    with pytest.raises(ValueError):
        data.columns["time_s"][0] = 5.0


# ------------------------------------------------------------------------------ derived signals

def test_smoothed_derivative_of_a_sine_on_an_irregular_grid() -> None:
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.8e-3, 1.2e-3, 5000))
    derivative = smoothed_derivative(np.sin(2 * np.pi * t), t)
    # 0.1 % of the amplitude 2*pi: the irregular grid adds no bias (the fit is centred on
    # each sample's own time).
    np.testing.assert_allclose(derivative, 2 * np.pi * np.cos(2 * np.pi * t), atol=6e-3)


def test_friction_from_newton_when_only_drive_force_is_given() -> None:
    mass_kg, w = 2.0, 2 * np.pi * 3.0
    t = np.arange(0.0, 1.0, 1e-3)
    friction_N = 0.8 * np.tanh(100 * np.cos(w * t))
    drive_N = mass_kg * (-0.01 * w**2 * np.sin(w * t)) + friction_N  # m a = F_d - F_f
    columns = {"time_s": t, "position_m": 0.01 * np.sin(w * t), "drive_force_N": drive_N}
    data = Dataset("newton", columns, DatasetMetadata(mass_kg=mass_kg))
    np.testing.assert_allclose(data.velocity_m_per_s[5:-5], 0.01 * w * np.cos(w * t[5:-5]),
                               rtol=0, atol=3e-4)
    inner = slice(10, -10)
    np.testing.assert_allclose(data.friction_force_N[inner], friction_N[inner], atol=0.02)
    with pytest.raises(DatasetError, match="mass_kg"):
        _ = Dataset("newton", columns).friction_force_N


def test_relative_velocity_subtracts_the_support() -> None:
    t = np.arange(0.0, 0.1, 1e-4)
    support_m = 1e-6 * np.sin(2 * np.pi * 100 * t)
    columns = {"time_s": t, "velocity_m_per_s": np.full_like(t, 1e-3),
               "support_position_m": support_m, "friction_force_N": np.ones_like(t)}
    data = Dataset("support", columns)
    expected = 1e-3 - 2 * np.pi * 100 * 1e-6 * np.cos(2 * np.pi * 100 * t)
    # The 11-sample window (1.1 ms) attenuates 100 Hz by ~1 %: allow 2 % of the amplitude.
    np.testing.assert_allclose(data.relative_velocity_m_per_s[5:-5], expected[5:-5],
                               atol=0.02 * 2 * np.pi * 100 * 1e-6)
    np.testing.assert_allclose(data.position_m, 1e-3 * t, atol=1e-15)


# ----------------------------------------------------------------------------------- bad input

def test_missing_required_column(tmp_path: Path) -> None:
    message = _read_fails(_put(tmp_path, "position_m,drive_force_N\n0,1\n1,2\n"))
    assert "run.csv" in message and "missing required column 'time_s'" in message


def test_missing_force_column_names_both_choices(tmp_path: Path) -> None:
    message = _read_fails(_put(tmp_path, "time_s,position_m\n0,1\n1,2\n"))
    assert "'drive_force_N' or 'friction_force_N'" in message


def test_non_increasing_time_names_the_line(tmp_path: Path) -> None:
    text = GOOD_CSV.replace("0.3,0.004", "0.2,0.004")  # 4th data row = line 5
    message = _read_fails(_put(tmp_path, text))
    assert "line 5" in message and "'time_s'" in message and "strictly increase" in message


@pytest.mark.parametrize("cell, shown", [("nan", "nan"), ("inf", "inf"), ("-inf", "-inf")])
def test_nan_and_inf_name_line_and_column(tmp_path: Path, cell: str, shown: str) -> None:
    text = GOOD_CSV.replace("0.1,0.001,1.5", f"0.1,{cell},1.5")  # line 3
    message = _read_fails(_put(tmp_path, text))
    assert "line 3" in message and "'position_m'" in message and shown in message
    assert "finite" in message


@pytest.mark.parametrize("cell", ["abc", "", "1.5.2"])
def test_unparsable_cell(tmp_path: Path, cell: str) -> None:
    text = GOOD_CSV.replace("0.2,0.002,2.0", f"0.2,0.002,{cell}")  # line 4
    message = _read_fails(_put(tmp_path, text))
    assert "line 4" in message and "'drive_force_N'" in message and repr(cell) in message


def test_row_with_wrong_number_of_cells(tmp_path: Path) -> None:
    message = _read_fails(_put(tmp_path, GOOD_CSV.replace("0.1,0.001,1.5", "0.1,0.001")))
    assert "line 3 has 2 cells, expected 3" in message


@pytest.mark.parametrize("sidecar, key, words", [
    ({"mass_kg": "heavy"}, "mass_kg", "must be a number"),
    ({"mass_kg": True}, "mass_kg", "must be a number"),
    ({"mass_kg": -1.0}, "mass_kg", "> 0"),
    ({"sample_rate_Hz": None, "description": 3}, "description", "must be text"),
])
def test_wrong_sidecar_type(tmp_path: Path, sidecar: dict, key: str, words: str) -> None:
    message = _read_fails(_put(tmp_path, GOOD_CSV, sidecar))
    assert "run.json" in message and f"'{key}'" in message and words in message


def test_sidecar_not_an_object_or_not_json(tmp_path: Path) -> None:
    assert "JSON object" in _read_fails(_put(tmp_path, GOOD_CSV, [1, 2]))
    (tmp_path / "run.json").write_text('{"mass_kg": 1,\n oops}')
    assert "run.json: line 2: not valid JSON" in _read_fails(tmp_path / "run.csv")


def test_unknown_column_is_ignored_with_one_notice(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    text = "time_s,temperature_C,position_m,drive_force_N\n0,warm,0,1\n1,hot,1,2\n"
    data = read_dataset(_put(tmp_path, text, {"mass_kg": 1.0, "operator": "me"}))
    assert list(data.columns) == ["time_s", "position_m", "drive_force_N"]
    lines = capsys.readouterr().err.splitlines()
    assert any("ignoring unknown columns 'temperature_C'" in line for line in lines)
    assert any("ignoring unknown keys 'operator'" in line for line in lines)
    assert len(lines) == 2


def test_missing_sidecar_gives_empty_metadata_and_a_notice(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    data = read_dataset(_put(tmp_path, GOOD_CSV))
    assert data.metadata == DatasetMetadata()
    assert "no sidecar" in capsys.readouterr().err


def test_bad_file_names_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="NAME.csv or NAME.csv.gz"):
        read_dataset(tmp_path / "run.txt")
    with pytest.raises(DatasetError, match="no such file"):
        read_dataset(tmp_path / "absent.csv")
    (tmp_path / "broken.csv.gz").write_bytes(b"not gzip")
    assert "cannot read" in _read_fails(tmp_path / "broken.csv.gz")


def test_in_memory_dataset_is_validated_with_its_row() -> None:
    t = np.array([0.0, 1.0, 1.0])
    with pytest.raises(DatasetError, match=r"data row 3, column 'time_s'"):
        Dataset("x", {"time_s": t, "position_m": t, "friction_force_N": t})
    with pytest.raises(DatasetError, match="unknown columns 'speed'"):
        Dataset("x", {"time_s": t, "speed": t})


def test_samples_closer_than_a_nanosecond_are_refused() -> None:
    t = np.array([0.0, 1e-3, 1e-3 + 1e-12, 2e-3])
    with pytest.raises(DatasetError, match=r"data row 3, column 'time_s': 1e-12 s after the "
                                           r"previous row; samples closer than 1e-09 s"):
        Dataset("x", {"time_s": t, "position_m": t, "friction_force_N": t})
    t = np.arange(200_000) * 1e-9  # 1 GHz: the limit itself (rounded steps too) is a record
    Dataset("x", {"time_s": t, "position_m": t, "friction_force_N": t})


def test_messages_show_plain_numbers_not_numpy_reprs() -> None:
    t = np.array([0.0, 0.1, 0.05])
    with pytest.raises(DatasetError) as exc:
        Dataset("x", {"time_s": t, "position_m": t, "friction_force_N": t})
    assert "0.05 is not after the previous row's 0.1" in str(exc.value)
    with pytest.raises(DatasetError) as exc:
        DatasetMetadata(mass_kg=np.float64(-1.5))
    assert "got -1.5" in str(exc.value) and "np." not in str(exc.value)


def test_failed_write_leaves_nothing_behind(tmp_path: Path) -> None:
    (tmp_path / "run.json").mkdir()  # the sidecar cannot replace a folder
    with pytest.raises(DatasetError, match="cannot write"):
        write_dataset(_dataset(), tmp_path / "run.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["run.json"]
    assert not any((tmp_path / "run.json").iterdir())


def test_write_refuses_a_bad_name_without_writing(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="NAME.csv"):
        write_dataset(_dataset(), tmp_path / "run.dat")
    assert not any(tmp_path.iterdir())


def test_a_failed_write_keeps_the_previous_files(tmp_path: Path) -> None:
    write_dataset(_dataset(), tmp_path / "run.csv")
    before = (tmp_path / "run.csv").read_bytes()
    (tmp_path / "run.json").unlink()
    (tmp_path / "run.json").mkdir()  # the sidecar cannot be written
    with pytest.raises(DatasetError, match=r"run.json: cannot write: it is a folder"):
        write_dataset(_dataset(50), tmp_path / "run.csv")
    assert (tmp_path / "run.csv").read_bytes() == before  # not deleted, not changed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "run.json"]
