"""The paper's rig as a MuJoCo model: built from parameters, its timestep rule, its sensors
read as a run.

The MJCF files in ``mjcf_models/rig/`` are the source of truth for the rig's structure; this
module only sets the numbers (from RigParameters and FrictionParameters) through MjSpec, and
reads the recorded sensors back as a ``RigRun``. Running it is ``rig.py``'s (one run, many,
until steady through ``steady.py``, which builds on this module).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from ..laws import load
from ..params import (VIBRATION_RAMP_PERIODS, FrictionParameters, ParameterError, RigParameters,
                      plain_value)
from ..sim import MJCF_DIR, set_plugin_config, sensor_slices
from ..summary import RunSummary, summarize
from ..vocabulary import MJCF_KEYS as VOCABULARY_MJCF_KEYS
from ..vocabulary import config_values

RIG_DIR = MJCF_DIR / "rig"
DEFAULT_TIMESTEP_S = 1e-5

# FrictionParameters field -> MJCF config key of vibrofriction.friction (vocabulary.FRICTION_TERMS)
MJCF_KEYS = dict(VOCABULARY_MJCF_KEYS)


def scene_path(law: str) -> Path:
    """Installed scene file of the rig with the given law."""
    path = RIG_DIR / f"scene_{law}.xml"
    if not path.is_file():
        raise ParameterError(f"no rig scene for law {law!r} ({path}); use coulomb, dahl, "
                             "dupont, lugre or gms")
    return path


def friction_config(rig: RigParameters, friction: FrictionParameters) -> dict[str, str]:
    """Config of the vibrofriction.friction instance for these parameters."""
    config = {"law": friction.law, "normal": repr(float(rig.normal_force_N)),
              **config_values(friction, MJCF_KEYS)}
    if friction.normal_force_modulation_frequency_Hz == 0:
        # Normal-load modulation defaults to the support's vibration frequency.
        config[MJCF_KEYS["normal_force_modulation_frequency_Hz"]] = repr(float(
            rig.vibration_frequency_Hz))
    return config


def dynamometer_config(rig: RigParameters, time_constant_s: float = 0.0) -> dict[str, str]:
    """Config of the rig's dynamometer: the drive spring's extension (beyond the play, with
    backlash) through a first-order lag of ``time_constant_s``. Its force is
    -rig.drive_chain_stiffness_N_per_m times the reading."""
    config = {"tendon": "drive_spring", "time_constant": repr(float(time_constant_s))}
    if rig.drive_backlash_m > 0:
        config["beyond_deadband"] = "true"
    return config


def build_spec(rig: RigParameters, friction: FrictionParameters,
               timestep_s: float = DEFAULT_TIMESTEP_S) -> mujoco.MjSpec:
    """MjSpec of the rig scene for ``friction.law`` with every parameter applied."""
    load()
    rig.validate()
    friction.validate()
    if not (timestep_s > 0 and math.isfinite(timestep_s)):
        raise ParameterError(f"timestep {plain_value(timestep_s)!r} must be a positive number of "
                             "seconds")
    spec = mujoco.MjSpec.from_file(str(scene_path(friction.law)))
    spec.option.timestep = timestep_s
    spec.body("slider").mass = rig.mass_kg
    drive = spec.actuator("drive_spring")
    # Tendon length x - x_B, velocity xdot - v_d: F_d = -k_d (x - x_B) - h_d (xdot - v_d).
    drive.biasprm[:3] = [0.0, -rig.drive_stiffness_N_per_m, -rig.drive_damping_N_s_per_m]
    if rig.drive_backlash_m > 0:
        # Backlash: the spring becomes the tendon's own, with MuJoCo's dead band (springlength
        # "low high": no force within the play), and the dynamometer reads its extension
        # beyond the play. The actuator keeps the damping.
        drive.biasprm[1] = 0.0
        tendon = spec.tendon("drive_spring")
        stiffness = np.zeros(np.size(tendon.stiffness))  # linear (and polynomial) terms
        stiffness[0] = rig.drive_chain_stiffness_N_per_m
        tendon.stiffness = stiffness if stiffness.size > 1 else float(stiffness[0])
        centre, half = rig.drive_backlash_centre_m, 0.5 * rig.drive_backlash_m
        tendon.springlength = [centre - half, centre + half]
        set_plugin_config(spec, "dynamometer", dynamometer_config(rig))
    shaker = {"frequency": repr(float(rig.vibration_frequency_Hz)),
              "velocity_amplitude": repr(float(rig.vibration_velocity_amplitude_m_per_s))}
    if rig.vibration_from_s > 0 and rig.vibration_velocity_amplitude_m_per_s > 0:
        shaker.update(start_time=repr(float(rig.vibration_from_s)),
                      ramp_periods=repr(float(VIBRATION_RAMP_PERIODS)))
    set_plugin_config(spec, "table_shaker", shaker)
    set_plugin_config(spec, "drive_end_motion", {
        "velocity": repr(float(rig.drive_velocity_m_per_s))})
    set_plugin_config(spec, "friction", friction_config(rig, friction))
    if friction.law == "gms":  # one deflection per element
        spec.actuator("friction").actdim = len(friction.gms_stiffness_N_per_m)
    return spec


def build_model(rig: RigParameters, friction: FrictionParameters,
                timestep_s: float = DEFAULT_TIMESTEP_S) -> mujoco.MjModel:
    """The compiled rig model for ``friction.law`` with every parameter applied
    (``build_spec(...).compile()``).

    Parameters
    ----------
    rig : RigParameters
        The rig (SI units).
    friction : FrictionParameters
        The friction law and its parameters (SI units).
    timestep_s : float
        MuJoCo timestep (s); default 1e-5 s.

    Returns
    -------
    mujoco.MjModel
        The model of the law's rig scene (``mjcf_models/rig/scene_<law>.xml``).

    Raises
    ------
    ParameterError
        For invalid parameters, a timestep that is not a positive number, or a law without
        a rig scene.
    """
    return build_spec(rig, friction, timestep_s).compile()


# Timestep rule. The plugin holds the Coulomb force and the inputs of the state laws over a
# step, so the mean force depends on where the force switches within each period. With an
# integer number of steps per period the step grid repeats identically every period and the
# rigid Coulomb mean is quantized to multiples of 2/N (at 4 kHz and 10 us: 0.04 mu F_N). Use
# N + 0.382 steps per period (0.382 = 2 - golden ratio): the grid slides along the vibration
# phase from period to period and the quantization averages out over the window. N = 50,
# doubled for every doubling of kappa_v above 10 (measured at 4 kHz: mean drive force within
# 1 % of a 16x finer step for Dahl up to kappa_v = 80 and for Coulomb up to 40).
BASE_STEPS_PER_PERIOD = 50
STEPS_DOUBLING_KAPPA = 10.0
STEP_PHASE_SLIDE = 0.381966


def steps_per_period(kappa: float, base: int = BASE_STEPS_PER_PERIOD) -> int:
    """N = base * 2^ceil(log2(max(1, kappa/10)))."""
    doublings = max(0, math.ceil(math.log2(max(1.0, abs(kappa) / STEPS_DOUBLING_KAPPA)) - 1e-12))
    return base * 2 ** doublings


def period_timestep(frequency_Hz: float, steps: int) -> float:
    """dt = T / (N + 0.382): N steps and a sliding fraction per vibration period."""
    return 1.0 / (frequency_Hz * (steps + STEP_PHASE_SLIDE))


def recommended_timestep(rig: RigParameters) -> float:
    """Timestep for the rig's vibration (DEFAULT_TIMESTEP_S without vibration)."""
    f = rig.vibration_frequency_Hz
    if f <= 0 or rig.vibration_velocity_amplitude_m_per_s <= 0:
        return DEFAULT_TIMESTEP_S
    return period_timestep(f, steps_per_period(rig.kappa))


def default_times(rig: RigParameters, friction: FrictionParameters) -> tuple[float, float]:
    """(duration_s, settle_time_s): loading to breakaway, transient, then an averaging window.

    The spring loads to mu F_N in t_load = mu F_N / (k_d v_d) (k_d in series with a play's
    faces), after taking up any play on the side it pulls; the transient is given that, two
    loadings plus 30 ms, and the mean is taken over the following 40 ms of whole periods. A
    vibration switched on later (``vibration_from_s``) adds its start and build-up.
    """
    static_force_N = friction.friction_coefficient * rig.normal_force_N * friction.static_ratio
    v_d = abs(rig.drive_velocity_m_per_s)
    t_load_s = static_force_N / (rig.drive_chain_stiffness_N_per_m * v_d)
    # x - x_B starts at 0 and moves at -v_d toward the face pulled on (centre -+ play / 2)
    t_take_up_s = max(0.0, 0.5 * rig.drive_backlash_m - math.copysign(
        1.0, rig.drive_velocity_m_per_s) * rig.drive_backlash_centre_m) / v_d
    settle_time_s = t_take_up_s + 2.0 * t_load_s + 0.03
    if rig.vibration_from_s > 0 and rig.vibration_frequency_Hz > 0 and \
            rig.vibration_velocity_amplitude_m_per_s > 0:
        settle_time_s += rig.vibration_from_s + VIBRATION_RAMP_PERIODS / rig.vibration_frequency_Hz
    return settle_time_s + 0.04, settle_time_s


class UnconvergedWarning(UserWarning):
    """A run to steady state whose mean drive force had not settled: its summary is not the
    steady answer."""


@dataclass(frozen=True)
class Convergence:
    """How a run's mean drive force settled (all ratios relative to the last window's mean)."""

    converged: bool
    tolerance: float
    window_s: float  # length of each averaging window (whole periods)
    windows: int  # windows after the transient guess, the reported one included
    relative_change: float  # |m_k - m_{k-1}| / |m_k|
    estimated_remaining_error: float  # |limit - m_k| / |m_k| (geometric estimate; inf if none)
    simulated_s: float  # end of the reported window (periodic: every step the solver ran)
    # how the steady state was found: "transient" (this module: windows of a run from rest)
    # or "periodic" (rigs.periodic: the orbit by shooting); ``note`` says why a periodic
    # solve fell back to the transient, or how the orbit converged
    method: str = "transient"
    note: str = ""

    def as_dict(self) -> dict:
        def finite(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"converged": self.converged, "tolerance": self.tolerance,
                "window_s": self.window_s, "windows": self.windows,
                "relative_change": finite(self.relative_change),
                "estimated_remaining_error": finite(self.estimated_remaining_error),
                "simulated_s": self.simulated_s, "method": self.method, "note": self.note}


@dataclass(frozen=True)
class RigRun:
    """Time series of one run (row i at t_i = i dt, before step i) and its parameters."""

    rig: RigParameters
    friction: FrictionParameters
    timestep_s: float
    settle_time_s: float
    time_s: np.ndarray
    slider_position_m: np.ndarray
    slider_velocity_m_per_s: np.ndarray
    slider_acceleration_m_per_s2: np.ndarray
    support_position_m: np.ndarray
    support_velocity_m_per_s: np.ndarray
    relative_velocity_m_per_s: np.ndarray
    deflection_m: np.ndarray
    friction_force_N: np.ndarray
    drive_force_N: np.ndarray  # the drive actuator's force on the slider (spring + damper)
    normal_force_N: np.ndarray
    dynamometer_force_N: np.ndarray  # the spring's force alone: what a dynamometer in it reads
    convergence: Convergence | None = None  # a run to steady state: how it settled
    steady_summary: RunSummary | None = None  # ... and the summary it was judged on

    @property
    def period_s(self) -> float:
        f = self.rig.vibration_frequency_Hz
        return 1.0 / f if f > 0 and self.rig.vibration_velocity_amplitude_m_per_s > 0 else 0.0

    def summary(self, settle_time_s: float | None = None) -> RunSummary:
        """Means over whole periods after ``settle_time_s``; without it, for a run to steady
        state, the converged window's (Hann-weighted) summary."""
        if settle_time_s is None and self.steady_summary is not None:
            if self.convergence is not None and not self.convergence.converged:
                # a number a user could take for the steady answer: said where it is read
                warnings.warn(
                    f"the run did not settle within its {self.convergence.simulated_s:.3g} s: "
                    f"its mean drive force still moved by {self.convergence.relative_change:.2g} "
                    f"of itself (tolerance {self.convergence.tolerance:g}) between the last "
                    "two windows; run longer (max_duration_s) or read run.convergence",
                    UnconvergedWarning, stacklevel=2)
            return self.steady_summary
        settle = self.settle_time_s if settle_time_s is None else settle_time_s
        return summarize(self.time_s, self.drive_force_N, self.friction_force_N, self.period_s,
                         settle)

    def columns(self) -> dict[str, np.ndarray]:
        """The run in the dataset format's column names (docs/dataset-format.md)."""
        return {
            "time_s": self.time_s,
            "position_m": self.slider_position_m,
            "velocity_m_per_s": self.slider_velocity_m_per_s,
            "acceleration_m_per_s2": self.slider_acceleration_m_per_s2,
            "drive_force_N": self.dynamometer_force_N,
            "friction_force_N": self.friction_force_N,
            "support_velocity_m_per_s": self.support_velocity_m_per_s,
            "support_position_m": self.support_position_m,
            "normal_force_N": self.normal_force_N,
        }


def drive_force_columns(model: mujoco.MjModel, rig: RigParameters,
                        sensordata: np.ndarray) -> np.ndarray:
    """The drive's force on the slider at each step (N): the drive actuator's (spring and
    damper), plus, with backlash, the tendon spring's through the play (MuJoCo applies it as a
    passive force, which no built-in sensor reads: the dynamometer's unlagged extension does)."""
    s = sensor_slices(model)
    force = sensordata[:, s["drive_force"]][:, 0]
    if rig.drive_backlash_m > 0:
        force = force - rig.drive_chain_stiffness_N_per_m * \
            sensordata[:, s["drive_spring_extension"]][:, 0]
    return force


def runs_from_sensordata(model: mujoco.MjModel, rig: RigParameters,
                         friction: FrictionParameters, sensordata: np.ndarray,
                         settle_time_s: float) -> RigRun:
    """Turn rollout sensordata (nstep x nsensordata) into a RigRun."""
    s = sensor_slices(model)
    dt = model.opt.timestep
    n = sensordata.shape[0]
    friction_state = sensordata[:, s["friction_state"]]
    return RigRun(
        rig=rig, friction=friction, timestep_s=dt, settle_time_s=settle_time_s,
        time_s=np.arange(n) * dt,
        slider_position_m=sensordata[:, s["slider_position"]][:, 0],
        slider_velocity_m_per_s=sensordata[:, s["slider_velocity"]][:, 0],
        slider_acceleration_m_per_s2=sensordata[:, s["slider_acceleration"]][:, 0],
        support_position_m=sensordata[:, s["table_position"]][:, 0],
        support_velocity_m_per_s=sensordata[:, s["table_velocity"]][:, 0],
        relative_velocity_m_per_s=friction_state[:, 2],
        deflection_m=friction_state[:, 1],
        # The lagged channel equals the force itself unless sensor_lag_s > 0.
        friction_force_N=friction_state[:, 4],
        drive_force_N=drive_force_columns(model, rig, sensordata),
        normal_force_N=friction_state[:, 3],
        dynamometer_force_N=-rig.drive_chain_stiffness_N_per_m *
        sensordata[:, s["drive_spring_extension"]][:, 0],
    )
