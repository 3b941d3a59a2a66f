"""``vibrofriction simulate`` and ``vibrofriction sweep`` (interfaces.md): outputs, exit codes,
bad input (one clear message, exit 2, nothing written)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

import vibrofriction
from vibrofriction.cli import main
from vibrofriction.data.datasets import COLUMNS, MACHINE_INPUT_COLUMNS, read_dataset
from vibrofriction.rigs.sweep import CONVERGENCE_KEYS, POINT_KEYS

SHORT = ["--duration", "0.04", "--settle", "0.03"]  # 40 periods averaged, loaded at 22 ms


def test_simulate_writes_dataset_and_summary(tmp_path, capsys):
    csv_path, json_path = tmp_path / "run.csv", tmp_path / "summary.json"
    code = main(["simulate", "--set", "vibration_velocity_amplitude_m_per_s=3e-3", "--static",
                 "--csv", str(csv_path), "--json", str(json_path), *SHORT])
    assert code == 0
    summary = json.loads(json_path.read_text())
    assert summary["law"] == "dahl"
    assert summary["schema_version"] == 1  # (every JSON output: the schema and its makers)
    assert summary["versions"] == {"vibrofriction": vibrofriction.__version__,
                                   "mujoco": mujoco.__version__}
    assert summary["timestep_s"] > 0 and summary["duration_s"] == 0.04
    assert summary["parameters"]["vibration_velocity_amplitude_m_per_s"] == 3e-3
    assert summary["parameters"]["law"] == "dahl"
    assert summary["kappa"] == pytest.approx(6.0)
    assert summary["static_drive_force_N"] == pytest.approx(11.04, rel=2e-3)
    assert summary["ratio"] == pytest.approx(0.166, abs=0.01)
    assert summary["ratio"] == pytest.approx(
        summary["mean_drive_force_N"] / summary["static_drive_force_N"])
    assert summary["sign_change"] is True
    assert summary["friction_min_N"] < 0 < summary["friction_max_N"]
    # default timestep: N + 0.382 steps per period, N = 50 at kappa 6 (rig.recommended_timestep)
    timestep = 1.0 / (4000.0 * (50 + 0.381966))
    assert summary["timestep_s"] == pytest.approx(timestep, rel=1e-12)
    assert summary["duration_s"] == 0.04
    dataset = read_dataset(csv_path)
    # every column of the rig (a machine's inputs are not the rig's)
    assert list(dataset.columns) == [c for c in COLUMNS if c not in MACHINE_INPUT_COLUMNS]
    assert dataset.n_rows == round(0.04 / timestep)
    assert dataset.metadata.mass_kg == 0.5
    assert dataset.metadata.vibration_frequency_Hz == 4000.0
    assert dataset.metadata.drive_velocity_m_per_s == 5e-4
    assert dataset.metadata.sample_rate_Hz == pytest.approx(1.0 / timestep, rel=1e-8)
    sidecar = json.loads((tmp_path / "run.json").read_text())
    assert set(sidecar) >= {"mass_kg", "drive_stiffness_N_per_m", "drive_velocity_m_per_s",
                            "vibration_frequency_Hz", "normal_force_N", "sample_rate_Hz"}
    assert capsys.readouterr().out == ""  # everything went to files


def test_simulate_prints_summary_without_json(capsys):
    assert main(["simulate", "--law", "coulomb", *SHORT]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["law"] == "coulomb"
    assert summary["static_drive_force_N"] is None and summary["ratio"] is None
    assert summary["mean_drive_force_N"] == pytest.approx(11.04, rel=2e-3)  # no vibration


def test_sweep_json_is_exactly_the_interface(tmp_path, capsys):
    out = tmp_path / "sweep.json"
    code = main(["sweep", "--va", "0.75e-3,3e-3,20e-3", "--law", "dahl", "--json", str(out),
                 "--timestep", "1e-5"])
    assert code == 0
    result = json.loads(out.read_text())
    # the interface's keys after the two every JSON output begins with
    assert list(result) == ["schema_version", "versions", "law", "parameters",
                            "static_drive_force_N", "points", "static_convergence",
                            "all_converged"]
    assert list(result["static_convergence"]) == list(CONVERGENCE_KEYS)
    assert result["law"] == "dahl"
    assert result["static_drive_force_N"] == pytest.approx(11.04, rel=1e-3)
    assert [list(p) for p in result["points"]] == [list(POINT_KEYS + CONVERGENCE_KEYS)] * 3
    assert result["all_converged"] and all(p["converged"] for p in result["points"])
    ratios = [p["ratio"] for p in result["points"]]
    # Done-when of issue 2: reduction without sign change at 0.75 mm/s, with sign changes at
    # 3 mm/s, more than 20-fold at large kappa
    assert ratios[0] == pytest.approx(0.77, abs=0.01)
    assert ratios[1] == pytest.approx(0.166, abs=0.01)
    # kappa 40 at 1e-5 s (25 steps a period, the rule wants 200): the transient (the default
    # method) on exactly 25 steps a period locks the step phase (0.0206; the rule's converged
    # value is 0.0167, and the periodic orbit, averaging 13 step phases, 0.0164)
    assert ratios[2] < 1 / 20 * 1.05 and ratios[2] == pytest.approx(0.0206, abs=0.002)
    assert [p["method"] for p in result["points"]] == ["transient"] * 3
    assert [p["sign_change"] for p in result["points"]] == [False, True, True]
    assert [p["kappa"] for p in result["points"]] == pytest.approx([1.5, 6.0, 40.0])
    for p in result["points"]:
        assert p["ratio"] == pytest.approx(p["mean_drive_force_N"]
                                           / result["static_drive_force_N"])
    assert "sweep: 4/4" in capsys.readouterr().err  # progress on stderr (a log: lines)


def test_sweep_runs_every_law_with_overrides(tmp_path):
    out = tmp_path / "sweep.json"
    for law in ("coulomb", "dupont", "lugre"):
        assert main(["sweep", "--va", "3e-3", "--law", law, "--set", "mass_kg=0.4",
                     "--set", "friction_coefficient=0.25", "--json", str(out), *SHORT]) == 0
        result = json.loads(out.read_text())
        assert result["law"] == law
        assert result["parameters"]["mass_kg"] == 0.4
        assert result["static_drive_force_N"] == pytest.approx(0.25 * 55.2, rel=0.01)
        assert 0 < result["points"][0]["ratio"] < 0.5
    # LuGre's default bristle damping follows the overridden mass: 0.2 sqrt(k_t m)
    assert result["parameters"]["bristle_damping_N_s_per_m"] == pytest.approx(
        0.2 * (8e7 * 0.4) ** 0.5)


def test_sweep_with_more_threads_than_runs(tmp_path):
    out = tmp_path / "sweep.json"
    assert main(["sweep", "--va", "3e-3", "--threads", "3", "--json", str(out), *SHORT]) == 0
    one_thread = tmp_path / "one.json"
    assert main(["sweep", "--va", "3e-3", "--threads", "1", "--json", str(one_thread),
                 *SHORT]) == 0
    assert json.loads(out.read_text()) == json.loads(one_thread.read_text())



def test_a_sweep_point_carries_the_mean_friction_force_of_its_run_summary(tmp_path,
                                                                          monkeypatch):
    """Every point has mean_friction_force_N, taken from the run's own summary (the object
    simulate reports it from): equal to it, and to simulate's for the same run."""
    import vibrofriction.rigs.sweep as sweep_module

    summaries = []
    run_cases = sweep_module.run_cases

    def recording_run_cases(*args, **kwargs):
        results = run_cases(*args, **kwargs)
        summaries.extend(result.summary for result in results)
        return results

    monkeypatch.setattr(sweep_module, "run_cases", recording_run_cases)
    fixed = [*SHORT, "--timestep", "1e-5"]
    sweep_json = tmp_path / "sweep.json"
    assert main(["sweep", "--va", "3e-3", "--json", str(sweep_json), *fixed]) == 0
    point = json.loads(sweep_json.read_text())["points"][0]
    static_summary, point_summary = summaries  # the static run, then the --va run
    assert point["mean_friction_force_N"] == point_summary.mean_friction_force_N
    assert point["mean_friction_force_N"] != static_summary.mean_friction_force_N
    simulate_json = tmp_path / "simulate.json"
    assert main(["simulate", "--set", "vibration_velocity_amplitude_m_per_s=3e-3", "--json",
                 str(simulate_json), *fixed]) == 0
    simulated = json.loads(simulate_json.read_text())
    assert point["mean_friction_force_N"] == simulated["mean_friction_force_N"]


def test_sweep_threads_with_a_scheduler_is_refused_before_connecting(tmp_path, capsys,
                                                                     monkeypatch):
    """--threads sets local rollout threads; with --scheduler it could not apply, so the pair
    is one usage error (exit 2) naming both options and the fix, before any connection."""
    import vibrofriction.rigs.sweep as sweep_engine

    def no_cluster(*args, **kwargs):
        raise AssertionError("the sweep reached the Dask cluster")

    monkeypatch.setattr(sweep_engine, "dask_map", no_cluster)
    out = tmp_path / "sweep.json"
    assert main(["sweep", "--va", "3e-3", "--threads", "2", "--scheduler", "tcp://127.0.0.1:9",
                 "--json", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("vibrofriction sweep: error: --threads 2 ")
    assert "--scheduler tcp://127.0.0.1:9" in lines[0]
    assert "drop --threads" in lines[0] and "drop --scheduler" in lines[0]
    assert not out.exists()

BAD_INPUT = [
    (["simulate", "--set", "mass=1"], "unknown parameter 'mass'"),
    (["simulate", "--set", "mass_kg=nan"], "mass_kg"),
    (["simulate", "--set", "mass_kg=heavy"], "not a number"),
    (["simulate", "--set", "mass_kg"], "NAME=VALUE"),
    (["simulate", "--set", "mass_kg=-1"], "mass_kg"),
    (["simulate", "--law", "stribeck"], "unknown friction law 'stribeck'"),
    (["simulate", "--set", "law=amontons"], "unknown friction law 'amontons'"),
    (["simulate", "--timestep", "nan"], "--timestep"),
    (["simulate", "--timestep=-1e-5"], "--timestep"),
    (["simulate", "--duration", "abc"], "--duration"),
    (["simulate", "--duration", "0.01", "--settle", "0.02"], "--settle"),
    (["simulate", "--set", "breakaway_ratio=1.5"], "breakaway_ratio"),
    (["sweep", "--va", "1e-3,-2e-3"], "--va entry '-2e-3'"),
    (["sweep", "--va=-1e-3"], "--va entry '-1e-3'"),
    (["sweep", "--va", "1e-3,fast"], "--va entry 'fast' is not a number"),
    (["sweep", "--va", "1e-3,,2e-3"], "empty entry"),
    (["sweep", "--va", "nan"], "--va entry 'nan'"),
    (["sweep", "--va", "inf"], "--va entry 'inf'"),
    (["sweep", "--va", "1e-3", "--law", "dahl2"], "unknown friction law"),
    (["sweep", "--va", "1e-3", "--set", "alpha=-1"], "alpha"),
    (["sweep", "--va", "1e-3", "--threads", "0"], "--threads"),
]


@pytest.mark.parametrize("argv, message", BAD_INPUT, ids=[" ".join(a) for a, _ in BAD_INPUT])
def test_bad_input_one_message_exit_2_nothing_written(tmp_path, capsys, argv, message):
    outputs = ["--json", str(tmp_path / "out.json")]
    if argv[0] == "simulate":
        outputs += ["--csv", str(tmp_path / "run.csv")]
    assert main([*argv, *outputs]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert message in lines[0]
    assert lines[0].startswith(f"vibrofriction {argv[0]}: error: ")
    assert list(tmp_path.iterdir()) == []


def test_bad_csv_name_is_refused_before_simulating(tmp_path, capsys):
    assert main(["simulate", "--csv", str(tmp_path / "run.txt"), *SHORT]) == 2
    assert "NAME.csv" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_top_level_help_lists_every_command(capsys):
    """`vibrofriction --help` formats every command's one-line help (a bare "%" broke it)."""
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    shown = capsys.readouterr().out
    for command in ("simulate", "sweep", "reproduce", "compare-builtin", "identify", "convert"):
        assert command in shown


def test_console_script_and_module_entry_point(tmp_path):
    """`python -m vibrofriction sweep --help` and an argparse error exit with code 2."""
    help_run = subprocess.run([sys.executable, "-m", "vibrofriction", "sweep", "--help"],
                              capture_output=True, text=True, check=True)
    assert "--va" in help_run.stdout and "--set" in help_run.stdout
    missing = subprocess.run([sys.executable, "-m", "vibrofriction", "sweep"],
                             capture_output=True, text=True)
    assert missing.returncode == 2 and "--va" in missing.stderr
    version = subprocess.run([sys.executable, "-m", "vibrofriction", "--version"],
                             capture_output=True, text=True, check=True)
    assert version.stdout.startswith(f"vibrofriction {vibrofriction.__version__}, MuJoCo ")
    script = Path(sys.executable).parent / "vibrofriction"
    if script.exists():
        out = tmp_path / "s.json"
        run = subprocess.run([str(script), "simulate", "--law", "lugre", "--json", str(out),
                              *SHORT], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        assert json.loads(out.read_text())["law"] == "lugre"


def test_the_python_sweep_refuses_nthread_with_a_scheduler_before_running():
    """The library call names the pair too (it silently ran on the workers' threads)."""
    from vibrofriction.rigs import sweep as sweep_module
    from vibrofriction.errors import InputError
    from vibrofriction.params import RigParameters, default_friction
    with pytest.raises(InputError, match="nthread=2.*scheduler"):
        sweep_module.sweep(RigParameters(), default_friction("dahl"), [3e-3], nthread=2,
                           scheduler="tcp://127.0.0.1:9", progress=False)
