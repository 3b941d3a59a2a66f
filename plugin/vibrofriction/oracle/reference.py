"""Independent reference solution of the paper's rig with scipy ``solve_ivp``: the test oracle.

Re-derives every friction law from its equations (docs/physics.md; Gutowski & Leus 2012, eqs. 2-14)
and imports no other law code of this package, so that an error in the production laws cannot
hide in the oracle too. Only the parameter dataclasses and the summary are shared.

Rig (SI units)::

    u = u0 sin(wt),  u' = v_a cos(wt),  v_a = 2 pi f u0              support (table)
    m x'' = F_d - F_F,  F_d = k_d (v_d t - x) + h_d (v_d - x')       slider on the drive spring
    v_r = x' - u'                                                      relative velocity

F_F is the force of the support on the slider *against* +x: F_F > 0 when v_r > 0 in steady
sliding. Friction level with the effects, for the direction ``s`` of v_r::

    F_c = mu F_N (1 + m sin(2 pi f_m t + phi_m)) (1 + a s) (1 + r sin(2 pi (x - u)/lambda + phi))
    F_s = static_ratio F_c,   g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2)

times max(0, 1 + s(x - u)) with a position map, max(0, 1 + s(|v_r|)) with a velocity map and
max(0, 1 + s(t)) with a time map (scipy's CubicSpline: natural, or periodic; beyond the knots
constant, or linear for the speed).

Laws (s0 = k_t, s1 bristle damping, s2 viscous; all integrated with LSODA):

* ``dahl`` z' = v_r sgn(w)|w|^alpha, w = 1 - k_t z sgn(v_r)/g(v_r), F = k_t z + s2 v_r
  (for alpha < 1 smoothed within |w| < 1e-6, see ``_odd_power``);
* ``dupont`` (Dupont et al. 2002) z' = v_r (1 - a(z, v_r) z/z_ss(v_r)), z_ss = sgn(v) g(v)/s0,
  z_ba = breakaway_ratio F_c/s0, a = 0 when sgn(v) != sgn(z); F = s0 z + s1 z' + s2 v_r;
* ``lugre`` (Canudas de Wit et al. 1995) z' = v_r - |v_r| s0 z/g(v_r), F = s0 z + s1 z' + s2 v_r;
* ``gms`` (Al-Bender et al. 2005) elements i = spring k_i + slide at w_i F_c: stuck, z_i' = v_r;
  slipping (after k_i z_i reached +-w_i F_c), z_i = +-w_i F_c / k_i until v_r returns to 0;
  F = sum k_i z_i + s2 v_r. A hybrid system (events: an element reaching its level, v_r = 0)
  for constant levels only: no Stribeck, load modulation or ripple, where the element's
  relaxation time has no effect;
* ``coulomb`` rigid, a hybrid system with true stick: sliding, F = sgn(v_r) g(|v_r|) + s2 v_r;
  stuck, the slider rides with the support while |F_d - m u''| <= F_s. Integration restarts
  at each event (v_r = 0, stick force reaching +-F_s).

``contact_play_m`` = b > 0 (dahl, dupont, lugre): z is the whole deflection; while |z| < b/2
the contact is open (z' = v_r, F = the offset alone), beyond it the law runs on z -+ b/2.

``force_offset_N`` is added to F (it acts on the slider); ``sensor_lag_s`` lags only the
reported friction force. Coulomb's reported force jumps, so its sampled mean carries an error
of order F_c sample_dt/period per jump (~0.005-0.02 N at 1 us, 4 kHz); F_d is smooth.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from ..params import VIBRATION_RAMP_PERIODS, FrictionParameters, ParameterError, RigParameters
from ..summary import RunSummary, summarize

# LSODA switches between Adams (non-stiff) and BDF (stiff) by itself: the contact is mildly stiff
# at the paper's parameters (2 kHz resonance) and very stiff with heavy bristle damping.
ODE_METHOD = "LSODA"
# Steps per vibration (or load-modulation) period at most, so no forcing cycle is stepped over.
STEPS_PER_PERIOD = 20
# Width in w of the smoothing of sgn(w)|w|^alpha, alpha < 1, at saturation (F moves ~1e-6 F_c).
DAHL_LAYER = 1e-6
# Consecutive zero-length Coulomb segments tolerated before declaring the event logic stuck.
_MAX_EMPTY_SEGMENTS = 20

Law = Callable[[float, float, float, float], tuple[float, float]]


@dataclass(frozen=True, eq=False)
class ReferenceResult:
    """Sampled time series of one reference run; forces in N, F_F > 0 against +x motion."""

    time_s: np.ndarray
    slider_position_m: np.ndarray  # x
    slider_velocity_m_per_s: np.ndarray  # x'
    support_velocity_m_per_s: np.ndarray  # u' = v_a cos(wt)
    relative_velocity_m_per_s: np.ndarray  # v_r = x' - u'
    deflection_m: np.ndarray  # z (zero for the rigid Coulomb law)
    friction_force_N: np.ndarray  # F_F as reported (after the sensor lag)
    drive_force_N: np.ndarray  # F_d = k_d (v_d t - x) + h_d (v_d - x'), through any backlash
    sticking: np.ndarray  # True where the rigid Coulomb contact sticks (always False otherwise)
    rig: RigParameters
    friction: FrictionParameters

    @property
    def period_s(self) -> float:
        """Averaging period: the vibration's, else the load modulation's, else 0 (none)."""
        return _averaging_period_s(self.rig, self.friction)

    def summary(self, settle_time_s: float) -> RunSummary:
        """Means over whole periods after ``settle_time_s`` (see summary.summarize)."""
        return summarize(self.time_s, self.drive_force_N, self.friction_force_N,
                         self.period_s, settle_time_s)


def simulate_reference(rig: RigParameters, friction: FrictionParameters, duration_s: float, *,
                       sample_dt_s: float = 1e-6, rtol: float = 1e-8,
                       atol: float | Sequence[float] | None = None,
                       t_start_s: float = 0.0,
                       vibration_from_s: float | None = None,
                       level_factor: Callable[[float, float, float], float] | None = None
                       ) -> ReferenceResult:
    """Integrate the rig from rest (x = x' = z = 0, drive spring unloaded at t = 0).

    ``level_factor(t_s, x_rel_m, v_rel_m_per_s)``: a factor on the Coulomb level for an effect
    no parameter names (heating over time, a speed curve of another shape), state laws only:
    the out-of-vocabulary records the tracer is tested on.

    ``vibration_from_s`` (default: the rig's) > 0: the support stands still until then and
    vibrates from then on,
    u = u0 r(t) sin(w (t - vibration_from_s)), r rising as (1 - cos)/2 over
    ``VIBRATION_RAMP_PERIODS`` periods (a stage without vibration first; state laws only).

    Samples are uniform from 0 to ``duration_s`` (spacing adjusted so the last sample falls on
    ``duration_s``); those before ``t_start_s`` are dropped from the result. ``atol`` defaults
    to ``rtol`` times the natural scale of each state: F_c/k_d for x, max(v_a, v_d) for x',
    F_c/k_t for z.
    """
    rig.validate()
    friction.validate()
    _check_times(duration_s, sample_dt_s, t_start_s, rtol)
    if vibration_from_s is None:
        vibration_from_s = rig.vibration_from_s
    if not (math.isfinite(vibration_from_s) and 0.0 <= vibration_from_s < duration_s):
        raise ParameterError(f"vibration_from_s={vibration_from_s!r} must lie in "
                             f"[0, duration_s={duration_s!r})")
    if vibration_from_s > 0 and friction.law in ("coulomb", "gms"):
        raise ParameterError("vibration_from_s is supported for the state laws (dahl, dupont, "
                             f"lugre), not for the hybrid {friction.law} reference")
    if friction.law == "gms" and (friction.static_ratio != 1 or friction.normal_force_modulation
                                  or friction.position_ripple or friction.position_map_knots_m
                                  or friction.velocity_map_knots_m_per_s
                                  or friction.time_map_knots_s):
        raise ParameterError("the gms reference covers constant levels: static_ratio 1, no "
                             "normal_force_modulation, position_ripple or level maps")
    if level_factor is not None and friction.law in ("coulomb", "gms"):
        raise ParameterError("level_factor is supported for the state laws (dahl, dupont, "
                             f"lugre), not for the hybrid {friction.law} reference")
    n_intervals = max(1, round(duration_s / sample_dt_s))
    t_grid = np.linspace(0.0, duration_s, n_intervals + 1)
    contact = _Contact(rig, friction, level_factor)
    drive = _Rig(rig, vibration_from_s)
    tolerances = _tolerances(rig, contact, rtol, atol)
    max_step_s = _max_step_s(rig, friction)
    if friction.law == "coulomb":
        series = _simulate_coulomb(drive, contact, t_grid, tolerances, max_step_s)
    elif friction.law == "gms":
        series = _simulate_gms(drive, contact, friction, t_grid, tolerances, max_step_s)
    else:
        law: Law = getattr(contact, friction.law)
        if friction.contact_play_m > 0:
            law = _through_play(law, friction.contact_play_m, contact.offset_N)
        series = _simulate_state_law(drive, law, t_grid, tolerances, max_step_s)
    friction_N = first_order_lag(series["friction_force_N"], t_grid[1] - t_grid[0],
                                  friction.sensor_lag_s)
    series["friction_force_N"] = friction_N
    keep = t_grid >= t_start_s - 1e-12 * duration_s
    return ReferenceResult(time_s=t_grid[keep], rig=rig, friction=friction,
                           **{name: values[keep] for name, values in series.items()})


# --------------------------------------------------------------------------------------------
# Inputs


def _check_times(duration_s: float, sample_dt_s: float, t_start_s: float, rtol: float) -> None:
    if not _finite_positive(duration_s):
        raise ParameterError(f"duration_s={duration_s!r} must be a finite number > 0")
    if not _finite_positive(sample_dt_s) or sample_dt_s > duration_s:
        raise ParameterError(
            f"sample_dt_s={sample_dt_s!r} must be a finite number in (0, duration_s]")
    if not (_is_number(t_start_s) and 0 <= t_start_s < duration_s):
        raise ParameterError(f"t_start_s={t_start_s!r} must lie in [0, duration_s)")
    if not _finite_positive(rtol):
        raise ParameterError(f"rtol={rtol!r} must be a finite number > 0")


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _finite_positive(value: object) -> bool:
    return _is_number(value) and math.isfinite(value) and value > 0


def _averaging_period_s(rig: RigParameters, friction: FrictionParameters) -> float:
    f = rig.vibration_frequency_Hz
    if f > 0 and rig.vibration_velocity_amplitude_m_per_s > 0:
        return 1.0 / f
    f_mod = friction.normal_force_modulation_frequency_Hz or f
    if friction.normal_force_modulation > 0 and f_mod > 0:
        return 1.0 / f_mod
    return 0.0


def _max_step_s(rig: RigParameters, friction: FrictionParameters) -> float:
    period = _averaging_period_s(rig, friction)
    return period / STEPS_PER_PERIOD if period > 0 else math.inf


def _tolerances(rig: RigParameters, contact: "_Contact", rtol: float,
                atol: float | Sequence[float] | None) -> tuple[float, float | np.ndarray]:
    """(rtol, atol); the default atol is rtol times the scale of x, x' and z."""
    if atol is not None:
        return rtol, atol
    force_N = max(contact.bound_N, abs(contact.offset_N), 1e-6)
    scales = [force_N / rig.drive_stiffness_N_per_m,
              max(rig.vibration_velocity_amplitude_m_per_s, abs(rig.drive_velocity_m_per_s)),
              force_N / contact.kt if contact.kt > 0 else 1.0]
    return rtol, rtol * np.array(scales)


# --------------------------------------------------------------------------------------------
# Friction laws (scalar, math module only: called once per right-hand-side evaluation)


class _Contact:
    """Friction level with all effects, and the laws as functions (t, x_rel, v_r, z) -> (z', F)."""

    def __init__(self, rig: RigParameters, friction: FrictionParameters,
                 level_factor: Callable[[float, float, float], float] | None = None):
        p = friction
        self.bound_N = p.friction_coefficient * rig.normal_force_N
        self.level_factor = level_factor
        self.asymmetry = p.asymmetry
        self.ripple = p.position_ripple
        self.ripple_k_per_m = 2 * math.pi / p.position_ripple_wavelength_m
        self.ripple_phase = p.position_ripple_phase_rad
        self.modulation = p.normal_force_modulation
        # f_m = 0 means "at the vibration frequency".
        f_mod = p.normal_force_modulation_frequency_Hz or rig.vibration_frequency_Hz
        self.modulation_w = 2 * math.pi * f_mod
        self.modulation_phase = p.normal_force_modulation_phase_rad
        self.kt = p.contact_stiffness_N_per_m
        self.alpha = p.alpha
        self.breakaway_ratio = p.breakaway_ratio
        self.s1 = p.bristle_damping_N_s_per_m
        self.s2 = p.viscous_N_s_per_m
        self.static_ratio = p.static_ratio
        self.vs = p.stribeck_velocity_m_per_s
        self.offset_N = p.force_offset_N
        self.position_map = _level_map(p.position_map_knots_m, p.position_map_factors,
                                       p.position_map_period_m)
        self.velocity_map = _level_map(p.velocity_map_knots_m_per_s, p.velocity_map_factors,
                                       0.0, linear_ends=True)
        self.time_map = _level_map(p.time_map_knots_s, p.time_map_factors, 0.0)

    def coulomb_level(self, t: float, x_rel: float, direction: float) -> float:
        """F_c (N) with normal-load modulation, direction asymmetry, position ripple and the
        position and time maps."""
        level = self.bound_N
        if self.modulation:
            level *= 1 + self.modulation * math.sin(self.modulation_w * t + self.modulation_phase)
        if direction > 0:
            level *= 1 + self.asymmetry
        elif direction < 0:
            level *= 1 - self.asymmetry
        if self.ripple:
            level *= 1 + self.ripple * math.sin(self.ripple_k_per_m * x_rel + self.ripple_phase)
        if self.position_map:
            level *= max(0.0, 1.0 + self.position_map(x_rel))
        if self.time_map:
            level *= max(0.0, 1.0 + self.time_map(t))
        return level

    def state_level(self, t: float, x_rel: float, v: float) -> float:
        """``coulomb_level`` of a state law (direction: the sign of v) times ``level_factor``."""
        level = self.coulomb_level(t, x_rel, v)
        if self.level_factor is not None:
            level *= max(0.0, float(self.level_factor(t, x_rel, v)))
        return level

    def stribeck(self, fc: float, v: float) -> float:
        """g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2), times the velocity map's 1 + s(|v|)."""
        if self.velocity_map:
            fc = fc * max(0.0, 1.0 + self.velocity_map(abs(v)))
        if self.static_ratio == 1:
            return fc
        return fc * (1 + (self.static_ratio - 1) * math.exp(-(v / self.vs) ** 2))

    # State laws; with no friction bound (mu F_N = 0) the deflection stays at zero.

    def dahl(self, t: float, x_rel: float, v: float, z: float) -> tuple[float, float]:
        fc = self.state_level(t, x_rel, v)
        zdot = 0.0
        if fc > 0 and v != 0:
            w = 1 - self.kt * z * math.copysign(1.0, v) / self.stribeck(fc, v)
            zdot = v * _odd_power(w, self.alpha)
        return zdot, self.kt * z + self.s2 * v + self.offset_N

    def dupont(self, t: float, x_rel: float, v: float, z: float) -> tuple[float, float]:
        fc = self.state_level(t, x_rel, v)
        zdot = v if fc > 0 else 0.0  # a = 0 (elastic) unless sgn(v) = sgn(z), see below
        if fc > 0 and v * z > 0:
            z_ss = self.stribeck(fc, v) / self.kt  # |z_ss(v)|
            z_ba = self.breakaway_ratio * fc / self.kt  # at the Coulomb level, not g(v)
            a = _dupont_shape(abs(z), z_ba, z_ss)
            zdot = v * (1 - a * abs(z) / z_ss)
        return zdot, self.kt * z + self.s1 * zdot + self.s2 * v + self.offset_N

    def lugre(self, t: float, x_rel: float, v: float, z: float) -> tuple[float, float]:
        fc = self.state_level(t, x_rel, v)
        zdot = v - abs(v) * self.kt * z / self.stribeck(fc, v) if fc > 0 else 0.0
        return zdot, self.kt * z + self.s1 * zdot + self.s2 * v + self.offset_N

    def sliding_force(self, t: float, x_rel: float, v: float, direction: float) -> float:
        """Rigid Coulomb force while sliding in ``direction`` (+1/-1)."""
        g = self.stribeck(self.coulomb_level(t, x_rel, direction), v)
        return direction * g + self.s2 * v + self.offset_N

    def static_limit(self, t: float, x_rel: float, direction: float) -> float:
        """F_s (N) the stuck contact can hold against impending slip in ``direction``."""
        return self.stribeck(self.coulomb_level(t, x_rel, direction), 0.0)


def _through_play(law: Law, play_m: float, offset_N: float) -> Law:
    """``law`` behind a play of width ``play_m``: z is the whole deflection; the bristles see
    the part beyond half the play, and inside it the contact is open (z' = v_r, only the
    offset acts)."""
    half = 0.5 * play_m

    def through(t: float, x_rel: float, v: float, z: float) -> tuple[float, float]:
        if abs(z) < half or (abs(z) == half and v * z < 0):
            return v, offset_N
        return law(t, x_rel, v, z - math.copysign(half, z))
    return through


def _level_map(knots: Sequence[float], factors: Sequence[float], period: float,
               linear_ends: bool = False) -> Callable[[float], float] | None:
    """s(x) of a level map by scipy's CubicSpline (natural, or periodic with ``period`` > 0):
    constant beyond the knots, or (``linear_ends``) continued along the end slopes."""
    if not knots:
        return None
    if len(knots) == 1:
        return lambda x, c=float(factors[0]): c
    if period > 0:
        spline = CubicSpline([*knots, knots[0] + period], [*factors, factors[0]],
                             bc_type="periodic")
        return lambda x: float(spline(knots[0] + (x - knots[0]) % period))
    spline = CubicSpline(knots, factors, bc_type="natural")
    lo, hi = knots[0], knots[-1]

    def value(x: float) -> float:
        if lo <= x <= hi:
            return float(spline(x))
        end = lo if x < lo else hi
        return float(spline(end) + (spline(end, 1) * (x - end) if linear_ends else 0.0))
    return value


def _odd_power(w: float, alpha: float) -> float:
    """sgn(w)|w|^alpha: real for alpha < 1, and relaxes |F| > F_c back to F_c.

    For alpha < 1 it is not Lipschitz (alpha = 0: not even continuous) at w = 0, where the
    contact saturates; there it is smoothed to w (w^2 + d^2)^((alpha-1)/2), d = DAHL_LAYER, so
    the implicit solver sees a stiff but smooth attractor. This moves F by about d F_c.
    """
    if alpha >= 1:
        return math.copysign(abs(w) ** alpha, w)
    return w * (w * w + DAHL_LAYER * DAHL_LAYER) ** (0.5 * (alpha - 1))


def _dupont_shape(abs_z: float, z_ba: float, z_max: float) -> float:
    """a(z, v) of Dupont et al. (2002) for sgn(v) = sgn(z): 0 (stick), sine ramp, 1 (slip)."""
    if abs_z <= z_ba:
        return 0.0
    if abs_z >= z_max:
        return 1.0
    return 0.5 * math.sin(math.pi * (abs_z - 0.5 * (z_max + z_ba)) / (z_max - z_ba)) + 0.5


# --------------------------------------------------------------------------------------------
# State laws: one smooth ODE in (x, x', z)


class _Rig:
    """Support motion and drive force (scalar)."""

    def __init__(self, rig: RigParameters, vibration_from_s: float = 0.0):
        self.m = rig.mass_kg
        self.kd = rig.drive_stiffness_N_per_m
        self.hd = rig.drive_damping_N_s_per_m
        # Backlash: no spring force within +-gap of the start; outside, the spring in series
        # with the play's faces (0: rigid).
        half = 0.5 * rig.drive_backlash_m
        self.play = (rig.drive_backlash_centre_m - half, rig.drive_backlash_centre_m + half) \
            if half > 0 else (0.0, 0.0)
        faces = rig.drive_backlash_stiffness_N_per_m
        self.k_chain = self.kd if half == 0 or faces == 0 else 1.0 / (1 / self.kd + 1 / faces)
        self.vd = rig.drive_velocity_m_per_s
        self.w = 2 * math.pi * rig.vibration_frequency_Hz
        # f = 0 means no vibration (the support stands still), whatever v_a says.
        self.va = rig.vibration_velocity_amplitude_m_per_s if self.w > 0 else 0.0
        self.u0 = rig.vibration_amplitude_m
        self.t_on = vibration_from_s
        self.ramp_s = VIBRATION_RAMP_PERIODS * 2 * math.pi / self.w if self.w > 0 else 0.0

    def support(self, t: float) -> tuple[float, float, float]:
        """u, u', u''."""
        tau = t - self.t_on
        if tau < 0:
            return 0.0, 0.0, 0.0
        s, c = math.sin(self.w * tau), math.cos(self.w * tau)
        if self.t_on == 0 or tau >= self.ramp_s:
            return self.u0 * s, self.va * c, -self.va * self.w * s
        # Amplitude ramp r = (1 - cos(pi tau / T)) / 2 over T = ramp_s (a shaker's build-up).
        k = math.pi / self.ramp_s
        r, r1, r2 = 0.5 * (1 - math.cos(k * tau)), 0.5 * k * math.sin(k * tau), \
            0.5 * k * k * math.cos(k * tau)
        w = self.w
        return (self.u0 * r * s, self.u0 * (r1 * s + r * w * c),
                self.u0 * (r2 * s + 2 * r1 * w * c - r * w * w * s))

    def support_velocity(self, t: np.ndarray) -> np.ndarray:
        return np.array([self.support(ti)[1] for ti in np.asarray(t, dtype=float).tolist()])

    def spring_force(self, t: float, x: float) -> float:
        extension = x - self.vd * t  # x - x_B
        low, high = self.play
        return -self.k_chain * (extension - min(max(extension, low), high))

    def drive_force(self, t: float, x: float, xdot: float) -> float:
        return self.spring_force(t, x) + self.hd * (self.vd - xdot)


def _simulate_state_law(drive: _Rig, law: Law, t_grid: np.ndarray, tolerances,
                        max_step_s: float) -> dict[str, np.ndarray]:
    def rhs(t: float, y: np.ndarray) -> tuple[float, float, float]:
        x, xdot, z = y.tolist()
        u, udot, _ = drive.support(t)
        zdot, force = law(t, x - u, xdot - udot, z)
        return xdot, (drive.drive_force(t, x, xdot) - force) / drive.m, zdot

    rtol, atol = tolerances
    # One solve per stage: the support's acceleration has a kink where the vibration starts.
    breaks = [0.0] + ([drive.t_on] if drive.t_on > 0 else []) + [float(t_grid[-1])]
    y0, pieces = np.zeros(3), []
    for start, end in zip(breaks[:-1], breaks[1:]):
        last = end == breaks[-1]
        keep = (t_grid >= start) & ((t_grid <= end) if last else (t_grid < end))
        t_eval = t_grid[keep] if last else np.append(t_grid[keep], end)
        sol = solve_ivp(rhs, (start, end), y0, method=ODE_METHOD, t_eval=t_eval, rtol=rtol,
                        atol=atol, max_step=max_step_s)
        if sol.status != 0:
            raise RuntimeError(f"reference integration failed: {sol.message}")
        pieces.append(sol.y if last else sol.y[:, :-1])
        y0 = sol.y[:, -1]
    x, xdot, z = np.hstack(pieces)
    friction_N = np.empty_like(x)
    for i, t in enumerate(t_grid.tolist()):
        u, udot, _ = drive.support(t)
        friction_N[i] = law(t, x[i] - u, xdot[i] - udot, z[i])[1]
    return _series(drive, t_grid, x, xdot, z, friction_N, np.zeros(x.shape, dtype=bool))


# --------------------------------------------------------------------------------------------
# Rigid Coulomb: hybrid system, modes +1 / -1 (sliding in that direction) and 0 (stick)


def _simulate_coulomb(drive: _Rig, contact: _Contact, t_grid: np.ndarray, tolerances,
                      max_step_s: float) -> dict[str, np.ndarray]:
    """Integrate mode by mode, restarting at each event; stick rides with the support."""
    rtol, atol = tolerances
    atol = atol[:2] if np.ndim(atol) else atol
    modes = _coulomb_modes(drive, contact)
    t_end = t_grid[-1]
    t, y = 0.0, np.zeros(2)
    mode = -1 if drive.va > 0 else _coulomb_mode_at_rest(drive, contact, t, y)
    chunks: list[tuple[np.ndarray, np.ndarray, int]] = []
    n_done, n_empty = 0, 0
    while n_done < t_grid.size:
        rhs, events = modes[mode]
        sol = solve_ivp(rhs, (t, t_end), y, method=ODE_METHOD, t_eval=t_grid[n_done:],
                        events=events, rtol=rtol, atol=atol, max_step=max_step_s)
        if sol.status == -1:
            raise RuntimeError(f"reference integration failed at t={t} s: {sol.message}")
        if len(sol.t):  # a segment shorter than the sample spacing may hold no sample
            chunks.append((sol.t, sol.y, mode))
            n_done += len(sol.t)
        if sol.status == 0:
            break
        fired = next(i for i, times in enumerate(sol.t_events) if times.size)
        t_event, y = sol.t_events[fired][0], sol.y_events[fired][0].copy()
        # Leaving stick: the event says which way; reaching v_r = 0: the forces decide.
        mode = (1 if fired == 0 else -1) if mode == 0 else \
            _coulomb_mode_at_rest(drive, contact, t_event, y)
        if mode == 0:
            y[1] = drive.support(t_event)[1]  # ride exactly with the support
        n_empty = n_empty + 1 if t_event <= t else 0
        if n_empty > _MAX_EMPTY_SEGMENTS:
            raise RuntimeError(f"Coulomb stick/slip events do not advance at t={t} s")
        t = t_event
    return _coulomb_series(drive, contact, t_grid, chunks)


def _coulomb_needed_force(drive: _Rig, contact: _Contact, t: float, x: float,
                          xdot: float) -> float:
    """Contact force, less the offset, that keeps the slider riding with the support (stick)."""
    return drive.drive_force(t, x, xdot) - drive.m * drive.support(t)[2] - contact.offset_N


def _coulomb_mode_at_rest(drive: _Rig, contact: _Contact, t: float, y: np.ndarray) -> int:
    """Mode at v_r = 0: stick if the static level holds the needed force, else slide its way."""
    x_rel = y[0] - drive.support(t)[0]
    needed = _coulomb_needed_force(drive, contact, t, y[0], y[1])
    if needed > contact.static_limit(t, x_rel, 1):
        return 1
    if needed < -contact.static_limit(t, x_rel, -1):
        return -1
    return 0


def _coulomb_modes(drive: _Rig, contact: _Contact) -> dict[int, tuple[Callable, list]]:
    """mode -> (right-hand side, terminal events) for solve_ivp."""

    def sliding(direction: int):
        def rhs(t: float, y: np.ndarray) -> tuple[float, float]:
            x, xdot = y.tolist()
            u, udot, _ = drive.support(t)
            force = contact.sliding_force(t, x - u, xdot - udot, direction)
            return xdot, (drive.drive_force(t, x, xdot) - force) / drive.m

        def relative_velocity(t: float, y: np.ndarray) -> float:
            return y[1] - drive.support(t)[1]

        relative_velocity.terminal = True
        relative_velocity.direction = -direction  # v_r returns to zero
        return rhs, [relative_velocity]

    def stick_rhs(t: float, y: np.ndarray) -> tuple[float, float]:
        _, udot, uddot = drive.support(t)
        return udot, uddot

    def stick_limit(direction: int):
        def margin(t: float, y: np.ndarray) -> float:
            x_rel = y[0] - drive.support(t)[0]
            needed = _coulomb_needed_force(drive, contact, t, y[0], y[1])
            return needed - direction * contact.static_limit(t, x_rel, direction)

        margin.terminal = True
        margin.direction = direction
        return margin

    return {1: sliding(1), -1: sliding(-1), 0: (stick_rhs, [stick_limit(1), stick_limit(-1)])}


def _coulomb_series(drive: _Rig, contact: _Contact, t_grid: np.ndarray,
                    chunks: list) -> dict[str, np.ndarray]:
    x = np.concatenate([states[0] for _, states, _ in chunks])
    xdot = np.concatenate([states[1] for _, states, _ in chunks])
    modes = np.concatenate([np.full(times.size, mode) for times, _, mode in chunks])
    if x.size != t_grid.size:
        raise RuntimeError("Coulomb reference lost samples between segments")
    friction_N = np.empty_like(x)
    for i, (t, mode) in enumerate(zip(t_grid.tolist(), modes.tolist())):
        u, udot, _ = drive.support(t)
        if mode == 0:
            xdot[i] = udot  # v_r = 0 exactly while stuck
            friction_N[i] = _coulomb_needed_force(drive, contact, t, x[i], xdot[i]) + \
                contact.offset_N
        else:
            friction_N[i] = contact.sliding_force(t, x[i] - u, xdot[i] - udot, mode)
    return _series(drive, t_grid, x, xdot, np.zeros_like(x), friction_N, modes == 0)


# --------------------------------------------------------------------------------------------
# gms with constant levels: hybrid system, each element stuck (0) or slipping (+1 / -1)


def _simulate_gms(drive: _Rig, contact: _Contact, friction: FrictionParameters,
                  t_grid: np.ndarray, tolerances, max_step_s: float) -> dict[str, np.ndarray]:
    """Integrate between events (an element reaching its level, v_r = 0 while one slips)."""
    k = np.array(friction.gms_stiffness_N_per_m)
    n = len(k)
    weights = np.array(friction.gms_element_weights)
    weights = weights / weights.sum()  # (exactly 1 in all, as the plugin reads them)
    # the slip deflections in either direction (asymmetry gives each direction its level)
    limit = {s: weights * contact.coulomb_level(0.0, 0.0, s) / k for s in (1, -1)}
    rtol, atol = tolerances
    atol = np.concatenate([np.asarray(atol, dtype=float)[:2] if np.ndim(atol) else [atol] * 2,
                           np.full(n, atol[2] if np.ndim(atol) else atol)])

    t_end = t_grid[-1]
    t, y, modes = 0.0, np.zeros(2 + n), np.zeros(n, dtype=int)
    chunks: list[tuple[np.ndarray, np.ndarray]] = []
    n_done, n_empty = 0, 0
    while n_done < t_grid.size:
        rhs, events, meaning = _gms_segment(drive, contact, k, limit, modes)
        sol = solve_ivp(rhs, (t, t_end), y, method=ODE_METHOD, t_eval=t_grid[n_done:],
                        events=events or None, rtol=rtol, atol=atol, max_step=max_step_s)
        if sol.status == -1:
            raise RuntimeError(f"reference integration failed at t={t} s: {sol.message}")
        if len(sol.t):
            chunks.append((sol.t, sol.y))
            n_done += len(sol.t)
        if sol.status == 0:
            break
        fired = next(i for i, times in enumerate(sol.t_events) if times.size)
        t_event, y = sol.t_events[fired][0], sol.y_events[fired][0].copy()
        _gms_event(drive, contact, k, limit, meaning[fired], t_event, y, modes)
        n_empty = n_empty + 1 if t_event <= t else 0
        if n_empty > _MAX_EMPTY_SEGMENTS:
            raise RuntimeError(f"gms stick/slip events do not advance at t={t} s")
        t = t_event
    x = np.concatenate([states[0] for _, states in chunks])
    xdot = np.concatenate([states[1] for _, states in chunks])
    z = np.concatenate([states[2:] for _, states in chunks], axis=1)
    if x.size != t_grid.size:
        raise RuntimeError("gms reference lost samples between segments")
    v = xdot - drive.support_velocity(t_grid)
    friction_N = k @ z + contact.s2 * v + contact.offset_N
    return _series(drive, t_grid, x, xdot, k @ z / k.sum(), friction_N,
                   np.zeros(x.shape, dtype=bool))


# --------------------------------------------------------------------------------------------
# Outputs


def _gms_force(contact: _Contact, k: np.ndarray, v: float, z: np.ndarray) -> float:
    """The gms friction force (N) at relative velocity v (m/s) and element deflections z (m)."""
    return float(k @ z) + contact.s2 * v + contact.offset_N


def _gms_segment(drive: _Rig, contact: _Contact, k: np.ndarray, limit: dict,
                 modes: np.ndarray) -> tuple[Callable, list, list]:
    """(the right-hand side, the events, what each event means) of a segment in which the
    elements' modes (0 stuck, +-1 slipping that way, held at their level) stay as they are:
    a stuck element reaching its level, or (while one slips) v_r = 0."""
    stuck = modes == 0

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        _, udot, _ = drive.support(t)
        v = y[1] - udot
        out = np.empty_like(y)
        out[0] = y[1]
        out[1] = (drive.drive_force(t, y[0], y[1]) - _gms_force(contact, k, v, y[2:])) / drive.m
        out[2:] = np.where(stuck, v, 0.0)
        return out

    events, meaning = [], []
    for i in np.flatnonzero(stuck):
        for s in (1, -1):
            # (a margin of 1e-9 of the level: an element stuck at its level after v_r = 0
            # starts below its event, not on it within roundoff)
            def reach(t, y, i=i, s=s):
                return s * y[2 + i] - limit[s][i] * (1 + 1e-9)
            reach.terminal, reach.direction = True, 1
            events.append(reach)
            meaning.append((i, s))
    if not stuck.all():
        direction = int(modes[~stuck][0])

        def stop(t, y):
            return y[1] - drive.support(t)[1]
        stop.terminal, stop.direction = True, -direction
        events.append(stop)
        meaning.append((-1, 0))
    return rhs, events, meaning


def _gms_event(drive: _Rig, contact: _Contact, k: np.ndarray, limit: dict,
               meaning: tuple[int, int], t_event: float, y: np.ndarray,
               modes: np.ndarray) -> None:
    """Apply an event to the state y and the modes (in place): an element that reached its
    level slips from here, held at it; at v_r = 0 the slipping elements stick, unless the
    motion resumes their way."""
    element, s = meaning
    if element >= 0:
        modes[element] = s
        y[2 + element] = s * limit[s][element]
        return
    _, udot, uddot = drive.support(t_event)
    y[1] = udot  # v_r = 0
    modes[:] = 0
    v = y[1] - udot
    acceleration = (drive.drive_force(t_event, y[0], y[1]) -
                    _gms_force(contact, k, v, y[2:])) / drive.m - uddot
    resumes = np.sign(acceleration)
    if resumes:
        at_level = np.isclose(resumes * y[2:], limit[int(resumes)], rtol=1e-9, atol=0)
        modes[at_level] = int(resumes)


def _series(drive: _Rig, t: np.ndarray, x: np.ndarray, xdot: np.ndarray, z: np.ndarray,
            friction_N: np.ndarray, sticking: np.ndarray) -> dict[str, np.ndarray]:
    udot = drive.support_velocity(t)
    return {
        "slider_position_m": x, "slider_velocity_m_per_s": xdot,
        "support_velocity_m_per_s": udot, "relative_velocity_m_per_s": xdot - udot,
        "deflection_m": z,
        "friction_force_N": friction_N,
        "drive_force_N": np.array([drive.drive_force(ti, xi, vi) for ti, xi, vi in
                                   zip(t.tolist(), x.tolist(), xdot.tolist())]),
        "sticking": sticking,
    }


def drive_spring_force_N(rig: RigParameters, time_s: np.ndarray,
                         position_m: np.ndarray) -> np.ndarray:
    """The drive spring's force on the slider (what a dynamometer in it reads), through any
    backlash; the damper in parallel excluded."""
    drive = _Rig(rig)
    return np.array([drive.spring_force(t, x) for t, x in
                     zip(np.asarray(time_s, dtype=float).tolist(),
                         np.asarray(position_m, dtype=float).tolist())])


def first_order_lag(signal: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """tau y' + y = signal, exact for a signal linear between samples; starts at rest on it."""
    if tau_s <= 0:
        return signal
    one_minus_a = -math.expm1(-dt_s / tau_s)
    a = 1 - one_minus_a
    c = a - tau_s / dt_s * one_minus_a  # weight of the ramp between samples
    b, den = [one_minus_a + c, -c], [1.0, -a]
    zi = np.array([signal[0] * (1 - (one_minus_a + c))])  # steady state y = x = signal[0]
    return lfilter(b, den, signal, zi=zi)[0]


def support_motion(rig: RigParameters, t_s: np.ndarray,
                   vibration_from_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The support's displacement and velocity at ``t_s``, as ``simulate_reference`` moves it
    (``vibration_from_s``: default the rig's)."""
    drive = _Rig(rig, rig.vibration_from_s if vibration_from_s is None else vibration_from_s)
    motion = np.array([drive.support(t)[:2] for t in np.asarray(t_s, dtype=float).tolist()])
    return motion[:, 0], motion[:, 1]


__all__ = ["ReferenceResult", "simulate_reference", "support_motion", "first_order_lag",
           "drive_spring_force_N",
           "ODE_METHOD"]
