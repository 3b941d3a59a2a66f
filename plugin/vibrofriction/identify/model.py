"""The inverse model: measured motion in, predicted measured force out, via the plugin's laws.

    friction target:  y_hat = lag( F(v_r, x_rel, psi) )
    drive target:     y_hat = lag( m a + F(v_r, x_rel, psi) - h_d (v_d - xdot) )

F is ``laws.run_law`` -- the C++ law the MuJoCo plugin runs -- driven along the record's law
grid (record.py). The drive-force form is Newton's law for the body, m a = F_drive,measured +
h_d (v_d - xdot) - F: the dynamometer reads the drive spring, a damper acting in parallel
(``drive_damping``) pushes without passing through it. ``lag`` is the first-order sensor lag
(``sensor_lag_s``), discretized exactly for a signal linear between points and applied on the
law grid's substep ends (a contact transition is shorter than a sample interval).

Every fitted quantity is a field of FrictionParameters or RigParameters (``mass_kg``,
``drive_damping_N_s_per_m``), so a fitted model is a rig model the plugin can run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.signal import lfilter

from ..laws.run import run_law, steady_deflection_m
from ..params import LIMITS, FrictionParameters
from .record import Record

# The identification vocabulary (docs/interfaces.md), in the order candidates are listed.
EFFECTS = ("viscous", "stribeck", "asymmetry", "position_ripple", "normal_force_modulation",
           "normal_force_modulation_2f", "normal_force_modulation_3f",
           "normal_force_modulation_4f", "drive_damping", "sensor_lag", "force_offset")
# The normal load modulated at a harmonic n f of the vibration (a support that rocks or
# bounces twice a period, a cam): amplitude and phase fitted, one harmonic at a time (the
# plugin modulates the load at one frequency, so they exclude each other).
MODULATION_HARMONICS = {"normal_force_modulation": 1, "normal_force_modulation_2f": 2,
                        "normal_force_modulation_3f": 3, "normal_force_modulation_4f": 4}
# Effects of which a model holds at most one (the selection drops the others once one joins).
EXCLUSIVE_GROUPS = (tuple(MODULATION_HARMONICS),)


def exclusive_groups() -> tuple[tuple[str, ...], ...]:
    """EXCLUSIVE_GROUPS, and per level map the built-in map with the own effects it runs."""
    own = OWN_EFFECTS
    maps = tuple((m, *(n for n, e in own.items() if e.level_map == m)) for m in MAP_EFFECTS)
    return EXCLUSIVE_GROUPS + tuple(g for g in maps if len(g) > 1)


def excluded_by(effects: Sequence[str]) -> set[str]:
    """The effects that cannot join a model holding ``effects`` (their exclusive groups)."""
    out: set[str] = set()
    for group in exclusive_groups():
        if any(e in group for e in effects):
            out.update(e for e in group if e not in effects)
    return out


def modulation_not_applicable(reason: str | None, frequency_Hz: float | None = None,
                              dt_s: float | None = None) -> dict[str, str]:
    """effect -> why not, for the load modulations: all of them with ``reason`` (the support
    does not vibrate, ...), else the harmonics a record sampled every ``dt_s`` cannot resolve
    (above 0.8 of its Nyquist frequency)."""
    if reason:
        return {e: reason for e in MODULATION_HARMONICS}
    if not frequency_Hz or not dt_s:
        return {}
    nyquist = 0.5 / dt_s
    return {e: f"{n} f = {n * frequency_Hz:.4g} Hz is above 0.8 of the record's Nyquist "
               f"frequency ({nyquist:.4g} Hz)"
            for e, n in MODULATION_HARMONICS.items() if n * frequency_Hz > 0.8 * nyquist}


def without_declared(not_applicable: dict[str, str], declared: Sequence[str]) -> dict[str, str]:
    """``not_applicable`` (effect -> why not) less the declared effects (a declaration
    overrides, both paths); InputError for a declared harmonic of the load modulation that
    does not apply (it has no frequency without the vibration's; the fundamental keeps its
    meaning, the modulation frequency 0: the rig's vibration frequency)."""
    from ..errors import InputError
    out = dict(not_applicable)
    for effect in declared:
        if MODULATION_HARMONICS.get(effect, 1) > 1 and effect in out:
            raise InputError(f"--with {effect}: not applicable to this record: {out[effect]}")
        out.pop(effect, None)
    return out


def modulation_harmonic(effects: Sequence[str]) -> int:
    """n of the normal-load modulation among ``effects`` (0: none)."""
    return next((MODULATION_HARMONICS[e] for e in effects if e in MODULATION_HARMONICS), 0)
# Free-form effects beyond the vocabulary's narrow forms: the friction level as a spline along
# the travel, over the speed, and over time (a drift: heating, run-in, wear). Their shapes are
# free, so they compete with the vocabulary's narrower forms on the information criterion.
MAP_EFFECTS = ("position_map", "velocity_map", "time_map")
# A play in the contact before the bristles (FrictionParameters.contact_play_m): after each
# reversal the force falls to 0 and stays there across the play before the contact loads
# again on its other face. Traced on the inverse path, where the measured displacement drives
# the contact itself (the rig's backlash, below, sits before the dynamometer instead).
CONTACT_EFFECTS = ("contact_play",)
INVERSE_EFFECTS = EFFECTS + MAP_EFFECTS + CONTACT_EFFECTS
# Effects of the rig beyond the friction, which only the simulation path traces: backlash
# between the drive and the slider (a dead band of the drive spring). The inverse model takes
# the measured drive force as it is, so a play before the dynamometer does not enter it.
RIG_EFFECTS = ("backlash",)
SIMULATION_EFFECTS = EFFECTS + MAP_EFFECTS + RIG_EFFECTS
BUILT_IN_EFFECTS = INVERSE_EFFECTS + RIG_EFFECTS
# A researcher's own effects by name (``own_effects.LevelEffect``, put here by
# ``own_effects.register_effect``): candidates after the vocabulary's, on both paths.
OWN_EFFECTS: dict = {}


def inverse_effects() -> tuple[str, ...]:
    """The inverse path's candidates: the vocabulary's, then the own effects registered."""
    return INVERSE_EFFECTS + tuple(OWN_EFFECTS)


def simulation_effects() -> tuple[str, ...]:
    """The simulation path's candidates: the vocabulary's, then the own effects registered."""
    return SIMULATION_EFFECTS + tuple(OWN_EFFECTS)
# Knots of a fitted map: evenly over the record's relative position (its range) and over
# its speeds (0 to the 99th percentile of |v|); the factors sum to 0, so the map cannot trade
# with the friction coefficient.
POSITION_MAP_KNOTS = 8
VELOCITY_MAP_KNOTS = 6
# a drift is slow: a natural cubic spline through 4 knots over the record (a low-order curve
# that a vibration or a stick-slip cycle cannot imitate)
TIME_MAP_KNOTS = 4
MAP_FACTOR_BOUND = 0.9  # |factor| at a knot: the level stays within 0.1 and 1.9 times its mean

# Law parameters fitted in the baseline, per law (the effect fields are not law parameters).
LAW_PARAMETERS: dict[str, tuple[str, ...]] = {
    "coulomb": ("friction_coefficient",),
    "dahl": ("friction_coefficient", "contact_stiffness_N_per_m", "alpha"),
    "dupont": ("friction_coefficient", "contact_stiffness_N_per_m", "breakaway_ratio",
               "bristle_damping_N_s_per_m"),
    "lugre": ("friction_coefficient", "contact_stiffness_N_per_m", "bristle_damping_N_s_per_m"),
    # Maxwell-slip elements (their presliding curve): the total stiffness and the spread of
    # the elements' break-away deflections (``gms_elements``)
    "gms": ("friction_coefficient", "contact_stiffness_N_per_m", "gms_spread"),
}
IDENTIFIABLE_LAWS = tuple(LAW_PARAMETERS)
# Law gms is fitted with this many elements of equal weight whose break-away deflections
# w_i mu F_N / k_i lie evenly on a log scale between d and gms_spread d: the total stiffness
# sets the presliding slope, the spread how gradually the elements let go (1: all at once, the
# elasto-plastic limit). A record of the presliding loop informs two numbers of that curve,
# not every element's stiffness and weight.
GMS_FITTED_ELEMENTS = 3


def gms_elements(total_stiffness_N_per_m: float, spread: float,
                 count: int = GMS_FITTED_ELEMENTS) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(stiffnesses, weights) of ``count`` equal-weight elements with this total stiffness,
    their break-away deflections spread by the ratio ``spread`` (geometric)."""
    weights = tuple(1.0 / count for _ in range(count))
    ratios = [spread ** (i / (count - 1)) if count > 1 else 1.0 for i in range(count)]
    shares = [w / r for w, r in zip(weights, ratios)]  # k_i proportional to w_i / d_i
    stiffness = tuple(total_stiffness_N_per_m * c / sum(shares) for c in shares)
    return stiffness, weights


@dataclass(frozen=True)
class Param:
    """One internal coordinate q of the fit: theta = scale*q, or scale*exp(q) when log."""

    name: str
    lower: float
    upper: float
    scale: float
    log: bool = False

    def to_internal(self, value: float) -> float:
        if self.log:
            return math.log(max(value, self.lower * (1 + 1e-12)) / self.scale)
        return value / self.scale

    def from_internal(self, q: float) -> float:
        # (within the bounds exactly: exp and the product may land a few ulps past them)
        value = self.scale * math.exp(q) if self.log else self.scale * q
        return min(max(value, self.lower), self.upper)

    def internal_bounds(self) -> tuple[float, float]:
        if self.log:
            return math.log(self.lower / self.scale), math.log(self.upper / self.scale)
        return self.lower / self.scale, self.upper / self.scale


@dataclass(frozen=True)
class Scales:
    """Typical sizes in the record, used to scale the internal coordinates to O(1)."""

    force_N: float  # friction level
    velocity_m_per_s: float
    normal_force_N: float
    dt_s: float
    travel_m: float
    # quantiles of the record's estimated sliding speed: with a Stribeck curve the fit moves
    # the mean friction level over them, not mu (``Model.level_speeds_m_per_s``)
    sliding_speeds_m_per_s: tuple[float, ...] = ()
    # the record's relative-position range and top speed (the maps' knots)
    position_range_m: tuple[float, float] = (0.0, 1e-3)
    top_speed_m_per_s: float = 1e-3
    # the times a time map spans: from 0 at each record's first sample, on both paths (the
    # replayed scene's clock; a held-out record's map starts with it)
    time_range_s: tuple[float, float] = (0.0, 1.0)

    @classmethod
    def of(cls, record: Record, friction_level_N: float) -> "Scales":
        v = float(np.sqrt(np.mean(record.relative_velocity_m_per_s ** 2))) or 1e-3
        dt = float(np.median(np.diff(record.time_s)))
        travel = float(np.ptp(record.relative_position_m)) or 1e-3
        x = record.relative_position_m
        top = float(np.quantile(np.abs(record.relative_velocity_m_per_s), 0.99)) or v
        return cls(force_N=max(friction_level_N, 1e-9), velocity_m_per_s=v,
                   normal_force_N=float(np.median(record.normal_force_N)) or 1.0,
                   dt_s=dt, travel_m=travel, position_range_m=(float(x.min()), float(x.max())),
                   top_speed_m_per_s=top,
                   time_range_s=(0.0, float(record.time_s[-1] - record.time_s[0])))

    def map_knots(self, effect: str, count: int | None = None) -> tuple[float, ...]:
        """The knots of a fitted position, velocity or time map (``count`` of them, or the
        built-in map's number)."""
        if effect == "time_map":
            low, high = self.time_range_s
            return tuple(np.linspace(low, high if high > low else low + 1.0,
                                     count or TIME_MAP_KNOTS).tolist())
        if effect == "position_map":
            low, high = self.position_range_m
            return tuple(np.linspace(low, high if high > low else low + self.travel_m,
                                     count or POSITION_MAP_KNOTS).tolist())
        return tuple(np.linspace(0.0, self.top_speed_m_per_s,
                                 count or VELOCITY_MAP_KNOTS).tolist())


def parameter_table(law: str, effects: Sequence[str], fit_mass: bool,
                    scales: Scales, state: Sequence[str] = (),
                    scene: Sequence[str] = ()) -> list[Param]:
    """Internal coordinates for a law + effects (+ mass, + a scene's named values,
    + initial-state values)."""
    fn = scales.normal_force_N
    f, v = scales.force_N, scales.velocity_m_per_s
    mu = f / fn
    table: dict[str, Param] = {
        "friction_coefficient": Param("friction_coefficient", 0.0, 1e6 * mu, mu),
        "contact_stiffness_N_per_m": Param("contact_stiffness_N_per_m", f * 1e-6 / scales.travel_m,
                                           f * 1e12 / scales.travel_m,
                                           f * 100 / scales.travel_m, log=True),
        "alpha": Param("alpha", 0.05, 6.0, 1.0),
        "gms_spread": Param("gms_spread", 1.0, 1e4, 10.0, log=True),
        "breakaway_ratio": Param("breakaway_ratio", 0.02, 0.98, 1.0),
        "bristle_damping_N_s_per_m": Param("bristle_damping_N_s_per_m", 0.0, 1e6 * f / v,
                                           f / v),
        "viscous_N_s_per_m": Param("viscous_N_s_per_m", 0.0, 1e6 * f / v, 0.1 * f / v),
        # A Stribeck peak below 5x the Coulomb level, at a velocity the record resolves.
        "static_ratio": Param("static_ratio", 1.0, 5.0, 1.0),
        "stribeck_velocity_m_per_s": Param("stribeck_velocity_m_per_s", v * 1e-3, v * 10, v,
                                           log=True),
        "asymmetry": Param("asymmetry", -0.95, 0.95, 0.1),
        "ripple_cos": Param("ripple_cos", -0.65, 0.65, 0.1),
        "ripple_sin": Param("ripple_sin", -0.65, 0.65, 0.1),
        # Periodic in position: at least one whole wavelength within the record's travel.
        "position_ripple_wavelength_m": Param("position_ripple_wavelength_m",
                                              scales.travel_m * 1e-5, scales.travel_m,
                                              scales.travel_m, log=True),
        "modulation_cos": Param("modulation_cos", -0.65, 0.65, 0.1),
        "modulation_sin": Param("modulation_sin", -0.65, 0.65, 0.1),
        "drive_damping_N_s_per_m": Param("drive_damping_N_s_per_m", 0.0, 1e6 * f / v, 0.1 * f / v),
        # the play's whole width (the slider may stand while the drive end takes it up, so
        # it can exceed the slider's travel)
        "drive_backlash_m": Param("drive_backlash_m", 0.0, 10 * scales.travel_m,
                                  0.01 * scales.travel_m),
        "sensor_lag_s": Param("sensor_lag_s", 0.0, 1e4 * scales.dt_s, scales.dt_s),
        # a play in the contact: at most the record's travel (a wider one never closes)
        "contact_play_m": Param("contact_play_m", 0.0, scales.travel_m, 0.01 * scales.travel_m),
        "force_offset_N": Param("force_offset_N", -1e3 * f, 1e3 * f, 0.1 * f),
        "mass_kg": Param("mass_kg", 1e-9, 1e9, 1.0),
        # a scene's named value: the damping of the slide joint its mapping names
        "joint_damping_N_s_per_m": Param("joint_damping_N_s_per_m", 0.0, 1e6 * f / v,
                                         0.1 * f / v),
        # the replayed body's velocity at the first sample (a nuisance of the training record)
        "initial_velocity_m_per_s": Param("initial_velocity_m_per_s", -1e3 * v, 1e3 * v, v),
        # a map's free factors (the last is minus their sum, held within the same bound)
        **{name: Param(name, -MAP_FACTOR_BOUND, MAP_FACTOR_BOUND, 0.1)
           for effect in MAP_EFFECTS for name in EFFECT_INTERNALS[effect]},
        # an own effect's parameters, as its author bounded them
        **{p.name: Param(p.name, p.lower, p.upper, p.scale, p.log)
           for e in OWN_EFFECTS.values() for p in e.parameters},
    }
    # Within the vocabulary's limits (params.LIMITS): a fit never proposes a value the
    # plugin or the parameter check would refuse.
    for name, param in list(table.items()):
        if name in LIMITS:
            smallest, largest = LIMITS[name]
            upper = min(param.upper, largest)
            lower = param.lower if param.lower == 0 or param.lower >= smallest or \
                param.lower < 0 else smallest
            lower = max(lower, -largest)
            if lower >= upper:  # a record of absurd scale: keep the table's own bounds
                lower, upper = param.lower, param.upper
            table[name] = replace(param, lower=lower, upper=upper)
    names = list(LAW_PARAMETERS[law])
    for effect in effects:
        names.extend(effect_internals(effect))
    if fit_mass:
        names.append("mass_kg")
    names.extend(scene)
    names.extend(state)
    return [table[name] for name in names]


# Internal coordinates of each effect.
EFFECT_INTERNALS: dict[str, tuple[str, ...]] = {
    "viscous": ("viscous_N_s_per_m",),
    "stribeck": ("static_ratio", "stribeck_velocity_m_per_s"),
    "asymmetry": ("asymmetry",),
    "position_ripple": ("ripple_cos", "ripple_sin", "position_ripple_wavelength_m"),
    **{e: ("modulation_cos", "modulation_sin") for e in MODULATION_HARMONICS},
    "drive_damping": ("drive_damping_N_s_per_m",),
    "sensor_lag": ("sensor_lag_s",),
    "force_offset": ("force_offset_N",),
    "backlash": ("drive_backlash_m",),
    "contact_play": ("contact_play_m",),
    "position_map": tuple(f"position_map_c{i}" for i in range(1, POSITION_MAP_KNOTS)),
    "velocity_map": tuple(f"velocity_map_c{i}" for i in range(1, VELOCITY_MAP_KNOTS)),
    "time_map": tuple(f"time_map_c{i}" for i in range(1, TIME_MAP_KNOTS)),
}
# Physical parameters each effect sets (vocabulary names: FrictionParameters / RigParameters).
EFFECT_FIELDS: dict[str, tuple[str, ...]] = {
    "viscous": ("viscous_N_s_per_m",),
    "stribeck": ("static_ratio", "stribeck_velocity_m_per_s"),
    "asymmetry": ("asymmetry",),
    "position_ripple": ("position_ripple", "position_ripple_wavelength_m",
                        "position_ripple_phase_rad"),
    **{e: ("normal_force_modulation", "normal_force_modulation_phase_rad")
       for e in MODULATION_HARMONICS},
    "drive_damping": ("drive_damping_N_s_per_m",),
    "sensor_lag": ("sensor_lag_s",),
    "force_offset": ("force_offset_N",),
    "backlash": ("drive_backlash_m",),
    "contact_play": ("contact_play_m",),
    # a map's factor at each knot (FrictionParameters' position_map_factors /
    # velocity_map_factors, with the knots the model holds)
    "position_map": tuple(f"position_map_factor_{i}" for i in range(1, POSITION_MAP_KNOTS + 1)),
    "velocity_map": tuple(f"velocity_map_factor_{i}" for i in range(1, VELOCITY_MAP_KNOTS + 1)),
    "time_map": tuple(f"time_map_factor_{i}" for i in range(1, TIME_MAP_KNOTS + 1)),
}


def effect_internals(effect: str) -> tuple[str, ...]:
    """An effect's internal coordinates (an own effect's: its parameters)."""
    own = OWN_EFFECTS.get(effect)
    return tuple(p.name for p in own.parameters) if own else EFFECT_INTERNALS[effect]


def effect_fields(effect: str) -> tuple[str, ...]:
    """The values an effect reports (an own effect's: its parameters)."""
    own = OWN_EFFECTS.get(effect)
    return tuple(p.name for p in own.parameters) if own else EFFECT_FIELDS[effect]


def own_map_effects(effects: Sequence[str]) -> list[str]:
    """The level maps that the own effects among ``effects`` run as."""
    own = OWN_EFFECTS
    return [own[e].level_map for e in effects if e in own]


def own_parameter_names(effects: Sequence[str]) -> list[str]:
    """The parameters of the own effects among ``effects`` (reported; not --set names: the
    plugin runs them as their level map's knots and factors)."""
    own = OWN_EFFECTS
    return [p.name for e in effects if e in own for p in own[e].parameters]


# prefixes of the fit's internal coordinates (an own parameter named so would be taken for one)
RESERVED_PREFIXES = ("position_map_", "velocity_map_", "time_map_", "ripple_", "modulation_")


def taken_parameter_names() -> set[str]:
    """Names an own effect's parameter may not take (the fit's and the vocabulary's: the
    friction's and the rig's parameters, the reported values)."""
    from dataclasses import fields as dataclass_fields
    from ..params import RigParameters
    taken = {f.name for f in dataclass_fields(FrictionParameters)}
    taken.update(f.name for f in dataclass_fields(RigParameters))
    taken.update(("normal_force_N", "drive_backlash_centre_m", "friction_coefficient_unit"))
    for names in (*EFFECT_INTERNALS.values(), *EFFECT_FIELDS.values(),
                  *LAW_PARAMETERS.values()):
        taken.update(names)
    taken.update(("mass_kg", "joint_damping_N_s_per_m", "initial_velocity_m_per_s",
                  "gms_spread"))
    for e in OWN_EFFECTS.values():
        taken.update(p.name for p in e.parameters)
    return taken


@dataclass(frozen=True)
class Model:
    """A law with a set of effects (and maybe the mass) over a fixed parameter table."""

    law: str
    effects: tuple[str, ...]
    fit_mass: bool
    params: tuple[Param, ...]
    base: FrictionParameters = field(default_factory=FrictionParameters)
    # initial-state values fitted with the parameters (a nuisance, not part of the model
    # users simulate): ``initial_velocity_m_per_s`` on a rig record
    state: tuple[str, ...] = ()
    # named values of a machine scene fitted with the parameters (part of the model users
    # simulate: they are written into the fitted scene), e.g. ``joint_damping_N_s_per_m``
    scene: tuple[str, ...] = ()
    # With a Stribeck curve, friction_coefficient's coordinate is the mean friction level over
    # these sliding speeds, mu <g/mu F_N>, not mu. A record fixes that level tightly and the
    # curve's shape loosely: in (mu, static_ratio) the optimum lies at the end of a long
    # curved valley (measured: a noise-free position-only LuGre record with static ratio 1.3
    # came back at 1.01-1.02 and mu +14 %; in the level coordinate, with the restarts of
    # ``simulation._STRIBECK_RESTARTS``, exactly). Empty: mu itself.
    level_speeds_m_per_s: tuple[float, ...] = ()
    # the knots of the fitted maps (Scales.map_knots), empty when the map is not fitted
    position_map_knots_m: tuple[float, ...] = ()
    velocity_map_knots_m_per_s: tuple[float, ...] = ()
    time_map_knots_s: tuple[float, ...] = ()

    @classmethod
    def build(cls, law: str, effects: Sequence[str], fit_mass: bool, scales: Scales,
              base: FrictionParameters | None = None, state: Sequence[str] = (),
              scene: Sequence[str] = ()) -> "Model":
        effects = tuple(e for e in BUILT_IN_EFFECTS + tuple(OWN_EFFECTS)
                        if e in effects)
        base = base or FrictionParameters(law=law)
        speeds = tuple(scales.sliding_speeds_m_per_s) if "stribeck" in effects else ()
        knots = {}  # each level map's knots: a built-in map's, or an own effect's over it
        for effect in effects:
            own = OWN_EFFECTS.get(effect)
            if own is not None:
                knots[own.level_map] = scales.map_knots(own.level_map, own.knots)
            elif effect in MAP_EFFECTS:
                knots[effect] = scales.map_knots(effect)
        return cls(law=law, effects=effects, fit_mass=fit_mass,
                   params=tuple(parameter_table(law, effects, fit_mass, scales, state, scene)),
                   base=replace(base, law=law), state=tuple(state), scene=tuple(scene),
                   level_speeds_m_per_s=speeds,
                   position_map_knots_m=knots.get("position_map", ()),
                   velocity_map_knots_m_per_s=knots.get("velocity_map", ()),
                   time_map_knots_s=knots.get("time_map", ()))

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def k(self) -> int:
        return len(self.params)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = zip(*(p.internal_bounds() for p in self.params))
        return np.array(lo), np.array(hi)

    def internal(self, values: Mapping[str, float]) -> np.ndarray:
        """q for the given named internal values (missing ones: the table's neutral value)."""
        # (within the bounds before the level is formed: the clipped curve is the one run)
        named = {p.name: min(max(values.get(p.name, _neutral(p)), p.lower), p.upper)
                 for p in self.params}
        if self.level_speeds_m_per_s:
            named["friction_coefficient"] *= self._mean_shape(named)
        q = np.array([p.to_internal(named[p.name]) for p in self.params])
        lo, hi = self.bounds()
        return np.clip(q, lo, hi)

    def internal_values(self, q: np.ndarray) -> dict[str, float]:
        """The named values (physical: mu, not the level coordinate) at q."""
        raw = {p.name: p.from_internal(float(x)) for p, x in zip(self.params, q)}
        if self.level_speeds_m_per_s:
            mu = next(p for p in self.params if p.name == "friction_coefficient")
            raw[mu.name] = min(max(raw[mu.name] / self._mean_shape(raw), mu.lower), mu.upper)
        return raw

    def _mean_shape(self, named: Mapping[str, float]) -> float:
        """<g(v)> / (mu F_N) over the level speeds: the Stribeck curve's mean factor."""
        speeds = np.asarray(self.level_speeds_m_per_s)
        excess = named.get("static_ratio", 1.0) - 1.0
        v_s = named.get("stribeck_velocity_m_per_s", 1.0)
        return float(1.0 + excess * np.mean(np.exp(-(speeds / v_s) ** 2)))

    def values(self, q: np.ndarray) -> dict[str, float]:
        """Physical values (vocabulary names) of everything this model fits."""
        raw = self.internal_values(q)
        out = {k: v for k, v in raw.items()
               if k not in ("ripple_cos", "ripple_sin", "modulation_cos", "modulation_sin")
               and not k.startswith(tuple(f"{e}_c" for e in MAP_EFFECTS))}
        for effect in MAP_EFFECTS:
            free = [raw[n] for n in EFFECT_INTERNALS[effect] if n in raw]
            if free:  # the last factor closes the sum to 0, within the factors' range (> -1)
                closing = min(max(-sum(free), -MAP_FACTOR_BOUND), MAP_FACTOR_BOUND)
                for name, value in zip(EFFECT_FIELDS[effect], [*free, closing]):
                    out[name] = value
        if "ripple_cos" in raw:
            out["position_ripple"] = math.hypot(raw["ripple_cos"], raw["ripple_sin"])
            out["position_ripple_phase_rad"] = math.atan2(raw["ripple_sin"], raw["ripple_cos"])
        if "modulation_cos" in raw:
            out["normal_force_modulation"] = math.hypot(raw["modulation_cos"],
                                                        raw["modulation_sin"])
            out["normal_force_modulation_phase_rad"] = math.atan2(raw["modulation_sin"],
                                                                  raw["modulation_cos"])
        return out

    def extended(self, effect: str, scales: Scales) -> "Model":
        return Model.build(self.law, (*self.effects, effect), self.fit_mass, scales, self.base,
                           self.state, self.scene)

    # ------------------------------------------------------------------------------ predict

    def friction_parameters(self, values: Mapping[str, float],
                            vibration_frequency_Hz: float | None = None) -> FrictionParameters:
        """The FrictionParameters these values define (for the plugin / rig)."""
        fields = {k: v for k, v in values.items() if hasattr(self.base, k)}
        registered = OWN_EFFECTS
        knots = {"position_map": self.position_map_knots_m,
                 "velocity_map": self.velocity_map_knots_m_per_s,
                 "time_map": self.time_map_knots_s}
        for effect in self.effects:
            if effect in MAP_EFFECTS:
                factors = tuple(values[n] for n in EFFECT_FIELDS[effect])
            elif effect in registered:  # an own effect: its factor at its map's knots
                factors = registered[effect].factors(np.asarray(knots[registered[effect]
                                                                      .level_map]), values)
                effect = registered[effect].level_map
            else:
                continue
            unit = {"position_map": "m", "velocity_map": "m_per_s", "time_map": "s"}[effect]
            fields[f"{effect}_knots_{unit}"] = knots[effect]
            fields[f"{effect}_factors"] = factors
        if self.law == "gms":
            fields["gms_stiffness_N_per_m"], fields["gms_weights"] = gms_elements(
                values.get("contact_stiffness_N_per_m", self.base.contact_stiffness_N_per_m),
                values.get("gms_spread", 10.0))
        friction = replace(self.base, **fields)
        harmonic = modulation_harmonic(self.effects)
        if harmonic and "normal_force_modulation" in values:
            if vibration_frequency_Hz:
                friction = replace(friction, normal_force_modulation_frequency_Hz=harmonic *
                                   vibration_frequency_Hz)
            elif harmonic > 1:  # (0 would mean the vibration frequency itself)
                raise ValueError(f"a load modulation at {harmonic} f needs the vibration "
                                 "frequency")
        return friction

    def predict(self, record: Record, q: np.ndarray, *,
                mass_kg: float | None = None) -> np.ndarray:
        """Predicted measured force at the record's samples (before the record's low-pass)."""
        return self.predict_values(record, self.values(q), mass_kg=mass_kg)

    def predict_values(self, record: Record, values: Mapping[str, float], *,
                       mass_kg: float | None = None) -> np.ndarray:
        # (the modulation is applied here, on the support's measured phase)
        friction = replace(self.friction_parameters(values, record.vibration_frequency_Hz),
                           normal_force_modulation=0.0,
                           sensor_lag_s=0.0)
        normal = record.grid_normal_force_N
        modulation = values.get("normal_force_modulation", 0.0)
        if modulation and record.vibrating:
            phase = values.get("normal_force_modulation_phase_rad", 0.0)
            harmonic = modulation_harmonic(self.effects) or 1
            normal = normal * (1.0 + modulation * np.sin(harmonic * record.grid_support_phase_rad()
                                                         + phase))
        position = record.grid_position_m if (values.get("position_ripple", 0.0) or
                                              self.position_map_knots_m) else None
        z0 = 0.0
        if record.starts_in_motion:  # sliding when the record starts: the steady state there
            z0 = steady_deflection_m(
                friction, record.grid_velocity_m_per_s[0], normal_force_N=float(normal[0]),
                position_m=None if position is None else float(position[0]),
                time_s=0.0)
        # (the law's clock from 0 at the record's first sample: a time map's, as by
        # simulation; nothing else in the law reads the time here)
        run = run_law(friction, record.grid_time_s - record.time_s[0],
                      record.grid_velocity_m_per_s,
                      normal_force_N=normal, position_m=position, initial_deflection_m=z0)
        lag = values.get("sensor_lag_s", 0.0)
        if lag > 0 and record.stride > 1 and record.target == "friction":
            # Lag on the substep ends (every second grid point): a contact transition is
            # shorter than a sample interval, and the filter is exact only for a signal
            # linear between its points.
            substeps = record.stride // 2
            dt = None if record.uniform_dt_s is None else record.uniform_dt_s / substeps
            ends = first_order_lag(run.friction_force_N[0::2], record.grid_time_s[0::2], lag,
                                   dt)
            return ends[::substeps]
        force = run.friction_force_N[::record.stride]
        if record.target == "drive":
            mass = values.get("mass_kg", mass_kg if mass_kg is not None else record.mass_kg)
            force = mass * record.acceleration_m_per_s2 + force
            damping = values.get("drive_damping_N_s_per_m", 0.0)
            if damping:
                force = force - damping * (record.drive_velocity_m_per_s -
                                           record.body_velocity_m_per_s)
        lag = values.get("sensor_lag_s", 0.0)
        if lag > 0:
            force = first_order_lag(force, record.time_s, lag, record.uniform_dt_s)
        return force


def forward_steps(q: np.ndarray, upper: np.ndarray, count: int, relative_step: float
                  ) -> list[tuple[np.ndarray, float]]:
    """(q with coordinate j moved, the step) for each of the first ``count`` coordinates: a
    forward step of ``relative_step`` max(1, |q_j|), backward where it would pass ``upper``."""
    out = []
    for j in range(count):
        h = relative_step * max(1.0, abs(q[j]))
        h = h if q[j] + h <= upper[j] else -h
        moved = np.array(q, dtype=float)
        moved[j] += h
        out.append((moved, h))
    return out


def _neutral(p: Param) -> float:
    """Value of a parameter that switches its effect off (or a middle value)."""
    neutral = {"static_ratio": 1.0, "alpha": 1.0, "breakaway_ratio": 0.7, "gms_spread": 10.0}
    if p.name in neutral:
        return neutral[p.name]
    if p.log:
        return p.scale
    return min(max(0.0, p.lower), p.upper)


def first_order_lag(signal: np.ndarray, time_s: np.ndarray, tau_s: float,
                    uniform_dt_s: float | None) -> np.ndarray:
    """tau y' + y = signal, exact for a signal linear between samples; y starts at signal[0]."""
    if uniform_dt_s is not None:
        a = math.exp(-uniform_dt_s / tau_s)
        one_minus_a = -math.expm1(-uniform_dt_s / tau_s)
        c = a - tau_s / uniform_dt_s * one_minus_a  # weight of the ramp between samples
        b, den = [one_minus_a + c, -c], [1.0, -a]
        zi = np.array([signal[0] * (1 - (one_minus_a + c))])
        return lfilter(b, den, signal, zi=zi)[0]
    out = np.empty_like(signal)
    out[0] = signal[0]
    dts = np.diff(time_s)
    for i, dt in enumerate(dts.tolist()):
        a = math.exp(-dt / tau_s)
        one_minus_a = 1.0 - a
        c = a - tau_s / dt * one_minus_a
        out[i + 1] = a * out[i] + (one_minus_a + c) * signal[i + 1] - c * signal[i]
    return out


ProgressFn = Callable[[str], None]

__all__ = ["BUILT_IN_EFFECTS", "inverse_effects", "simulation_effects", "effect_internals",
           "effect_fields", "exclusive_groups", "own_map_effects", "own_parameter_names",
           "taken_parameter_names", "IDENTIFIABLE_LAWS", "MODULATION_HARMONICS", "EXCLUSIVE_GROUPS", "excluded_by",
           "modulation_harmonic", "modulation_not_applicable", "without_declared", "gms_elements", "GMS_FITTED_ELEMENTS", "EFFECTS", "MAP_EFFECTS", "CONTACT_EFFECTS", "INVERSE_EFFECTS", "LAW_PARAMETERS", "EFFECT_FIELDS", "EFFECT_INTERNALS", "Param", "Scales",
           "Model", "first_order_lag", "forward_steps"]
