"""What the data cannot tell (identify/identifiability.py): whether a record informs each fitted
value, presliding the sample interval does not resolve, and residual outliers, on both
identification paths (report.json ``final``, report.md).

Records are short (1000-1500 samples): the inverse path's are the plugin's own laws along a
prescribed motion, sampled at 1 kHz from a 20 kHz run, with white force noise; the simulation
path's is the pushed block of tests/test_machine_closed_loop.py.
"""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.data.datasets import Dataset, DatasetMetadata, write_dataset
from vibrofriction.identify import identify
from vibrofriction.identify.identifiability import (BOUND_TOLERANCE, OUTLIER_ROBUST_SD,
                                                    OUTLIER_SHARE, RELATIVE_ERROR_LIMIT,
                                                    bound_sides, identifiability,
                                                    moved_parameters, residual_outliers)
from vibrofriction.identify.model import Model, Scales
from vibrofriction.identify.replay import Replayer
from vibrofriction.identify.replays import prepare_replay
from vibrofriction.identify.report import report_json, report_markdown
from vibrofriction.laws.run import run_law
from vibrofriction.params import FrictionParameters

from test_machine_closed_loop import USER_SCENE

SAMPLE_INTERVAL_S = 1e-3
SAMPLES = 1000
FINE = 20  # law steps a sample interval when the record is made
FORCE_NOISE_N = 0.01
LEVEL_N = 1.0  # friction level (no normal force given: F_N = 1 N)
GLITCH_N = 2.0  # one bad force sample of a held-out record
GLITCH_SAMPLE = 400


def _record(name: str, seed: int, glitch: bool = False, **friction) -> Dataset:
    """A friction record of ``friction`` along a two-tone motion (about 7 mm/s rms)."""
    t = np.arange(SAMPLES * FINE) * SAMPLE_INTERVAL_S / FINE
    v = 10e-3 * np.sin(2 * np.pi * 2.0 * t) + 3e-3 * np.sin(2 * np.pi * 5.3 * t)
    x = np.cumsum(v) * SAMPLE_INTERVAL_S / FINE
    force = run_law(FrictionParameters(friction_coefficient=LEVEL_N, **friction), t, v,
                    normal_force_N=1.0).friction_force_N
    force = force[::FINE] + FORCE_NOISE_N * np.random.default_rng(seed).standard_normal(SAMPLES)
    if glitch:
        force[GLITCH_SAMPLE] += GLITCH_N
    return Dataset(name=name, columns={"time_s": t[::FINE], "position_m": x[::FINE],
                                       "velocity_m_per_s": v[::FINE],
                                       "friction_force_N": force})


def test_a_slow_sampled_stiff_contact_leaves_presliding_uninformed() -> None:
    """LuGre with z_c = 1e-7 m: 14 us of presliding at 7 mm/s, 1 ms between samples. The
    stiffness and the bristle damping are flagged whatever their standard errors; the level
    is informed; report.md says presliding is not resolved and that coulomb is the honest
    model."""
    stiff = _record("stiff", 1, law="lugre", contact_stiffness_N_per_m=1e7,
                    bristle_damping_N_s_per_m=30.0)
    result = identify(stiff, law="lugre")
    final = report_json(result)["final"]
    p = final["presliding"]
    assert p["sample_interval_s"] == pytest.approx(SAMPLE_INTERVAL_S)
    assert p["presliding_time_s"] == pytest.approx(p["deflection_m"] /
                                                   p["typical_sliding_speed_m_per_s"])
    assert p["deflection_m"] == pytest.approx(
        result.final.values["friction_coefficient"] /
        result.final.values["contact_stiffness_N_per_m"])
    assert p["resolved"] is False and p["presliding_time_s"] < p["sample_interval_s"]
    flags = final["identifiability"]
    for name in ("contact_stiffness_N_per_m", "bristle_damping_N_s_per_m"):
        assert flags[name]["informed"] is False, name
        assert "presliding not resolved" in flags[name]["reason"], name
    assert flags["friction_coefficient"]["informed"] is True
    assert final["friction_coefficient_unit"] == "N"
    md = report_markdown(result)
    assert "Presliding is not resolved" in md and "`--law coulomb`" in md
    assert "friction_coefficient (friction level, N)" in md
    assert "| contact_stiffness_N_per_m |" in md and "**no**: presliding not resolved" in md


def test_a_soft_contact_at_the_same_sampling_is_informed() -> None:
    """The same motion and sampling with z_c = 1e-4 m (13 ms of presliding, damping time
    10 ms): resolved, every value informed."""
    soft = _record("soft", 1, law="lugre", contact_stiffness_N_per_m=1e4,
                   bristle_damping_N_s_per_m=100.0)
    final = report_json(identify(soft, law="lugre"))["final"]
    assert final["presliding"]["resolved"] is True
    assert final["presliding"]["damping_resolved"] is True
    for name, flag in final["identifiability"].items():
        assert flag["informed"] is True, (name, flag)
        assert flag["relative_standard_error"] <= RELATIVE_ERROR_LIMIT


def test_a_well_sampled_coulomb_viscous_record_is_informed() -> None:
    record = _record("rigid", 3, law="coulomb", viscous_N_s_per_m=20.0)
    result = identify(record, law="coulomb", declared=["viscous"])
    final = report_json(result)["final"]
    assert final["presliding"] is None  # a rigid law has no presliding
    assert set(final["identifiability"]) == {"friction_coefficient", "viscous_N_s_per_m"}
    for name, flag in final["identifiability"].items():
        assert flag == {"informed": True, "relative_standard_error": pytest.approx(
            result.final.uncertainties[name] / abs(result.final.values[name])),
            "at_bound": None, "reason": None}, name
    assert final["residual_outliers"] == []
    assert "Residual outliers: none" in report_markdown(result)


def test_a_glitch_in_a_held_out_record_is_flagged_with_its_time(tmp_path, capsys) -> None:
    """One bad sample of a held-out record (2 N on 0.01 N of noise): reported with its
    record, time, share and the error without it, through the command line; the training
    record has none."""
    friction = dict(law="lugre", contact_stiffness_N_per_m=1e4, bristle_damping_N_s_per_m=100.0)
    train = write_dataset(_record("train", 1, **friction), tmp_path / "train.csv")[0]
    held = write_dataset(_record("held", 2, glitch=True, **friction), tmp_path / "held.csv")[0]
    out = tmp_path / "out"
    code = cli.main(["identify", str(train), "--validate", str(held), "--law", "lugre",
                     "--method", "inverse", "--out", str(out), "--no-figures"])
    assert code == 0, capsys.readouterr().err
    report = json.loads((out / "report.json").read_text())
    outliers = report["final"]["residual_outliers"]
    assert len(outliers) == 1, outliers
    (o,) = outliers
    assert o["dataset"] == "held" and o["held_out"] is True
    assert o["channel"] == "friction_force_N"
    assert o["time_s"] == pytest.approx(GLITCH_SAMPLE * SAMPLE_INTERVAL_S)
    # measured - predicted: the glitch, give or take the noise (5 sd)
    assert abs(o["residual"] - GLITCH_N) < 5 * FORCE_NOISE_N
    assert o["share_of_squared_error"] > OUTLIER_SHARE
    # without it the held-out record is fitted as well as the training record (both noise:
    # the rms of 1000 noise samples is within 3 x 2.2 % of the sd)
    assert o["rmse_without"] == pytest.approx(report["final"]["train"]["rmse_N"], rel=0.1)
    assert o["rmse"] == pytest.approx(report["final"]["validation"][0]["rmse_N"])
    md = (out / "report.md").read_text()
    errors = md[md.index("## Error before and after"):md.index("## Selected effects")]
    assert "held-out `held`, friction_force_N at t = 0.4 s" in errors
    assert "without it the RMSE would be" in errors


def test_values_are_flagged_by_their_standard_error_and_bounds() -> None:
    values = {"friction_coefficient": 2.0, "viscous_N_s_per_m": 1.0, "asymmetry": 0.1,
              "static_ratio": 1.2, "position_ripple_phase_rad": 0.3, "force_offset_N": 0.5}
    errors = {"friction_coefficient": 0.01, "viscous_N_s_per_m": None, "asymmetry": 0.2,
              "static_ratio": 0.15, "position_ripple_phase_rad": 0.8, "force_offset_N": 0.1}
    flags = identifiability(values, errors, {"force_offset_N": "upper"}, None)
    assert flags["friction_coefficient"].informed
    assert flags["friction_coefficient"].relative_standard_error == pytest.approx(0.005)
    assert not flags["viscous_N_s_per_m"].informed  # no standard error
    assert not flags["asymmetry"].informed  # 2 times its value
    assert not flags["static_ratio"].informed  # 0.75 of its excess over 1, not 0.125 of 1.2
    assert not flags["position_ripple_phase_rad"].informed  # 0.8 rad
    assert flags["position_ripple_phase_rad"].relative_standard_error is None
    assert flags["force_offset_N"].at_bound == "upper" and not flags["force_offset_N"].informed


def test_a_coordinate_at_its_bound_is_told_lower_or_upper() -> None:
    scales = Scales(force_N=1.0, velocity_m_per_s=1e-2, normal_force_N=1.0, dt_s=1e-3,
                    travel_m=1e-2)
    model = Model.build("lugre", ["viscous"], False, scales)
    lo, hi = model.bounds()
    q = 0.5 * (lo + hi)
    names = model.names
    q[names.index("contact_stiffness_N_per_m")] = hi[names.index("contact_stiffness_N_per_m")]
    q[names.index("viscous_N_s_per_m")] = lo[names.index("viscous_N_s_per_m")] + \
        0.5 * BOUND_TOLERANCE  # within the tolerance
    assert bound_sides(model, q) == {"contact_stiffness_N_per_m": "upper",
                                     "viscous_N_s_per_m": "lower"}


def test_white_noise_has_no_outliers_and_a_lone_spike_is_found() -> None:
    """No false alarm on white noise (200 records each of 100 and 2000 samples: the 5 robust
    sd every outlier needs has a chance of 6e-7 a sample); a lone spike beyond 8 robust sd is
    found even where it carries under 10 % of the squared error, a stretch of misfit is
    not (it is no single sample)."""
    rng = np.random.default_rng(5)
    for n in (100, 2000):
        for _ in range(200):
            t = np.arange(n) * 1e-3
            assert residual_outliers("r", "c", False, t, rng.standard_normal(n),
                                     np.zeros(n)) == []
    n = 20000
    t = np.arange(n) * 1e-3
    noise = rng.standard_normal(n)
    spiked = noise.copy()
    spiked[12345] += 2 * OUTLIER_ROBUST_SD  # 16 sd: 256 of the 20000 units, about 1.3 %
    (o,) = residual_outliers("r", "c", True, t, spiked, np.zeros(n))
    assert o.time_s == pytest.approx(t[12345]) and o.share_of_squared_error < OUTLIER_SHARE
    stretch = noise.copy()
    stretch[5000:5010] += 2 * OUTLIER_ROBUST_SD
    assert residual_outliers("r", "c", False, t, stretch, np.zeros(n)) == []


def test_simulation_path_flags_a_held_out_glitch_and_informs_a_pushed_block(tmp_path,
                                                                             capsys) -> None:
    """--model SCENE.xml, Coulomb + viscous on the pushed block's position (1500 samples):
    level, viscous and mass informed, no presliding (a rigid law), a 1 mm glitch of the
    held-out position reported at its time from the simulation the held-out error came
    from."""
    scene = tmp_path / "pushed_block.xml"
    scene.write_text(USER_SCENE)
    friction = FrictionParameters(law="coulomb", friction_coefficient=3.0,
                                  viscous_N_s_per_m=4.0)
    glitch_m, glitch_sample = 1e-3, 700
    paths = []
    for name, seed, tone_Hz in (("pushed", 11, 3.7), ("pushed_held", 12, 2.9)):
        t = np.arange(1500) * 1e-3
        push = 5.0 * np.sin(2 * np.pi * 1.0 * t) + 1.0 * np.sin(2 * np.pi * tone_Hz * t)
        columns = {"time_s": t, "position_m": np.zeros_like(t), "drive_force_N": push}
        meta = DatasetMetadata(model=str(scene), simulation_timestep_s=2.5e-4)
        replay = prepare_replay(Dataset(name=name, columns=columns, metadata=meta))
        with Replayer(replay) as runner:
            out = runner.run([(replace(replay.rig, mass_kg=2.0), friction)])[0]
        position = out["position_m"] + 1e-6 * np.random.default_rng(seed).standard_normal(len(t))
        if name == "pushed_held":
            position[glitch_sample] += glitch_m
        paths.append(write_dataset(Dataset(name=name, columns={**columns, "position_m": position},
                                           metadata=DatasetMetadata(
                                               simulation_timestep_s=2.5e-4)),
                                   tmp_path / f"{name}.csv")[0])
    out = tmp_path / "out"
    code = cli.main(["identify", str(paths[0]), "--validate", str(paths[1]), "--model",
                     str(scene), "--law", "coulomb", "--with", "viscous", "--out", str(out),
                     "--no-figures"])
    assert code == 0, capsys.readouterr().err
    final = json.loads((out / "report.json").read_text())["final"]
    assert final["presliding"] is None
    assert {n for n, f in final["identifiability"].items() if f["informed"]} == \
        {"friction_coefficient", "viscous_N_s_per_m", "mass_kg"}
    assert final["friction_coefficient_unit"] == "1"  # the scene's constant load
    (o,) = final["residual_outliers"]
    assert (o["dataset"], o["channel"], o["held_out"]) == ("pushed_held", "position_m", True)
    assert o["time_s"] == pytest.approx(glitch_sample * 1e-3)
    assert o["share_of_squared_error"] > OUTLIER_SHARE
    assert math.copysign(1.0, o["residual"]) == 1.0  # measured - predicted
    md = (out / "report.md").read_text()
    assert "held-out `pushed_held`, position_m at t = 0.7 s" in md
    assert "| informed |" in md


def test_a_law_parameter_moved_by_an_added_effect_is_flagged_biased() -> None:
    """A law parameter is flagged when the selected effects move it by more than its final
    standard error; within it, or with nothing selected, it is not."""
    baseline = {"friction_coefficient": 0.30, "contact_stiffness_N_per_m": 1e4}
    final = {"friction_coefficient": 0.301, "contact_stiffness_N_per_m": 2e5,
             "contact_play_m": 1e-3}
    errors = {"friction_coefficient": 0.002, "contact_stiffness_N_per_m": 1e3}
    moved = moved_parameters("lugre", baseline, final, errors, ["contact_play"])
    assert [m.name for m in moved] == ["contact_stiffness_N_per_m"]
    assert moved[0].standard_errors == pytest.approx(190.0)
    assert moved[0].as_dict()["effects"] == ["contact_play"]
    assert moved_parameters("lugre", baseline, final, errors, []) == []
    # a refit's wobble is no bias: 5 standard errors, but 0.17 % of the value
    wobble = moved_parameters("lugre", {"bristle_damping_N_s_per_m": 600.0},
                              {"bristle_damping_N_s_per_m": 601.0},
                              {"bristle_damping_N_s_per_m": 0.2}, ["time_map"])
    assert wobble == []
