"""The planar friction element (``vibrofriction.planar``) from Python.

* :func:`run_planar_law` drives the plugin's own C++ planar law (plugin/cpp/laws/friction_law.cc)
  along a prescribed relative-velocity history, as :func:`vibrofriction.laws.run_law` does in 1D.
* :func:`build_rig_spec` / :func:`simulate_rigs`: the paper's rig in the plane
  (``mjcf_models/robots/planar_rig.xml``): support vibration and drive along any in-plane
  directions, so longitudinal (drive along the vibration) and transverse (drive across it)
  vibration come out of one model.
* Kinematic-limit laws of rigid Coulomb friction for a body moving uniformly at V over a support
  vibrating at velocity amplitude v_a (xi = V / v_a): :func:`longitudinal_coulomb_ratio`
  (2/pi) arcsin(xi) and :func:`transverse_coulomb_ratio`
  (2/pi) xi / sqrt(1 + xi^2) K(1 / (1 + xi^2)), K the complete elliptic integral of the first
  kind with parameter m (scipy.special.ellipk).
"""
from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout
from scipy import special

from ..laws import c_array, c_law_parameters, c_normal_argument, c_time_argument, load
from ..params import PAPER_NORMAL_FORCE_N, FrictionParameters, ParameterError, RigParameters
from .rig import default_times
from ..sim import MJCF_DIR, initial_state, sensor_slices, set_plugin_config
from ..summary import averaging_window
from ..vocabulary import FRICTION_TERMS, MJCF_KEYS, config_values, element_keys

PLANAR_RIG_PATH = MJCF_DIR / "robots" / "planar_rig_resolved.xml"
AVERAGED_RIG_PATH = MJCF_DIR / "robots" / "planar_rig_averaged.xml"

# FrictionParameters field -> MJCF config key of vibrofriction.planar (vocabulary.FRICTION_TERMS):
# the 1D element's keys less the effects that have no isotropic meaning.
PLANAR_MJCF_KEYS = element_keys("planar")
# Those effects (0: off), which must be 0; their wavelength and phase are idle then.
_NOT_PLANAR = tuple(term.name for term in FRICTION_TERMS
                    if "planar" not in term.elements and term.shapes is None)


def check_planar(friction: FrictionParameters) -> FrictionParameters:
    """Validate and reject the 1D-only effects (direction asymmetry, ripple, offset, lag,
    the maps, the contact play)."""
    friction.validate()
    for name in _NOT_PLANAR:
        if getattr(friction, name) not in (0, ()):
            raise ParameterError(f"parameter {name}={getattr(friction, name)!r} has no planar "
                                 "(isotropic) meaning; set it to 0 for the planar element")
    return friction


def planar_config(friction: FrictionParameters, *, normal_force_N: float | None = None,
                  contact_geoms: tuple[str, str] | None = None) -> dict[str, str]:
    """Config of a vibrofriction.planar instance (MJCF keys, string values).

    No rig here: normal_force_modulation_frequency_Hz is written as it is, so 0 is 0 Hz in the
    MJCF (build_rig_spec writes the rig's vibration frequency in its place)."""
    check_planar(friction)
    config = {"law": friction.law, **config_values(friction, PLANAR_MJCF_KEYS)}
    if normal_force_N is not None:
        config["normal"] = repr(float(normal_force_N))
    if contact_geoms is not None:
        config["contact_geom1"], config["contact_geom2"] = contact_geoms
    return config


@dataclass(frozen=True)
class PlanarLawRun:
    """What ``run_planar_law`` returns: per sample, the friction force (N) and the deflection z
    (m), each as (x, y) columns, shape (n, 2)."""

    force_N: np.ndarray        # (n, 2) friction force against the motion
    deflection_m: np.ndarray   # (n, 2) deflection z


def run_planar_law(friction: FrictionParameters, time_s, relative_velocity_m_per_s, *,
                   normal_force_N=PAPER_NORMAL_FORCE_N, initial_deflection_m=(0.0, 0.0)) -> PlanarLawRun:
    """The planar law along a prescribed relative velocity history (n x 2), kinematic driving.

    Step order as the plugin: force i uses (z_i, v_i); z_{i+1} advances with v_{i+1}. Coulomb
    is kinematic: F = g(|v|) v/|v| + sigma2 v. No rig here: normal_force_modulation_frequency_Hz
    = 0 is 0 Hz, as in MJCF.
    """
    check_planar(friction)
    if friction.law == "gms":
        raise ParameterError("law gms has no kinematic planar driver (its elements' slip flags "
                             "live in the planar element): simulate it with vibrofriction.planar "
                             "in MuJoCo (planar.build_rig_spec)")
    lib = load()
    fn = lib.vf_run_planar_law
    dp = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ctypes.c_void_p, ctypes.c_int, dp, dp, dp, dp, ctypes.c_double,
                   ctypes.c_double, dp, dp, dp, dp]
    fn.restype = ctypes.c_int
    t = c_time_argument(time_s)
    n = t.shape[0]
    v = np.asarray(relative_velocity_m_per_s, dtype=np.float64)
    if v.shape != (n, 2):
        raise ParameterError(f"relative_velocity_m_per_s has shape {v.shape}, expected ({n}, 2)")
    vx = c_array(v[:, 0], n, "relative_velocity_m_per_s[:, 0]")
    vy = c_array(v[:, 1], n, "relative_velocity_m_per_s[:, 1]")
    constant_normal, normal = c_normal_argument(normal_force_N, n)
    out = [np.empty(n) for _ in range(4)]
    params = c_law_parameters(friction, constant_normal)

    def ptr(a):
        return None if a is None else a.ctypes.data_as(dp)

    z0 = [float(x) for x in initial_deflection_m]
    status = fn(ctypes.byref(params), n, ptr(t), ptr(vx), ptr(vy), ptr(normal), z0[0], z0[1],
                *[ptr(a) for a in out])
    if status != 0:
        raise ParameterError("the planar-law C API rejected its arguments")
    return PlanarLawRun(force_N=np.stack(out[:2], axis=1),
                        deflection_m=np.stack(out[2:], axis=1))


def longitudinal_coulomb_ratio(xi):
    """F_mean / (mu F_N) for rigid Coulomb, drive along the vibration: (2/pi) arcsin(xi), 1 past 1."""
    xi = np.asarray(xi, dtype=float)
    return np.where(np.abs(xi) < 1, 2 / np.pi * np.arcsin(np.clip(xi, -1, 1)), np.sign(xi))


def transverse_coulomb_ratio(xi):
    """F_mean / (mu F_N) for rigid Coulomb, drive across the vibration:
    (2/pi) xi / sqrt(1 + xi^2) K(1 / (1 + xi^2))."""
    xi = np.asarray(xi, dtype=float)
    safe = np.where(xi == 0, 1.0, xi)  # K(1) is infinite; the ratio tends to 0 as xi log(1/xi)
    m = 1.0 / (1.0 + safe * safe)
    ratio = 2 / np.pi * safe / np.sqrt(1 + safe * safe) * special.ellipk(m)
    return np.where(xi == 0, 0.0, ratio)


# ---- The planar rig ------------------------------------------------------------------------------

@dataclass(frozen=True)
class PlanarRigRun:
    """Time series of one planar-rig run (row i at t_i = i dt, before step i)."""

    rig: RigParameters
    friction: FrictionParameters
    vibration_angle_rad: float
    drive_angle_rad: float
    timestep_s: float
    settle_time_s: float
    time_s: np.ndarray
    slider_position_m: np.ndarray     # (n, 2) world frame
    slider_velocity_m_per_s: np.ndarray
    relative_velocity_m_per_s: np.ndarray
    deflection_m: np.ndarray
    friction_force_N: np.ndarray      # (n, 2)
    drive_force_N: np.ndarray         # (n, 2)
    normal_force_N: np.ndarray

    @property
    def period_s(self) -> float:
        f = self.rig.vibration_frequency_Hz
        return 1.0 / f if f > 0 and self.rig.vibration_velocity_amplitude_m_per_s > 0 else 0.0

    def window(self, settle_time_s: float | None = None) -> np.ndarray:
        settle = self.settle_time_s if settle_time_s is None else settle_time_s
        return averaging_window(self.time_s, self.period_s, settle)

    def mean(self, series: np.ndarray, settle_time_s: float | None = None) -> np.ndarray:
        """Time-weighted mean over whole vibration periods after the transient."""
        mask = self.window(settle_time_s)
        t = self.time_s[mask]
        return np.trapezoid(series[mask], t, axis=0) / (t[-1] - t[0])

    def mean_drive_force_N(self, settle_time_s: float | None = None) -> np.ndarray:
        return self.mean(self.drive_force_N, settle_time_s)

    def mean_friction_force_N(self, settle_time_s: float | None = None) -> np.ndarray:
        return self.mean(self.friction_force_N, settle_time_s)


def _component_motion(frequency: float, amplitude: float, component: float) -> dict[str, str]:
    # The motion plugin takes a non-negative amplitude: a negative component is a phase of pi.
    return {"frequency": repr(float(frequency)),
            "velocity_amplitude": repr(float(abs(amplitude * component))),
            "phase": repr(math.pi if component < 0 else 0.0)}


def build_rig_spec(rig: RigParameters, friction: FrictionParameters, *,
                   vibration_angle_rad: float = 0.0, drive_angle_rad: float = 0.0,
                   timestep_s: float = 1e-5,
                   averaged_config: dict[str, str] | None = None) -> mujoco.MjSpec:
    """MjSpec of the planar rig: table vibration along ``vibration_angle_rad`` and drive along
    ``drive_angle_rad`` (both from x), every parameter applied.

    With ``averaged_config`` (a vibrofriction.averaged config, e.g. AveragedTable.config()) the
    friction is the averaged element and the table stays at rest: the vibration lives in the
    table of the averaged law (whose axis the config gives).
    """
    load()
    rig.validate()
    if rig.vibration_from_s > 0:
        raise ParameterError("the planar rig vibrates from the start; vibration_from_s="
                             f"{rig.vibration_from_s!r} is for the 1D rig (rig.simulate)")
    if rig.drive_backlash_m > 0:
        raise ParameterError(f"drive_backlash_m={rig.drive_backlash_m!r}: the planar rig's "
                             "drive springs have no play; backlash is the 1D rig's "
                             "(rig.simulate)")
    check_planar(friction)
    if not (timestep_s > 0 and math.isfinite(timestep_s)):
        raise ParameterError(f"timestep {timestep_s!r} must be a positive number of seconds")
    spec = mujoco.MjSpec.from_file(str(AVERAGED_RIG_PATH if averaged_config else PLANAR_RIG_PATH))
    spec.option.timestep = timestep_s
    spec.body("slider").mass = rig.mass_kg
    for axis in ("x", "y"):
        spec.actuator(f"drive_spring_{axis}").biasprm[:3] = [
            0.0, -rig.drive_stiffness_N_per_m, -rig.drive_damping_N_s_per_m]
    f, va = rig.vibration_frequency_Hz, rig.vibration_velocity_amplitude_m_per_s
    if averaged_config:
        va = 0.0
    c, s = math.cos(vibration_angle_rad), math.sin(vibration_angle_rad)
    set_plugin_config(spec, "table_shaker_x", _component_motion(f, va, c if abs(c) > 1e-15 else 0.0))
    set_plugin_config(spec, "table_shaker_y", _component_motion(f, va, s if abs(s) > 1e-15 else 0.0))
    vd = rig.drive_velocity_m_per_s
    cd, sd = math.cos(drive_angle_rad), math.sin(drive_angle_rad)
    set_plugin_config(spec, "drive_end_x", {"velocity": repr(float(vd * cd if abs(cd) > 1e-15 else 0.0))})
    set_plugin_config(spec, "drive_end_y", {"velocity": repr(float(vd * sd if abs(sd) > 1e-15 else 0.0))})
    config = planar_config(friction, normal_force_N=rig.normal_force_N)
    if friction.normal_force_modulation_frequency_Hz == 0:
        config[MJCF_KEYS["normal_force_modulation_frequency_Hz"]] = repr(float(f))
    set_plugin_config(spec, "friction", dict(averaged_config) if averaged_config else config)
    if friction.law == "gms" and not averaged_config:  # one deflection per element and axis
        for axis in ("x", "y"):
            spec.actuator(f"friction_{axis}").actdim = len(friction.gms_stiffness_N_per_m)
    return spec


def simulate_rigs(cases: Sequence[tuple[RigParameters, FrictionParameters, float, float]], *,
                  duration_s: float | None = None, timestep_s: float = 1e-5,
                  settle_time_s: float | None = None, nthread: int | None = None,
                  averaged_config: dict[str, str] | None = None) -> list[PlanarRigRun]:
    """Run planar rigs (rig, friction, vibration_angle_rad, drive_angle_rad) on rollout threads.

    The drive spring damps with the tendon velocity (the slider relative to the drive end), so
    h_d adds no mean force in steady sliding."""
    if not cases:
        return []
    times = [default_times(r, f) for r, f, _, _ in cases]
    duration = duration_s if duration_s is not None else max(t[0] for t in times)
    settle = settle_time_s if settle_time_s is not None else max(t[1] for t in times)
    nstep = int(round(duration / timestep_s))
    models = [build_rig_spec(r, f, vibration_angle_rad=a, drive_angle_rad=b,
                             timestep_s=timestep_s, averaged_config=averaged_config).compile()
              for r, f, a, b in cases]
    if nthread is None:
        import os
        nthread = min(len(cases), len(os.sched_getaffinity(0)))
    data = [mujoco.MjData(models[0]) for _ in range(max(1, nthread))]
    states = np.stack([initial_state(m, data[0]) for m in models])
    with mj_rollout.Rollout(nthread=nthread if len(cases) > 1 else 0) as pool:
        _, sensordata = pool.rollout(models, data, states, nstep=nstep)
    runs = []
    for k, (r, f, a, b) in enumerate(cases):
        s = sensor_slices(models[k])
        sd = sensordata[k]
        state = sd[:, s["friction_state"]]
        runs.append(PlanarRigRun(
            rig=r, friction=f, vibration_angle_rad=a, drive_angle_rad=b,
            timestep_s=timestep_s, settle_time_s=settle,
            time_s=np.arange(sd.shape[0]) * timestep_s,
            slider_position_m=np.stack([sd[:, s["slider_position_x"]][:, 0],
                                        sd[:, s["slider_position_y"]][:, 0]], axis=1),
            slider_velocity_m_per_s=np.stack([sd[:, s["slider_velocity_x"]][:, 0],
                                              sd[:, s["slider_velocity_y"]][:, 0]], axis=1),
            relative_velocity_m_per_s=state[:, 4:6], deflection_m=state[:, 2:4],
            friction_force_N=state[:, 0:2],
            drive_force_N=np.stack([sd[:, s["drive_force_x"]][:, 0],
                                    sd[:, s["drive_force_y"]][:, 0]], axis=1),
            normal_force_N=state[:, 6]))
    return runs


def simulate_rig(rig: RigParameters, friction: FrictionParameters, *,
                 vibration_angle_rad: float = 0.0, drive_angle_rad: float = 0.0,
                 **kwargs) -> PlanarRigRun:
    """Run one planar rig: ``simulate_rigs`` for a single case.

    Parameters
    ----------
    rig : RigParameters
        The rig (SI units); it vibrates from the start and has no drive backlash.
    friction : FrictionParameters
        The planar friction law (no 1D-only effects: ``check_planar``).
    vibration_angle_rad : float
        Direction of the table's vibration, from the x axis (rad).
    drive_angle_rad : float
        Direction of the drive, from the x axis (rad).
    **kwargs
        ``duration_s``, ``timestep_s`` (default 1e-5 s), ``settle_time_s``, ``nthread`` and
        ``averaged_config``, as in ``simulate_rigs`` (the duration and the settle time (s)
        default to ``default_times(rig, friction)``).

    Returns
    -------
    PlanarRigRun
        The run's time series.
    """
    return simulate_rigs([(rig, friction, vibration_angle_rad, drive_angle_rad)], **kwargs)[0]


__all__ = [
    "AVERAGED_RIG_PATH", "PLANAR_MJCF_KEYS", "PLANAR_RIG_PATH", "PlanarLawRun", "PlanarRigRun", "build_rig_spec",
    "check_planar", "longitudinal_coulomb_ratio", "planar_config", "run_planar_law",
    "simulate_rig", "simulate_rigs", "transverse_coulomb_ratio",
]
