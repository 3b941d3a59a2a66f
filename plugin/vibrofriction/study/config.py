"""The study's configurations: the paper's parameter sets, grids and the timestep rule.

Every number here is either the paper's (Gutowski & Leus, Tribology International 2012; section
and figure named) or a choice of this study, with its reason. Values the paper does not give
(mu, k_d, alpha, Dupont and LuGre extras) are chosen once in ``vibrofriction.params``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..rigs import rig as rig_module
from ..params import (PAPER_CONTACT_STIFFNESS_N_PER_M, FrictionParameters, RigParameters,
                      default_friction, lugre_default_bristle_damping)

MM_PER_S = 1e-3  # m/s per mm/s
N_PER_UM = 1e6  # N/m per N/um

# Section 4, Figs. 7-12: f = 4 kHz, v_d = 0.5 mm/s, m = 0.5 kg, F_N = p S = 0.046 N/mm^2 x
# 1200 mm^2 = 55.2 N, k_t = 80 N/um (RigParameters / FrictionParameters defaults).
PAPER_RIG = RigParameters()

# Figs. 7-10: v_a below, a little above and well above v_d = 0.5 mm/s.
TRACE_VIBRATION_VELOCITIES_M_PER_S = (0.25 * MM_PER_S, 0.75 * MM_PER_S, 3.0 * MM_PER_S)
# Fig. 11: Dahl at five amplitudes, Coulomb at the last one.
PROFILE_VIBRATION_VELOCITIES_M_PER_S = (0.60 * MM_PER_S, 0.75 * MM_PER_S, 1.0 * MM_PER_S,
                                        1.75 * MM_PER_S, 8.0 * MM_PER_S)
PROFILE_COULOMB_VIBRATION_VELOCITY_M_PER_S = 8.0 * MM_PER_S
# Fig. 12: the paper shows "selected values of k_t" without listing them. This study uses the
# paper's 80 N/um and factors 1/8 ... 4 around it (contact resonance sqrt(k_t/m)/2pi from 0.71
# to 4.0 kHz, i.e. up to the 4 kHz excitation).
STIFFNESS_STUDY_N_PER_M = tuple(k * N_PER_UM for k in (10.0, 20.0, 40.0, 80.0, 160.0, 320.0))
STIFFNESS_PROFILE_VIBRATION_VELOCITY_M_PER_S = 0.75 * MM_PER_S

# Section 5: contact area S = 1200 mm^2 and m = 0.5 kg for both experimental configurations.
CONTACT_AREA_MM2 = 1200.0
GRAVITY_M_PER_S2 = 9.81


@dataclass(frozen=True)
class ExperimentConfig:
    """An experimental configuration of section 5 (Fig. 13 or Fig. 14).

    The normal load is F_N = p S (the paper's normal stress on the nominal contact area), the
    same definition as the simulation study's F_N = 0.046 N/mm^2 x 1200 mm^2. The paper also
    gives the external load F_e; F_e + m g differs from p S by 0.7 % (Fig. 13) and 1.3 % (Fig.
    14) -- the study reports how much that changes the results.
    """

    name: str
    figure: str
    vibration_frequency_Hz: float
    drive_velocity_m_per_s: float
    pressure_N_per_mm2: float
    external_load_N: float
    contact_stiffness_N_per_m: float
    mass_kg: float = 0.5
    vibration_velocities_m_per_s: tuple[float, ...] = ()

    @property
    def normal_force_N(self) -> float:
        """F_N = p S."""
        return self.pressure_N_per_mm2 * CONTACT_AREA_MM2

    @property
    def normal_force_from_loads_N(self) -> float:
        """The alternative F_N = F_e + m g."""
        return self.external_load_N + self.mass_kg * GRAVITY_M_PER_S2

    def rig(self, vibration_velocity_amplitude_m_per_s: float = 0.0,
            base: RigParameters = PAPER_RIG, *, normal_force_N: float | None = None
            ) -> RigParameters:
        return replace(base, mass_kg=self.mass_kg,
                       vibration_frequency_Hz=self.vibration_frequency_Hz,
                       drive_velocity_m_per_s=self.drive_velocity_m_per_s,
                       normal_force_N=(self.normal_force_N if normal_force_N is None
                                       else normal_force_N),
                       vibration_velocity_amplitude_m_per_s=vibration_velocity_amplitude_m_per_s
                       ).validate()


# Fig. 13: f 3900 Hz, v_d 0.62 mm/s, m 0.5 kg, S 1200 mm^2, F_e 61.8 N, p 0.056 N/mm^2,
# k_t 78 N/um, v_a 1.76 and 3.44 mm/s.
EXPERIMENT_FIG13 = ExperimentConfig(
    name="fig13", figure="Fig. 13", vibration_frequency_Hz=3900.0,
    drive_velocity_m_per_s=0.62 * MM_PER_S, pressure_N_per_mm2=0.056, external_load_N=61.8,
    contact_stiffness_N_per_m=78.0 * N_PER_UM,
    vibration_velocities_m_per_s=(1.76 * MM_PER_S, 3.44 * MM_PER_S))
# Fig. 14: f 2600 Hz, v_d 0.31 mm/s, F_e 31.8 N, p 0.031 N/mm^2, k_t 72 N/um, v_a swept
# (the swept values are the study's grid; m = 0.5 kg as in Fig. 13, the paper does not restate it).
EXPERIMENT_FIG14 = ExperimentConfig(
    name="fig14", figure="Fig. 14", vibration_frequency_Hz=2600.0,
    drive_velocity_m_per_s=0.31 * MM_PER_S, pressure_N_per_mm2=0.031, external_load_N=31.8,
    contact_stiffness_N_per_m=72.0 * N_PER_UM)

# Timestep rule: rig.recommended_timestep (N + 0.382 steps per vibration period, N = 50 doubled
# for every doubling of kappa_v above 10; see rig.py for why).
BASE_STEPS_PER_PERIOD = rig_module.BASE_STEPS_PER_PERIOD
STATIC_TIMESTEP_S = rig_module.DEFAULT_TIMESTEP_S
steps_per_period = rig_module.steps_per_period
period_timestep = rig_module.period_timestep
study_timestep = rig_module.recommended_timestep


def friction_for(law: str, rig: RigParameters, *,
                 contact_stiffness_N_per_m: float | None = None,
                 base: FrictionParameters | None = None) -> FrictionParameters:
    """The study's friction parameters for ``law``: defaults (params.py) with k_t set.

    LuGre's bristle damping follows k_t and m (damping ratio 0.1 of the contact resonance,
    ``lugre_default_bristle_damping``) unless ``base`` fixes it.
    """
    friction = default_friction(law, rig) if base is None else replace(base, law=law)
    kt = (friction.contact_stiffness_N_per_m if contact_stiffness_N_per_m is None
          else contact_stiffness_N_per_m)
    friction = replace(friction, contact_stiffness_N_per_m=kt)
    if law == "lugre" and (base is None or base.bristle_damping_N_s_per_m == 0):
        friction = replace(friction, bristle_damping_N_s_per_m=lugre_default_bristle_damping(
            kt, rig.mass_kg))
    return friction.validate()


def _geomspace(lo: float, hi: float, n: int) -> tuple[float, ...]:
    return tuple(lo * (hi / lo) ** (i / (n - 1)) for i in range(n))


def _kappa_grid(extra: tuple[float, ...], lo: float, hi: float, n: int) -> tuple[float, ...]:
    values = sorted(set(round(k, 6) for k in (*extra, *_geomspace(lo, hi, n))))
    return tuple(values)


@dataclass(frozen=True)
class StudyConfig:
    """Grid sizes of one reproduction; ``quick()`` for tests and smoke runs."""

    quick: bool = False
    # kappa_v grid of the master curves (Fig. 12b, master curves, Fig. 14); always contains
    # the paper's anchors 0.5 (v_a = v_d/2), 1 (v_a = v_d), 1.5 (Fig. 8) and 6 (Fig. 9).
    kappas: tuple[float, ...] = field(default_factory=lambda: _kappa_grid(
        (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 6.0, 20.0, 40.0), 1.1, 100.0, 16))
    stiffness_kappas: tuple[float, ...] = field(default_factory=lambda: _kappa_grid(
        (0.5, 1.0, 1.5, 3.0, 6.0, 20.0, 40.0), 1.2, 80.0, 10))
    stiffness_values_N_per_m: tuple[float, ...] = STIFFNESS_STUDY_N_PER_M
    experiment_kappas: tuple[float, ...] = field(default_factory=lambda: _kappa_grid(
        (0.25, 0.5, 0.75, 1.0, 2.0), 1.1, 60.0, 14))
    trace_periods: int = 3
    kinematic_periods: int = 200
    kinematic_samples_per_period: int = 2000
    # Grid sweep (v_a x f x k_t x F_N), Dahl.
    sweep_kappas: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 3.0, 6.0, 12.0, 24.0)
    sweep_frequencies_Hz: tuple[float, ...] = (2600.0, 3900.0, 4000.0)
    sweep_stiffnesses_N_per_m: tuple[float, ...] = (40.0 * N_PER_UM, 80.0 * N_PER_UM,
                                                      160.0 * N_PER_UM)
    sweep_normal_forces_N: tuple[float, ...] = (0.031 * CONTACT_AREA_MM2,
                                                0.046 * CONTACT_AREA_MM2,
                                                0.056 * CONTACT_AREA_MM2)
    # A fixed timestep for every run instead of the rule (None: study_timestep).
    timestep_s: float | None = None
    # How each run reaches its steady state (rigs.sweep.run_cases): "transient" (from rest:
    # the study's orbits, where several coexist near the contact resonance), "periodic" or
    # "auto" (the orbit where it is found: 10-30x cheaper).
    method: str = "transient"
    # Base parameters (--set overrides): the paper's rig; friction None = params defaults.
    rig: RigParameters = PAPER_RIG
    friction: FrictionParameters | None = None

    @classmethod
    def full(cls) -> "StudyConfig":
        return cls()

    @classmethod
    def quick_config(cls) -> "StudyConfig":
        return cls(
            quick=True,
            kappas=(0.5, 1.0, 1.5, 2.0, 3.0, 6.0, 12.0, 20.0, 40.0),
            stiffness_kappas=(1.0, 1.5, 3.0, 6.0, 12.0, 20.0),
            stiffness_values_N_per_m=(20.0 * N_PER_UM, 80.0 * N_PER_UM, 320.0 * N_PER_UM),
            experiment_kappas=(0.5, 1.0, 2.0, 4.0, 8.0, 16.0),
            trace_periods=3, kinematic_periods=60, kinematic_samples_per_period=1000,
            sweep_kappas=(1.0, 3.0), sweep_frequencies_Hz=(2600.0, 4000.0),
            sweep_stiffnesses_N_per_m=(40.0 * N_PER_UM, 80.0 * N_PER_UM),
            sweep_normal_forces_N=(0.046 * CONTACT_AREA_MM2,))

    def timestep(self, rig: RigParameters) -> float:
        return self.timestep_s if self.timestep_s is not None else study_timestep(rig)

    def friction_for(self, law: str, rig: RigParameters,
                     contact_stiffness_N_per_m: float | None = None) -> FrictionParameters:
        return friction_for(law, rig, contact_stiffness_N_per_m=contact_stiffness_N_per_m,
                            base=self.friction)


def contact_resonance_Hz(contact_stiffness_N_per_m: float, mass_kg: float) -> float:
    """The slider-on-contact resonance sqrt(k_t/m)/(2 pi) (Hz) of a contact stiffness k_t
    (N/m) and a mass m (kg)."""
    return math.sqrt(contact_stiffness_N_per_m / mass_kg) / (2 * math.pi)


__all__ = [
    "MM_PER_S", "N_PER_UM", "PAPER_RIG", "PAPER_CONTACT_STIFFNESS_N_PER_M",
    "TRACE_VIBRATION_VELOCITIES_M_PER_S", "PROFILE_VIBRATION_VELOCITIES_M_PER_S",
    "PROFILE_COULOMB_VIBRATION_VELOCITY_M_PER_S", "STIFFNESS_STUDY_N_PER_M",
    "STIFFNESS_PROFILE_VIBRATION_VELOCITY_M_PER_S", "ExperimentConfig", "EXPERIMENT_FIG13",
    "EXPERIMENT_FIG14", "steps_per_period", "period_timestep", "study_timestep", "friction_for", "StudyConfig",
    "contact_resonance_Hz",
]
