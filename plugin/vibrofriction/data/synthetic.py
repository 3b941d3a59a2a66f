"""Rig records with an undeclared effect hidden in them, for testing identification.

The generator is independent of the plugin: motion and forces come from the scipy reference
model (``vibrofriction.oracle.reference``, which re-derives every law and effect from its equations),
never from the C++ laws that ``identify`` fits with. Realistic sensor noise is then added:

* force sensor (piezo, charge amplifier): white Gaussian noise ``force_N`` and 16-bit ADC
  quantization over +-2.5 mu F_N;
* slider and table velocity (laser vibrometers): white Gaussian ``velocity_m_per_s``;
* positions (laser interferometer): white Gaussian ``position_m``;
* slider acceleration (accelerometer, only for drive-force records): ``acceleration_m_per_s2``.

Effects outside the vocabulary can be added as a :class:`PeriodicDisturbance` (an additive tone
on the force channel, e.g. a structural resonance of the sensor mount or mains pickup).

The base scenario is the paper's rig (Gutowski & Leus 2012: m = 0.5 kg, F_N = 55.2 N,
k_t = 80 N/um, f = 4 kHz) with a LuGre contact, pulled at ``BASE_RIG.drive_velocity_m_per_s``
over a table vibrating at v_a = 20 mm/s (kappa = 20: the friction force reverses every
vibration half-period, so direction-, velocity- and phase-dependent effects all show).
``python -m vibrofriction.data.synthetic --effect asymmetry --out DIR`` writes one record.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from .datasets import Dataset, DatasetMetadata, write_dataset
from ..params import PAPER_NORMAL_FORCE_N, FrictionParameters, ParameterError, RigParameters
from ..oracle.reference import (drive_spring_force_N, first_order_lag, simulate_reference,
                               support_motion)

# The rig of the paper, pulled faster than in its figs. 7-12 (1 mm/s instead of 0.5 mm/s) so
# that a 0.08 s record crosses several wavelengths of a position ripple.
BASE_RIG = RigParameters(mass_kg=0.5, drive_stiffness_N_per_m=1.0e6,
                         drive_damping_N_s_per_m=0.0, drive_velocity_m_per_s=1.0e-3,
                         vibration_frequency_Hz=4000.0,
                         vibration_velocity_amplitude_m_per_s=20.0e-3,
                         normal_force_N=PAPER_NORMAL_FORCE_N)
# LuGre with the paper's contact stiffness; sigma1 gives damping ratio ~0.05 of the 2 kHz
# contact resonance with m = 0.5 kg.
BASE_FRICTION = FrictionParameters(law="lugre", friction_coefficient=0.2,
                                   contact_stiffness_N_per_m=80.0e6,
                                   bristle_damping_N_s_per_m=600.0)
DEFAULT_DURATION_S = 0.08
DEFAULT_SAMPLE_RATE_HZ = 100.0e3

# One hidden effect each (field -> value); sizes are what a careful rig would still care about
# (a few per cent to 10 % of the friction level).
EFFECTS: dict[str, dict[str, float]] = {
    "viscous": {"viscous_N_s_per_m": 60.0},  # 1.2 N at v_r = 20 mm/s (11 % of mu F_N)
    "stribeck": {"static_ratio": 1.5, "stribeck_velocity_m_per_s": 3.0e-3},
    "asymmetry": {"asymmetry": 0.1},
    "position_ripple": {"position_ripple": 0.1, "position_ripple_wavelength_m": 12.0e-6,
                        "position_ripple_phase_rad": 0.6},
    "normal_force_modulation": {"normal_force_modulation": 0.1,
                                "normal_force_modulation_phase_rad": 0.8},
    # at twice the vibration frequency (a support that rocks twice a period)
    "normal_force_modulation_2f": {"normal_force_modulation": 0.1,
                                   "normal_force_modulation_phase_rad": 0.8,
                                   "normal_force_modulation_frequency_Hz":
                                       2 * BASE_RIG.vibration_frequency_Hz},
    "drive_damping": {"drive_damping_N_s_per_m": 500.0},  # rig field; drive-force record
    "sensor_lag": {"sensor_lag_s": 8.0e-6},  # 11 degrees at 4 kHz
    "force_offset": {"force_offset_N": 0.6},
}
LAG_OVERSAMPLING = 10
# Effects whose record must measure the drive force (friction then follows from m a).
DRIVE_FORCE_EFFECTS = ("drive_damping",)


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of white sensor noise (0 = none) and the force ADC resolution."""

    force_N: float = 0.05
    velocity_m_per_s: float = 20.0e-6
    position_m: float = 1.0e-9
    acceleration_m_per_s2: float = 0.2
    force_adc_bits: int = 16

    @classmethod
    def none(cls) -> "SensorNoise":
        return cls(force_N=0.0, velocity_m_per_s=0.0, position_m=0.0,
                   acceleration_m_per_s2=0.0, force_adc_bits=0)


@dataclass(frozen=True)
class PeriodicDisturbance:
    """An additive tone on the force channel: outside the effect vocabulary on purpose."""

    frequency_Hz: float
    amplitude_N: float
    phase_rad: float = 0.0


@dataclass(frozen=True)
class Scenario:
    """What to generate: the true parameters, the record, the sensors."""

    rig: RigParameters = BASE_RIG
    friction: FrictionParameters = BASE_FRICTION
    duration_s: float = DEFAULT_DURATION_S
    sample_rate_Hz: float = DEFAULT_SAMPLE_RATE_HZ
    measured: str = "friction"  # "friction" (force sensor under the table) or "drive"
    noise: SensorNoise = SensorNoise()
    disturbance: PeriodicDisturbance | None = None
    seed: int = 0
    # an effect no parameter names: the reference's level_factor(t_s, x_rel_m, v_rel_m_per_s)
    level_factor: Callable[[float, float, float], float] | None = None


def with_effect(effect: str | None, scenario: Scenario | None = None, *,
                overrides: Mapping[str, float] | None = None) -> Scenario:
    """The base scenario with one vocabulary effect switched on (None: clean)."""
    scenario = scenario or Scenario()
    changes = dict(EFFECTS[_check_effect(effect)]) if effect else {}
    changes.update(overrides or {})
    rig_names = {f.name for f in fields(RigParameters)}
    rig = replace(scenario.rig, **{k: v for k, v in changes.items() if k in rig_names})
    friction = replace(scenario.friction,
                       **{k: v for k, v in changes.items() if k not in rig_names})
    measured = "drive" if effect in DRIVE_FORCE_EFFECTS else scenario.measured
    return replace(scenario, rig=rig.validate(), friction=friction.validate(), measured=measured)


# A lab's position-only record of the rig: a dynamometer on the drive spring, a displacement
# sensor on the slider, a vibrometer on the support; 20 ms without vibration (the spring loads,
# the slider breaks away and slides), then 30 ms of vibration.
LAB_COLUMNS = ("time_s", "drive_force_N", "position_m", "support_velocity_m_per_s")
LAB_DURATION_S = 0.05
LAB_VIBRATION_FROM_S = 0.02
# The dynamometer's lag in a lab record: 50 us (a 3 kHz conditioning bandwidth).
LAB_OVERRIDES = {"sensor_lag": {"sensor_lag_s": 5e-5}}


def lab_scenario(effect: str | None,
                 disturbance: PeriodicDisturbance | None = None) -> Scenario:
    """The base rig measured as a lab would (``LAB_COLUMNS``), one effect hidden (or none)."""
    base = Scenario(rig=replace(BASE_RIG, vibration_from_s=LAB_VIBRATION_FROM_S),
                    measured="drive", duration_s=LAB_DURATION_S, disturbance=disturbance)
    return with_effect(effect, base, overrides=LAB_OVERRIDES.get(effect or ""))


def lab_record(scenario: Scenario, name: str = "lab") -> Dataset:
    """``generate`` keeping only the columns of a position-only lab record."""
    record = generate(scenario, name=name)
    return Dataset(name=record.name, metadata=record.metadata,
                   columns={c: record.columns[c] for c in LAB_COLUMNS})


def generate(scenario: Scenario, name: str = "synthetic", description: str = "") -> Dataset:
    """Integrate the reference rig, sample it like the sensors would, return a Dataset."""
    rig, friction = scenario.rig, scenario.friction
    if scenario.measured not in ("friction", "drive"):
        raise ParameterError(f"measured={scenario.measured!r}: use 'friction' or 'drive'")
    dt = 1.0 / scenario.sample_rate_Hz
    # The reference lags the friction exactly for a signal linear between its samples: with a
    # lag, sample it 10x finer (a contact transition lasts ~15 us) and keep every 10th sample.
    oversample = LAG_OVERSAMPLING if friction.sensor_lag_s > 0 else 1
    # A drive-force record's lag is the dynamometer's: the friction itself is not lagged.
    lag_s = friction.sensor_lag_s
    simulated = replace(friction, sensor_lag_s=0.0) if scenario.measured == "drive" else friction
    ref = simulate_reference(rig, simulated, scenario.duration_s, sample_dt_s=dt / oversample,
                             level_factor=scenario.level_factor)
    # The dynamometer is the drive spring: it reads k_d (v_d t - x) (through any backlash),
    # through its lag; a damper acting in parallel (drive_damping) pushes the slider without
    # passing through it.
    spring = drive_spring_force_N(rig, ref.time_s, ref.slider_position_m)
    if scenario.measured == "drive" and lag_s > 0:
        spring = first_order_lag(spring, float(ref.time_s[1] - ref.time_s[0]), lag_s)
    if oversample > 1:
        ref = _every(ref, oversample)
        spring = spring[::oversample]
    rng = np.random.default_rng(scenario.seed)
    noise = scenario.noise
    t = ref.time_s
    support_position, _ = support_motion(rig, t)  # (the rig's vibration_from_s)

    def noisy(values: np.ndarray, sigma: float) -> np.ndarray:
        return values + sigma * rng.standard_normal(values.shape) if sigma > 0 else values

    columns = {
        "time_s": t,
        "position_m": noisy(ref.slider_position_m, noise.position_m),
        "velocity_m_per_s": noisy(ref.slider_velocity_m_per_s, noise.velocity_m_per_s),
        "support_velocity_m_per_s": noisy(ref.support_velocity_m_per_s, noise.velocity_m_per_s),
        "support_position_m": noisy(support_position, noise.position_m),
    }
    if scenario.measured == "friction":
        force = ref.friction_force_N
        columns["friction_force_N"] = _force_sensor(force, t, scenario, rng)
    else:
        # Newton: m a = total drive force - friction (the reference friction is not lagged).
        acceleration = (ref.drive_force_N - ref.friction_force_N) / rig.mass_kg
        columns["drive_force_N"] = _force_sensor(spring, t, scenario, rng)
        columns["acceleration_m_per_s2"] = noisy(acceleration, noise.acceleration_m_per_s2)
    metadata = DatasetMetadata(
        description=description or _describe(scenario),
        mass_kg=rig.mass_kg, drive_stiffness_N_per_m=rig.drive_stiffness_N_per_m,
        drive_velocity_m_per_s=rig.drive_velocity_m_per_s,
        vibration_frequency_Hz=rig.vibration_frequency_Hz, normal_force_N=rig.normal_force_N,
        sample_rate_Hz=scenario.sample_rate_Hz,
        source="vibrofriction.data.synthetic (scipy reference model + sensor noise)")
    return Dataset(name=name, columns=columns, metadata=metadata)


def with_sensor_noise(dataset: Dataset, noise: SensorNoise = SensorNoise(),
                      seed: int = 0) -> Dataset:
    """``dataset`` as sensors would give it: white noise of ``noise``'s sizes on every
    measured column, the support's motion included (e.g. a noise-free record of
    ``vibrofriction simulate --csv``)."""
    sigma = {"position_m": noise.position_m, "support_position_m": noise.position_m,
             "velocity_m_per_s": noise.velocity_m_per_s,
             "support_velocity_m_per_s": noise.velocity_m_per_s,
             "acceleration_m_per_s2": noise.acceleration_m_per_s2,
             "drive_force_N": noise.force_N, "friction_force_N": noise.force_N}
    rng = np.random.default_rng(seed)
    columns = {c: np.asarray(v, dtype=float) + sigma[c] * rng.standard_normal(len(v))
               if c in sigma else v for c, v in dataset.columns.items()}
    return Dataset(name=f"{dataset.name}-noisy", columns=columns, metadata=dataset.metadata)


def _every(ref, step: int):
    """The reference result at every ``step``-th sample."""
    arrays = {f.name: getattr(ref, f.name)[::step] for f in fields(ref)
              if isinstance(getattr(ref, f.name), np.ndarray)}
    return replace(ref, **arrays)


def _force_sensor(force: np.ndarray, t: np.ndarray, scenario: Scenario,
                  rng: np.random.Generator) -> np.ndarray:
    noise = scenario.noise
    out = np.array(force, dtype=float)
    if scenario.disturbance is not None:
        d = scenario.disturbance
        out = out + d.amplitude_N * np.sin(2 * math.pi * d.frequency_Hz * t + d.phase_rad)
    if noise.force_N > 0:
        out = out + noise.force_N * rng.standard_normal(out.shape)
    if noise.force_adc_bits > 0:
        full_scale = 2.5 * scenario.friction.friction_coefficient * scenario.rig.normal_force_N
        step = 2 * full_scale / 2 ** noise.force_adc_bits
        out = np.round(out / step) * step
    return out


def _describe(scenario: Scenario) -> str:
    hidden = {k: v for k, v in _effect_fields(scenario).items() if v}
    text = (f"synthetic rig record ({scenario.friction.law}, f = "
            f"{scenario.rig.vibration_frequency_Hz:g} Hz, v_a = "
            f"{scenario.rig.vibration_velocity_amplitude_m_per_s:g} m/s, v_d = "
            f"{scenario.rig.drive_velocity_m_per_s:g} m/s), {scenario.measured} force measured")
    if hidden:
        text += "; hidden: " + ", ".join(f"{k}={v:g}" for k, v in hidden.items())
    if scenario.disturbance:
        d = scenario.disturbance
        text += f"; disturbance {d.amplitude_N:g} N at {d.frequency_Hz:g} Hz"
    return text


def _effect_fields(scenario: Scenario) -> dict[str, float]:
    names = {name for values in EFFECTS.values() for name in values}
    out = {}
    for name in sorted(names):
        owner = scenario.rig if hasattr(scenario.rig, name) else scenario.friction
        out[name] = getattr(owner, name)
    return out


def _check_effect(effect: str) -> str:
    if effect not in EFFECTS:
        raise ParameterError(f"unknown effect {effect!r}; use one of: {', '.join(EFFECTS)}")
    return effect


def main(argv: list[str] | None = None) -> int:
    """``python -m vibrofriction.data.synthetic``: write one synthetic record (with ``--effect``
    hidden in it) to ``--out``; return the exit status (2 for bad input)."""
    parser = argparse.ArgumentParser(
        prog="python -m vibrofriction.data.synthetic",
        description="Write a synthetic rig record (dataset format) with one hidden effect.")
    parser.add_argument("--effect", default="none",
                        help=f"none or one of: {', '.join(EFFECTS)}")
    parser.add_argument("--disturbance", default=None, metavar="HZ:N",
                        help="add a periodic disturbance, e.g. 150:0.3 (frequency Hz, N)")
    parser.add_argument("--drive-velocity", type=float, default=None, metavar="M_PER_S")
    parser.add_argument("--duration", type=float, default=DEFAULT_DURATION_S, metavar="S")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True, metavar="NAME.csv")
    args = parser.parse_args(argv)
    try:
        scenario = Scenario(duration_s=args.duration, seed=args.seed)
        if args.drive_velocity is not None:
            scenario = replace(scenario, rig=replace(
                scenario.rig, drive_velocity_m_per_s=args.drive_velocity))
        scenario = with_effect(None if args.effect == "none" else args.effect, scenario)
        if args.disturbance:
            frequency, amplitude = (float(x) for x in args.disturbance.split(":"))
            scenario = replace(scenario, disturbance=PeriodicDisturbance(frequency, amplitude))
        stem = args.out.name.split(".csv")[0]
        dataset = generate(scenario, name=stem)
        csv_path, json_path = write_dataset(dataset, args.out)
    except (ParameterError, ValueError) as exc:
        print(f"synthetic: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {csv_path} and {json_path}: {dataset.n_rows} rows")
    return 0


__all__ = ["BASE_RIG", "BASE_FRICTION", "EFFECTS", "DRIVE_FORCE_EFFECTS", "SensorNoise",
           "with_sensor_noise",
           "LAB_COLUMNS", "lab_scenario", "lab_record",
           "PeriodicDisturbance", "Scenario", "with_effect", "generate", "main"]

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
