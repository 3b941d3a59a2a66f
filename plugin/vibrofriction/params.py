"""Parameter dataclasses of the rig and the friction element (the friction part's names,
defaults and limits: ``vocabulary.FRICTION_TERMS``, the one table; docs/simulation.md).

Every field is in SI units with the unit in its name. The same names are used by the
Python API, the CLI's ``--set NAME=VALUE``, JSON outputs and dataset sidecars.

Values the paper (Gutowski & Leus 2012) does not give are chosen here, once:

* ``friction_coefficient`` 0.2 -- dry steel on cast iron is 0.15-0.25 in handbooks; the paper's
  results are reported as ratios F_d-v/F_d-s, which do not depend on it.
* ``drive_stiffness_N_per_m`` 1e6 -- a ring dynamometer in series with a screw drive; it puts the
  drive resonance (225 Hz with m = 0.5 kg) far below the 2.6-4 kHz excitation, so the drive
  spring averages the vibration as in the paper's rig, and loads to breakaway in about 50 ms.
* ``alpha`` 1 -- Dahl's usual value ("ductile" materials, Bliman 1992).
* ``breakaway_ratio`` 0.7 -- Dupont et al. (2002) suggest z_ba a fraction of z_ss; 0.7 keeps a
  clear elastic stick range.
* ``bristle_damping_N_s_per_m`` 0 for Dupont; LuGre uses sqrt(k_t m)/5 (damping ratio 0.1 of
  the contact resonance) -- see ``lugre_default_bristle_damping``.
* ``static_ratio`` 1 and ``stribeck_velocity_m_per_s`` 1e-3 -- the paper's rig shows no Stribeck
  peak; 1.0 disables it.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields, replace
from typing import Any, Mapping

from .errors import InputError
from .vocabulary import (ALL_LAWS, DEFAULTS, FRICTION_TERMS, MAX_GMS_ELEMENTS, MAX_MAP_KNOTS,
                         PAPER_CONTACT_STIFFNESS_N_PER_M, PAPER_LAWS, TERMS_BY_NAME)
from .vocabulary import LIMITS as _FRICTION_LIMITS

# The list-valued fields (tuples; --set takes "a,b,c" or "a b c")
_LIST_FIELDS = tuple(t.name for t in FRICTION_TERMS if t.is_list)
# The fields only law gms uses (empty or idle for the other laws)
_GMS_FIELDS = tuple(t.name for t in FRICTION_TERMS if t.laws == ("gms",))

# The laws the study and identification run (the paper's four); ALL_LAWS adds gms, which the
# elements simulate. ALL_LAWS is the C++ Law enum's order: ALL_LAWS.index(law) is its value.
LAWS = PAPER_LAWS

# Paper values (Gutowski & Leus 2012, section 4): p = 0.046 N/mm^2 on S = 1200 mm^2.
PAPER_NORMAL_FORCE_N = 0.046 * 1200.0
# A vibration switched on during a run (``vibration_from_s``) builds up over this many periods
# (amplitude (1 - cos(pi tau / T)) / 2, as a shaker's): neither velocity nor acceleration jumps.
VIBRATION_RAMP_PERIODS = 20


# The largest magnitude each value may take (SI): far beyond any friction rig or machine, so no
# real value is refused, small enough that the simulation's arithmetic stays finite (a mass of
# 1e-300 kg is below MuJoCo's mjMINVAL, a vibration of 1e308 m/s overflows the timestep rule).
LIMITS: dict[str, tuple[float, float]] = {  # name -> (smallest nonzero magnitude, largest)
    "mass_kg": (1e-9, 1e9),
    "drive_stiffness_N_per_m": (1e-9, 1e15),
    "drive_damping_N_s_per_m": (0.0, 1e12),
    "drive_velocity_m_per_s": (1e-12, 1e3),
    "vibration_frequency_Hz": (0.0, 1e7),
    "vibration_velocity_amplitude_m_per_s": (0.0, 1e3),
    "vibration_from_s": (0.0, 1e9),
    "normal_force_N": (0.0, 1e9),
    "drive_backlash_m": (0.0, 1.0),
    "drive_backlash_stiffness_N_per_m": (1e-9, 1e15),
    "drive_backlash_centre_m": (0.0, 1.0),
    **_FRICTION_LIMITS,  # (vocabulary.FRICTION_TERMS)
}


def _check_limits(params: Any) -> None:
    for name, (smallest, largest) in LIMITS.items():
        if not hasattr(params, name):
            continue
        value = getattr(params, name)
        for item in value if isinstance(value, tuple) else (value,):  # (a list: each value)
            if isinstance(item, (int, float)) and math.isfinite(item) and (
                    abs(item) > largest or 0 < abs(item) < smallest):
                rule = f"must lie within +-{largest:g}" + (
                    f" and be 0 or at least {smallest:g} in magnitude" if smallest else "")
                raise ParameterError(f"parameter {name}={plain_value(value)!r} {rule} (SI units)")


class ParameterError(InputError):
    """A parameter is unknown, not a number, or out of its range; the message says which."""


@dataclass(frozen=True)
class RigParameters:
    """The paper's rig: slider on a table vibrating along the sliding direction (eqs. 2-14)."""

    mass_kg: float = 0.5
    drive_stiffness_N_per_m: float = 1.0e6
    drive_damping_N_s_per_m: float = 0.0
    drive_velocity_m_per_s: float = 0.5e-3
    vibration_frequency_Hz: float = 4000.0
    vibration_velocity_amplitude_m_per_s: float = 0.0
    normal_force_N: float = PAPER_NORMAL_FORCE_N
    # > 0: the table stands still until then, and its vibration builds up over
    # VIBRATION_RAMP_PERIODS periods from then on (a stage without vibration first)
    vibration_from_s: float = 0.0
    # Backlash between the drive and the slider: the drive spring transmits nothing while its
    # extension x - x_B lies within drive_backlash_centre_m +- drive_backlash_m / 2 (the play;
    # centre 0: centred on the start, where x = x_B), then acts through the play's faces,
    # whose contact stiffness is in series with it (0: rigid faces).
    drive_backlash_m: float = 0.0
    drive_backlash_stiffness_N_per_m: float = 0.0
    drive_backlash_centre_m: float = 0.0

    @property
    def drive_chain_stiffness_N_per_m(self) -> float:
        """The stiffness the drive pulls with outside the play: k_d in series with the play's
        faces (k_d alone with rigid faces or no backlash)."""
        k_d, k_c = self.drive_stiffness_N_per_m, self.drive_backlash_stiffness_N_per_m
        if self.drive_backlash_m == 0 or k_c == 0:
            return k_d
        return k_d * k_c / (k_d + k_c)

    @property
    def vibration_amplitude_m(self) -> float:
        """u0 = v_a / (2 pi f)  (eq. 14)."""
        if self.vibration_frequency_Hz <= 0:
            return 0.0
        return self.vibration_velocity_amplitude_m_per_s / (2 * math.pi * self.vibration_frequency_Hz)

    @property
    def kappa(self) -> float:
        """kappa_v = v_a / v_d."""
        return self.vibration_velocity_amplitude_m_per_s / self.drive_velocity_m_per_s

    def validate(self) -> "RigParameters":
        _check_limits(self)
        _require(self.mass_kg > 0, "mass_kg", self.mass_kg, "must be > 0")
        _require(self.drive_stiffness_N_per_m > 0, "drive_stiffness_N_per_m",
                 self.drive_stiffness_N_per_m, "must be > 0")
        _require(self.drive_damping_N_s_per_m >= 0, "drive_damping_N_s_per_m",
                 self.drive_damping_N_s_per_m, "must be >= 0")
        _require(self.vibration_frequency_Hz >= 0, "vibration_frequency_Hz",
                 self.vibration_frequency_Hz, "must be >= 0")
        _require(self.vibration_velocity_amplitude_m_per_s >= 0,
                 "vibration_velocity_amplitude_m_per_s",
                 self.vibration_velocity_amplitude_m_per_s, "must be >= 0")
        _require(self.normal_force_N >= 0, "normal_force_N", self.normal_force_N, "must be >= 0")
        _require(self.vibration_from_s >= 0, "vibration_from_s", self.vibration_from_s,
                 "must be >= 0 (s)")
        _require(self.drive_backlash_m >= 0, "drive_backlash_m", self.drive_backlash_m,
                 "must be >= 0 (m, the play's whole width)")
        _require(self.drive_backlash_stiffness_N_per_m >= 0, "drive_backlash_stiffness_N_per_m",
                 self.drive_backlash_stiffness_N_per_m, "must be >= 0 (N/m; 0: rigid faces)")
        _require(self.drive_velocity_m_per_s != 0, "drive_velocity_m_per_s",
                 self.drive_velocity_m_per_s, "must be non-zero")
        return self


@dataclass(frozen=True)
class FrictionParameters:
    """A friction law and its parameters; the effect fields are switched off at 0."""

    # (defaults: vocabulary.FRICTION_TERMS, the one table of names, keys, units and defaults)
    law: str = "dahl"
    friction_coefficient: float = DEFAULTS["friction_coefficient"]
    contact_stiffness_N_per_m: float = DEFAULTS["contact_stiffness_N_per_m"]
    alpha: float = DEFAULTS["alpha"]
    breakaway_ratio: float = DEFAULTS["breakaway_ratio"]
    bristle_damping_N_s_per_m: float = DEFAULTS["bristle_damping_N_s_per_m"]
    viscous_N_s_per_m: float = DEFAULTS["viscous_N_s_per_m"]
    static_ratio: float = DEFAULTS["static_ratio"]
    stribeck_velocity_m_per_s: float = DEFAULTS["stribeck_velocity_m_per_s"]
    # Effects (identification vocabulary); each 0 = off.
    asymmetry: float = DEFAULTS["asymmetry"]  # level (1 + a) for v > 0, (1 - a) for v < 0
    position_ripple: float = DEFAULTS["position_ripple"]  # relative amplitude, periodic in x
    position_ripple_wavelength_m: float = DEFAULTS["position_ripple_wavelength_m"]
    position_ripple_phase_rad: float = DEFAULTS["position_ripple_phase_rad"]
    # F_N (1 + m sin(2 pi f_m t + phase)): m the relative amplitude, f_m the frequency (Hz).
    normal_force_modulation: float = DEFAULTS["normal_force_modulation"]
    # f_m = 0 means "the vibration frequency" wherever a rig is given (rig.build_spec and
    # rig.friction_config, planar.build_rig_spec, reference.simulate_reference): they write
    # RigParameters.vibration_frequency_Hz into the MJCF key modulation_frequency, in which 0
    # means 0 Hz (a constant factor 1 + m sin(phase)). Without a rig (laws.run_law,
    # planar.planar_config, planar.run_planar_law) 0 is passed on, so it is 0 Hz there.
    normal_force_modulation_frequency_Hz: float = \
        DEFAULTS["normal_force_modulation_frequency_Hz"]
    normal_force_modulation_phase_rad: float = DEFAULTS["normal_force_modulation_phase_rad"]
    force_offset_N: float = DEFAULTS["force_offset_N"]
    # width (m) of a play in the contact before the bristles (dahl, dupont, lugre): inside it
    # the contact is open and carries no friction force
    contact_play_m: float = DEFAULTS["contact_play_m"]
    # law gms: element i's stiffness (N/m) and share of the level (default: equal shares), and
    # the time constant (s) with which a slipping element's force reaches its level (0: at once)
    gms_stiffness_N_per_m: tuple[float, ...] = DEFAULTS["gms_stiffness_N_per_m"]
    gms_weights: tuple[float, ...] = DEFAULTS["gms_weights"]
    gms_relaxation_time_s: float = DEFAULTS["gms_relaxation_time_s"]
    # The level times max(0, 1 + s), s a cubic spline through (knot, factor) pairs along the
    # relative position (periodic when the period is > 0), over the speed |v| and over the
    # time t (drift: heating, run-in, wear) (1D element)
    position_map_knots_m: tuple[float, ...] = DEFAULTS["position_map_knots_m"]
    position_map_factors: tuple[float, ...] = DEFAULTS["position_map_factors"]
    position_map_period_m: float = DEFAULTS["position_map_period_m"]
    velocity_map_knots_m_per_s: tuple[float, ...] = DEFAULTS["velocity_map_knots_m_per_s"]
    velocity_map_factors: tuple[float, ...] = DEFAULTS["velocity_map_factors"]
    time_map_knots_s: tuple[float, ...] = DEFAULTS["time_map_knots_s"]
    time_map_factors: tuple[float, ...] = DEFAULTS["time_map_factors"]
    sensor_lag_s: float = DEFAULTS["sensor_lag_s"]  # first-order lag of the reported force

    def __post_init__(self) -> None:
        # Lists and arrays become tuples of floats: the parameters stay hashable and immutable.
        for name in _LIST_FIELDS:
            value = getattr(self, name)
            if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
                raise ParameterError(f"parameter {name}={plain_value(value)!r} must be a list of "
                                     "numbers")
            try:
                object.__setattr__(self, name, tuple(float(x) for x in value))
            except (TypeError, ValueError):
                raise ParameterError(f"parameter {name}={value!r} must be a list of "
                                     "numbers") from None

    def law_values(self) -> dict[str, Any]:
        """Every field but ``law`` (the reports' parameter blocks), law gms's element fields
        only for law gms and a map only when it is given (lists as tuples)."""
        map_off = {"position_map_period_m": not self.position_map_knots_m}
        return {k: v for k, v in dataclasses.asdict(self).items()
                if k != "law" and (self.law == "gms" or k not in _GMS_FIELDS)
                and v != () and not map_off.get(k, False)}

    @property
    def gms_element_weights(self) -> tuple[float, ...]:
        """The gms elements' shares of the level: gms_weights, or equal shares when empty."""
        count = len(self.gms_stiffness_N_per_m)
        return self.gms_weights or tuple(1.0 / count for _ in range(count))

    def validate(self) -> "FrictionParameters":
        if self.law not in ALL_LAWS:
            raise ParameterError(
                f"unknown friction law {self.law!r}; use one of: {', '.join(ALL_LAWS)}")
        _check_limits(self)
        if self.law == "gms":
            self._validate_gms()
        self._validate_map("position_map", self.position_map_knots_m, self.position_map_factors,
                           self.position_map_period_m)
        self._validate_map("velocity_map", self.velocity_map_knots_m_per_s,
                           self.velocity_map_factors, 0.0)
        self._validate_map("time_map", self.time_map_knots_s, self.time_map_factors, 0.0)
        _require(self.friction_coefficient >= 0, "friction_coefficient",
                 self.friction_coefficient, "must be >= 0")
        if self.law not in ("coulomb", "gms"):  # (gms: its elements' stiffnesses)
            _require(self.contact_stiffness_N_per_m > 0, "contact_stiffness_N_per_m",
                     self.contact_stiffness_N_per_m, "must be > 0")
        _require(self.alpha >= 0, "alpha", self.alpha, "must be >= 0")
        _require(0 < self.breakaway_ratio < 1, "breakaway_ratio", self.breakaway_ratio,
                 "must lie in (0, 1)")
        _require(self.bristle_damping_N_s_per_m >= 0, "bristle_damping_N_s_per_m",
                 self.bristle_damping_N_s_per_m, "must be >= 0")
        _require(self.viscous_N_s_per_m >= 0, "viscous_N_s_per_m", self.viscous_N_s_per_m,
                 "must be >= 0")
        _require(self.static_ratio >= 1, "static_ratio", self.static_ratio, "must be >= 1")
        _require(self.stribeck_velocity_m_per_s > 0, "stribeck_velocity_m_per_s",
                 self.stribeck_velocity_m_per_s, "must be > 0")
        _require(-1 < self.asymmetry < 1, "asymmetry", self.asymmetry, "must lie in (-1, 1)")
        _require(0 <= self.position_ripple < 1, "position_ripple", self.position_ripple,
                 "must lie in [0, 1)")
        _require(self.position_ripple_wavelength_m > 0, "position_ripple_wavelength_m",
                 self.position_ripple_wavelength_m, "must be > 0")
        _require(0 <= self.normal_force_modulation < 1, "normal_force_modulation",
                 self.normal_force_modulation, "must lie in [0, 1)")
        _require(self.normal_force_modulation_frequency_Hz >= 0,
                 "normal_force_modulation_frequency_Hz",
                 self.normal_force_modulation_frequency_Hz, "must be >= 0")
        _require(self.sensor_lag_s >= 0, "sensor_lag_s", self.sensor_lag_s, "must be >= 0")
        _require(self.contact_play_m >= 0, "contact_play_m", self.contact_play_m,
                 "must be >= 0")
        _require(self.contact_play_m == 0 or self.law in TERMS_BY_NAME["contact_play_m"].laws,
                 "contact_play_m", self.contact_play_m,
                 f"is a play before the bristles, which law {self.law} does not have; use law "
                 "dahl, dupont or lugre, or set it to 0")
        return self

    @staticmethod
    def _validate_map(name: str, knots: tuple[float, ...], factors: tuple[float, ...],
                      period: float) -> None:
        knots_name = f"{name}_knots_" + {"velocity_map": "m_per_s", "time_map": "s"}.get(name, "m")
        if len(knots) != len(factors):
            raise ParameterError(f"{knots_name} has {len(knots)} values and {name}_factors "
                                 f"{len(factors)}; give one factor per knot")
        if len(knots) > MAX_MAP_KNOTS:
            raise ParameterError(f"{knots_name} has {len(knots)} knots; a map takes at most "
                                 f"{MAX_MAP_KNOTS}")
        for value in (*knots, *factors):
            _require(math.isfinite(value), knots_name, knots, "must hold finite numbers")
        _require(all(f > -1 for f in factors), f"{name}_factors", factors,
                 "must hold factors > -1 (the level times 1 + factor stays positive)")
        _require(all(b > a for a, b in zip(knots, knots[1:])), knots_name, knots,
                 "must increase")
        if name == "velocity_map":
            _require(all(k >= 0 for k in knots), knots_name, knots, "must be speeds >= 0")
        if name == "time_map":
            _require(all(k >= 0 for k in knots), knots_name, knots, "must be times >= 0 (s)")
        _require(math.isfinite(period) and period >= 0, f"{name}_period_m", period,
                 "must be finite and >= 0 (0: not periodic)")
        if period > 0 and knots:
            _require(knots[-1] < knots[0] + period, knots_name, knots,
                     f"must lie within one period ({period:g} m)")

    def _validate_gms(self) -> None:
        stiffness, weights = self.gms_stiffness_N_per_m, self.gms_weights
        if not 1 <= len(stiffness) <= MAX_GMS_ELEMENTS:
            raise ParameterError(
                f"law gms needs gms_stiffness_N_per_m, the elements' stiffnesses: 1 to "
                f"{MAX_GMS_ELEMENTS} values (it has {len(stiffness)}), e.g. (4e7, 2e7, 1e7)")
        if weights and len(weights) != len(stiffness):
            raise ParameterError(
                f"gms_weights has {len(weights)} values and gms_stiffness_N_per_m "
                f"{len(stiffness)}; give one share of the level per element, or none for equal "
                "shares")
        for name, values in (("gms_stiffness_N_per_m", stiffness), ("gms_weights", weights)):
            for value in values:
                _require(math.isfinite(value) and value > 0, name, values,
                         "must hold finite values > 0")
        if weights:
            _require(abs(sum(weights) - 1.0) <= 1e-6, "gms_weights", weights,
                     f"must sum to 1 (they sum to {sum(weights):.9g}): the elements' shares of "
                     "the friction level")
        _require(self.gms_relaxation_time_s >= 0, "gms_relaxation_time_s",
                 self.gms_relaxation_time_s, "must be >= 0 (s)")
        _require(self.bristle_damping_N_s_per_m == 0, "bristle_damping_N_s_per_m",
                 self.bristle_damping_N_s_per_m,
                 "is not a gms parameter (its elements have no bristle damping); leave it at 0, "
                 "or use viscous_N_s_per_m for a damping in sliding")


def lugre_default_bristle_damping(contact_stiffness_N_per_m: float, mass_kg: float) -> float:
    """sigma1 at damping ratio 0.1 of the contact resonance: 0.2*sqrt(k_t m)."""
    return 0.2 * math.sqrt(contact_stiffness_N_per_m * mass_kg)


def _require(ok: bool, name: str, value: Any, rule: str) -> None:
    if not ok or (isinstance(value, float) and math.isnan(value)):
        raise ParameterError(f"parameter {name}={plain_value(value)!r} {rule}")


def plain_value(value: Any) -> Any:
    """A numpy scalar as the Python number it holds: messages show 0.5, not np.float64(0.5)."""
    numpy_scalar = type(value).__module__ == "numpy" and getattr(value, "ndim", None) == 0
    return value.item() if numpy_scalar else value


def _all_field_names() -> dict[str, type]:
    names: dict[str, type] = {}
    for cls in (RigParameters, FrictionParameters):
        for f in fields(cls):
            names[f.name] = cls
    return names


def apply_overrides(rig: RigParameters, friction: FrictionParameters,
                    overrides: Mapping[str, str | float]) -> tuple[RigParameters, FrictionParameters]:
    """Apply ``--set NAME=VALUE`` pairs; unknown names and non-numbers raise ParameterError."""
    owners = _all_field_names()
    rig_changes: dict[str, Any] = {}
    friction_changes: dict[str, Any] = {}
    for name, raw in overrides.items():
        if name not in owners:
            close = [n for n in owners if name.split("_")[0] in n][:4]
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise ParameterError(f"unknown parameter {name!r}{hint}; see 'vibrofriction --help'")
        if name == "law":
            friction_changes[name] = str(raw)
            continue
        if name in _LIST_FIELDS:  # "4e7,2e7,1e7" or "4e7 2e7 1e7" (a list as given in Python)
            items = raw if not isinstance(raw, str) else raw.replace(",", " ").split()
            try:
                values = tuple(float(x) for x in items)
            except (TypeError, ValueError):
                raise ParameterError(f"parameter {name}={raw!r} must be numbers separated by "
                                     "commas or spaces") from None
            if not all(math.isfinite(x) for x in values):
                raise ParameterError(f"parameter {name}={raw!r} must hold finite numbers")
            friction_changes[name] = values
            continue
        try:
            value = float(raw)
        except (TypeError, ValueError):
            raise ParameterError(f"parameter {name}={raw!r} is not a number") from None
        if not math.isfinite(value):
            raise ParameterError(f"parameter {name}={raw!r} must be finite")
        (rig_changes if owners[name] is RigParameters else friction_changes)[name] = value
    rig = replace(rig, **rig_changes).validate()
    friction = replace(friction, **friction_changes).validate()
    return rig, friction


def as_dict(*params: Any) -> dict[str, Any]:
    """The fields of each parameter set (a FrictionParameters' gms fields only for law gms)."""
    out: dict[str, Any] = {}
    for p in params:
        if isinstance(p, FrictionParameters):
            out.update({"law": p.law, **p.law_values()})
        else:
            out.update(dataclasses.asdict(p))
    return out


# law gms's default elements (mjcf_models/rig/scene_gms.xml): 80 N/um in all, as the other
# laws' contact stiffness, the stiffest holding the smallest share so that they slip in turn.
DEFAULT_GMS_STIFFNESS_N_PER_M = (5e7, 2e7, 1e7)
DEFAULT_GMS_WEIGHTS = (0.2, 0.3, 0.5)


def default_friction(law: str, rig: RigParameters | None = None) -> FrictionParameters:
    """Defaults per law (LuGre gets its bristle damping from the rig's mass, gms the rig scene's
    three elements)."""
    friction = FrictionParameters(law=law)
    if law == "gms":
        friction = replace(friction, gms_stiffness_N_per_m=DEFAULT_GMS_STIFFNESS_N_PER_M,
                           gms_weights=DEFAULT_GMS_WEIGHTS)
    if law == "lugre":
        mass = (rig or RigParameters()).mass_kg
        friction = replace(friction, bristle_damping_N_s_per_m=lugre_default_bristle_damping(
            friction.contact_stiffness_N_per_m, mass))
    return friction.validate()


__all__ = [
    "LAWS", "ParameterError", "RigParameters", "FrictionParameters", "apply_overrides",
    "as_dict", "default_friction", "lugre_default_bristle_damping", "PAPER_NORMAL_FORCE_N",
    "PAPER_CONTACT_STIFFNESS_N_PER_M", "VIBRATION_RAMP_PERIODS",
]
