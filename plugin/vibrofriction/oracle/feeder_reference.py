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
once the motion repeats (successive windows agree). The flight's height is evaluated without
cancellation near its start (it grows as tau^3 there), and each event search starts from the
sign it must have, so no false event follows a lift-off or a release. Independent of the plugin
and of MuJoCo.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..params import ParameterError

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
        if not (self.friction_coefficient > 0 and math.isfinite(self.friction_coefficient)):
            # (without friction the block keeps whatever velocity it starts with)
            raise ParameterError(f"Feeder friction_coefficient={self.friction_coefficient!r} "
                                 "must be > 0")

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


def _first_root(f, t0: float, t_end: float, step: float, sign: float) -> float | None:
    """The first t in (t0, t_end] where f, of the known `sign` just after t0, reaches 0 or the
    other sign: bracketed on `step`, refined by brentq. None when it keeps its sign. (The sign
    is given, not read at t0: an event leaves f at 0 there, and its rounding noise would make a
    false root.)"""
    a = t0
    while a < t_end:
        b = min(a + step, t_end)
        fb = f(b)
        if sign * fb <= 0:
            if fb == 0:
                return b
            if a == t0:
                # a short phase: bracket from the largest point after t0 that still has `sign`
                width = b - t0
                for _ in range(48):
                    width *= 0.5
                    if sign * f(t0 + width) > 0:
                        return brentq(f, t0 + width, b, xtol=1e-15, rtol=1e-14)
                return t0 + width  # ends at once, to rounding
            return brentq(f, a, b, xtol=1e-15, rtol=1e-14)
        a = b
    return None


def _one_minus_cos_minus_half_square(x: float) -> float:
    """1 - cos x - x^2/2, without cancellation for small x."""
    if abs(x) < 1e-2:
        x2 = x * x
        return x2 * x2 * (-1 / 24 + x2 * (1 / 720 - x2 / 40320))
    return 1 - math.cos(x) - 0.5 * x * x


def _x_minus_sin(x: float) -> float:
    """x - sin x, without cancellation for small x."""
    if abs(x) < 1e-2:
        x2 = x * x
        return x * x2 * (1 / 6 + x2 * (-1 / 120 + x2 / 5040))
    return x - math.sin(x)


@dataclass(frozen=True)
class FeederMotion:
    """The block's mean conveying velocity and how it moved over the measured periods."""

    mean_velocity_m_per_s: float
    flight_fraction: float    # of the measured time, in flight
    stick_fraction: float     # stuck to the track
    backward_fraction: float  # slipping backwards
    periods: int              # simulated, settling included
    converged: bool           # the last two windows agreed within the tolerance
    # each simulated period's relative displacement over the period (its start-up; the mean
    # relative velocity but in a first period that starts late, at start_phase_rad)
    period_velocities_m_per_s: tuple[float, ...] = ()

    def normalized(self, feeder: Feeder) -> float:
        """V / (A w cos beta)."""
        return self.mean_velocity_m_per_s / feeder.along_velocity_amplitude


def convey(feeder: Feeder, *, push_m_per_s2: float = 0.0, start_phase_rad: float = 0.0,
           at_rest: bool = False, settle_periods: int = 40, window_periods: int = 24,
           tolerance: float = 1e-7, max_periods: int = 4000,
           samples_per_period: int = 400) -> FeederMotion:
    """Event-driven motion of the block from t = start_phase_rad / w (the track at A sin of that
    phase), starting stuck to the track (co-moving with it), or with `at_rest` at rest in space
    (a part set down on the running feeder: relative to the track it moves at minus the
    track's velocity, along and normal; a track moving up into it lands it, one moving down
    leaves it in flight). Periods count from t = 0; the first is partial when the phase is not
    0. `push_m_per_s2`: a constant force per unit mass on the block along the track (a
    pusher, a slope's pull); |push| < mu g, else the block has no periodic motion. At the
    periodic motion the mean friction per unit mass is -push: this gives the feeder map's mean
    force against the mean velocity (vibrofriction.robots.feeder_map). After `settle_periods`, windows of `window_periods` (24: period-2, -3, -4, -6 motions
    average out) follow until two successive window means of the relative velocity agree within
    `tolerance` x A w cos(beta), or `max_periods` (then `converged` is False); the last
    window's mean is returned. Switching times are bracketed on `samples_per_period` points a
    period."""
    push = float(push_m_per_s2)
    mu, g = feeder.friction_coefficient, feeder.gravity_m_per_s2
    if not (math.isfinite(push) and abs(push) < mu * g):
        raise ParameterError(f"push_m_per_s2={push_m_per_s2!r} must be finite and below mu g = "
                             f"{mu * g:.6g} m/s^2 in size: a larger push slides the block "
                             "without end")
    run = _BlockRun(feeder, push, samples_per_period, max_periods)
    if not (math.isfinite(start_phase_rad) and 0 <= start_phase_rad < 2 * math.pi):
        raise ParameterError(f"start_phase_rad={start_phase_rad!r} must be in [0, 2 pi)")
    run.start(start_phase_rad / feeder.omega, at_rest)
    period = run.period
    periods = settle_periods + window_periods
    previous, converged = None, False
    while True:
        run.run_until(periods * period)
        current = run.window_mean(periods, window_periods)
        scale = tolerance * feeder.along_velocity_amplitude
        if previous is not None and abs(current["integral"] - previous["integral"]) <= scale:
            converged = True
            break
        if periods + window_periods > max_periods:
            break
        previous = current
        periods += window_periods
    return FeederMotion(current["integral"], current["flight"], current["stick"],
                        current["backward"], periods, converged,
                        tuple(x / period for x in run.bins["integral"][:periods]))


class _BlockRun:
    """The block's event-driven motion on the track (``convey``): its state (the time t, the
    relative velocity s along the track, in flight or in contact, a flight's normal rate) and
    the per-period sums of the integral of s and the times in flight, stuck and slipping
    backwards. Between events every phase is in closed form; the events (lift-off, landing,
    release, a stop of the slip) are bracketed roots."""

    def __init__(self, feeder: Feeder, push: float, samples_per_period: int,
                 max_periods: int) -> None:
        self.feeder = feeder
        w = self.w = feeder.omega
        self.g, self.mu = feeder.gravity_m_per_s2, feeder.friction_coefficient
        self.b = feeder.throw_angle_rad
        self.push = push
        self.along = feeder.amplitude_m * w * w * math.cos(self.b)  # the track's acceleration
        self.normal = feeder.amplitude_m * w * w * math.sin(self.b)  # amplitudes, along/across
        self.period = 2 * math.pi / w
        self.step = self.period / samples_per_period
        self.eps = 1e-9 * self.period  # past an event, to read which way the motion goes
        self.gamma = feeder.throw_number
        # the load turns negative there
        self.lift_phase = math.asin(1 / self.gamma) if self.gamma > 1 else None
        self.bins = {key: [] for key in ("integral", "flight", "stick", "backward")}
        self.t, self.s, self.in_flight, self.flight_rate = 0.0, 0.0, False, 0.0
        self.events_left = 50 * samples_per_period * max_periods  # a guard, far above any

    def load(self, x):  # normal load per unit mass while in contact
        return self.g - self.normal * math.sin(self.w * x)

    def excess(self, x):  # friction a stick needs beyond mu N (per unit mass)
        return abs(self.along * math.sin(self.w * x) + self.push) - self.mu * self.load(x)

    def next_lift(self, t0):
        """The first time after t0 where the load turns negative (closed form)."""
        if self.lift_phase is None:
            return None
        w = self.w
        k = math.floor((w * t0 - self.lift_phase) / (2 * math.pi)) + 1
        candidate = (self.lift_phase + 2 * math.pi * k) / w
        return candidate if candidate > t0 + self.eps else candidate + self.period

    def flight_height(self, t0, x, rate0=0.0):
        """Height above the track at x of a flight that left it at t0 with normal rate rate0
        (0 at a lift-off, where the load is 0, and after a landing into a re-lift, where it is
        negative; positive for a part set down at rest on a track moving away from it)."""
        w = self.w
        tau, theta, phase = x - t0, w * (x - t0), w * t0
        return (rate0 * tau - self.load(t0) * 0.5 * tau * tau + self.normal / (w * w) * (
            math.sin(phase) * _one_minus_cos_minus_half_square(theta)
            + math.cos(phase) * _x_minus_sin(theta)))

    def account(self, kind, t0, t1, P, Q, v0):
        """Adds [t0, t1] to the periods it covers."""
        period, w, bins = self.period, self.w, self.bins
        lo = t0
        while lo < t1:
            k = int(lo // period)
            hi = min(t1, (k + 1) * period)
            if hi <= lo:  # rounding at a boundary
                k += 1
                hi = min(t1, (k + 1) * period)
            for key in bins:
                while len(bins[key]) <= k:
                    bins[key].append(0.0)
            bins["integral"][k] += _position(P, Q, w, lo, _velocity(P, Q, w, t0, v0, lo), hi)
            if kind in bins:
                bins[kind][k] += hi - lo
            lo = hi

    def start(self, t: float, at_rest: bool) -> None:
        """Start at t stuck to the track, or (``at_rest``) at rest in space on it: relative to
        it, minus its velocity, along and normal; a track moving into the part lands it
        (plastic, friction impulse <= mu p), one moving away leaves it in flight with that
        normal rate."""
        feeder, w, mu = self.feeder, self.w, self.mu
        self.t = t
        if not at_rest:
            return
        s = -feeder.along_velocity_amplitude * math.cos(w * t)
        normal_rate = -feeder.amplitude_m * w * math.sin(self.b) * math.cos(w * t)
        if normal_rate < 0:
            impulse = -normal_rate
            s = 0.0 if abs(s) <= mu * impulse else s - mu * impulse * math.copysign(1.0, s)
        elif normal_rate > 0:
            self.in_flight, self.flight_rate = True, normal_rate
        self.s = s

    def run_until(self, t_stop: float) -> None:
        """Follow the motion event by event to t_stop (a flight to its landing, past t_stop if
        need be: the windows read whole periods only)."""
        while self.t < t_stop:
            self.events_left -= 1
            if self.events_left < 0:
                raise RuntimeError("feeder reference: more events than a run can have")
            if self.in_flight:
                self._fly()
            elif self.load(self.t + self.eps) < 0:
                self.in_flight = True
            else:
                self._contact(t_stop)

    def _fly(self) -> None:
        """A flight from t to its landing, and the landing's impulse (plastic, friction
        impulse <= mu p)."""
        w, mu, t0, s = self.w, self.mu, self.t, self.s
        rate0 = self.flight_rate
        land = _first_root(lambda x: self.flight_height(t0, x, rate0), t0,
                           t0 + 20 * self.period, self.step, +1.0)
        if land is None:
            raise RuntimeError("feeder reference: a flight longer than 20 periods "
                               f"(throw number {self.gamma:.3g})")
        self.account("flight", t0, land, self.along, self.push, s)
        s_minus = _velocity(self.along, self.push, w, t0, s, land)
        rate = rate0 - self.normal / w * (math.cos(w * land) - math.cos(w * t0)) \
            - self.g * (land - t0)
        impulse = -rate
        self.flight_rate = 0.0
        self.s = 0.0 if abs(s_minus) <= mu * impulse else \
            s_minus - mu * impulse * math.copysign(1.0, s_minus)
        self.t, self.in_flight = land, False

    def _contact(self, t_stop: float) -> None:
        """In contact from t: stuck until released or lifted, or slipping (the friction
        saturated) until the slip stops, the block lifts or t_stop."""
        w, mu, t = self.w, self.mu, self.t
        lift = self.next_lift(t)
        lift = lift if lift is not None and lift < t_stop else None
        if self.s == 0.0:
            if self.excess(t + self.eps) <= 0:  # it stays stuck until released or lifted
                release = _first_root(self.excess, t, t_stop, self.step, -1.0)
                t_end = min(x for x in (release, lift, t_stop) if x is not None)
                self.account("stick", t, t_end, 0.0, 0.0, 0.0)
                self.in_flight = lift is not None and t_end == lift
                self.t = t_end
                return
            # Released: it slips against the track's pull (the friction saturates).
            direction = 1.0 if self.along * math.sin(w * (t + self.eps)) + self.push > 0 \
                else -1.0
        else:
            direction = 1.0 if self.s > 0 else -1.0
        P, Q = (self.along + direction * mu * self.normal), self.push - direction * mu * self.g
        v0, t0 = self.s, t
        stop = _first_root(lambda x: direction * _velocity(P, Q, w, t0, v0, x), t0,
                           t_stop, self.step, +1.0)
        t_end = min(x for x in (stop, lift, t_stop) if x is not None)
        self.account("backward" if direction < 0 else "forward", t0, t_end, P, Q, v0)
        self.s = 0.0 if (stop is not None and t_end == stop) else \
            _velocity(P, Q, w, t0, v0, t_end)
        self.in_flight = lift is not None and t_end == lift
        self.t = t_end

    def window_mean(self, end_period: int, window_periods: int) -> dict[str, float]:
        """The per-period sums' means over the window of ``window_periods`` periods ending at
        ``end_period``: the mean relative velocity (m/s) and the time fractions."""
        lo = end_period - window_periods
        return {key: sum(values[lo:end_period]) / (window_periods * self.period)
                for key, values in self.bins.items()}


def set_down_travel(feeder: Feeder, periods: int, start_phase_rad: float = 0.0) -> np.ndarray:
    """A part set down at rest on the running track at t = start_phase_rad / w
    (``convey(..., at_rest=True)``): its travel in space along the track at the ends of periods
    1 ... `periods` (t = k / f), from where it was set down: relative to the track, plus the
    track's own motion. Periods past the run's (it stops once settled) convey at its mean
    velocity."""
    motion = convey(feeder, start_phase_rad=start_phase_rad, at_rest=True)
    period = 1 / feeder.frequency_Hz
    per_period = np.full(periods, motion.mean_velocity_m_per_s)
    ran = min(periods, len(motion.period_velocities_m_per_s))
    per_period[:ran] = motion.period_velocities_m_per_s[:ran]
    ends = (np.arange(periods) + 1) * period
    along = feeder.amplitude_m * math.cos(feeder.throw_angle_rad)
    return np.cumsum(per_period) * period + along * (np.sin(feeder.omega * ends)
                                                     - math.sin(start_phase_rad))


def flight_fraction_infinite_friction(throw_number: float) -> float:
    """n_F of classical throw theory: sqrt(G^2 - 1)(2 pi n - sin 2 pi n) = 2 pi^2 n^2 +
    cos 2 pi n - 1, for 1 < G <= sqrt(1 + pi^2) (one flight within a period)."""
    limit = math.sqrt(1 + math.pi**2)
    if not 1 < throw_number <= limit:
        raise ParameterError(f"throw number {throw_number!r} must be in (1, sqrt(1 + pi^2)]")
    if throw_number >= limit * (1 - 1e-14):
        return 1.0
    root = math.sqrt(throw_number**2 - 1)

    def f(n):  # (2 pi^2 n^2 + cos 2 pi n - 1 = -(1 - cos x - x^2/2), x = 2 pi n)
        x = 2 * math.pi * n
        return root * _x_minus_sin(x) + _one_minus_cos_minus_half_square(x)
    # f ~ n^3 > 0 near the trivial root n = 0 and f(1) < 0: start the bracket where f > 0
    low = 1e-3
    while f(low) <= 0 and low > 1e-12:
        low /= 10
    return brentq(f, low, 1.0, xtol=1e-15)


def infinite_friction_velocity_ratio(throw_number: float) -> float:
    """V / (A w cos beta) = pi n_F^2 / Gamma for mu -> infinity (classical throw theory)."""
    n = flight_fraction_infinite_friction(throw_number)
    return math.pi * n * n / throw_number


def stick_throw_number(throw_angle_rad: float, friction_coefficient: float) -> float:
    """The block sticks for all t iff Gamma <= mu sin b / (cos b + mu sin b)."""
    s, c = math.sin(throw_angle_rad), math.cos(throw_angle_rad)
    return friction_coefficient * s / (c + friction_coefficient * s)


__all__ = ["Feeder", "FeederMotion", "convey", "set_down_travel",
           "flight_fraction_infinite_friction",
           "infinite_friction_velocity_ratio", "stick_throw_number", "GRAVITY_M_PER_S2"]
