"""Analytic anchors (vibrofriction.oracle.analytic): literature values and independent quadratures."""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from vibrofriction.oracle import analytic
from vibrofriction.params import RigParameters, default_friction

# LuGre standard set (Canudas de Wit et al. 1995), docs/physics.md.
LUGRE = dict(sigma0=1e5, sigma2=0.4, Fc=1.0, Fs=1.5, vs=1e-3)


def _period_mean(fn) -> float:
    """Mean of fn(theta) over one period, split at the kinks so quad stays accurate."""
    return quad(fn, 0, 2 * math.pi, limit=200)[0] / (2 * math.pi)


@pytest.mark.parametrize("v, force_N", [(1e-4, 1.4951), (1e-3, 1.1843), (2e-3, 1.0100)])
def test_lugre_steady_state_standard_set(v, force_N):
    assert analytic.lugre_steady_state_force(v, **LUGRE) == pytest.approx(force_N, abs=5e-5)
    assert analytic.lugre_steady_state_force(-v, **LUGRE) == pytest.approx(-force_N, abs=5e-5)


def test_lugre_presliding_distance_standard_set():
    distance_m = analytic.lugre_presliding_distance(0.95, LUGRE["sigma0"], LUGRE["Fs"])
    assert distance_m == pytest.approx(44.9e-6, abs=0.05e-6)
    with pytest.raises(ValueError):
        analytic.lugre_presliding_distance(1.0, 1e5, 1.5)


def test_arcsin_law_twenty_fold_reduction():
    assert analytic.coulomb_kinematic_ratio(1 / 12.7) == pytest.approx(0.05, abs=1e-3)
    assert analytic.coulomb_kinematic_ratio(0.0) == 0.0
    np.testing.assert_array_equal(analytic.coulomb_kinematic_ratio([1.0, 2.0]), [1.0, 1.0])


@pytest.mark.parametrize("xi", [0.1, 0.5, 0.9])
def test_arcsin_law_is_mean_of_coulomb_sign(xi):
    # v_r = v_d - v_a cos(theta) for a body moving exactly at v_d.
    mean = _period_mean(lambda th: math.copysign(1.0, xi - math.cos(th)))
    assert analytic.coulomb_kinematic_ratio(xi) == pytest.approx(mean, abs=1e-6)


@pytest.mark.parametrize("xi", [0.05, 0.5, 2.0])
def test_transverse_law_is_mean_of_in_plane_coulomb(xi):
    mean = _period_mean(lambda th: xi / math.hypot(xi, math.cos(th)))
    assert analytic.transverse_kinematic_ratio(xi) == pytest.approx(mean, rel=1e-6)


def test_transverse_law_limits():
    assert analytic.transverse_kinematic_ratio(1e3) > 0.999
    assert analytic.transverse_kinematic_ratio(np.inf) == 1.0
    assert analytic.transverse_kinematic_ratio(1e-6) < 1e-4
    assert analytic.transverse_kinematic_ratio(0.0) == 0.0
    xs = np.logspace(-4, 3, 50)
    f = analytic.transverse_kinematic_ratio(xs)
    assert np.all(np.diff(f) > 0) and np.all(f <= 1)
    # Unlike longitudinal vibration, transverse vibration reduces friction even at v_a < v_d.
    assert analytic.transverse_kinematic_ratio(2.0) < 0.95


def test_dahl_vanishing_amplitude_sanity():
    xs = np.linspace(0, 0.999, 200)
    f = analytic.dahl_vanishing_amplitude_ratio(xs)
    assert f[0] == 0.0 and np.all(np.diff(f) > 0)
    assert analytic.dahl_vanishing_amplitude_ratio(0.99999) == pytest.approx(1.0, abs=1e-3)
    assert analytic.dahl_vanishing_amplitude_ratio(1.0) == 1.0
    assert analytic.dahl_vanishing_amplitude_ratio(3.0) == 1.0
    # Dahl drift reduces friction less than the rigid arcsin law, and a larger alpha more.
    assert np.all(f >= analytic.coulomb_kinematic_ratio(xs) - 1e-12)
    assert np.all(analytic.dahl_vanishing_amplitude_ratio(xs[1:], alpha=2.0) < f[1:])
    # alpha = 0 is the Jenkins element: no reduction at vanishing amplitude.
    np.testing.assert_array_equal(analytic.dahl_vanishing_amplitude_ratio([0.0, 0.3], 0.0),
                                  [0.0, 1.0])
    with pytest.raises(ValueError):
        analytic.dahl_vanishing_amplitude_ratio(0.5, alpha=-1.0)


@pytest.mark.parametrize("xi", [0.2, 0.6])
def test_dahl_vanishing_amplitude_alpha1_is_path_ratio(xi):
    # alpha = 1: no drift of z over a period means f = (integral v_r) / (integral |v_r|).
    signed = _period_mean(lambda th: xi - math.cos(th))
    absolute = _period_mean(lambda th: abs(xi - math.cos(th)))
    assert analytic.dahl_vanishing_amplitude_ratio(xi) == pytest.approx(signed / absolute,
                                                                        rel=1e-6)


def test_jenkins_and_dupont_limits():
    np.testing.assert_allclose(analytic.jenkins_kinematic_ratio([0.0, 0.25, 1.0, 3.0]),
                               [1.0, 0.75, 0.0, 0.0])
    assert analytic.dupont_vanishing_amplitude_ratio(0.7) == 0.7


@pytest.mark.parametrize("alpha", [0.0, 0.5, 1.0, 2.0])
def test_dahl_virgin_loading_solves_dahl_ode(alpha):
    sigma, fc = 8e7, 11.04
    x_end = 4 * fc / sigma

    def dahl(_x, f):  # dF/dx = sigma (1 - F/F_c)^alpha, zero once F = F_c
        base = 1 - f[0] / fc
        return [sigma * base ** alpha if base > 0 else 0.0]

    xs = np.linspace(0, x_end, 41)
    numeric = solve_ivp(dahl, (0, x_end), [0.0], t_eval=xs, rtol=1e-10, atol=1e-12,
                        max_step=x_end / 400).y[0]
    closed = analytic.dahl_virgin_loading(xs, sigma, fc, alpha)
    np.testing.assert_allclose(closed, numeric, atol=1e-4 * fc)
    assert np.all(closed <= fc) and np.all(np.diff(closed) >= 0)
    assert analytic.dahl_virgin_loading(-xs[5], sigma, fc, alpha) == pytest.approx(-closed[5])
    # initial slope is the contact stiffness
    assert analytic.dahl_virgin_loading(1e-6 * fc / sigma, sigma, fc, alpha) == \
        pytest.approx(1e-6 * fc, rel=1e-5)


def test_dahl_virgin_loading_alpha_below_one_saturates_in_finite_distance():
    sigma, fc = 8e7, 11.04
    for alpha in (0.0, 0.5):
        x_sat = fc / sigma / (1 - alpha)
        assert analytic.dahl_virgin_loading(x_sat, sigma, fc, alpha) == pytest.approx(fc)
        assert analytic.dahl_virgin_loading(2 * x_sat, sigma, fc, alpha) == fc
        assert analytic.dahl_virgin_loading(0.9 * x_sat, sigma, fc, alpha) < fc


def test_dimensionless_groups_at_paper_values():
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    friction = default_friction("dahl")
    assert analytic.xi(rig) == pytest.approx(1 / 6)
    u0 = 3e-3 / (2 * math.pi * 4000)
    assert analytic.epsilon(rig, friction) == pytest.approx(80e6 * u0 / (0.2 * 0.046 * 1200))
    assert analytic.r_squared(rig, friction) == pytest.approx(0.5 * (2 * math.pi * 4000) ** 2
                                                              / 80e6)
    assert analytic.xi(RigParameters()) == math.inf
