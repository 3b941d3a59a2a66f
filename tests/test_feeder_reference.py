"""The exact feeder reference against the anchors of the block-on-a-track model (docs/physics.md,
"Vibratory feeders"): frequency independence, the stick limit, no backward slip when
cot(beta) <= mu, classical throw theory as mu grows, a flight of a whole period."""
from __future__ import annotations

import math

import pytest

from vibrofriction.oracle.feeder_reference import (Feeder, convey,
                                                   flight_fraction_infinite_friction,
                                                   infinite_friction_velocity_ratio,
                                                   stick_throw_number)
from vibrofriction.params import ParameterError


def test_the_normalized_conveying_velocity_does_not_depend_on_the_frequency():
    """V / (A w cos beta) depends on (Gamma, beta, mu) only."""
    ratios = [convey(Feeder.from_throw_number(1.5, math.radians(20), f, 0.3)).normalized(
        Feeder.from_throw_number(1.5, math.radians(20), f, 0.3)) for f in (50.0, 100.0, 300.0)]
    assert ratios[0] > 0.1
    assert max(ratios) - min(ratios) < 1e-6 * ratios[0]


def test_the_block_sticks_throughout_up_to_the_stick_throw_number():
    beta, mu = math.radians(20), 0.5
    limit = stick_throw_number(beta, mu)
    below = Feeder.from_throw_number(0.99 * limit, beta, 100.0, mu)
    motion = convey(below)
    assert motion.stick_fraction == pytest.approx(1.0, abs=1e-12)
    assert motion.mean_velocity_m_per_s == 0
    above = convey(Feeder.from_throw_number(1.05 * limit, beta, 100.0, mu))
    assert above.stick_fraction < 0.95 and above.mean_velocity_m_per_s > 0


@pytest.mark.parametrize("mu, backward", [(1.5, False), (0.5, True)])
def test_there_is_no_backward_slip_when_cot_beta_is_at_most_mu(mu, backward):
    beta = math.radians(40)  # cot = 1.19
    motion = convey(Feeder.from_throw_number(1.5, beta, 100.0, mu))
    assert (motion.backward_fraction > 0.01) == backward
    if not backward:
        assert motion.backward_fraction == 0


@pytest.mark.parametrize("throw_number", [1.2, 1.6, 2.5, 3.2])
def test_as_mu_grows_the_motion_tends_to_classical_throw_theory(throw_number):
    """mu -> infinity: the flight fraction n_F of classical throw theory and V / (A w cos b) =
    pi n_F^2 / Gamma. The velocity converges at first order in 1/mu (measured at Gamma 1.6:
    +0.56 % at mu 100, +0.057 % at 1e3, +0.0057 % at 1e4; each tenfold mu divides the error by
    9.97)."""
    beta = math.radians(20)
    theory = infinite_friction_velocity_ratio(throw_number)
    errors = []
    for mu in (1e3, 1e4):
        feeder = Feeder.from_throw_number(throw_number, beta, 100.0, mu)
        motion = convey(feeder)
        assert motion.converged
        assert motion.flight_fraction == pytest.approx(
            flight_fraction_infinite_friction(throw_number), abs=1e-6)
        errors.append(motion.normalized(feeder) / theory - 1)
    assert 0 < errors[1] < 1e-3
    assert 9 < errors[0] / errors[1] < 11  # tenfold mu, a tenth of the error


@pytest.mark.parametrize("throw_number, mu", [(3.3, 0.3), (3.4, 5.0)])
def test_above_the_whole_period_flight_the_block_flies_on_at_pi_over_gamma(throw_number, mu):
    """For sqrt(1 + pi^2) < Gamma < 3.5 the repeating motion is one continuous flight a period,
    landing with no slip: V / (A w cos b) = pi / Gamma for any throw angle and mu > 0 (each
    landing is a re-lift: the load is still negative)."""
    feeder = Feeder.from_throw_number(throw_number, math.radians(30), 100.0, mu)
    motion = convey(feeder)
    assert motion.converged
    assert motion.normalized(feeder) == pytest.approx(math.pi / throw_number, rel=1e-9)


def test_the_result_does_not_depend_on_the_bracketing_grid():
    feeder = Feeder.from_throw_number(1.5, math.radians(20), 100.0, 0.3)
    coarse = convey(feeder, samples_per_period=400).mean_velocity_m_per_s
    fine = convey(feeder, samples_per_period=1200).mean_velocity_m_per_s
    assert fine == pytest.approx(coarse, rel=1e-9)


def test_a_slowly_settling_feeder_runs_until_its_windows_agree():
    """Small mu settles over hundreds of periods: the windows go on until two agree."""
    feeder = Feeder.from_throw_number(1.5, math.radians(20), 100.0, 0.05)
    motion = convey(feeder)
    assert motion.converged and motion.periods > 100
    capped = convey(feeder, max_periods=88)
    assert not capped.converged


def test_one_flight_lasts_a_whole_period_at_the_classical_limit():
    assert flight_fraction_infinite_friction(math.sqrt(1 + math.pi**2)) == 1.0
    assert 0 < flight_fraction_infinite_friction(1.000001) < 1e-3  # near the lift-off limit
    with pytest.raises(ParameterError, match="throw number"):
        flight_fraction_infinite_friction(1.0)
    assert infinite_friction_velocity_ratio(1.2) == pytest.approx(
        math.pi * flight_fraction_infinite_friction(1.2) ** 2 / 1.2, rel=1e-12)


@pytest.mark.parametrize("change, message", [
    ({"throw_angle_rad": 0.0}, "throw_angle_rad"),
    ({"friction_coefficient": -1.0}, "friction_coefficient"),
    ({"friction_coefficient": 0.0}, "must be > 0"),
    ({"frequency_Hz": float("nan")}, "frequency_Hz"),
])
def test_bad_feeder_parameters_are_refused_by_name(change, message):
    values = dict(amplitude_m=1e-4, frequency_Hz=100.0, throw_angle_rad=0.3,
                  friction_coefficient=0.5) | change
    with pytest.raises(ParameterError, match=message):
        Feeder(**values)
