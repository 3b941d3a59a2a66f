"""Residual diagnostics and the verdict on the final model (issue 34, deliverables 1 and 2).

Unit tests on synthetic residuals: white noise is adequate and follows nothing; a linear drift
leads with time and is not adequate; a tone at twice the vibration frequency leads with
harmonic 2. The tests' tolerances are the method's own: the verdict's threshold is checked
against the spread of white noise (Gaussian and heavy-tailed), the F-tests' false alarms
against their level on white and on strongly correlated noise, and each planted share against
its sampling sd. End to end (inverse path): a clean Dahl record is adequate, the same record
with its friction level rising linearly in time is not, with time leading.
"""
from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import lfilter

from vibrofriction.data.datasets import Dataset, DatasetMetadata
from vibrofriction.identify import identify
from vibrofriction.identify.report import report_json, report_markdown, write_report
from vibrofriction.identify.residual_diagnostics import (
    ALPHA, diagnose, for_identification, for_simulation, noise_floor, ratio_threshold,
    simulation_json, standard_regressors)
from vibrofriction.laws.run import run_law
from vibrofriction.params import FrictionParameters

F_HZ = 50.0
DT = 1e-3
TIME = np.arange(0.0, 4.0, DT)
# A support vibrating at F_HZ under a slider that goes back and forth once a second: the
# relative position does not grow with time (a steadily pulled slider's would, and could not
# be told from time).
VELOCITY = 0.02 * np.cos(2 * np.pi * F_HZ * TIME) + 0.01 * np.sin(2 * np.pi * TIME)
POSITION = np.cumsum(VELOCITY) * DT
PHASE = 2 * np.pi * F_HZ * TIME + 0.3
FORCE = 10.0 * np.tanh(VELOCITY / 0.002)
REGRESSORS = standard_regressors(TIME, relative_velocity=VELOCITY, relative_position=POSITION,
                                 support_phase_rad=PHASE, force=FORCE)


def _diagnose(residual: np.ndarray):
    return diagnose(residual, TIME, REGRESSORS, vibration_frequency_Hz=F_HZ)


def _share_tolerance(share: float, dof: int, n: int) -> tuple[float, float]:
    """(expected, 4 sd) of a planted share rho over n samples of unit noise: the fit also takes
    dof/n of the noise; sd from the signal-noise cross term and the noise's own spread."""
    sd = math.sqrt(4 * (1 - share) ** 3 * share / n + 2 * share ** 2 * (1 - share) ** 2 / n)
    return share + (1 - share) * dof / n, 4 * sd


@pytest.mark.parametrize("noise", ["gaussian", "laplace"])
def test_white_noise_is_adequate_and_follows_nothing(noise):
    rng = np.random.default_rng(11)
    residual = rng.standard_normal(TIME.size) if noise == "gaussian" else \
        rng.laplace(size=TIME.size) / math.sqrt(2)
    d = _diagnose(residual)
    assert d.model_adequate and d.ratio <= d.threshold
    assert d.leading_regressor is None
    assert not any(s.significant for s in d.regressors)
    names = {s.name for s in d.regressors}
    assert {"time", "relative_velocity", "relative_position", "support_phase",
            "time_since_reversal", "drive_force", "harmonic_1", "harmonic_2", "harmonic_3",
            "harmonic_4"} <= names
    assert d.noise_floor_from == "white noise"
    assert d.skipped_start_samples == math.ceil(0.01 * TIME.size)


def test_a_linear_drift_leads_with_time_and_is_not_adequate():
    rng = np.random.default_rng(12)
    drift = (TIME - TIME[0]) / (TIME[-1] - TIME[0])  # 0 to 1 noise sd: variance 1/12
    d = _diagnose(rng.standard_normal(TIME.size) + drift)
    assert not d.model_adequate
    lead = d.regressors[0]
    assert lead.name == "time" and lead.significant and d.leading_regressor == "time"
    planted = (1 / 12) / (1 / 12 + 1)
    expected, tolerance = _share_tolerance(planted, lead.dof, d.samples)
    assert lead.explained_share == pytest.approx(expected, abs=tolerance)


def test_a_tone_at_twice_the_vibration_leads_with_harmonic_2():
    """The support phase carries the tone too (with 15 degrees of freedom); the harmonic,
    with 2, ranks first."""
    rng = np.random.default_rng(13)
    amplitude = 0.5
    tone = amplitude * np.cos(2 * np.pi * 2 * F_HZ * TIME + 1.0)
    d = _diagnose(rng.standard_normal(TIME.size) + tone)
    lead = d.regressors[0]
    assert lead.name == "harmonic_2" and lead.significant
    assert lead.frequency_Hz == pytest.approx(2 * F_HZ)
    planted = (amplitude ** 2 / 2) / (amplitude ** 2 / 2 + 1)
    expected, tolerance = _share_tolerance(planted, lead.dof, d.samples)
    assert lead.explained_share == pytest.approx(expected, abs=tolerance)
    assert next(s for s in d.regressors if s.name == "support_phase").significant
    assert not any(s.significant for s in d.regressors if s.name in ("time", "harmonic_3"))


@pytest.mark.parametrize("noise", ["gaussian", "laplace"])
def test_the_threshold_is_the_spread_of_white_noise(noise):
    """ln(rms / floor) of white noise has sd 0.81 / sqrt(n) whatever its distribution: the
    spread of 400 draws within 4 sd of a sample sd (1 / sqrt(2 x 400) = 3.5 %), and the
    ratio stays below the threshold but for about ALPHA of them."""
    rng = np.random.default_rng(14)
    n, draws = 2000, 400
    logs = []
    for _ in range(draws):
        x = rng.standard_normal(n) if noise == "gaussian" else rng.laplace(size=n)
        logs.append(math.log(math.sqrt(np.mean(x ** 2)) / noise_floor(x)))
    predicted = math.log(ratio_threshold(n)) / 3.090232306167813  # z at ALPHA = 1e-3
    assert ALPHA == 1e-3
    assert np.std(logs) == pytest.approx(predicted, rel=4 / math.sqrt(2 * draws))
    assert abs(np.mean(logs)) < 4 * predicted / math.sqrt(draws) + 1.5 / n
    assert np.sum(np.exp(logs) > ratio_threshold(n)) <= 3  # expected 0.4


@pytest.mark.parametrize("phi", [0.0, 0.9])
def test_the_tests_keep_their_level_on_white_and_on_correlated_noise(phi):
    """A residual correlated over ~19 samples (AR(1), phi = 0.9) counts as its effective
    samples: the time regressor's test does not fire more often than its level (5 %, within
    3 binomial sd over 120 draws); counted as 4000 independent samples it would fire nearly
    always."""
    rng = np.random.default_rng(15)
    draws, level = 120, 0.05
    regressors = standard_regressors(TIME)
    fired = 0
    for _ in range(draws):
        e = rng.standard_normal(TIME.size)
        if phi:
            e = lfilter([1.0], [1.0, -phi], e)
        d = diagnose(e, TIME, regressors)
        fired += d.regressors[0].p_value < level
    assert fired <= draws * level + 3 * math.sqrt(draws * level * (1 - level))


def test_a_noise_free_residual_is_judged_at_the_records_resolution():
    d = diagnose(np.zeros(TIME.size), TIME, REGRESSORS, measured=FORCE)
    assert d.noise_floor_from == "resolution" and d.noise_floor == pytest.approx(1e-4 * 20.0,
                                                                                   rel=1e-3)
    assert d.model_adequate and d.regressors == []


def test_the_simulation_path_diagnoses_every_channel_primary_first():
    """On the simulation path's SimIdentification (here its few fields): one verdict per
    measured channel, the measured force's at the top level; the support phase from the
    replayed table motion (u ~ sin psi)."""
    rng = np.random.default_rng(16)
    table = 1e-6 * np.sin(2 * np.pi * F_HZ * TIME + 0.7)
    replay = SimpleNamespace(
        time_s=TIME, channels=("position_m", "friction_force_N"), vibrating=True,
        rig=SimpleNamespace(vibration_frequency_Hz=F_HZ), timestep_s=DT,
        control=np.column_stack([np.interp(TIME + DT, TIME, table), np.zeros(TIME.size)]),
        measured={"position_m": POSITION, "friction_force_N": FORCE})
    predicted = {"position_m": POSITION + 1e-6 * rng.standard_normal(TIME.size) +
                 1e-6 * np.sin(2 * np.pi * F_HZ * TIME + 0.7),  # locked to the table
                 "friction_force_N": FORCE + 0.1 * rng.standard_normal(TIME.size),
                 "relative_velocity_m_per_s": VELOCITY, "relative_position_m": POSITION}
    result = SimpleNamespace(train=replay, final=SimpleNamespace(predicted=predicted),
                             primary="friction_force_N")
    found = for_simulation(result)
    assert list(found) == ["friction_force_N", "position_m"]
    assert found["friction_force_N"].model_adequate and found["position_m"].unit == "m"
    position = found["position_m"]
    assert not position.model_adequate and position.leading_regressor == "harmonic_1"
    payload = json.loads(json.dumps(simulation_json(found)))
    assert payload["channel"] == "friction_force_N" and payload["model_adequate"] is True
    assert set(payload["channels"]) == {"friction_force_N", "position_m"}
    assert payload["channels"]["position_m"]["leading_regressor"] == "harmonic_1"


# ------------------------------------------------------------------------------ end to end

TRUTH = FrictionParameters(law="dahl", friction_coefficient=0.3, contact_stiffness_N_per_m=2e5)
NORMAL_N = 100.0


def _record(rise: float) -> Dataset:
    """Dahl along a back-and-forth motion from rest (4 cycles at 2 Hz, 1 kHz), made on a 10x
    finer grid, with white force noise of 1 % of the level; ``rise``: the friction level
    grows by that fraction over the record (an effect no candidate names: the motion repeats,
    so no map of position or speed carries it)."""
    over = 10
    fine = np.arange(0.0, 2.0, DT / over)
    omega = 2 * np.pi * 2.0
    v = 5e-3 * omega * np.sin(omega * fine)
    x = 5e-3 * (1 - np.cos(omega * fine))
    force = run_law(TRUTH, fine, v, normal_force_N=NORMAL_N).friction_force_N[::over]
    t, x, v = fine[::over], x[::over], v[::over]
    force = force * (1 + rise * (t - t[0]) / (t[-1] - t[0]))
    noise = 0.01 * TRUTH.friction_coefficient * NORMAL_N
    rng = np.random.default_rng(17)
    return Dataset(name="rising" if rise else "clean", columns={
        "time_s": t, "position_m": x, "velocity_m_per_s": v,
        "friction_force_N": force + noise * rng.standard_normal(t.size),
        "normal_force_N": np.full(t.size, NORMAL_N)},
        metadata=DatasetMetadata(description="Dahl along a prescribed motion"))


def test_identification_says_a_clean_record_is_adequate_and_a_drift_is_not(tmp_path):
    clean = identify(_record(0.0), law="dahl")
    d = for_identification(clean)
    assert d.model_adequate and d.leading_regressor is None, d
    payload = report_json(clean)["diagnostics"]
    assert payload["model_adequate"] is True and payload["channel"] == "friction_force_N"
    lines = report_markdown(clean).splitlines()
    verdict = lines.index(next(line for line in lines if line.startswith("**Model")))
    assert lines[verdict].startswith("**Model adequate:**")
    assert lines[verdict - 2].startswith("- support:")  # right after the header bullets

    # a drift of the level in time: traced to a time map, after which the model is adequate
    traced = identify(_record(0.05), law="dahl")
    assert traced.selected[:1] == ["time_map"]
    assert for_identification(traced).model_adequate
    # with no effect allowed to join (each must cut the error by 90 %; the time map cuts 40 %),
    # the law alone is called inadequate, its residual following time
    rising = identify(_record(0.05), law="dahl", min_improvement=0.9)
    assert rising.selected == []
    d = for_identification(rising)
    assert not d.model_adequate and d.leading_regressor == "time"
    assert d.regressors[0].name == "time" and d.regressors[0].p_value < 1e-6
    write_report(rising, tmp_path / "report")
    payload = json.loads((tmp_path / "report" / "report.json").read_text())["diagnostics"]
    assert payload["model_adequate"] is False and payload["leading_regressor"] == "time"
    assert payload["regressors"][0]["name"] == "time"
    assert payload["ratio"] > payload["threshold"]
    text = (tmp_path / "report" / "report.md").read_text()
    assert "**Model NOT adequate:**" in text and "follows time" in text
    assert (tmp_path / "report" / "diagnostics.png").stat().st_size > 1000
    write_report(rising, tmp_path / "bare", figures=False)
    assert not (tmp_path / "bare" / "diagnostics.png").exists()
