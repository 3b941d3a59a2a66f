"""Bad input on the command line (issue 9): one line naming what is wrong and how to fix it,
exit code 2, no traceback, nothing written and nothing existing changed."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.datasets import Dataset, DatasetMetadata, write_dataset

SHORT = ["--duration", "0.01"]


def _records(folder: Path) -> None:
    t = np.arange(200) * 1e-3
    z = np.zeros_like(t)
    motion = 1e-3 * np.sin(20 * t)
    force = np.sin(50 * t)
    big_force = force.copy()
    big_force[50] = 1e300
    big_position = motion.copy()
    big_position[50] = 1e200
    for name, columns in {
        "two": {"time_s": t[:2], "position_m": motion[:2], "friction_force_N": force[:2]},
        "zeros": {"time_s": t, "position_m": motion, "friction_force_N": z},
        "still": {"time_s": t, "position_m": z, "friction_force_N": force},
        "big_force": {"time_s": t, "position_m": motion, "friction_force_N": big_force},
        "big_position": {"time_s": t, "position_m": big_position, "friction_force_N": force},
        "good": {"time_s": t, "position_m": motion, "friction_force_N": force},
    }.items():
        if name.startswith("big"):  # written by hand: the writer refuses them too
            text = ",".join(columns) + "\n" + "\n".join(
                ",".join(repr(float(v)) for v in row) for row in zip(*columns.values()))
            (folder / f"{name}.csv").write_text(text + "\n")
            (folder / f"{name}.json").write_text("{}\n")
        else:
            write_dataset(Dataset(name=name, columns=columns, metadata=DatasetMetadata()),
                          folder / f"{name}.csv")


CASES = [
    (["simulate", "--json", "a_folder", *SHORT], "--json a_folder is a folder"),
    (["simulate", "--csv", "a_file/run.csv", *SHORT], "is a file, not a folder"),
    (["simulate", "--set", "mass_kg=1e-300", *SHORT], "mass_kg=1e-300 must lie within"),
    (["simulate", "--set", "vibration_velocity_amplitude_m_per_s=1e308", *SHORT],
     "vibration_velocity_amplitude_m_per_s=1e+308 must lie within"),
    (["sweep", "--va", "1e308"], "must lie within"),
    (["identify", "two.csv"], "2 samples; identification needs at least 16"),
    (["identify", "zeros.csv"], "friction_force_N never changes (all 0)"),
    (["identify", "still.csv"], "position_m never changes"),
    (["identify", "big_force.csv"], "column 'friction_force_N': 1e+300 is beyond"),
    (["identify", "big_position.csv"], "column 'position_m': 1e+200 is beyond"),
    (["identify", "good.csv", "--out", "a_file"], "--out a_file: a_file is a file"),
    (["identify", "good.csv", "--json", "a_folder"], "--json a_folder is a folder"),
    (["convert", "emps", "missing.mat", "--out", "a_folder"], "--out a_folder is a folder"),
]


@pytest.mark.parametrize("argv, words", CASES, ids=[" ".join(c[0][:3]) for c in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, monkeypatch, capsys, argv,
                                                          words):
    monkeypatch.chdir(tmp_path)
    _records(tmp_path)
    (tmp_path / "a_folder").mkdir()
    (tmp_path / "a_folder" / "keep.txt").write_text("keep")
    (tmp_path / "a_file").write_text("keep")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert words in err
    after = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert after == before  # nothing written, nothing existing changed
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == ["a_folder"]


def test_a_held_body_on_a_moving_support_and_an_absolute_clock_are_accepted():
    from vibrofriction.identify.selection import check_identifiable
    t = 1.7e9 + np.arange(200) * 1e-3  # Unix time
    held = Dataset(name="held", metadata=DatasetMetadata(), columns={
        "time_s": t, "position_m": np.zeros_like(t), "friction_force_N": np.sin(50 * t),
        "support_velocity_m_per_s": np.cos(30 * t)})
    check_identifiable(held)  # the counterface moves under a body held on a load cell
