"""Runs to steady state (vibrofriction.rigs.steady): converged by default, flagged when not, the same
alone or in any batch.

Measured (Dahl, the paper's rig with a soft drive spring k_d = 2e5 N/m, mu 0.15, v_a 0.75 mm/s):
the default run stops at 0.45 s with F_dv/F_ds = 0.77160; a 2.5 s run gives 0.77230 (its
windows change by 1e-8), so the default is 0.09 % off, within its own estimate of 0.092 %.
"""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from vibrofriction.rigs import rig as rig_module
from vibrofriction.cli import main
from vibrofriction.params import RigParameters, default_friction
from vibrofriction.rigs.steady import (DEFAULT_TOLERANCE, hann_mean, judge, run_until_steady,
                                       window_length_s)
from vibrofriction.rigs.sweep import sweep

SOFT = RigParameters(drive_stiffness_N_per_m=2e5, vibration_velocity_amplitude_m_per_s=0.75e-3)
SOFT_FRICTION = replace(default_friction("dahl", SOFT), friction_coefficient=0.15)


def test_the_judge_estimates_the_distance_to_a_geometric_limit():
    limit, r = 10.0, 0.9
    means = [limit + 0.05 * r ** k for k in range(3)]
    converged, change, remaining = judge(means, 1e-3)
    assert remaining == pytest.approx((means[-1] - limit) / means[-1], rel=1e-9)
    assert not converged  # the change is small (4.5e-4) but the limit is 4e-3 away
    assert change < 1e-3 < remaining
    # alternating differences bracket the limit; growing ones have no estimate
    assert judge([10.0, 10.002, 10.001], 1e-3)[2] == pytest.approx(1e-4, rel=1e-3)
    assert judge([10.0, 10.001, 10.003], 1e-3)[2] == math.inf
    assert judge([10.0, 10.0], 1e-3) == (False, math.inf, math.inf)  # three windows needed


def test_a_hann_mean_of_whole_periods_is_the_plain_mean():
    t = np.linspace(0.0, 1.0, 20001)
    y = 3.0 + np.sin(2 * np.pi * 40 * t) + 0.5 * np.cos(2 * np.pi * 120 * t)
    assert hann_mean(t, y, 0.1, 0.6) == pytest.approx(3.0, abs=1e-9)
    # a ring that fits the window 9.3 times leaks k^2 - 1 = 85 times less than into a plain
    # mean (both have the same phase factor: the windows are symmetric)
    ring = np.sin(2 * np.pi * 18.6 * t + 0.3)
    inside = (t >= 0.1) & (t <= 0.6)
    plain = abs(np.trapezoid(ring[inside], t[inside]) / 0.5)
    assert abs(hann_mean(t, ring, 0.1, 0.6)) < plain / 40


def test_windows_are_whole_multiples_of_twelve_periods():
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=1e-3, vibration_frequency_Hz=2600)
    periods = window_length_s(rig) * 2600
    assert periods == pytest.approx(round(periods)) and round(periods) % 48 == 0
    assert window_length_s(replace(rig, vibration_velocity_amplitude_m_per_s=0.0)) == 0.04


def test_continuing_a_run_chunk_by_chunk_is_the_same_run():
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=0.75e-3)
    friction = default_friction("dahl", rig)
    dt = rig_module.recommended_timestep(rig)
    # a tolerance no run meets: chunk after chunk up to the maximum time
    chunked = run_until_steady([(rig, friction)], tolerance=1e-12, max_duration_s=0.2,
                               keep_series=True)[0]
    assert not chunked.convergence.converged
    whole = rig_module.simulate(rig, friction, duration_s=0.21, timestep_s=dt)
    n = len(chunked.run.time_s)
    np.testing.assert_array_equal(chunked.run.drive_force_N, whole.drive_force_N[:n])


def test_the_soft_spring_converges_within_0_3_percent():
    still = replace(SOFT, vibration_velocity_amplitude_m_per_s=0.0)
    vib, static = run_until_steady([(SOFT, SOFT_FRICTION), (still, SOFT_FRICTION)])
    assert vib.convergence.converged and static.convergence.converged
    ratio = vib.mean_drive_force_N / static.mean_drive_force_N
    # the converged value: 2.5 s, where successive windows agree to 1e-7
    long_vib, long_static = run_until_steady([(SOFT, SOFT_FRICTION), (still, SOFT_FRICTION)],
                                             tolerance=1e-12, max_duration_s=2.5)
    assert long_vib.convergence.relative_change < 1e-6
    assert long_static.convergence.relative_change < 1e-6
    converged = long_vib.mean_drive_force_N / long_static.mean_drive_force_N
    assert ratio == pytest.approx(converged, rel=3e-3)
    # the old default (two loadings + 30 ms + 40 ms) ended inside the transient
    assert vib.convergence.simulated_s > sum(rig_module.default_times(SOFT, SOFT_FRICTION)) / 2


def test_the_static_mean_is_mu_fn_although_the_slider_rings_on_the_spring():
    """Dahl sliding steadily is saturated: the slider rings on the drive spring undamped, at
    225 Hz, and a plain 10 ms mean was 0.1 % off mu F_N; the Hann mean is exact to 1e-5."""
    still = RigParameters(vibration_velocity_amplitude_m_per_s=0.0)
    friction = default_friction("dahl", still)
    result = run_until_steady([(still, friction)])[0]
    assert result.convergence.converged
    expected = friction.friction_coefficient * still.normal_force_N
    assert result.mean_drive_force_N == pytest.approx(expected, rel=1e-5)


def test_a_point_is_the_same_alone_or_in_any_sweep():
    rig = RigParameters()
    friction = default_friction("lugre", rig)
    together = sweep(rig, friction, [0.25e-3, 0.75e-3, 20e-3], progress=False)
    alone = sweep(rig, friction, [0.75e-3], progress=False)
    a = together["points"][1]["mean_drive_force_N"]
    b = alone["points"][0]["mean_drive_force_N"]
    assert a == pytest.approx(b, rel=1e-6)
    assert together["static_drive_force_N"] == pytest.approx(alone["static_drive_force_N"],
                                                             rel=1e-6)
    assert together["all_converged"] and alone["all_converged"]
    for p in together["points"]:
        assert p["converged"] and p["estimated_remaining_error"] <= DEFAULT_TOLERANCE


def test_an_unconverged_point_is_flagged_in_the_json_and_on_stderr(tmp_path, capsys):
    out = tmp_path / "sweep.json"
    assert main(["sweep", "--va", "0.75e-3", "--tolerance", "1e-12", "--max-duration", "0.25",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    assert not result["all_converged"]
    assert [p["converged"] for p in result["points"]] == [False]
    assert 0.2 < result["points"][0]["window_end_s"] <= 0.25 + 1e-9
    err = capsys.readouterr().err
    assert "v_a = 0.00075 m/s did not converge to 1e-12 within" in err
    assert "--max-duration" in err


def test_a_fixed_duration_too_short_to_judge_is_flagged(capsys):
    assert main(["simulate", "--duration", "0.05"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["converged"] is False and summary["duration_s"] == 0.05


def test_the_python_api_warns_when_a_summary_is_not_converged():
    """``run.summary()`` of a run to steady state that did not settle says so where it is
    read (issue 36: an example printed 0.676 for 0.77 without a word)."""
    import warnings
    run = rig_module.simulate(RigParameters(vibration_velocity_amplitude_m_per_s=3e-3),
                              default_friction("dahl"))
    assert run.convergence.converged
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run.summary()  # converged: silent
    unsettled = replace(run, convergence=replace(run.convergence, converged=False))
    with pytest.warns(rig_module.UnconvergedWarning, match="did not settle"):
        unsettled.summary()
