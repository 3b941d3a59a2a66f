"""Exact reference for a linear vibratory feeder: a rigid block on a track that moves
A sin(w t) along a throw line at angle beta above the track, Coulomb friction mu, rigid
unilateral contact, plastic landing.

This is the reference an averaged feeder model is checked against (docs/physics.md,
"Vibratory feeders"): MuJoCo's soft contact is not one in the flight regime. Every phase has a
relative acceleration P sin(w t) + Q, so velocities and positions are closed-form and only the
switching times are found numerically (bracketed roots):

* contact, the normal load per unit mass g (1 - Gamma sin w t), Gamma = A w^2 sin(beta) / g;
* stick while |a_track| <= mu N / m, else slip against the relative velocity s:
  forward  s' = A w^2 (cos b + mu sin b) sin w t - mu g
  backward s' = A w^2 (cos b - mu sin b) sin w t + mu g;
* flight when the load would turn negative: s' = A w^2 cos(b) sin w t, and the height above
  the track h'' = A w^2 sin(b) sin w t - g until h = 0 again;
* landing: the normal impulse (per unit mass) p = -h'; s+ = 0 if |s-| <= mu p, else
  s- - mu p sign(s-).

The conveying velocity is the mean of s (the track's own mean velocity is 0) over whole periods
once the motion repeats. Independent of the plugin and of MuJoCo. For mu above about 1e5 the slip
phases' closed forms (P, Q ~ mu g) lose digits to cancellation: use mu <= 1e4 as "infinite".
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .params import ParameterError

GRAVITY_M_PER_S2 = 9.81


@dataclass(frozen=True)
class Feeder:
    """The track's motion and the block's friction."""

    amplitude_m: float           # A, along the throw line
    frequency_Hz: float
    throw_angle_rad: float       # beta, from the track
    friction_coefficient: float  # mu
    gravity_m_per_s2: float = GRAVITY_M_PER_S2

    def __post_init__(self) -> None:
        for name in ("amplitude_m", "frequency_Hz", "gravity_m_per_s2"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ParameterError(f"Feeder {name}={value!r} must be a positive number")
        if not 0 < self.throw_angle_rad < math.pi / 2:
            raise ParameterError(f"Feeder throw_angle_rad={self.throw_angle_rad!r} must be in "
                             "(0, pi/2)")
        if not (self.friction_coefficient >= 0 and math.isfinite(self.friction_coefficient)):
            raise ParameterError(f"Feeder friction_coefficient={self.friction_coefficient!r} must be "
                             ">= 0")

    @property
    def omega(self) -> float:
        return 2 * math.pi * self.frequency_Hz

    @property
    def throw_number(self) -> float:
        """Gamma = A w^2 sin(beta) / g: lift-off needs Gamma > 1."""
        return self.amplitude_m * self.omega**2 * math.sin(self.throw_angle_rad) / \
            self.gravity_m_per_s2

    @property
    def along_velocity_amplitude(self) -> float:
        """A w cos(beta): the track's velocity amplitude along the track."""
        return self.amplitude_m * self.omega * math.cos(self.throw_angle_rad)

    @classmethod
    def from_throw_number(cls, throw_number: float, throw_angle_rad: float,
                          frequency_Hz: float, friction_coefficient: float,
                          gravity_m_per_s2: float = GRAVITY_M_PER_S2) -> "Feeder":
        omega = 2 * math.pi * frequency_Hz
        amplitude = throw_number * gravity_m_per_s2 / (omega**2 * math.sin(throw_angle_rad))
        return cls(amplitude, frequency_Hz, throw_angle_rad, friction_coefficient,
                   gravity_m_per_s2)


# A phase's relative acceleration P sin(w t) + Q, and its closed-form integrals.
def _velocity(P: float, Q: float, w: float, t0: float, v0: float, t: float) -> float:
    return v0 - P / w * (math.cos(w * t) - math.cos(w * t0)) + Q * (t - t0)


def _position(P: float, Q: float, w: float, t0: float, v0: float, t: float) -> float:
    """Displacement from t0 (the integral of _velocity)."""
    tau = t - t0
    return (v0 * tau - P / w * ((math.sin(w * t) - math.sin(w * t0)) / w - math.cos(w * t0) * tau)
            + 0.5 * Q * tau**2)


def _first_root(f, t0: float, t_end: float, step: float) -> float | None:
    """The first t in (t0, t_end] where f changes sign, bracketed on `step`, refined by brentq;
    None when it keeps the sign of f(t0)."""
    a, fa = t0, f(t0)
    while a < t_end:
        b = min(a + step, t_end)
        fb = f(b)
        if fa * fb < 0 or fb == 0:
            return b if fb == 0 else brentq(f, a, b, xtol=1e-15, rtol=1e-14)
        a, fa = b, fb
    return None


@dataclass(frozen=True)
class FeederMotion:
    """The block's mean conveying velocity and how it moved over the measured periods."""

    mean_velocity_m_per_s: float
    flight_fraction: float    # of the measured time, in flight
    stick_fraction: float     # stuck to the track
    backward_fraction: float  # slipping backwards
    periods: int              # simulated, settling included

    def normalized(self, feeder: Feeder) -> float:
        """V / (A w cos beta)."""
        return self.mean_velocity_m_per_s / feeder.along_velocity_amplitude


def convey(feeder: Feeder, *, settle_periods: int = 40, measure_periods: int = 20,
           samples_per_period: int = 400) -> FeederMotion:
    """Event-driven motion of the block from rest on the track at t = 0, and its mean over
    `measure_periods` after `settle_periods`; switching times are bracketed on
    `samples_per_period` points a period."""
    w, g, mu = feeder.omega, feeder.gravity_m_per_s2, feeder.friction_coefficient
    b = feeder.throw_angle_rad
    along = feeder.amplitude_m * w * w * math.cos(b)    # the track's acceleration amplitudes,
    normal = feeder.amplitude_m * w * w * math.sin(b)   # along the track and across it
    period = 2 * math.pi / w
    step = period / samples_per_period
    eps = 1e-9 * period  # past an event, to read which way the motion goes
    t_start = settle_periods * period
    t_stop = (settle_periods + measure_periods) * period

    def load(x):  # normal load per unit mass while in contact
        return g - normal * math.sin(w * x)

    def excess(x):  # friction a stick needs beyond mu N (per unit mass)
        return abs(along * math.sin(w * x)) - mu * load(x)

    totals = {"integral": 0.0, "flight": 0.0, "stick": 0.0, "backward": 0.0}

    def account(kind, t0, t1, P, Q, v0):
        """Adds the part of [t0, t1] inside the measured window."""
        lo, hi = max(t0, t_start), min(t1, t_stop)
        if hi <= lo:
            return
        totals["integral"] += _position(P, Q, w, lo, _velocity(P, Q, w, t0, v0, lo), hi)
        if kind in totals:
            totals[kind] += hi - lo

    t, s, in_flight = 0.0, 0.0, False
    for _ in range(100 * samples_per_period * (settle_periods + measure_periods)):
        if t >= t_stop:
            break
        if in_flight:
            # Height above the track from 0 with rate 0; the block lands when it is 0 again.
            def height(x, t0=t):
                return _position(normal, -g, w, t0, 0.0, x)
            land = _first_root(height, t + eps, t_stop, step)
            t_end = t_stop if land is None else land
            account("flight", t, t_end, along, 0.0, s)
            s_minus = _velocity(along, 0.0, w, t, s, t_end)
            if land is not None:
                impulse = -_velocity(normal, -g, w, t, 0.0, land)
                s = 0.0 if abs(s_minus) <= mu * impulse else \
                    s_minus - mu * impulse * math.copysign(1.0, s_minus)
            t, in_flight = t_end, False
            continue
        if load(t + eps) < 0:
            in_flight = True
            continue
        lift = _first_root(load, t + eps, t_stop, step)
        if s == 0.0:
            if excess(t + eps) <= 0:  # it stays stuck until released or lifted
                release = _first_root(excess, t + eps, t_stop, step)
                t_end = min(x for x in (release, lift, t_stop) if x is not None)
                account("stick", t, t_end, 0.0, 0.0, 0.0)
                t = t_end
                in_flight = lift is not None and t == lift
                continue
            # Released: it slips against the track's pull (the friction saturates).
            direction = 1.0 if along * math.sin(w * (t + eps)) > 0 else -1.0
        else:
            direction = 1.0 if s > 0 else -1.0
        P, Q = (along + direction * mu * normal), -direction * mu * g
        v0, t0 = s, t

        def relative(x):  # > 0 while it slips in `direction`
            return direction * _velocity(P, Q, w, t0, v0, x)
        stop = _first_root(relative, t + eps, t_stop, step)
        t_end = min(x for x in (stop, lift, t_stop) if x is not None)
        account("backward" if direction < 0 else "forward", t, t_end, P, Q, v0)
        s = 0.0 if (stop is not None and t_end == stop) else _velocity(P, Q, w, t0, v0, t_end)
        t = t_end
        in_flight = lift is not None and t == lift
    else:
        raise RuntimeError("feeder reference: more events than a run can have")
    window = t_stop - t_start
    return FeederMotion(totals["integral"] / window, totals["flight"] / window,
                        totals["stick"] / window, totals["backward"] / window,
                        settle_periods + measure_periods)


def flight_fraction_infinite_friction(throw_number: float) -> float:
    """n_F of classical throw theory: sqrt(G^2 - 1)(2 pi n - sin 2 pi n) = 2 pi^2 n^2 +
    cos 2 pi n - 1, for 1 < G <= sqrt(1 + pi^2) (one flight within a period)."""
    if not 1 < throw_number <= math.sqrt(1 + math.pi**2) + 1e-12:
        raise ParameterError(f"throw number {throw_number!r} must be in (1, sqrt(1 + pi^2)]")
    root = math.sqrt(throw_number**2 - 1)

    def f(n):
        return root * (2 * math.pi * n - math.sin(2 * math.pi * n)) - \
            (2 * math.pi**2 * n**2 + math.cos(2 * math.pi * n) - 1)
    # f ~ n^3 > 0 near the trivial root n = 0 and f(1) < 0: bracket away from 0
    return brentq(f, 1e-3, 1.0, xtol=1e-14)


def infinite_friction_velocity_ratio(throw_number: float) -> float:
    """V / (A w cos beta) = pi n_F^2 / Gamma for mu -> infinity (classical throw theory)."""
    n = flight_fraction_infinite_friction(throw_number)
    return math.pi * n * n / throw_number


def stick_throw_number(throw_angle_rad: float, friction_coefficient: float) -> float:
    """The block sticks for all t iff Gamma <= mu sin b / (cos b + mu sin b)."""
    s, c = math.sin(throw_angle_rad), math.cos(throw_angle_rad)
    return friction_coefficient * s / (c + friction_coefficient * s)


__all__ = ["Feeder", "FeederMotion", "convey", "flight_fraction_infinite_friction",
           "infinite_friction_velocity_ratio", "stick_throw_number", "GRAVITY_M_PER_S2"]
