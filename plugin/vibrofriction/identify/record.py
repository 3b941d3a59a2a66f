"""One measured record prepared for identification: signals, target force, law input grid.

The law is driven by the measured relative velocity v_r = body velocity - support velocity.
The plugin's step order (force with the old state, the deflection advanced over the step with
the input at the step's end, see laws.run_law) is first order in the sample interval: at
100 kHz on a 4 kHz vibration it puts the model 5 us ahead of a continuous-time contact, which
looks exactly like a sensor lag. So the law runs on a finer grid built once per record: every
sample interval is cut into ``substeps`` pieces, and each piece is represented by two grid
points -- one just before its end carrying the velocity at its *midpoint* (so the closed-form
update integrates with the midpoint rule), and one at its end carrying the velocity there (so
the force output at each sample uses that sample's own velocity and the state there).
Velocity and position between samples come from a cubic interpolating spline. The outputs at
the data samples are every ``stride``-th grid point. Error against solve_ivp on the rig at
100 kHz: 1.1 N (12 %) with the plain grid, 0.003 N (0.03 %) with 4 substeps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import make_interp_spline
from scipy.signal import butter, sosfiltfilt

from ..data.datasets import Dataset, DatasetError, smoothed_derivative
from ..errors import InputError
from .start import starts_in_motion

# Fraction of a substep left between the midpoint-carrying point and the substep's end.
_END_GAP = 1.0e-3
DEFAULT_SUBSTEPS = 4
# Unit normal load when the data give none: the friction coefficient is then the level in N.
UNIT_NORMAL_FORCE_N = 1.0


@dataclass(frozen=True, eq=False)
class Record:
    """A dataset as identification sees it (all arrays over the data samples)."""

    name: str
    time_s: np.ndarray
    target_N: np.ndarray  # measured friction force, or measured drive force
    target: str  # "friction" or "drive"
    body_velocity_m_per_s: np.ndarray
    relative_velocity_m_per_s: np.ndarray
    relative_position_m: np.ndarray  # position of the body on its support
    acceleration_m_per_s2: np.ndarray | None  # needed for a drive-force target
    normal_force_N: np.ndarray  # per sample (constant when only the sidecar gives it)
    normal_force_known: bool
    mass_kg: float | None  # sidecar value; None = identify it
    drive_velocity_m_per_s: float  # far end of the drive spring (0 when not a spring)
    vibration_frequency_Hz: float | None
    support_phase_offset_rad: float  # support velocity ~ cos(omega t + offset)
    vibrating: bool
    lowpass_Hz: float | None
    # law input grid
    grid_time_s: np.ndarray
    grid_eval_time_s: np.ndarray  # where each grid point's inputs are evaluated
    grid_velocity_m_per_s: np.ndarray
    grid_position_m: np.ndarray
    grid_normal_force_N: np.ndarray
    stride: int
    uniform_dt_s: float | None  # sample interval when uniform
    # the body slides at the first sample: state laws start at their steady sliding state
    starts_in_motion: bool = False

    @property
    def n(self) -> int:
        return len(self.time_s)

    @property
    def support_phase_rad(self) -> np.ndarray | None:
        """Phase psi of the support vibration, u ~ sin(psi), u' ~ cos(psi); None if fixed."""
        if not self.vibrating:
            return None
        return 2 * math.pi * self.vibration_frequency_Hz * self.time_s + \
            self.support_phase_offset_rad

    def grid_support_phase_rad(self) -> np.ndarray:
        return 2 * math.pi * self.vibration_frequency_Hz * self.grid_eval_time_s + \
            self.support_phase_offset_rad

    def lowpass(self, values: np.ndarray) -> np.ndarray:
        """The record's parallel zero-phase low-pass (identity when none)."""
        if self.lowpass_Hz is None:
            return values
        return _zero_phase_lowpass(values, self.uniform_dt_s, self.lowpass_Hz)


def prepare(dataset: Dataset, *, substeps: int | None = None,
            lowpass_Hz: float | None = None, state_law: bool = True) -> Record:
    """Turn a Dataset into a Record; raise InputError when identification cannot use it."""
    where = str(dataset.source_path or dataset.name)
    t = np.asarray(dataset.time_s, dtype=float)
    dt = np.diff(t)
    # Uniform within 0.1 %: time stamps stored in single precision (EMPS: 4e-5) still count.
    uniform = bool(np.ptp(dt) <= 1e-3 * np.median(dt))
    uniform_dt = float(np.median(dt)) if uniform else None
    if lowpass_Hz is not None:
        if not uniform:
            raise InputError(f"{where}: --lowpass needs uniformly sampled data")
        if not 0 < lowpass_Hz < 0.5 / uniform_dt:
            raise InputError(f"{where}: --lowpass {lowpass_Hz} Hz must lie between 0 and the "
                             f"Nyquist frequency {0.5 / uniform_dt:g} Hz")
    columns = dataset.columns
    meta = dataset.metadata
    if lowpass_Hz is not None and "velocity_m_per_s" not in columns:
        # IDIM practice (EMPS description, 3.1): filter the position, then differentiate.
        position = _zero_phase_lowpass(np.asarray(columns["position_m"]), uniform_dt, lowpass_Hz)
        velocity = smoothed_derivative(position, t)
    else:
        position = np.asarray(dataset.position_m, dtype=float)
        velocity = np.asarray(dataset.velocity_m_per_s, dtype=float)
    if "friction_force_N" in columns:
        target, target_N = "friction", np.asarray(columns["friction_force_N"], dtype=float)
        acceleration = None
    else:
        target, target_N = "drive", np.asarray(columns["drive_force_N"], dtype=float)
        if "acceleration_m_per_s2" in columns:
            acceleration = np.asarray(columns["acceleration_m_per_s2"], dtype=float)
        else:
            acceleration = smoothed_derivative(velocity, t)
    support_velocity = np.asarray(dataset.support_velocity_m_per_s, dtype=float)
    if "support_position_m" in columns:
        support_position = np.asarray(columns["support_position_m"], dtype=float)
    else:
        support_position = _integrate(support_velocity, t)
    relative_velocity = velocity - support_velocity
    relative_position = position - support_position
    normal = dataset.normal_force_N
    normal_known = normal is not None
    normal = np.full_like(t, UNIT_NORMAL_FORCE_N) if normal is None else \
        np.asarray(normal, dtype=float)
    if np.any(normal < 0):
        raise DatasetError(f"{where}: column 'normal_force_N' must be >= 0")
    frequency = meta.vibration_frequency_Hz
    vibrating = bool(frequency and np.ptp(support_velocity) > 0)
    phase_offset = _support_phase_offset(t, support_velocity, frequency) if vibrating else 0.0
    substeps = DEFAULT_SUBSTEPS if substeps is None else int(substeps)
    if not state_law:
        substeps = 0
    grid = _law_grid(t, relative_velocity, relative_position, normal, substeps)
    # sliding on the support at the start (a vibrating support's relative velocity changes
    # sign every half period: no steady state to start from, the contact starts at rest)
    in_motion = not vibrating and starts_in_motion(
        t, relative_position, relative_velocity if "velocity_m_per_s" in columns else None)
    return Record(
        name=dataset.name, time_s=t, target_N=target_N, target=target,
        body_velocity_m_per_s=velocity, relative_velocity_m_per_s=relative_velocity,
        relative_position_m=relative_position, acceleration_m_per_s2=acceleration,
        normal_force_N=normal, normal_force_known=normal_known, mass_kg=meta.mass_kg,
        drive_velocity_m_per_s=float(meta.drive_velocity_m_per_s or 0.0),
        vibration_frequency_Hz=frequency, support_phase_offset_rad=phase_offset,
        vibrating=vibrating, lowpass_Hz=lowpass_Hz, uniform_dt_s=uniform_dt,
        starts_in_motion=in_motion, **grid)


def _law_grid(t, velocity, position, normal, substeps: int) -> dict:
    n = len(t)
    if substeps <= 0 or n < 4:  # memoryless law (Coulomb): the samples themselves
        return dict(grid_time_s=t, grid_eval_time_s=t, grid_velocity_m_per_s=velocity,
                    grid_position_m=position, grid_normal_force_N=normal, stride=1)
    s = substeps
    dt = np.diff(t)[:, None]
    ends = t[:-1, None] + dt * (np.arange(1, s + 1) / s)[None, :]
    mids = t[:-1, None] + dt * ((np.arange(s) + 0.5) / s)[None, :]
    before_end = ends - _END_GAP * dt / s
    v_spline = make_interp_spline(t, velocity, k=3)
    x_spline = make_interp_spline(t, position, k=3)
    times = np.empty((n - 1, 2 * s))
    evals = np.empty((n - 1, 2 * s))
    times[:, 0::2], times[:, 1::2] = before_end, ends
    evals[:, 0::2], evals[:, 1::2] = mids, ends
    # Exact sample values at the interval ends (the spline interpolates them anyway).
    velocity_grid = v_spline(evals)
    velocity_grid[:, -1] = velocity[1:]
    position_grid = x_spline(evals)
    position_grid[:, -1] = position[1:]
    normal_grid = np.interp(evals, t, normal)

    def flat(first, rest):
        return np.concatenate([[first], rest.ravel()])

    return dict(grid_time_s=flat(t[0], times), grid_eval_time_s=flat(t[0], evals),
                grid_velocity_m_per_s=flat(velocity[0], velocity_grid),
                grid_position_m=flat(position[0], position_grid),
                grid_normal_force_N=flat(normal[0], normal_grid), stride=2 * s)


def _support_phase_offset(t, support_velocity, frequency_Hz) -> float:
    """beta with u' ~ cos(omega t + beta), least squares at the known frequency."""
    omega = 2 * math.pi * frequency_Hz
    basis = np.column_stack([np.cos(omega * t), np.sin(omega * t)])
    (a, b), *_ = np.linalg.lstsq(basis, support_velocity, rcond=None)
    # a cos + b sin = R cos(omega t - atan2(b, a))
    return float(-math.atan2(b, a))


def _integrate(values, t):
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(increments)])


def _zero_phase_lowpass(values: np.ndarray, dt_s: float, cutoff_Hz: float) -> np.ndarray:
    """4th-order Butterworth run forward and backward (no lag), as IDIM practice does."""
    sos = butter(4, cutoff_Hz, fs=1.0 / dt_s, output="sos")
    return sosfiltfilt(sos, values)


__all__ = ["Record", "prepare", "DEFAULT_SUBSTEPS", "UNIT_NORMAL_FORCE_N"]
