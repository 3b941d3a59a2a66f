"""Bad input on the command line (issue 9): one line naming what is wrong and how to fix it,
exit code 2, no traceback, nothing written and nothing existing changed."""
from __future__ import annotations

import json
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.data.datasets import (Dataset, DatasetError, DatasetMetadata, all_or_nothing,
                                         write_dataset)
from vibrofriction.identify.report import write_folder

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
    rows = [f"{i / 1000},{m},{f}" for i, (m, f) in enumerate(zip(motion, force))]
    rows[50] = rows[50].replace("0.05,", "0.2,")  # line 52: 0.2, then line 53: 0.051
    tiny = "\n".join(f"{i * 1e-300!r},{m},{f}" for i, (m, f) in enumerate(zip(motion, force)))
    for name, text in {"backwards": "\n".join(rows), "tiny_steps": tiny}.items():
        (folder / f"{name}.csv").write_text("time_s,position_m,friction_force_N\n" + text + "\n")
        (folder / f"{name}.json").write_text("{}\n")
    # a pneumatic-seal text cut off inside its last number (the originals end with CR LF)
    seal = "".join(f"{10 * i:.3f}\t3.474\t1.499\t3.248\t{0.1 * np.sin(i):.3f}\t2.997\t"
                   f"151.092\r\n" for i in range(40))
    (folder / "cut.txt").write_text(seal + "400.000\t3.474\t1.499\t3.248\t0.013\t2.997\t15",
                                    newline="")


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
    # every target checked before anything is computed or written; the user's path named
    (["simulate", "--csv", "run.csv", "--json", "/proc/x.json", *SHORT],
     "--json /proc/x.json: cannot write in /proc"),
    (["identify", "good.csv", "--json", "/proc/x.json"], "--json /proc/x.json: cannot write"),
    (["simulate", "--csv", "run.csv", "--json", "run.json", *SHORT],
     "--json run.json is also written as the sidecar of --csv run.csv"),
    # an existing --out is replaced as a whole: only an earlier report or an empty folder
    (["identify", "good.csv", "--out", "a_folder"], "not an earlier output (no report.json)"),
    (["identify", "good.csv", "--out", "."], "holds the current folder"),
    (["reproduce", "--quick", "--out", "a_folder"], "not an earlier output (no claims.json)"),
    (["reproduce", "--quick", "--out", "."], "holds the current folder"),
    (["compare-builtin", "--quick", "--out", "a_folder"],
     "not an earlier output (no builtin.json)"),
    (["compare-builtin", "--quick", "--out", "a_run"], "holds claims.json, the output of "
     "vibrofriction reproduce"),
    (["reproduce", "--quick", "--out", "a_run", "--json", "a_run/summary.json"],
     "--json a_run/summary.json is inside --out a_run"),
    # too many steps: the parameter values that made the default duration or timestep
    (["simulate", "--set", "normal_force_N=1e9"],
     "a run to steady state of up to 800000 s (two loadings of the drive spring to breakaway"),
    (["simulate", "--set", "drive_velocity_m_per_s=1e-9"], "--set a smaller normal_force_N or "
     "a larger drive_velocity_m_per_s"),
    (["sweep", "--va", "1e3"], "kappa_v = vibration_velocity_amplitude_m_per_s / "
     "drive_velocity_m_per_s = 1000/0.0005"),
    (["simulate", "--duration", "1e6", "--timestep", "1e-3"],
     "--duration 1e+06 s at --timestep 0.001 s is 1e+09 steps"),
    # the run to steady state and its options
    (["simulate", "--settle", "0.01"], "--settle needs --duration"),
    (["simulate", "--timestep", "0.05"], "timestep 0.05 s is too coarse to average over "
     "windows"),
    (["sweep", "--va", "1e-3", "--tolerance", "0"], "--tolerance '0' must be a finite number"),
    (["simulate", "--max-duration", "nan"], "--max-duration 'nan' must be a finite number"),
    (["simulate", "--max-duration", "1", *SHORT], "--max-duration applies to runs to steady "
     "state"),
    (["simulate", "--max-duration", "1e5", "--timestep", "1e-7"], "a run to steady state of up "
     "to 100000 s at --timestep 1e-07 s is 1e+12 steps, more than 5e+08; give a shorter "
     "--max-duration"),
    # negative numbers in scientific notation are values: the option's own check speaks
    (["sweep", "--va", "-1e-3"], "--va entry '-1e-3' must be a finite velocity amplitude >= 0"),
    (["simulate", "--timestep", "-1e-5", *SHORT], "--timestep -1e-05 must be a finite number"),
    (["simulate", "--duration", "-1E-3"], "--duration '-1E-3' must be a finite number"),
    (["simulate", "--set", "mass_kg=-1e-3", *SHORT], "mass_kg=-0.001"),
    # plain numbers in messages, never np.float64(...)
    (["identify", "backwards.csv"], "line 53, column 'time_s': 0.051 is not after the "
     "previous row's 0.2"),
    # a sample interval below 1 ns is a unit or a glitch
    (["identify", "tiny_steps.csv"], "line 3, column 'time_s': 1e-300 s after the previous row"),
    (["simulate", "--csv", "run.csv", "--timestep", "1e-10", "--duration", "1e-4"],
     "finer than the 1e-09 s a dataset accepts"),
    # a truncated source file
    (["convert", "pneumatic-seal", "cut.txt", "--out", "seal.csv"], "line 41 ('400.000"),
]


@pytest.mark.parametrize("argv, words", CASES, ids=[" ".join(c[0][:3]) for c in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, monkeypatch, capsys, argv,
                                                          words):
    monkeypatch.chdir(tmp_path)
    _records(tmp_path)
    (tmp_path / "a_folder").mkdir()
    (tmp_path / "a_folder" / "keep.txt").write_text("keep")
    (tmp_path / "a_file").write_text("keep")
    (tmp_path / "a_run").mkdir()  # an earlier reproduce run: it holds builtin.json too
    for name in ("claims.json", "builtin.json", "summary.md"):
        (tmp_path / "a_run" / name).write_text("{}")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert words in err and "np.float64" not in err and ".tmp" not in err, err
    after = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert after == before  # nothing written, nothing existing changed
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == ["a_folder", "a_run"]


def test_a_held_body_on_a_moving_support_and_an_absolute_clock_are_accepted():
    from vibrofriction.identify.selection import check_identifiable
    t = 1.7e9 + np.arange(200) * 1e-3  # Unix time
    held = Dataset(name="held", metadata=DatasetMetadata(), columns={
        "time_s": t, "position_m": np.zeros_like(t), "friction_force_N": np.sin(50 * t),
        "support_velocity_m_per_s": np.cos(30 * t)})
    check_identifiable(held)  # the counterface moves under a body held on a load cell


def _one_line_exit_2(capsys, code: int, words: str) -> None:
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert words in err, err


def _files(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_a_failed_simulate_keeps_the_previous_csv(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["simulate", "--csv", "run.csv", *SHORT]) == 0
    capsys.readouterr()
    (tmp_path / "run.json").unlink()
    (tmp_path / "run.json").mkdir()  # the sidecar cannot be written
    before = _files(tmp_path)
    _one_line_exit_2(capsys, cli.main(["simulate", "--csv", "run.csv", *SHORT]),
                     "--csv run.csv: its sidecar run.json is a folder")
    assert _files(tmp_path) == before  # the previous run.csv survives unchanged


def test_outputs_are_all_or_nothing_when_the_last_one_fails(tmp_path, monkeypatch, capsys):
    """Past the checks (here switched off), a target that fails at the end undoes the others:
    the previous run.csv and run.json are back, no temporary file is left, and the message
    names the user's path, not a temporary one."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["simulate", "--csv", "run.csv", *SHORT]) == 0
    capsys.readouterr()
    before = _files(tmp_path)
    from vibrofriction.commands import common  # (where the output checks live)
    monkeypatch.setattr(common, "check_writable", lambda *args, **kwargs: None)
    code = cli.main(["simulate", "--csv", "run.csv", "--json", "/proc/x.json", *SHORT,
                     "--set", "mass_kg=0.7"])
    _one_line_exit_2(capsys, code, "/proc/x.json: cannot write")
    assert _files(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "run.json"]


def test_a_failed_rename_restores_every_target(tmp_path, monkeypatch):
    (tmp_path / "run.csv").write_text("old csv")
    (tmp_path / "run.json").write_text("old json")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "report.json").write_text("old report")
    before = _files(tmp_path)
    rename = os.rename

    def failing(source, target):
        if Path(target) == tmp_path / "run.json" and ".tmp" in str(source):
            raise PermissionError(13, "Permission denied")
        rename(source, target)

    monkeypatch.setattr(os, "rename", failing)
    dataset = Dataset(name="run", metadata=DatasetMetadata(), columns={
        "time_s": [0.0, 1.0], "position_m": [0.0, 1.0], "friction_force_N": [0.0, 1.0]})
    with pytest.raises(DatasetError, match=r"run.json: cannot write: Permission denied"):
        with all_or_nothing():
            write_folder(tmp_path / "out", lambda tmp: (tmp / "report.json").write_text("new"))
            write_dataset(dataset, tmp_path / "run.csv")
    assert _files(tmp_path) == before  # the folder and run.csv placed, then put back
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "run.csv", "run.json"]


def test_an_existing_out_folder_is_replaced_as_a_whole(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    _records(tmp_path)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "report.json").write_text("{}")
    (tmp_path / "out" / "stale.png").write_text("from an earlier run")
    assert cli.main(["identify", "good.csv", "--out", "out", "--method", "inverse",
                     "--no-figures"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["report.json", "report.md",
                                                                  "series_good.csv"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    capsys.readouterr()
    with pytest.raises(SystemExit):
        cli.main(["identify", "--help"])
    assert "is replaced as a whole: files in it that this run does not write are deleted" in \
        " ".join(capsys.readouterr().out.split())  # the rule, said where --out is explained


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_while_writing_leaves_the_old_folder_and_no_temporary(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "report.json").write_text("old")
    handler = signal.getsignal(signal.SIGTERM)

    def write(tmp: Path) -> None:
        (tmp / "report.json").write_text("new")
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler raises here

    with pytest.raises(SystemExit) as exc:
        write_folder(tmp_path / "out", write)
    assert exc.value.code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == handler  # restored
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert (tmp_path / "out" / "report.json").read_text() == "old"


def test_a_mujoco_version_mismatch_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    from vibrofriction import build_info
    from vibrofriction.laws import _native
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(build_info, "MUJOCO_VERSION", "0.0.1")
    monkeypatch.setattr(_native, "_library", None)  # as in a fresh process: load() checks
    _one_line_exit_2(capsys, cli.main(["simulate", *SHORT]),
                     "compiled against MuJoCo 0.0.1 but MuJoCo")
    assert not any(tmp_path.iterdir())


def test_parameter_messages_show_plain_numbers_for_numpy_values():
    from vibrofriction.params import ParameterError, RigParameters
    for value, words in ((-1.0, "mass_kg=-1.0 must be > 0"), (1e-300, "mass_kg=1e-300 must lie")):
        with pytest.raises(ParameterError) as exc:
            RigParameters(mass_kg=np.float64(value)).validate()
        assert words in str(exc.value) and "np." not in str(exc.value)


def test_a_run_larger_than_memory_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    from vibrofriction.rigs import rig

    def too_large(*args, **kwargs):
        raise MemoryError("Unable to allocate 33.6 GiB for an array")

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(rig, "simulate_many", too_large)
    _one_line_exit_2(capsys, cli.main(["simulate", *SHORT]), "not enough memory")


def test_a_stage_without_vibration_is_refused_where_the_study_averages(tmp_path, capsys):
    """reproduce and compare-builtin average steady vibration: --set vibration_from_s is one
    message before anything runs, not an oracle failure after the study."""
    for command in (["reproduce", "--quick"], ["compare-builtin", "--quick"]):
        out = tmp_path / command[0]
        _one_line_exit_2(capsys, cli.main([*command, "--set", "vibration_from_s=0.01",
                                           "--out", str(out)]),
                         "vibration_from_s=... is not accepted")
        assert not out.exists()


def test_an_unreachable_dask_scheduler_is_one_message(monkeypatch, capsys):
    pytest.importorskip("dask.distributed", reason="the optional extra dask is not installed")
    from vibrofriction.rigs import sweep as sweep_engine
    monkeypatch.setattr(sweep_engine, "CONNECT_TIMEOUT_S", 1)
    _one_line_exit_2(capsys, cli.main(["sweep", "--va", "1e-3", "--scheduler", "127.0.0.1:9",
                                       *SHORT]), "no Dask scheduler answers there")


def test_info_shows_the_versions_when_the_plugins_cannot_load(tmp_path, monkeypatch):
    from vibrofriction import build_info
    from vibrofriction.laws import _native
    monkeypatch.setattr(build_info, "MUJOCO_VERSION", "0.0.1")
    monkeypatch.setattr(_native, "_library", None)  # as in a fresh process: load() checks
    path = tmp_path / "info.json"
    assert cli.main(["info", "--json", str(path)]) == 0
    payload = json.loads(path.read_text())
    assert payload["versions"]["mujoco_built_against"] == "0.0.1"
    assert payload["plugins"] == [] and "compiled against MuJoCo 0.0.1" in payload["error"]
