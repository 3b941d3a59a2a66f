"""The held-out part shown: series_<dataset>.csv (and .png) of every record, on both paths.

Each report folder holds, for the training record and each held-out record, the final
model's measured, predicted and residual series (report.json ``series`` names the files);
the residual is measured - predicted, and a held-out record's RMSE is report.json's."""
from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.data.datasets import Dataset, DatasetMetadata, write_dataset
from vibrofriction.identify.series import Series, file_names, zoom

from test_machine_closed_loop import USER_SCENE


def _read(path: Path) -> dict[str, np.ndarray]:
    with path.open() as handle:
        rows = list(csv.reader(handle))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def _check_folder(out: Path, train: str, held: list[str], channels: tuple[str, ...],
                  primary: str, figures: bool) -> dict:
    report = json.loads((out / "report.json").read_text())
    assert report["series"] == {"train": f"series_{train}.csv",
                                "validation": [f"series_{h}.csv" for h in held]}
    files = [report["series"]["train"], *report["series"]["validation"]]
    for index, name in enumerate(files):
        columns = _read(out / name)
        assert list(columns) == ["time_s"] + [f"{kind}_{c}" for c in channels
                                             for kind in ("measured", "predicted", "residual")]
        for c in channels:
            np.testing.assert_allclose(
                columns[f"residual_{c}"], columns[f"measured_{c}"] - columns[f"predicted_{c}"],
                rtol=0, atol=1e-12 * np.max(np.abs(columns[f"measured_{c}"])))
        rmse = float(np.sqrt(np.mean(columns[f"residual_{primary}"] ** 2)))
        metric = report["final"]["train"] if index == 0 else \
            report["final"]["validation"][index - 1]
        if index:
            assert metric["dataset"] == held[index - 1]
        key = "rmse_N" if "rmse_N" in metric else "rmse"
        assert rmse == pytest.approx(metric[key], rel=1e-9)
        png = out / (Path(name).stem + ".png")
        assert png.exists() == figures
        if figures:
            assert png.stat().st_size > 1000
    return report


# ------------------------------------------------------------------------------ inverse path

def _pushed_carriage(name: str, folder: Path, seed: int, frequencies: tuple[float, float]
                     ) -> Path:
    """A carriage pushed through a load cell (drive_force_N), its velocity and acceleration
    from the servo: 1 kHz, Coulomb 2 N + viscous 5 N s/m, mass 1.5 kg in the sidecar."""
    rng = np.random.default_rng(seed)
    t = np.arange(1500) * 1e-3
    f1, f2 = frequencies
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    v = 0.05 * np.sin(w1 * t) + 0.02 * np.sin(w2 * t)
    a = 0.05 * w1 * np.cos(w1 * t) + 0.02 * w2 * np.cos(w2 * t)
    x = 0.05 / w1 * (1 - np.cos(w1 * t)) + 0.02 / w2 * (1 - np.cos(w2 * t))
    force = 1.5 * a + 2.0 * np.sign(v) + 5.0 * v + 0.02 * rng.standard_normal(len(t))
    path, _ = write_dataset(Dataset(name=name, columns={
        "time_s": t, "position_m": x, "velocity_m_per_s": v, "acceleration_m_per_s2": a,
        "drive_force_N": force},
        metadata=DatasetMetadata(mass_kg=1.5)), folder / f"{name}.csv")
    return path


def test_inverse_path_writes_every_records_series(tmp_path, capsys) -> None:
    train = _pushed_carriage("push_a", tmp_path, 1, (1.0, 3.7))
    held = _pushed_carriage("push_b", tmp_path, 2, (1.5, 2.3))
    out = tmp_path / "out"
    assert cli.main(["identify", str(train), "--validate", str(held), "--method", "inverse",
                     "--law", "coulomb", "--out", str(out)]) == 0, capsys.readouterr().err
    report = _check_folder(out, "push_a", ["push_b"], ("drive_force_N",), "drive_force_N",
                           figures=True)
    assert report["final"]["parameters"]["friction_coefficient"] == pytest.approx(2.0, rel=0.1)
    assert (out / "fit.png").exists()
    # --no-figures: the series still, no PNG at all
    assert cli.main(["identify", str(train), "--validate", str(held), "--method", "inverse",
                     "--law", "coulomb", "--out", str(out), "--no-figures"]) == 0
    _check_folder(out, "push_a", ["push_b"], ("drive_force_N",), "drive_force_N",
                  figures=False)
    assert not list(out.glob("*.png"))


# --------------------------------------------------------------------------- simulation path

def _pushed_block(name: str, folder: Path, scene: Path, seed: int, scale: float) -> Path:
    """USER_SCENE's block (mass 2 kg, Coulomb 3 N) pushed by a measured force, its
    position measured (the truth from the scene itself, plus 1 um of noise)."""
    from vibrofriction.identify.replay import Replayer
    from vibrofriction.identify.replays import prepare_replay
    from vibrofriction.params import FrictionParameters
    t = np.arange(2000) * 1e-3
    push = scale * (5.0 * np.sin(2 * np.pi * 1.0 * t) + 1.0 * np.sin(2 * np.pi * 3.7 * t))
    columns = {"time_s": t, "position_m": np.zeros_like(t), "drive_force_N": push}
    meta = DatasetMetadata(model=str(scene), simulation_timestep_s=2.5e-4)
    replay = prepare_replay(Dataset(name=name, columns=columns, metadata=meta))
    with Replayer(replay, threads=1) as runner:
        out = runner.run([(replace(replay.rig, mass_kg=2.0),
                           FrictionParameters(law="coulomb", friction_coefficient=3.0))])[0]
    columns["position_m"] = out["position_m"] + \
        1e-6 * np.random.default_rng(seed).standard_normal(len(t))
    path, _ = write_dataset(Dataset(name=name, columns=columns, metadata=DatasetMetadata(
        simulation_timestep_s=2.5e-4)), folder / f"{name}.csv")
    return path


def test_simulation_path_writes_every_records_series(tmp_path, capsys) -> None:
    scene = tmp_path / "pushed_block.xml"
    scene.write_text(USER_SCENE)
    train = _pushed_block("block_a", tmp_path, scene, 1, 1.0)
    held = _pushed_block("block_b", tmp_path, scene, 2, 1.3)
    out = tmp_path / "out"
    assert cli.main(["identify", str(train), "--validate", str(held), "--model", str(scene),
                     "--law", "coulomb", "--out", str(out)]) == 0, capsys.readouterr().err
    report = _check_folder(out, "block_a", ["block_b"], ("position_m",), "position_m",
                           figures=True)
    assert report["final"]["parameters"]["friction_coefficient"] == pytest.approx(3.0,
                                                                                  rel=0.02)
    assert (out / "fit.png").exists() and (out / "fitted_model.xml").exists()


# ---------------------------------------------------------------------------------- helpers

def test_file_names_are_safe_and_distinct() -> None:
    assert file_names("run 1", ["run 1", "run/2", "run 1"]) == [
        "series_run_1.csv", "series_run_1_2.csv", "series_run_2.csv", "series_run_1_3.csv"]


def test_the_window_is_a_few_periods_or_a_stretch_around_the_largest_residual() -> None:
    t = np.arange(10000) * 1e-5  # 0.1 s at 100 kHz
    measured = np.sin(2 * np.pi * 500 * t)
    predicted = measured.copy()
    predicted[7000] += 1.0
    vibrating = Series("r", "train", "series_r.csv", t, {"friction_force_N": (measured,
                                                                              predicted)},
                       "friction_force_N", vibration_frequency_Hz=500.0)
    window = zoom(vibrating)
    assert window[7000] and np.ptp(t[window]) == pytest.approx(5 / 500, abs=2e-5)
    still = replace(vibrating, vibration_frequency_Hz=None)
    window = zoom(still)
    assert window[7000] and np.ptp(t[window]) == pytest.approx(0.05 * t[-1], abs=2e-5)
    predicted[7000] -= 1.0
    predicted[-1] += 1.0  # at the very end: the window shifted to lie within the record
    assert zoom(still)[-1] and zoom(still).sum() > 400
