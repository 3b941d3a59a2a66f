"""The rig replayed in MuJoCo along a measured record: the model that identification fits.

The model is the rig scene (``mjcf_models/rig``) with the friction element, run by MuJoCo with
the plugin. The record's measured inputs drive it, step by step, through the two
``vibrofriction.motion`` actuators in ``displacement_from_ctrl`` mode:

* the table follows the measured support motion: ``support_position_m`` (a cubic spline
  between samples), else the exact integral of ``support_velocity_m_per_s``'s cubic spline,
  the velocity of a vibrating support first kept in its vibration band (``vibration_band``);
* the drive spring's far end moves at the sidecar's ``drive_velocity_m_per_s`` from where the
  measured drive force puts it (x_B = x + F_d / k_d - v_d t, averaged over the record).

The prediction is what the record measured, each channel from a sensor of the scene, never from
a differentiated measurement: ``position_m`` (slider position), ``velocity_m_per_s``,
``acceleration_m_per_s2``, ``drive_force_N`` (the dynamometer in the spring: -k_d (x - x_B)),
``friction_force_N`` (the element's reported force, after its sensor lag). ``sensor_lag_s`` is
the lag of whichever force the record measures: the friction sensor's, else the dynamometer's
(the rig's ``vibrofriction.lagged_tendon`` sensor on the drive spring).

Initial state: slider position measured; velocity measured or, where not, a smoothing estimate
(``datasets.smoothed_derivative``: an estimate of the state, not a prediction); contact
deflection at equilibrium with the drive force at the first sample (else the friction force;
z = F / k_t, inside the elastic range).

Each sample interval is cut into ``substeps`` MuJoCo steps (default: the record's own
``simulation_timestep_s`` when a simulator made it, else the fewest that give at least
``MIN_STEPS_PER_PERIOD`` steps a vibration period; identification then refines the timestep
until it converges). A vibrating sensor record is stepped on a grid that slides along the
vibration (about ``substeps`` steps a sample, N + 0.382 a period: ``sliding_timestep``) and
its samples are read between steps; a lab's sample rate is usually a multiple of the vibration
frequency, and a grid repeating every period repeats its discretization error too. Many
parameter sets run at once on ``mujoco.rollout`` threads, one model each (a finite-difference
Jacobian is one call).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout
from scipy.interpolate import BSpline, make_interp_spline
from scipy.signal import butter, sosfiltfilt
from scipy.linalg import LinAlgError, solve_banded, solveh_banded
from scipy.sparse import coo_matrix, csr_matrix

from .. import sim
from ..rigs import rig as rig_module
from ..data.datasets import Dataset, smoothed_derivative, white_noise_sd
from ..errors import InputError
from ..laws.run import steady_deflection_m
from ..params import FrictionParameters, RigParameters
from .start import starts_in_motion

# Columns the replay predicts (in this order when present) and the scene sensor of each.
OUTPUT_CHANNELS = ("position_m", "velocity_m_per_s", "acceleration_m_per_s2", "drive_force_N",
                   "friction_force_N")
# The rig's sensors each predicted channel (or extra output) reads: a replay's model keeps only
# those it needs (the accelerometer alone costs 15 % of a step: mj_rnePostConstraint).
SENSORS_OF_OUTPUT = {
    "position_m": ("slider_position",), "velocity_m_per_s": ("slider_velocity",),
    "acceleration_m_per_s2": ("slider_acceleration",),
    "drive_force_N": ("drive_spring_extension",), "friction_force_N": ("friction_state",),
    "relative_position_m": ("slider_position", "table_position"),
    "relative_velocity_m_per_s": ("relative_velocity",)}
MIN_STEPS_PER_PERIOD = 40  # at 4 kHz: 6.25 us; the study's timestep rule uses ~50
MAX_SUBSTEPS = 16
NOISE_FLOOR_OF_RANGE = 1e-4
# A measured support motion is kept at the vibration frequency and this many harmonics
# (``vibration_band``).
VIBRATION_HARMONICS = 3
# Of the vibration frequency: a support's slow motion (``slow_part``), and the band whose noise
# share a vibration must stand above (``noise_only_vibration``).
ENVELOPE_BANDWIDTH = 0.25
# ``vibration_band`` splits an envelope span while its misfit beyond the finest spline's exceeds
# the noise's chi-square mean by this many of its standard deviations; at most this many
# rounds of splits (each halves the spans that need it: 2^16 periods).
SPLIT_SIGMAS = 4.0
OUTLIER_SIGMAS = 6.0  # ``vibration_band`` keeps a sample as measured beyond this
OUTLIER_ROUNDS = 3
# ``vibration_band`` fits again without the slow part only where its rms is above this many
# times what the noise alone leaves in it (a second fit costs a second for a 0.4 s, 100 kHz
# record, and moving the input by the noise's slow part changes a fit's path, not its result)
SLOW_PART_ABOVE_NOISE = 3.0
ENVELOPE_DEGREE = 3  # cubic: a 20-period amplitude ramp within 1e-4 of its amplitude
MAX_ENVELOPE_ROUNDS = 16
_CASES_PER_ROLLOUT = 16
MIN_SAMPLES = 16  # a record shorter than this identifies nothing
RIG_MODEL = "rig"  # the sidecar's "model" of a rig record (the default when absent)
# Unit normal load when the record gives none: the fitted coefficient is then the level in N.
UNIT_NORMAL_FORCE_N = 1.0
_ELASTIC_FRACTION = 0.9  # initial deflection at most this fraction of the static level's
# A segment of a segmented replay (``Replayer(segment_steps=...)``) starts from the slider's
# position and velocity of a least-squares parabola through this many samples either side.
SEGMENT_SMOOTHING_SAMPLES = 5

# ctrl column of the rig's friction actuator (rig.xml's actuator order: table_shaker,
# drive_end_motion, drive_spring, then each scene's friction): a record's measured normal load
FRICTION_CTRL = 3


class SampleGrid:
    """What every replay derives from its record's samples (``time_s``, ``substeps``,
    ``measured``): the rig's and a machine's (``machine_replay.MachineReplay``)."""

    @property
    def n(self) -> int:
        return len(self.time_s)

    @property
    def sliding(self) -> bool:
        """Whether the step grid slides along the vibration (``RigReplay``)."""
        return False

    @property
    def steps_per_sample(self) -> float:
        """MuJoCo steps per sample interval: ``substeps``, or (a vibrating record replayed on
        a step grid that slides along the vibration, ``RigReplay.sliding_steps_per_sample``)
        a fraction more."""
        return float(self.substeps)

    @property
    def nstep(self) -> int:
        return grid_steps(self.n, self.substeps, self.steps_per_sample if self.sliding else None)

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.measured)

    def at_samples(self, rows: np.ndarray) -> np.ndarray:
        """Rollout rows (row k at the k-th step's start, nstep x ...) at the record's sample
        times: every ``substeps``-th row, or, on a sliding grid, linearly interpolated between
        the two steps around each sample (second order in the step)."""
        if not self.sliding:
            return rows[0:self.nstep:self.substeps]
        position = np.arange(self.n) * self.steps_per_sample
        k = np.minimum(np.floor(position).astype(int), self.nstep - 2)
        w = (position - k).reshape((-1,) + (1,) * (rows.ndim - 1))
        return (1.0 - w) * rows[k] + w * rows[k + 1]


def grid_steps(samples: int, substeps: int, sliding_steps_per_sample: float | None) -> int:
    """Steps of a replay: the last sample a step's start (whole steps a sample), or (a sliding
    grid) between the last two steps' starts."""
    if sliding_steps_per_sample is None:
        return (samples - 1) * substeps + 1
    return int(math.floor((samples - 1) * sliding_steps_per_sample)) + 2


def uniform_times(dataset: Dataset, where: str, sample_dt: Callable[[np.ndarray], float]
                  ) -> tuple[np.ndarray, float]:
    """(times, sample interval) of a record a replay can step through: at least
    ``MIN_SAMPLES`` samples, evenly spaced (``sample_dt`` gives the interval from the times)."""
    t = np.asarray(dataset.time_s, dtype=float)
    if len(t) < MIN_SAMPLES:
        raise InputError(f"{where}: {len(t)} samples; identification needs at least "
                         f"{MIN_SAMPLES}")
    dt = np.diff(t)
    interval = sample_dt(t)
    if np.ptp(dt) > 1e-3 * interval:
        raise InputError(f"{where}: the replay needs uniformly sampled data (time steps from "
                         f"{dt.min():.6g} to {dt.max():.6g} s); resample the record")
    return t, interval


def deflection_at_rest(friction: FrictionParameters, force_N: float,
                       normal_force_N: float) -> float:
    """The element's deflection holding ``force_N`` at rest, within the elastic range (below
    the static level mu F_N max(1, static_ratio)); 0 for Coulomb."""
    if friction.law == "coulomb":
        return 0.0
    bound = _ELASTIC_FRACTION * friction.friction_coefficient * \
        max(1.0, friction.static_ratio) * normal_force_N
    return min(max(force_N, -bound), bound) / friction.contact_stiffness_N_per_m


def contact_at_rest(model: mujoco.MjModel, data: mujoco.MjData, friction: FrictionParameters,
                    force_N: float, normal_force_N: float) -> None:
    """``deflection_at_rest`` in ``data.act`` (law gms: the elements from one common
    displacement, each up to its break-away, ``_gms_at_rest``); nothing for Coulomb."""
    if friction.law == "coulomb" or not model.na:
        return
    actuator = model.actuator("friction")
    if friction.law == "gms":
        data.act[actuator.actadr[0]:actuator.actadr[0] + len(friction.gms_stiffness_N_per_m)] = \
            _gms_at_rest(friction, force_N, normal_force_N)
        return
    data.act[actuator.actadr] = deflection_at_rest(friction, force_N, normal_force_N)


def _gms_at_rest(friction: FrictionParameters, force_N: float,
                 normal_force_N: float) -> np.ndarray:
    """The gms elements' deflections holding ``force_N`` (within the elastic range) from a
    common displacement z: each element k_i z up to its break-away w_i level, where it stays
    (sum min(k_i z, w_i level) = F, piecewise linear in z)."""
    stiffness = np.asarray(friction.gms_stiffness_N_per_m, dtype=float)
    level = friction.friction_coefficient * max(1.0, friction.static_ratio) * normal_force_N
    limits = np.asarray(friction.gms_element_weights, dtype=float) * level / stiffness
    force = min(abs(force_N), _ELASTIC_FRACTION * level)
    held = lambda z: float(np.sum(stiffness * np.minimum(z, limits)))  # noqa: E731
    lo, hi = 0.0, float(limits.max())
    for _ in range(100):  # bisection: held(z) is monotone
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if held(mid) < force else (lo, mid)
    return math.copysign(1.0, force_N) * np.minimum(0.5 * (lo + hi), limits)


def contact_sliding(model: mujoco.MjModel, data: mujoco.MjData, friction: FrictionParameters,
                    relative_velocity_m_per_s: float, normal_force_N: float,
                    relative_position_m: float) -> None:
    """The law's steady sliding deflection at this relative velocity in ``data.act`` (every
    element's for gms); nothing for Coulomb."""
    if friction.law == "coulomb" or not model.na:
        return
    actuator = model.actuator("friction")
    z = np.atleast_1d(steady_deflection_m(friction, relative_velocity_m_per_s,
                                          normal_force_N=normal_force_N,
                                          position_m=relative_position_m))
    data.act[actuator.actadr[0]:actuator.actadr[0] + len(z)] = z


def place_rig(model: mujoco.MjModel, data: mujoco.MjData, table_m: float,
              table_velocity_m_per_s: float, slider_m: float, slider_velocity_m_per_s: float,
              drive_end_m: float, drive_velocity_m_per_s: float) -> None:
    """The rig's joints at these absolute positions and velocities (the slider's joint is
    relative to the table's)."""
    table, slider = model.joint("table_slide"), model.joint("slider_on_table")
    drive_end = model.joint("drive_end_slide")
    data.qpos[table.qposadr[0]] = table_m
    data.qpos[slider.qposadr[0]] = slider_m - table_m
    data.qpos[drive_end.qposadr[0]] = drive_end_m
    data.qvel[table.dofadr[0]] = table_velocity_m_per_s
    data.qvel[slider.dofadr[0]] = slider_velocity_m_per_s - table_velocity_m_per_s
    data.qvel[drive_end.dofadr[0]] = drive_velocity_m_per_s


def slider_state(model: mujoco.MjModel, states: np.ndarray) -> np.ndarray:
    """(position, velocity, deflection) of the rig's slider in full-physics states
    (... x nstate; the deflection 0 without a friction state): what ``place_rig`` and the
    friction state set, read back."""
    table, slider = model.joint("table_slide"), model.joint("slider_on_table")
    qvel = 1 + model.nq  # mjSTATE_FULLPHYSICS: time, qpos, qvel, act, ...
    x = states[..., 1 + table.qposadr[0]] + states[..., 1 + slider.qposadr[0]]
    v = states[..., qvel + table.dofadr[0]] + states[..., qvel + slider.dofadr[0]]
    z = states[..., qvel + model.nv + model.actuator("friction").actadr[0]] if model.na \
        else np.zeros_like(x)
    return np.stack([x, v, z], axis=-1)


@dataclass(frozen=True, eq=False)
class RigReplay(SampleGrid):
    """A record set up for replay in the rig: inputs as controls, outputs as channels."""

    name: str
    time_s: np.ndarray
    substeps: int
    timestep_s: float
    control: np.ndarray  # (nstep, nu): table and drive-end displacement at each step's end
    measured: dict[str, np.ndarray]  # output channel -> measured samples
    noise: dict[str, float]  # output channel -> estimated white-noise sd
    rig: RigParameters  # sidecar values (mass: a placeholder when it is identified)
    mass_known: bool
    normal_force_known: bool
    initial_position_m: float
    initial_velocity_m_per_s: float
    initial_support_position_m: float
    initial_support_velocity_m_per_s: float
    initial_drive_end_m: float
    initial_friction_N: float
    vibrating: bool
    timestep_from_record: bool = False  # substeps from the sidecar's simulation_timestep_s
    # a vibrating sensor record: steps per sample on a grid that slides along the vibration
    # (``sliding_timestep``); None: exactly ``substeps``
    sliding_steps_per_sample: float | None = None
    # the support's measured velocity held only its sensor's noise: replayed still
    support_still: bool = False
    # the record's normal_force_N column drives F_N step by step (the friction actuator's
    # ctrl, control[:, 3], through the element's normal_from_ctrl); False: rig.normal_force_N
    normal_force_from_record: bool = False
    # The side the spring pulls on at the first sample (sign of the force holding the slider,
    # 0 when it is within the force's noise): where a backlash candidate's play starts.
    initial_play_side: float = 0.0
    # the slider slides on its support at the first sample: the contact starts at its steady
    # sliding state there (``start.starts_in_motion``), not holding a load at rest
    starts_in_motion: bool = False

    def backlash_centre_m(self, backlash_m: float) -> float:
        """Where a play of ``backlash_m`` is centred in this replay's coordinates (the drive
        end at initial_drive_end_m + v_d (t - t0)): a record that starts unloaded starts at
        the play's centre (as ``simulate`` runs do; a drive that never reverses shows only the
        face it pulls on, so the width is twice the distance from the start to that face),
        one that starts loaded starts against the face it pulls on, deflected by F / k_d."""
        if backlash_m == 0:
            return 0.0
        start = self.initial_position_m - self.initial_drive_end_m
        return start + self.backlash_centre_from_start_m(backlash_m)

    def backlash_centre_from_start_m(self, backlash_m: float) -> float:
        """The same centre relative to the record's start (x - x_B there taken as 0, as a
        ``simulate`` run starts): what RigParameters.drive_backlash_centre_m means."""
        if backlash_m == 0 or self.initial_play_side == 0:
            return 0.0
        return self.initial_friction_N / self.rig.drive_chain_stiffness_N_per_m + \
            0.5 * backlash_m * self.initial_play_side

    def fitted_rig(self, values: Mapping[str, float], mass_kg: float) -> RigParameters:
        """The rig with the fitted values: mass, drive damping, backlash (placed relative to
        the record's start: ``backlash_centre_m``)."""
        backlash = values.get("drive_backlash_m", 0.0)
        return replace(self.rig, mass_kg=mass_kg,
                       drive_damping_N_s_per_m=values.get("drive_damping_N_s_per_m", 0.0),
                       drive_backlash_m=backlash,
                       drive_backlash_centre_m=self.backlash_centre_m(backlash))

    @property
    def sliding(self) -> bool:
        return self.sliding_steps_per_sample is not None

    @property
    def steps_per_sample(self) -> float:
        return self.sliding_steps_per_sample or float(self.substeps)

    @property
    def estimated_state(self) -> tuple[str, ...]:
        """Initial-state values identification fits with the parameters: the slider's
        velocity, started from the measured first sample or a smoothing estimate (one noisy
        sample, or an estimate biased by the vibration and the start of the motion, is off
        by more than the fit can afford: a lightly damped contact carries the error through
        the whole record)."""
        return ("initial_velocity_m_per_s",)

    @property
    def lagged_sensor(self) -> str:
        """The sensor whose lag ``sensor_lag_s`` is: the friction sensor's when the record
        measures friction, else the dynamometer's (``drive_force_N``)."""
        return "friction" if "friction_force_N" in self.measured else "dynamometer"

    @property
    def velocity_scale_m_per_s(self) -> float:
        """rms support speed (or the drive speed): the scale of the fit's velocities."""
        v_rms = math.sqrt(float(np.mean(np.diff(self.control[:, 0]) ** 2))) / self.timestep_s
        return max(v_rms, abs(self.rig.drive_velocity_m_per_s))

    @property
    def support_step_velocity_m_per_s(self) -> np.ndarray:
        """The table's mean velocity over each step, from its controls."""
        return np.diff(self.control[:, 0], prepend=self.initial_support_position_m) / \
            self.timestep_s

    @property
    def support_velocity_at_samples_m_per_s(self) -> np.ndarray:
        """``support_step_velocity_m_per_s`` at the record's samples (each step's mean placed
        at its midpoint, linearly interpolated)."""
        support = self.support_step_velocity_m_per_s
        step_mid_s = self.time_s[0] + (np.arange(len(support)) + 0.5) * self.timestep_s
        return np.interp(self.time_s, step_mid_s, support)

    @property
    def sliding_speeds_m_per_s(self) -> tuple[float, ...]:
        """Quantiles of the estimated sliding speed |slider - support| (the fit's Stribeck
        level coordinate): the slider's from the measured position, else the drive's."""
        return speed_quantiles(self.time_s, self.measured.get("position_m"),
                               self.rig.drive_velocity_m_per_s,
                               self.support_velocity_at_samples_m_per_s)

    def start_levels(self, scan: Sequence[float]) -> tuple[float, list[float]]:
        """The friction level that scales the fit and the levels a start scan tries: the
        measured friction's, else the drive force's late mean times ``scan`` (vibration lowers
        the drive force below the friction level), carried on from the largest drive force
        measured where that lies beyond."""
        if "friction_force_N" in self.measured:
            level = float(np.quantile(np.abs(self.measured["friction_force_N"]), 0.95))
            return max(level, 1e-9), [level]
        drive = self.measured["drive_force_N"]
        level = float(np.mean(np.abs(drive[len(drive) // 2:])))
        levels = [level * r for r in scan]
        # A strong vibration lowers the drive force far more than the scan reaches (F_dv/F_ds
        # 0.04 at kappa_v 20), and a spring that has not loaded to breakaway before it leaves
        # the level above every force measured: the scan goes on from the largest force the
        # record holds. (A 0.8 kg Dahl rig, 50 ms, 40 N at mu 0.2: late mean 0.32 N, largest
        # 2.6 N, level 8 N; from the late mean alone the fit ended at mu 0.138 with a position
        # residual 26 times its noise.)
        peak = float(np.quantile(np.abs(drive), 0.99))
        levels += [peak * r for r in scan if peak * r > levels[-1] * (1 + 1e-9)]
        return max(level, 1e-9), levels

    def slider_estimate(self, step: int, friction: FrictionParameters,
                        mass_kg: float) -> np.ndarray:
        """The slider's (position, velocity, deflection) at the start of ``step`` from the
        record: a least-squares parabola through the measured positions around (the
        measured velocity where there is one), the contact at rest holding the measured
        friction (else the drive force less mass times the parabola's acceleration; within
        the elastic range; 0 for Coulomb)."""
        t = self.time_s[0] + step * self.timestep_s
        sample_dt = float(self.time_s[1] - self.time_s[0])
        width = 2 * SEGMENT_SMOOTHING_SAMPLES + 1
        first = min(max(0, int(round((t - self.time_s[0]) / sample_dt)) -
                        SEGMENT_SMOOTHING_SAMPLES), self.n - width)
        window = slice(first, first + width)
        curvature, slope, position = np.polyfit(self.time_s[window] - t,
                                                self.measured["position_m"][window], 2)
        def line_at_t(values: np.ndarray) -> float:  # (a line through the window: less noise)
            return float(np.polyval(np.polyfit(self.time_s[window] - t, values[window], 1), 0.0))

        velocity = line_at_t(self.measured["velocity_m_per_s"]) \
            if "velocity_m_per_s" in self.measured else float(slope)
        if "friction_force_N" in self.measured:
            force = line_at_t(self.measured["friction_force_N"])
        else:
            force = line_at_t(self.measured["drive_force_N"]) - mass_kg * 2.0 * float(curvature)
        normal = self.control[min(step, self.nstep - 1), FRICTION_CTRL] \
            if self.normal_force_from_record else self.rig.normal_force_N
        return np.array([float(position), velocity,
                         deflection_at_rest(friction, force, normal)])

    def segment_state(self, model: mujoco.MjModel, friction: FrictionParameters,
                      data: mujoco.MjData, step: int, mass_kg: float,
                      offset: Sequence[float] | None = None) -> np.ndarray:
        """The state at the start of ``step`` (at least 2): the table and the drive end where
        their controls put them, the slider at ``slider_estimate`` (+ ``offset``)."""
        mujoco.mj_resetData(model, data)
        h = self.timestep_s
        data.time = step * h
        x, v, z = self.slider_estimate(step, friction, mass_kg) + (
            0.0 if offset is None else np.asarray(offset, dtype=float))
        c = self.control
        table = c[step - 1, 0]
        table_velocity = (c[step, 0] - c[step - 2, 0]) / (2 * h)
        place_rig(model, data, table, table_velocity, x, v, c[step - 1, 1],
                  self.rig.drive_velocity_m_per_s)
        if friction.law != "coulomb" and model.na:
            data.act[model.actuator("friction").actadr[0]] = z
        return sim.full_state(model, data)

    def halved(self) -> "RigReplay":
        """The same replay at half the timestep: the step ends in between by linear
        interpolation of the controls (they already follow the measured motion's spline)."""
        c = self.control
        first = np.array([[self.initial_support_position_m, self.initial_drive_end_m, 0.0, 0.0]])
        previous = np.vstack([first, c[:-1]])
        out = np.empty((2 * len(c), c.shape[1]))
        out[0::2] = 0.5 * (previous + c)
        out[1::2] = c
        if self.normal_force_from_record:
            # the load is each step's middle value: the half steps' middles lie a quarter
            # step either side of it (linear between the middles, held at the first)
            load = c[:, FRICTION_CTRL]
            before = np.concatenate([load[:1], load[:-1]])
            after = np.concatenate([load[1:], load[-1:]])
            out[0::2, FRICTION_CTRL] = 0.75 * load + 0.25 * before
            out[1::2, FRICTION_CTRL] = 0.75 * load + 0.25 * after
        sliding = self.sliding_steps_per_sample
        half = replace(self, substeps=2 * self.substeps, timestep_s=self.timestep_s / 2,
                       sliding_steps_per_sample=2 * sliding if sliding else None, control=out)
        return replace(half, control=out[:half.nstep])

    def outputs(self, model: mujoco.MjModel, rig: RigParameters, sensordata: np.ndarray,
                names: Sequence[str]) -> dict[str, np.ndarray]:
        return _channels(model, rig, sensordata, names)

    def model(self, rig: RigParameters, friction: FrictionParameters,
              outputs: Sequence[str] | None = None) -> mujoco.MjModel:
        """The rig scene with these values, its motions driven by ctrl (``outputs``: only the
        sensors these channels read)."""
        lag_s = friction.sensor_lag_s
        if self.lagged_sensor == "dynamometer":
            friction = replace(friction, sensor_lag_s=0.0)
        spec = rig_module.build_spec(rig, friction, self.timestep_s)
        for name in ("table_shaker", "drive_end_motion"):
            sim.set_plugin_config(spec, name, {"displacement_from_ctrl": "true"})
        if self.normal_force_from_record:
            sim.set_plugin_config(spec, "friction", {
                **rig_module.friction_config(rig, friction), "normal": "0.0",
                "normal_gain": "1.0", "normal_from_ctrl": "true"})
        if self.lagged_sensor == "dynamometer":
            sim.set_plugin_config(spec, "dynamometer",
                                         rig_module.dynamometer_config(rig, lag_s))
        if outputs is not None:
            keep = {s for name in outputs for s in SENSORS_OF_OUTPUT[name]}
            for sensor in list(spec.sensors):
                if sensor.name not in keep:
                    spec.delete(sensor)
        model = spec.compile()
        ctrl = int(model.actuator_ctrladr[model.actuator("friction").id])
        if ctrl != FRICTION_CTRL:  # (the scenes' actuator order)
            raise RuntimeError(f"the rig's friction actuator's ctrl is {ctrl}, not "
                               f"{FRICTION_CTRL}")
        return model

    def initial_state(self, model: mujoco.MjModel, friction: FrictionParameters,
                      data: mujoco.MjData, initial_velocity_m_per_s: float | None = None
                      ) -> np.ndarray:
        """The state at the first sample (``initial_velocity_m_per_s``: the slider's, in place
        of the record's measured or estimated one)."""
        mujoco.mj_resetData(model, data)
        v0 = self.initial_velocity_m_per_s if initial_velocity_m_per_s is None else \
            initial_velocity_m_per_s
        place_rig(model, data, self.initial_support_position_m,
                  self.initial_support_velocity_m_per_s, self.initial_position_m, v0,
                  self.initial_drive_end_m, self.rig.drive_velocity_m_per_s)
        normal = self.control[0, FRICTION_CTRL] if self.normal_force_from_record else \
            self.rig.normal_force_N
        if self.starts_in_motion:
            contact_sliding(model, data, friction, v0 - self.initial_support_velocity_m_per_s,
                            normal, self.initial_position_m - self.initial_support_position_m)
        else:
            contact_at_rest(model, data, friction, self.initial_friction_N, normal)
        return sim.full_state(model, data)


class Replayer:
    """Runs parameter sets through a replay on a pool of rollout threads.

    With ``segment_steps`` (the steps where segments start, each at least 2, increasing) each
    case runs as segments in parallel: the first from the record's start, each other from the
    record's state at its start (``RigReplay.segment_state``), each up to the next one's
    start. An error of the model then carries over at most one segment (multiple shooting
    with the segments' start states estimated from the record instead of fitted)."""

    def __init__(self, replay: RigReplay, threads: int | None = None,
                 segment_steps: Sequence[int] = ()):
        self.replay = replay
        self.threads = max(1, threads or sim.cpu_count())
        self._pool = mj_rollout.Rollout(nthread=self.threads)
        self.simulations = 0
        self.segment_starts = [0, *segment_steps]
        ends = [*segment_steps, replay.nstep]
        self.segment_lengths = [b - a for a, b in zip(self.segment_starts, ends)]
        if min(self.segment_lengths) < 1 or (len(segment_steps) and min(segment_steps) < 2):
            raise ValueError(f"segment starts {list(segment_steps)} must increase from step 2 "
                             f"below the replay's {replay.nstep} steps")

    def close(self) -> None:
        self._pool.close()

    def __enter__(self) -> "Replayer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def run(self, cases: Sequence[tuple], extra: Sequence[str] = ()
            ) -> list[dict[str, np.ndarray]]:
        """Predicted channels at the record's samples, one dict per case: (RigParameters,
        FrictionParameters[, initial-state values for ``initial_state``[, a scene's named
        values]]) (``extra`` adds unmeasured channels, e.g. friction_force_N and
        relative_position_m of a drive record)."""
        return self._run(cases, extra, None)[0]

    def shoot(self, cases: Sequence[tuple], start_offsets: Sequence[np.ndarray]
              ) -> tuple[list[dict[str, np.ndarray]], list[np.ndarray]]:
        """Multiple shooting: ``run`` with each segment after the first started
        ``start_offsets[case][j - 1]`` = (position, velocity, deflection) away from the
        record's state (``RigReplay.segment_state``); also returns, per case, the slider's
        (position, velocity, deflection) at the end of every segment but the last (where the
        next one starts: the continuity)."""
        return self._run(cases, (), start_offsets)

    def _run(self, cases: Sequence[tuple], extra: Sequence[str],
             start_offsets: Sequence[np.ndarray] | None
             ) -> tuple[list[dict[str, np.ndarray]], list[np.ndarray]]:
        replay = self.replay
        names = list(replay.channels) + [c for c in extra if c not in replay.channels]
        models = [replay.model(case[0], case[1], *([case[3]] if len(case) > 3 and case[3]
                                                   else []), outputs=names)
                  for case in cases]
        out: list[dict[str, np.ndarray] | None] = [None] * len(models)
        ends: list[np.ndarray | None] = [None] * len(models)
        # One rollout per state size (a sensor lag adds a plugin state).
        groups: dict[int, list[int]] = {}
        for i, m in enumerate(models):
            groups.setdefault(m.nplugin and int(np.sum(m.plugin_statenum)), []).append(i)
        segments, steps = len(self.segment_starts), max(self.segment_lengths)
        # (rollout keeps every step of every case: as many steps a call as a whole run's
        # _CASES_PER_ROLLOUT cases, segments of a case running the longest one's steps)
        per_call = max(1, _CASES_PER_ROLLOUT * replay.nstep // (segments * steps))
        chunks = [members[k:k + per_call] for members in groups.values()
                  for k in range(0, len(members), per_call)]
        if segments > 1:  # each segment's controls, the last held where a segment is shorter
            padded = np.concatenate([replay.control,
                                     np.repeat(replay.control[-1:], steps, axis=0)])
            control = np.stack([padded[k:k + steps] for k in self.segment_starts])
        else:
            control = replay.control[None]
        for members in chunks:
            group = [models[i] for i in members for _ in range(segments)]
            datas = [mujoco.MjData(group[0]) for _ in range(self.threads)]
            states = []
            for i in members:
                states.append(replay.initial_state(models[i], cases[i][1], datas[0],
                                                   **(cases[i][2] if len(cases[i]) > 2
                                                      else {})))
                states.extend(replay.segment_state(
                    models[i], cases[i][1], datas[0], step, cases[i][0].mass_kg,
                    None if start_offsets is None else start_offsets[i][j])
                    for j, step in enumerate(self.segment_starts[1:]))
            controls = np.broadcast_to(control, (len(members), *control.shape))
            state, sensordata = self._pool.rollout(
                group, datas, np.stack(states),
                np.ascontiguousarray(controls.reshape(len(group), steps, -1)), nstep=steps)
            sensordata = sensordata.reshape(len(members), segments, steps, -1)
            state = state.reshape(len(members), segments, steps, -1)
            for k, i in enumerate(members):
                rows = np.concatenate([sensordata[k, j, :length] for j, length in
                                       enumerate(self.segment_lengths)])
                out[i] = replay.outputs(models[i], cases[i][0], replay.at_samples(rows), names)
                if start_offsets is not None:  # (state row L - 1: after L steps)
                    ends[i] = slider_state(models[i], np.array(
                        [state[k, j, length - 1]
                         for j, length in enumerate(self.segment_lengths[:-1])]))
        self.simulations += len(models)
        return out, ends


def _channels(model: mujoco.MjModel, rig: RigParameters, sensordata: np.ndarray,
              names: Sequence[str]) -> dict[str, np.ndarray]:
    def sensor(name: str) -> np.ndarray:
        return sim.sensor_columns(model, sensordata, name)

    out = {}
    for name in names:
        if name == "position_m":
            out[name] = sensor("slider_position")
        elif name == "velocity_m_per_s":
            out[name] = sensor("slider_velocity")
        elif name == "acceleration_m_per_s2":
            out[name] = sensor("slider_acceleration")[:, 0]
        elif name == "drive_force_N":
            out[name] = -rig.drive_chain_stiffness_N_per_m * sensor("drive_spring_extension")
        elif name == "friction_force_N":
            out[name] = sensor("friction_state")[:, 4]
        elif name == "relative_position_m":
            out[name] = sensor("slider_position") - sensor("table_position")
        elif name == "relative_velocity_m_per_s":
            out[name] = sensor("relative_velocity")
        else:  # pragma: no cover - a programming error
            raise KeyError(name)
    return out


def prepare_rig_replay(dataset: Dataset, *, substeps: int | None = None) -> RigReplay:
    """Set a rig record up for replay in the rig; InputError naming what is missing
    otherwise. (``replays.prepare_replay`` sends a record to the rig or to the machine its
    sidecar's ``model`` names.)"""
    if dataset.metadata.model not in (None, RIG_MODEL):
        raise ValueError(f"{dataset.name}: a record of the model {dataset.metadata.model!r}, "
                         "not the rig: replay it with replays.prepare_replay")
    where = str(dataset.source_path or dataset.name)
    meta = dataset.metadata
    columns = dataset.columns
    t, sample_dt = uniform_times(dataset, where, lambda t: float(np.median(np.diff(t))))
    # (the dataset format guarantees a force column: drive_force_N or friction_force_N)
    measured = {c: np.asarray(columns[c], dtype=float) for c in OUTPUT_CHANNELS if c in columns}
    k_d, v_d = _drive_spring(meta, where)
    frequency = meta.vibration_frequency_Hz
    support_velocity, vibrating, still = _support_vibration(dataset, sample_dt, where)
    substeps, from_record = substeps_of_record(dataset, sample_dt, substeps)
    if substeps is None:
        substeps = 1
        if vibrating:
            substeps = min(MAX_SUBSTEPS, max(1, math.ceil(
                MIN_STEPS_PER_PERIOD * frequency * sample_dt - 1e-9)))
    if not 1 <= int(substeps) <= 64:
        raise InputError(f"substeps {substeps} must lie in 1..64")
    substeps = int(substeps)
    timestep = sample_dt / substeps
    sliding = None
    if vibrating and not meta.simulation_timestep_s:  # (a simulator's record: its own grid)
        timestep = sliding_timestep(sample_dt, substeps, frequency)
        sliding = sample_dt / timestep
    nstep = grid_steps(len(t), substeps, sliding)
    step_ends = t[0] + timestep * np.arange(1, nstep + 1)
    support_position, table, support_velocity = _support_motion(
        dataset, t, sample_dt, step_ends, support_velocity, vibrating)
    position = np.asarray(dataset.position_m, dtype=float)
    velocity0 = float(dataset.velocity_m_per_s[0]) if "velocity_m_per_s" in columns else \
        float(smoothed_derivative(position[:32], t[:32])[0])
    friction0, drive_end0, play_side = _drive_start(columns, t, position, k_d, v_d)
    drive_end = drive_end0 + v_d * (step_ends - t[0])
    control = np.zeros((nstep, 4))
    control[:, 0], control[:, 1] = table, drive_end  # actuator order of rig.xml
    normal = dataset.normal_force_N
    normal_known = normal is not None
    normal_from_record = "normal_force_N" in columns
    if normal_from_record:  # the measured load at each step's middle, the friction's ctrl
        middles = step_ends - 0.5 * timestep
        control[:, FRICTION_CTRL] = np.interp(middles, t, np.asarray(normal, dtype=float))
    rig = RigParameters(
        mass_kg=meta.mass_kg or 1.0, drive_stiffness_N_per_m=k_d, drive_velocity_m_per_s=v_d,
        vibration_frequency_Hz=frequency or 0.0, vibration_velocity_amplitude_m_per_s=0.0,
        normal_force_N=float(np.median(normal)) if normal_known else UNIT_NORMAL_FORCE_N)
    return RigReplay(
        name=dataset.name, time_s=t, substeps=substeps, timestep_s=timestep, control=control,
        measured=measured, noise={c: noise_sd(v) for c, v in measured.items()}, rig=rig,
        mass_known=meta.mass_kg is not None, normal_force_known=normal_known,
        initial_position_m=float(position[0]), initial_velocity_m_per_s=velocity0,
        initial_support_position_m=float(support_position[0]),
        initial_support_velocity_m_per_s=float(support_velocity[0]),
        initial_drive_end_m=drive_end0, initial_friction_N=friction0, vibrating=vibrating,
        timestep_from_record=from_record, sliding_steps_per_sample=sliding,
        support_still=still, normal_force_from_record=normal_from_record,
        initial_play_side=play_side, starts_in_motion=not vibrating and starts_in_motion(
            t, position - support_position,
            np.asarray(columns["velocity_m_per_s"]) - support_velocity
            if "velocity_m_per_s" in columns else None))


def _drive_spring(meta, where: str) -> tuple[float, float]:
    """(k_d in N/m, v_d in m/s) of the record's drive spring, refused in one line when the
    sidecar lacks them or they cannot drive."""
    missing = [k for k in ("drive_stiffness_N_per_m", "drive_velocity_m_per_s")
               if getattr(meta, k) is None]
    if missing:
        raise InputError(f"{where}: the rig replay needs {' and '.join(missing)} in the "
                         "sidecar (or --set NAME=VALUE): the drive spring and the speed "
                         "of its far end")
    k_d, v_d = meta.drive_stiffness_N_per_m, meta.drive_velocity_m_per_s
    if k_d <= 0 or v_d == 0:
        raise InputError(f"{where}: the rig replay needs drive_stiffness_N_per_m > 0 and a "
                         f"non-zero drive_velocity_m_per_s (got {k_d!r}, {v_d!r})")
    return k_d, v_d


def _support_vibration(dataset: Dataset, sample_dt: float,
                       where: str) -> tuple[np.ndarray, bool, bool]:
    """(the support's measured velocity in m/s, whether it vibrates, whether a vibrometer's
    noise alone was taken for a still support: then the velocity is zeros)."""
    frequency = dataset.metadata.vibration_frequency_Hz
    support_velocity = np.asarray(dataset.support_velocity_m_per_s, dtype=float)
    vibrating = bool(frequency) and np.ptp(support_velocity) > 0
    if vibrating and frequency * sample_dt > 0.4:
        raise InputError(f"{where}: vibration_frequency_Hz {frequency:g} is above 0.8 of the "
                         f"Nyquist frequency of the record ({0.5 / sample_dt:g} Hz): the "
                         "support's motion is not resolved; record it faster")
    still = vibrating and "support_position_m" not in dataset.columns and \
        noise_only_vibration(support_velocity, sample_dt, frequency)
    if still:
        # A vibrometer's noise on a support that does not vibrate: the support stands still.
        # Kept in the vibration band, the noise dithered the contact (measured on a Dahl
        # stick-slip record with 20 um/s of noise: the true values 16 noise sd rms off, the
        # fit 5.6 % off in the drive force); low-passed (f/64), it integrated to a 4 nm
        # wander of the table, which the fit took for a ripple.
        vibrating = False
        support_velocity = np.zeros_like(support_velocity)
    return support_velocity, vibrating, still


def _support_motion(dataset: Dataset, t: np.ndarray, sample_dt: float, step_ends: np.ndarray,
                    support_velocity: np.ndarray,
                    vibrating: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the support's position at the samples (m), its displacement at every step's end (the
    motion actuator's ctrl, m), its velocity at the samples (m/s)): the measured position's
    cubic spline, else the exact integral of the measured velocity's (trapezoid sums lose
    ~(w dt)^2/12 of the amplitude: 0.5 % at 25 samples a period), else still."""
    columns = dataset.columns
    frequency = dataset.metadata.vibration_frequency_Hz
    if "support_position_m" in columns:
        support_position = np.asarray(columns["support_position_m"], dtype=float)
        if vibrating:
            # A displacement sensor's noise passes through a stiff contact as friction noise
            # (1 nm at 60 N/um: 0.06 N): kept to the vibration band and the slow motion.
            # (a straight line out first: the slow part is a low-pass, whose ends a large
            # offset or drift would bend)
            trend = np.polyval(np.polyfit(t - t[0], support_position, 1), t - t[0])
            band = vibration_band(support_position - trend, sample_dt, frequency)
            smooth = trend + band + slow_part(support_position - trend - band, sample_dt,
                                              frequency)
            support_position = _filtered_if_noisy(support_position, smooth)
        table = make_interp_spline(t, support_position, k=3)(step_ends, extrapolate=True)
    elif "support_velocity_m_per_s" in columns:
        if vibrating:
            # Only the vibration is kept: a vibrometer's broadband noise would otherwise shake
            # the contact like a real dither (20 um/s at 100 kHz makes a LuGre slider creep by
            # ~10 nm in 20 ms) and its integral would drift as a random walk. A velocity with
            # no such noise is kept whole (the band would smear an abrupt start).
            support_velocity = _filtered_if_noisy(
                support_velocity, vibration_band(support_velocity, sample_dt, frequency))
        support_position, table = support_displacement(
            t, support_velocity, step_ends, dataset.metadata.simulation_timestep_s)
    else:
        support_position = np.zeros_like(t)
        table = np.zeros(len(step_ends))
    return support_position, table, support_velocity


def _drive_start(columns: Mapping[str, np.ndarray], t: np.ndarray, position: np.ndarray,
                 k_d: float, v_d: float) -> tuple[float, float, float]:
    """(the friction force at the first sample (N), the drive's far end at the first sample
    (m), the side of a play the spring holds the slider on: +-1, 0 when it is open)."""
    # Quasi-static equilibrium: the spring holds the slider (a measured friction force at the
    # first sample may be mostly bristle damping of a starting motion, not deflection).
    if "drive_force_N" in columns:
        friction0 = float(columns["drive_force_N"][0])
    elif "friction_force_N" in columns:
        friction0 = float(columns["friction_force_N"][0])
    else:
        friction0 = 0.0
    if "drive_force_N" in columns:
        # The dynamometer is the drive spring: x + F_d / k_d - v_d t is the far end's start at
        # every sample; their mean has sqrt(n) less noise than the first sample alone. (With
        # a play the estimate is off by up to half of it; a backlash candidate's play is placed
        # relative to the start, so its faces land where the record puts them whatever this
        # estimate: ``backlash_centre_m``.)
        ends = position + np.asarray(columns["drive_force_N"], dtype=float) / k_d - \
            v_d * (t - t[0])
        drive_end0 = float(np.mean(ends))
    else:
        drive_end0 = float(position[0])
    holding = next((columns[c] for c in ("drive_force_N", "friction_force_N") if c in columns),
                   None)
    play_side = 0.0  # (a force within 5 noise sd of 0 at the start: the play is open)
    if holding is not None and abs(friction0) > 5.0 * noise_sd(np.asarray(holding, dtype=float)):
        play_side = math.copysign(1.0, friction0)
    return friction0, drive_end0, play_side


# Stick phases (``stick_phase_steps``): between two slips (speed relative to the support above
# ``SLIP_FRACTION`` of its 95th percentile), the sample closest to rest, where speed and
# acceleration over their 95th percentiles add up to less than ``STICK_FRACTION``. (Speed alone
# also takes the turning points of the contact's ringing after a slip, where the slider is not
# at rest: measured there, the deflection at equilibrium 8 % off and the velocity 62 um/s,
# against 0.2 % and 4 um/s at the sample closest to rest.)
SLIP_FRACTION = 0.5
SLIP_ABOVE_NOISE = 20.0  # slips' 95th-percentile speed over the smoothed derivative's noise
STICK_FRACTION = 0.05
MIN_STICK_SAMPLES = 2 * SEGMENT_SMOOTHING_SAMPLES + 1
MAX_SEGMENTS = 64


def stick_phase_steps(replay: RigReplay) -> list[int]:
    """The step at the sample closest to rest between each two slips (at most
    ``MAX_SEGMENTS`` - 1, evenly picked): where a segmented replay's segments start, since a
    sticking slider's state is best known there (at rest, its contact holding the measured
    force). Empty without a measured position, on a sliding step grid (a vibrating sensor
    record), where the support moves (rms velocity above ``STICK_FRACTION`` of the slider's
    95th-percentile speed relative to it), and where no slip stands out of the noise
    (``SLIP_ABOVE_NOISE``)."""
    if "position_m" not in replay.measured or replay.n < 4 * MIN_STICK_SAMPLES or \
            replay.sliding:  # (samples between two steps: a sample would straddle segments)
        return []
    support = replay.support_step_velocity_m_per_s
    velocity = smoothed_derivative(replay.measured["position_m"], replay.time_s,
                                   SEGMENT_SMOOTHING_SAMPLES) - \
        replay.support_velocity_at_samples_m_per_s
    acceleration = smoothed_derivative(velocity, replay.time_s, SEGMENT_SMOOTHING_SAMPLES)
    speed_95 = float(np.quantile(np.abs(velocity), 0.95))
    # (slips must stand out of the smoothed derivative's noise: sd sqrt(12 / (n (n^2 - 1)))
    # position sd / dt for a parabola through n samples; noise peaks of a slider that never
    # slips passed for slips otherwise. A moving support: turning points of the relative
    # motion while a vibration ramps up would pass for stick phases.)
    n = 2 * SEGMENT_SMOOTHING_SAMPLES + 1
    sample_dt = float(replay.time_s[1] - replay.time_s[0])
    derivative_noise = math.sqrt(12.0 / (n * (n * n - 1))) * white_noise_sd(
        replay.measured["position_m"]) / sample_dt
    if not speed_95 > SLIP_ABOVE_NOISE * derivative_noise or \
            math.sqrt(float(np.mean(support ** 2))) > STICK_FRACTION * speed_95:
        return []
    from_rest = np.abs(velocity) / speed_95 + np.abs(acceleration) / max(
        float(np.quantile(np.abs(acceleration), 0.95)), 1e-300)
    slipping = np.abs(velocity) > SLIP_FRACTION * speed_95
    changes = np.flatnonzero(np.diff(slipping.astype(int))) + 1
    runs = np.split(np.arange(replay.n), changes)
    slips = [run for run in runs if slipping[run[0]]]
    starts = []
    for before, after in zip(slips[:-1], slips[1:]):
        a, b = before[-1] + 1, after[0]
        if b - a < MIN_STICK_SAMPLES:
            continue
        sample = a + int(np.argmin(from_rest[a:b]))
        step = int(round(sample * replay.steps_per_sample))
        if from_rest[sample] < STICK_FRACTION and 2 <= step < replay.nstep - 1:
            starts.append(step)
    if len(starts) >= MAX_SEGMENTS:
        starts = [starts[int(i)] for i in
                  np.linspace(0, len(starts) - 1, MAX_SEGMENTS - 1).round()]
    return starts


LEVEL_SPEED_QUANTILES = 64


def speed_quantiles(time_s: np.ndarray, position_m: np.ndarray | None,
                    fallback_velocity_m_per_s: float,
                    support_velocity_m_per_s: np.ndarray | float = 0.0) -> tuple[float, ...]:
    """Quantiles of |body velocity - support velocity| over a record: the body's from a
    smoothed derivative of its measured position, else ``fallback_velocity_m_per_s``."""
    body = smoothed_derivative(position_m, time_s) if position_m is not None else \
        np.full(len(time_s), float(fallback_velocity_m_per_s))
    speed = np.abs(body - support_velocity_m_per_s)
    levels = (np.arange(LEVEL_SPEED_QUANTILES) + 0.5) / LEVEL_SPEED_QUANTILES
    return tuple(float(v) for v in np.quantile(speed, levels))


def sliding_timestep(sample_dt: float, substeps: int, frequency_Hz: float) -> float:
    """About ``substeps`` steps a sample, as N + 0.382 steps a vibration period
    (``rig.period_timestep``). A lab's sample rate is usually a multiple of the vibration
    frequency; on a step grid that repeats every period the element's discretization error
    repeats too and does not average out: measured on the lab scenario (LuGre, v_a/v_d = 20,
    the mean drive force), +8.9 % at 50 steps a period against +0.22 % at 50.382
    (docs/physics.md, scripts/check_strong_vibration_timestep.py)."""
    steps = max(1, round(substeps / (frequency_Hz * sample_dt)))
    return rig_module.period_timestep(frequency_Hz, steps)


def substeps_of_record(dataset: Dataset, sample_dt: float,
                       substeps: int | None) -> tuple[int | None, bool]:
    """(substeps, from the record): a record a simulator made is replayed at its timestep
    (the sidecar's ``simulation_timestep_s``) unless ``substeps`` is given."""
    simulated = dataset.metadata.simulation_timestep_s
    if substeps is not None or not simulated:
        return substeps, False
    ratio = sample_dt / simulated
    if abs(ratio - round(ratio)) > 1e-6 or not 1 <= round(ratio) <= 64:
        where = str(dataset.source_path or dataset.name)
        raise InputError(f"{where}: simulation_timestep_s {simulated:g} must divide the "
                         f"sample interval {sample_dt:g} s into 1 to 64 steps; fix the "
                         "sidecar or pass --substeps")
    return round(ratio), True  # replayed as the record was simulated


def slow_part(values: np.ndarray, dt: float, frequency_Hz: float) -> np.ndarray:
    """``values`` low-passed (zero phase, fourth order) at ``ENVELOPE_BANDWIDTH`` of the
    vibration frequency: a support's motion apart from its vibration (its rest position, a
    slow drift)."""
    sos = butter(4, ENVELOPE_BANDWIDTH * frequency_Hz, btype="lowpass", fs=1.0 / dt,
                 output="sos")
    return sosfiltfilt(sos, np.asarray(values, dtype=float))


def broadband_noise_sd(measured: np.ndarray, filtered: np.ndarray) -> float:
    """Robust sd of what a filter removes from a measured support motion (its sensor's
    broadband noise; a few samples at an abrupt start do not count)."""
    removed = np.asarray(measured, dtype=float) - filtered
    return 1.4826 * float(np.median(np.abs(removed - np.median(removed))))


def _filtered_if_noisy(measured: np.ndarray, filtered: np.ndarray) -> np.ndarray:
    """``filtered`` where the sensor's broadband noise is above ``NOISE_FLOOR_OF_RANGE`` of
    the signal's range, else ``measured`` as it is (a filter would smear an abrupt start)."""
    noisy = broadband_noise_sd(measured, filtered) > \
        NOISE_FLOOR_OF_RANGE * float(np.ptp(measured))
    return filtered if noisy else np.asarray(measured, dtype=float)


def support_displacement(t: np.ndarray, velocity: np.ndarray, step_ends: np.ndarray,
                         simulation_timestep_s: float | None) -> tuple[np.ndarray, np.ndarray]:
    """(displacement at the samples, at the replay's step ends) from a support's velocity,
    0 at the first sample.

    A sensor's velocity is the velocity at its sample time: the exact integral of its cubic
    spline. A simulator's (a record with ``simulation_timestep_s`` h) is the mean over the
    step that ends at the sample, (u_k - u(t_k - h)) / h: at one step a sample its running
    sum is the simulator's own displacement exactly; at more, the spline is placed at the
    steps' midpoints t - h/2 (a sensor's spline would lag by half a step: 6 % of the
    amplitude at 50 samples a period)."""
    dt = float(np.median(np.diff(t)))
    h = simulation_timestep_s or 0.0
    if h > 0 and abs(h - dt) <= 1e-6 * dt:
        at_samples = np.concatenate([[0.0], np.cumsum(velocity[1:] * np.diff(t))])
        return at_samples, make_interp_spline(t, at_samples, k=3)(step_ends, extrapolate=True)
    integral = make_interp_spline(t - h / 2, velocity, k=3).antiderivative()
    return (integral(t) - integral(t[0]),
            integral(step_ends, extrapolate=True) - integral(t[0]))


_BAND_CACHE: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}  # key -> (signal, band)
_BAND_CACHE_SIZE = 4


def vibration_band(signal: np.ndarray, dt: float, frequency_Hz: float) -> np.ndarray:
    """``_vibration_band``, remembered for the last few signals: a record is prepared for
    replay at several timesteps, and each preparation asks for its support's band twice
    (``noise_only_vibration`` first), about a second each for a 0.4 s, 100 kHz record."""
    x = np.ascontiguousarray(signal, dtype=float)
    key = (hash(x.tobytes()), len(x), float(dt), float(frequency_Hz))
    if key not in _BAND_CACHE or not np.array_equal(_BAND_CACHE[key][0], x):
        if len(_BAND_CACHE) >= _BAND_CACHE_SIZE:
            _BAND_CACHE.pop(next(iter(_BAND_CACHE)))
        _BAND_CACHE[key] = (x.copy(), _vibration_band(x, dt, frequency_Hz))
    return _BAND_CACHE[key][1].copy()


def _vibration_band(signal: np.ndarray, dt: float, frequency_Hz: float) -> np.ndarray:
    """The part of a vibrating support's measured motion at the vibration frequency and its
    harmonics (up to ``VIBRATION_HARMONICS``, below 0.8 of the Nyquist frequency), fitted by
    least squares with each harmonic's complex envelope a cubic spline in time
    (``_harmonic_fit``), after the signal's slow part (an offset, a drift: the first fit's
    residual low-passed at ``ENVELOPE_BANDWIDTH`` of the frequency) is taken out: left in, it
    counted as noise and let a real amplitude change pass for steady."""
    x = np.asarray(signal, dtype=float)
    first, fitted = _harmonic_fit(x, dt, frequency_Hz)
    # (the samples the fit left out do not enter the slow part: a jump or a glitch would;
    # ``slow_part``'s filter needs more than 15 samples: MIN_SAMPLES)
    slow = slow_part(np.where(fitted, x - first, 0.0), dt, frequency_Hz)
    # White noise alone leaves sqrt(2 fc dt) of its sd below the low-pass's cutoff fc. (Its sd
    # from third differences: the fit's residual holds the slow part too, which would count
    # as noise and hide itself at a few samples a period.)
    noise_alone = white_noise_sd(x - first) * math.sqrt(
        2 * ENVELOPE_BANDWIDTH * frequency_Hz * dt)
    if math.sqrt(float(np.mean(slow ** 2))) <= SLOW_PART_ABOVE_NOISE * noise_alone:
        return first
    return _harmonic_fit(x - slow, dt, frequency_Hz)[0]


def _harmonic_fit(x: np.ndarray, dt: float, frequency_Hz: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``_vibration_band``'s fit of ``x`` (whose slow part is taken out), and which samples it
    fitted.

    A steady vibration (constant amplitudes and phases fit as well as the finest spline, a knot
    every period, up to the noise) is fitted as one: a handful of values per harmonic, the
    vibrometer's noise averaged over the whole record. (A band filter kept the noise within
    its bandwidth, and the slider, whose mean speed follows the vibration's amplitude,
    integrated that amplitude noise into its position: 1.4 nm rms at 4 kHz, 1.5 mm/s and
    20 um/s of noise, against 0.5 nm now.) Otherwise the knots lie on period boundaries, as
    few as the record needs: starting from no interior knot, every span whose misfit exceeds
    the finest spline's by more than the noise explains (``SPLIT_SIGMAS`` above the
    chi-square mean of the finest spline's extra values there) is split at its middle period,
    until none is: a switch-on, a ramp or a fading amplitude get knots where they happen.

    Samples the finest spline misses by more than ``OUTLIER_SIGMAS`` noise sd are left out of
    the fits, which would ring around them. Those the final fit misses too are kept as
    measured (less the slow part, on ``_vibration_band``'s second pass) where they are the
    record's first or last samples or come in runs (an abrupt switch: a simulator's record
    starts with the support at rest and its vibration at full amplitude one sample later); a
    lone one (a sensor's glitch) takes the fit's value."""
    n = len(x)
    harmonics = _harmonics(dt, frequency_Hz)
    phase = 2 * math.pi * frequency_Hz * dt * np.arange(n)
    carriers = np.column_stack([f(h * phase) for h in harmonics for f in (np.cos, np.sin)])
    width = carriers.shape[1]
    cycles = frequency_Hz * dt * np.arange(n)  # time in periods
    # (the last period, if shorter than one, joins the one before)
    periods = max(1, int(math.floor(cycles[-1] + 1e-9)))
    finest = list(range(periods + 1))
    values = periods + ENVELOPE_DEGREE  # spline values of each envelope at the finest knots

    def finest_fit(kept: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        band, rss = _envelope_fit(x, carriers, cycles, finest, kept)
        dof = max(int(np.count_nonzero(kept)) - width * values, 1)
        return band, rss, float(np.sum(rss)) / dof

    kept = np.ones(n, dtype=bool)
    fine = finest_fit(kept)
    for _ in range(OUTLIER_ROUNDS):
        # (judged afresh against each fit: the first one rings around a jump)
        within = np.abs(x - fine[0]) <= OUTLIER_SIGMAS * math.sqrt(fine[2])
        if np.array_equal(within, kept):
            break
        kept = within
        fine = finest_fit(kept)
    else:  # (not settled: left out what either of the last two rounds left out)
        kept &= np.abs(x - fine[0]) <= OUTLIER_SIGMAS * math.sqrt(fine[2])
        fine = finest_fit(kept)
    _, finest_rss, noise_variance = fine

    def judged(band: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # Left out for good: what the final fit misses too (the finest spline's ends rest on
        # a few samples, and a glitch near an end took its ringing neighbours out with it);
        # kept as measured where at an end or in a run, else the fit's value.
        off = ~kept & (np.abs(x - band) > OUTLIER_SIGMAS * math.sqrt(noise_variance))
        joined = np.zeros(n, dtype=bool)  # with a left-out neighbour, or at an end
        joined[[0, -1]] = True
        joined[1:] |= off[:-1]
        joined[:-1] |= off[1:]
        return np.where(off & joined, x, band), ~off

    # A steady vibration: one amplitude and phase per harmonic, if the finest spline does not
    # fit better than noise would let it (a cubic envelope over the whole record moved the
    # fundamental's amplitude by up to 9e-4 of itself near the ends, where a constant one is
    # 2e-4 off throughout; the slider's predicted position 1.4 nm rms off against 0.5 nm).
    band, steady_rss = _envelope_fit(x, carriers, cycles, None, kept)
    dof = width * (values - 1)
    if float(np.sum(steady_rss)) - float(np.sum(finest_rss)) <= noise_variance * (
            dof + SPLIT_SIGMAS * math.sqrt(2 * dof)):
        return judged(band)
    knots = [0, periods]  # period indices where the envelope's knots lie
    for _ in range(MAX_ENVELOPE_ROUNDS):
        band, span_rss = _envelope_fit(x, carriers, cycles, knots, kept)
        split = []
        for j, (a, b) in enumerate(zip(knots[:-1], knots[1:])):
            dof = width * (b - a - 1)
            excess = span_rss[j] - float(np.sum(finest_rss[a:b]))
            if b - a >= 2 and excess > noise_variance * (dof + SPLIT_SIGMAS * math.sqrt(2 * dof)):
                split.append((a + b) // 2)
        if not split:
            break
        knots = sorted(knots + split)
    return judged(band)


def _harmonics(dt: float, frequency_Hz: float) -> list[int]:
    """The harmonics of the vibration that are kept: up to ``VIBRATION_HARMONICS``, below 0.8
    of the Nyquist frequency."""
    return [h for h in range(1, VIBRATION_HARMONICS + 1) if h * frequency_Hz <= 0.8 * 0.5 / dt]


# Samples whose rows of the envelope design are built at once: the design and its products
# hold about 1.5 kB a sample, so a record is assembled in chunks (at once, a 10 s record at
# 100 kHz needed GBs); the normal equations are banded, small, and solved as a band.
ENVELOPE_CHUNK_SAMPLES = 1 << 14


def _envelope_fit(x: np.ndarray, carriers: np.ndarray, cycles: np.ndarray,
                  knots: Sequence[int] | None, kept: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(the fit, the residual sum of squares of the ``kept`` samples in each span between
    knots) of ``x``'s ``kept`` samples by the carriers times envelopes that are cubic splines
    with knots at ``knots`` (period indices; ``cycles`` each sample's time in periods; the
    last knot stands for the record's end; None: constant envelopes, one span)."""
    ends = np.array([0, cycles[-1]] if knots is None else knots, dtype=float)
    ends[-1] = cycles[-1]
    k = ENVELOPE_DEGREE
    spline_knots = None if knots is None else \
        np.concatenate([[ends[0]] * k, ends, [ends[-1]] * k])

    width = carriers.shape[1]

    def design(rows: slice) -> csr_matrix:
        # (columns spline value-major, carrier-minor: the normal matrix is banded)
        count = rows.stop - rows.start
        if spline_knots is None:
            envelope = coo_matrix(np.ones((count, 1)))
        else:
            envelope = BSpline.design_matrix(cycles[rows], spline_knots, k).tocoo()
        row = np.repeat(envelope.row, width)
        column = (np.repeat(envelope.col, width) * width +
                  np.tile(np.arange(width), envelope.nnz))
        value = np.repeat(envelope.data, width) * carriers[rows][row, column % width]
        return csr_matrix((value, (row, column)), shape=(count, envelope.shape[1] * width))

    chunks = [slice(start, min(start + ENVELOPE_CHUNK_SAMPLES, len(x)))
              for start in range(0, len(x), ENVELOPE_CHUNK_SAMPLES)]
    normal, rhs = None, None
    for rows in chunks:
        used = design(rows)[np.flatnonzero(kept[rows])]
        part, part_rhs = used.T @ used, used.T @ x[rows][kept[rows]]
        normal = part if normal is None else normal + part
        rhs = part_rhs if rhs is None else rhs + part_rhs
    # Banded (each spline value overlaps the k next ones), solved by banded Cholesky with a
    # tiny ridge: a spline value whose samples were all left out stays 0, not singular.
    upper = (k + 1) * width - 1 if spline_knots is not None else width - 1
    size = normal.shape[0]
    banded = np.zeros((upper + 1, size))
    for offset in range(min(upper, size - 1) + 1):
        banded[upper - offset, offset:] = normal.diagonal(offset)
    banded[upper] += 1e-12 * float(np.mean(banded[upper]))
    try:
        coefficients = solveh_banded(banded, rhs)
    except LinAlgError:  # (not positive definite to rounding: the band's LU instead)
        full = np.vstack([banded, np.zeros((upper, size))])
        for offset in range(1, min(upper, size - 1) + 1):
            full[upper + offset, :-offset] = banded[upper - offset, offset:]
        coefficients = solve_banded((upper, upper), full, rhs)
    fitted = np.empty(len(x))
    for rows in chunks:
        fitted[rows] = design(rows) @ coefficients
    span = np.clip(np.searchsorted(ends, cycles, side="right") - 1, 0, len(ends) - 2)
    return fitted, np.bincount(span, np.where(kept, x - fitted, 0.0) ** 2,
                               minlength=len(ends) - 1)


# A support vibrates when its vibration band's rms is above this many times the rms the
# velocity's broadband noise alone leaves in a band f/4 either side of each harmonic.
VIBRATION_ABOVE_NOISE = 3.0


def noise_only_vibration(velocity: np.ndarray, dt: float, frequency_Hz: float) -> bool:
    """Whether a measured support velocity holds no vibration above its sensor's noise: the
    rms of ``vibration_band`` below ``VIBRATION_ABOVE_NOISE`` times the noise's share of a
    band ``ENVELOPE_BANDWIDTH`` of the frequency either side of each harmonic."""
    band = vibration_band(velocity, dt, frequency_Hz)
    share = 2 * ENVELOPE_BANDWIDTH * frequency_Hz * len(_harmonics(dt, frequency_Hz)) / (0.5 / dt)
    # (from first differences: a slow drift the band drops would count as noise in the
    # spread of what it removes, and hide a real vibration)
    noise = math.sqrt(0.5 * float(np.var(np.diff(np.asarray(velocity) - band))))
    return math.sqrt(float(np.mean(band ** 2))) < VIBRATION_ABOVE_NOISE * noise * \
        math.sqrt(share)


def noise_sd(values: np.ndarray) -> float:
    """White-noise standard deviation from the median absolute third difference.

    The third difference of white noise has variance 20 sigma^2; a signal smooth on the sample
    scale contributes little, and the median ignores the few samples at sharp transitions.
    A floor of ``NOISE_FLOOR_OF_RANGE`` of the signal's range: a channel resolved better than
    that (a noise-free record) does not outweigh the others, whose replay through measured,
    interpolated inputs is no more faithful either.
    """
    span = float(np.ptp(values)) or float(np.max(np.abs(values))) or 1.0
    return max(white_noise_sd(values), NOISE_FLOOR_OF_RANGE * span)


__all__ = ["RigReplay", "Replayer", "prepare_rig_replay", "noise_sd", "OUTPUT_CHANNELS",
           "MIN_STEPS_PER_PERIOD"]
