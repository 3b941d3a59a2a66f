"""The scipy oracle (vibrofriction.oracle.reference): conservation checks, analytic limits, effects.

Paper rig: m 0.5 kg, k_d 1e6 N/m, v_d 0.5 mm/s, f 4 kHz, F_N 55.2 N, mu 0.2 (mu F_N = 11.04 N).
The heavy-body rig (500 kg, stiff critically damped drive) settles in ~20 ms and moves almost
uniformly, so it must reproduce the kinematic formulas of vibrofriction.oracle.analytic.
"""
import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lsim

import vibrofriction.oracle.reference as reference_module
from vibrofriction.oracle import analytic
from vibrofriction.params import (PAPER_NORMAL_FORCE_N, FrictionParameters, ParameterError,
                                  RigParameters, default_friction)
from vibrofriction.oracle.reference import simulate_reference

BOUND_N = 0.2 * PAPER_NORMAL_FORCE_N  # mu F_N
LAWS = ["coulomb", "dahl", "dupont", "lugre"]
SMOOTH_LAWS = ["dahl", "dupont", "lugre"]


def _paper_rig(va: float = 0.0, **changes) -> RigParameters:
    return RigParameters(vibration_velocity_amplitude_m_per_s=va, **changes)


def _heavy_rig(va: float, vd: float = 0.5e-3) -> RigParameters:
    mass_kg, drive_stiffness = 500.0, 1e8
    return RigParameters(mass_kg=mass_kg, drive_stiffness_N_per_m=drive_stiffness,
                         drive_damping_N_s_per_m=2 * math.sqrt(drive_stiffness * mass_kg),
                         drive_velocity_m_per_s=vd, vibration_velocity_amplitude_m_per_s=va)


def _drive_ratio(rig, friction, duration_s, settle_s, sample_dt_s=1e-5) -> float:
    result = simulate_reference(rig, friction, duration_s, sample_dt_s=sample_dt_s,
                                t_start_s=settle_s)
    return result.summary(settle_s).mean_drive_force_N / BOUND_N


# ---------------------------------------------------------------------------------- inputs


@pytest.mark.parametrize("duration", [0.0, -1e-3, math.nan, math.inf, "0.1", None])
def test_bad_duration_raises_parameter_error(duration):
    with pytest.raises(ParameterError, match="duration_s"):
        simulate_reference(_paper_rig(), default_friction("dahl"), duration)


def test_bad_sampling_and_parameters_raise_parameter_error():
    rig, dahl = _paper_rig(), default_friction("dahl")
    with pytest.raises(ParameterError, match="sample_dt_s"):
        simulate_reference(rig, dahl, 1e-3, sample_dt_s=2e-3)
    with pytest.raises(ParameterError, match="t_start_s"):
        simulate_reference(rig, dahl, 1e-3, t_start_s=1e-3)
    with pytest.raises(ParameterError, match="mass_kg"):
        simulate_reference(replace(rig, mass_kg=0.0), dahl, 1e-3)
    with pytest.raises(ParameterError, match="law"):
        simulate_reference(rig, replace(dahl, law="stribeck"), 1e-3)


def test_oracle_imports_no_law_code():
    """Independence: only the parameter, summary and error modules of the package."""
    tree = ast.parse(Path(reference_module.__file__).read_text())
    local = {node.module for node in ast.walk(tree)
             if isinstance(node, ast.ImportFrom) and node.level > 0}
    assert local <= {"params", "summary", "errors"}


def test_outputs_are_consistent_and_t_start_only_crops():
    rig, dahl = _paper_rig(3e-3), default_friction("dahl")
    full = simulate_reference(rig, dahl, 2e-3)
    cropped = simulate_reference(rig, dahl, 2e-3, t_start_s=1e-3)
    assert full.time_s[0] == 0.0 and full.time_s[-1] == 2e-3 and full.time_s.size == 2001
    keep = full.time_s >= 1e-3 - 1e-15
    np.testing.assert_array_equal(cropped.friction_force_N, full.friction_force_N[keep])
    t = full.time_s
    np.testing.assert_allclose(full.support_velocity_m_per_s, 3e-3 * np.cos(2 * np.pi * 4000 * t))
    np.testing.assert_allclose(full.relative_velocity_m_per_s,
                               full.slider_velocity_m_per_s - full.support_velocity_m_per_s)
    np.testing.assert_allclose(full.drive_force_N, 1e6 * (0.5e-3 * t - full.slider_position_m))
    np.testing.assert_allclose(full.friction_force_N, 80e6 * full.deflection_m)  # Dahl
    assert full.period_s == 1 / 4000
    assert simulate_reference(_paper_rig(), dahl, 1e-3).period_s == 0.0  # no vibration


# ------------------------------------------------------------------- steady sliding, no vibration


@pytest.mark.parametrize("law", LAWS)
def test_steady_sliding_mean_drive_force_is_coulomb_level(law):
    ratio = _drive_ratio(_paper_rig(), default_friction(law), 0.06, 0.04)
    assert ratio == pytest.approx(1.0, rel=5e-3)


@pytest.mark.parametrize("law", SMOOTH_LAWS)
def test_a_level_factor_scales_the_sliding_level(law):
    """The out-of-vocabulary hook: a constant factor on the level scales steady sliding by it;
    a factor rising in time (heating) makes the level rise with it."""
    result = simulate_reference(_paper_rig(), default_friction(law), 0.06, sample_dt_s=1e-5,
                                t_start_s=0.04, level_factor=lambda t, x, v: 1.1)
    assert result.summary(0.04).mean_drive_force_N / BOUND_N == pytest.approx(1.1, rel=5e-3)
    heating = simulate_reference(_paper_rig(), default_friction(law), 0.1, sample_dt_s=1e-5,
                                 level_factor=lambda t, x, v: 1.0 + 2.0 * t)
    force = heating.drive_force_N
    early, late = force[(heating.time_s > 0.04) & (heating.time_s < 0.05)].mean(), \
        force[heating.time_s > 0.09].mean()
    assert late / early == pytest.approx((1 + 2 * 0.095) / (1 + 2 * 0.045), rel=1e-2)


def test_a_level_factor_is_refused_for_the_hybrid_laws():
    with pytest.raises(ParameterError, match="level_factor"):
        simulate_reference(_paper_rig(), default_friction("coulomb"), 0.01,
                           level_factor=lambda t, x, v: 1.0)


@pytest.mark.parametrize("alpha", [0.0, 0.5, 1.0, 2.0])
def test_dahl_virgin_loading_under_slow_drive(alpha):
    """Quasi-static presliding: F_F(x) follows the closed-form virgin curve up to 0.9 F_c."""
    friction = FrictionParameters(law="dahl", alpha=alpha)
    result = simulate_reference(_paper_rig(), friction, 0.02, sample_dt_s=1e-5)
    loading = result.friction_force_N < 0.9 * BOUND_N
    expected = analytic.dahl_virgin_loading(result.slider_position_m[loading],
                                            friction.contact_stiffness_N_per_m, BOUND_N, alpha)
    np.testing.assert_allclose(result.friction_force_N[loading], expected, atol=5e-3 * BOUND_N)


# ---------------------------------------------------------------------- vibrating paper rig


@pytest.mark.parametrize("law", SMOOTH_LAWS)
def test_mean_drive_force_equals_mean_friction_in_steady_periodic_motion(law):
    rig = _paper_rig(3e-3)
    result = simulate_reference(rig, default_friction(law, rig), 0.08, sample_dt_s=1e-5,
                                t_start_s=0.05)
    summary = result.summary(0.05)
    assert summary.periods_averaged == 120
    assert summary.mean_drive_force_N == pytest.approx(summary.mean_friction_force_N, rel=5e-3)
    assert summary.mean_drive_force_N < 0.3 * BOUND_N  # strong reduction at v_a = 6 v_d


@pytest.mark.parametrize("law", LAWS)
def test_no_reduction_when_vibration_is_slower_than_drive(law):
    rig = _paper_rig(0.25e-3)
    ratio = _drive_ratio(rig, default_friction(law, rig), 0.08, 0.05, sample_dt_s=1e-6)
    assert ratio == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("va, sign_change", [(0.75e-3, False), (3e-3, True)])
def test_dahl_friction_changes_sign_only_at_large_amplitude(va, sign_change):
    """Paper, figs. 8-9: reduction without sign change at 0.75 mm/s, with it at 3 mm/s."""
    result = simulate_reference(_paper_rig(va), default_friction("dahl"), 0.06,
                                t_start_s=0.04)
    summary = result.summary(0.04)
    assert summary.sign_change is sign_change
    assert summary.mean_drive_force_N < 0.85 * BOUND_N


def test_coulomb_sticks_to_the_table_until_the_static_level():
    """True stick: the slider rides with the table (v_r = 0) until F_d - m u'' reaches F_s."""
    rig = _paper_rig(0.25e-3)
    friction = FrictionParameters(law="coulomb", static_ratio=1.3)
    result = simulate_reference(rig, friction, 0.03)
    stuck = result.sticking
    first_stick = np.argmax(stuck)
    breakaway = first_stick + np.argmin(stuck[first_stick:])
    assert 0 < first_stick < 50 and result.time_s[breakaway] > 0.01
    phase = slice(first_stick, breakaway)
    assert np.all(result.relative_velocity_m_per_s[phase] == 0.0)
    support_m = rig.vibration_amplitude_m * np.sin(2 * np.pi * 4000 * result.time_s[phase])
    rel_m = result.slider_position_m[phase] - support_m
    assert np.ptp(rel_m) < 1e-12
    static_N = 1.3 * BOUND_N
    assert np.all(np.abs(result.friction_force_N[phase]) <= static_N * (1 + 1e-9))
    assert result.friction_force_N[breakaway - 1] == pytest.approx(static_N, rel=1e-3)


# ------------------------------------------------------------ heavy body: kinematic formulas


def test_heavy_body_coulomb_follows_arcsin_law():
    rig = _heavy_rig(2e-3)  # xi = 0.25
    ratio = _drive_ratio(rig, default_friction("coulomb"), 0.04, 0.02)
    assert ratio == pytest.approx(analytic.coulomb_kinematic_ratio(0.25), rel=0.02)


def test_heavy_body_dahl_small_amplitude_follows_drift_formula():
    rig = _heavy_rig(2e-3)
    friction = FrictionParameters(law="dahl", contact_stiffness_N_per_m=8e6)
    assert analytic.epsilon(rig, friction) < 0.06 and analytic.r_squared(rig, friction) > 20
    ratio = _drive_ratio(rig, friction, 0.04, 0.02)
    assert ratio == pytest.approx(analytic.dahl_vanishing_amplitude_ratio(0.25), rel=0.02)


def test_heavy_body_jenkins_static_friction_falls_linearly_with_amplitude():
    rig = _heavy_rig(2e-3, vd=0.01e-3)  # xi = 0.005
    friction = FrictionParameters(law="dahl", alpha=0.0)
    expected = analytic.jenkins_kinematic_ratio(analytic.epsilon(rig, friction))  # eps 0.58
    assert _drive_ratio(rig, friction, 0.04, 0.02) == pytest.approx(expected, rel=0.03)


def test_heavy_body_dupont_small_amplitude_ratchets_down_to_breakaway():
    rig = _heavy_rig(2e-3, vd=0.01e-3)
    friction = FrictionParameters(law="dupont", contact_stiffness_N_per_m=8e6)
    expected = analytic.dupont_vanishing_amplitude_ratio(friction.breakaway_ratio)
    assert _drive_ratio(rig, friction, 0.2, 0.15) == pytest.approx(expected, rel=0.02)


# ------------------------------------------------------------------------------- effects


@pytest.mark.parametrize("law", LAWS)
def test_asymmetry_and_viscous_set_the_steady_sliding_level(law):
    asymmetric = replace(default_friction(law), asymmetry=0.2)
    assert _drive_ratio(_paper_rig(), asymmetric, 0.06, 0.04) == pytest.approx(1.2, rel=5e-3)
    viscous = replace(default_friction(law), viscous_N_s_per_m=2000.0)
    expected = 1 + 2000.0 * 0.5e-3 / BOUND_N
    assert _drive_ratio(_paper_rig(), viscous, 0.06, 0.04) == pytest.approx(expected, rel=5e-3)


def test_asymmetry_raises_the_vibrated_mean():
    rig, dahl = _paper_rig(3e-3), default_friction("dahl")
    plain = _drive_ratio(rig, dahl, 0.06, 0.04)
    assert _drive_ratio(rig, replace(dahl, asymmetry=0.2), 0.06, 0.04) > plain + 0.03
    assert _drive_ratio(rig, replace(dahl, asymmetry=-0.2), 0.06, 0.04) < plain - 0.03


@pytest.mark.parametrize("law", SMOOTH_LAWS)
def test_force_offset_shifts_the_mean_friction_by_the_offset(law):
    """A constant force only shifts the drive-spring stretch: the rest is unchanged."""
    rig = _paper_rig(3e-3)
    friction = default_friction(law, rig)
    means = [simulate_reference(rig, replace(friction, force_offset_N=offset), 0.06,
                                sample_dt_s=1e-5, t_start_s=0.04).summary(0.04)
             for offset in (0.0, 1.0)]
    assert means[1].mean_friction_force_N - means[0].mean_friction_force_N == \
        pytest.approx(1.0, abs=2e-3)
    assert means[1].mean_drive_force_N - means[0].mean_drive_force_N == \
        pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("law", LAWS)
def test_position_ripple_is_periodic_in_relative_position(law):
    ripple = dict(position_ripple=0.05, position_ripple_wavelength_m=20e-6,
                  position_ripple_phase_rad=0.5)
    result = simulate_reference(_paper_rig(), FrictionParameters(law=law, **ripple), 0.15,
                                sample_dt_s=1e-5, t_start_s=0.06)
    expected = BOUND_N * (1 + 0.05 * np.sin(2 * np.pi * result.slider_position_m / 20e-6 + 0.5))
    np.testing.assert_allclose(result.friction_force_N, expected, atol=0.005 * BOUND_N)


@pytest.mark.parametrize("law", LAWS)
def test_normal_force_modulation_follows_the_load(law):
    modulation = dict(normal_force_modulation=0.1, normal_force_modulation_frequency_Hz=10.0,
                      normal_force_modulation_phase_rad=0.5)
    result = simulate_reference(_paper_rig(), FrictionParameters(law=law, **modulation), 0.3,
                                sample_dt_s=1e-5, t_start_s=0.1)
    expected = BOUND_N * (1 + 0.1 * np.sin(2 * np.pi * 10.0 * result.time_s + 0.5))
    np.testing.assert_allclose(result.friction_force_N, expected, atol=0.005 * BOUND_N)


def test_normal_force_modulation_frequency_zero_means_vibration_frequency():
    rig, dahl = _paper_rig(3e-3), default_friction("dahl")
    default = simulate_reference(rig, replace(dahl, normal_force_modulation=0.3), 2e-3)
    explicit = simulate_reference(rig, replace(dahl, normal_force_modulation=0.3,
                                               normal_force_modulation_frequency_Hz=4000.0), 2e-3)
    np.testing.assert_array_equal(default.friction_force_N, explicit.friction_force_N)
    plain = simulate_reference(rig, dahl, 2e-3)
    assert np.abs(default.friction_force_N - plain.friction_force_N).max() > 0.1


def test_sensor_lag_filters_only_the_reported_force():
    rig, dahl = _paper_rig(3e-3), default_friction("dahl")
    tau_s = 2e-5
    plain = simulate_reference(rig, dahl, 2e-3)
    lagged = simulate_reference(rig, replace(dahl, sensor_lag_s=tau_s), 2e-3)
    np.testing.assert_array_equal(lagged.drive_force_N, plain.drive_force_N)  # dynamics as is
    t, signal = plain.time_s, plain.friction_force_N
    # scipy's lsim integrates the lag exactly for an input linear between samples (its own
    # matrix exponential of the ramp): the two differ by rounding only, ~1e-13 of the force
    # per sample over 2000 samples. (An adaptive solver across the input's kinks at every
    # sample differed by 1e-6 of the bound, in a way that changed with the machine.)
    lag = ([[-1.0 / tau_s]], [[1.0 / tau_s]], [[1.0]], [[0.0]])
    _, expected, _ = lsim(lag, signal, t, X0=[signal[0]], interp=True)
    np.testing.assert_allclose(lagged.friction_force_N, expected, rtol=0, atol=1e-9 * BOUND_N)
    assert np.ptp(lagged.friction_force_N[1000:]) < np.ptp(signal[1000:])
