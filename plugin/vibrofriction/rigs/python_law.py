"""Prototype a friction law in Python: the paper's rig with the native friction element replaced
by MuJoCo's actuator-dynamics callback ``mjcb_act_dyn``.

The rig is the same MJCF (``mjcf_models/rig``); MjSpec editing deletes the plugin actuator
``friction``, its sensor ``friction_state`` and the plugin instance, and adds in their place::

    <general name="friction" joint="slider_on_table" dyntype="user" actdim="1" actearly="true"
             gainprm="-k_t" biastype="affine" biasprm="0 0 -sigma2"/>

so the force on the slider joint is ``-(k_t z + sigma2 v_r)`` with z = ``act[actadr]``, and the
deflection rate ż comes from a Python function ``law(z, v_r, params) -> zdot`` installed with
``mujoco.set_mjcb_act_dyn`` (the binding's name in MuJoCo 4.0.0). A sensor ``friction_force``
(actuatorfrc) records -F_F.

Example::

    from .python_law import dahl_zdot, simulate_python_law
    run = simulate_python_law(rig, friction, dahl_zdot, timestep_s=1e-6)

Differences from the native plugin, and the cost:

* MuJoCo integrates ``act`` explicitly (forward Euler on ż with the step's old velocity);
  ``actearly="true"`` makes the force use the updated z, so (z, v) form a symplectic-Euler pair
  that does not pump energy into the stuck contact. Forward Euler on ż is accurate only at small
  timesteps (the test uses 1e-6 s, where the mean drive force matches the native plugin within
  1 %); the native element's closed-form z update is stable and accurate at 1e-5 s and beyond.
* The callback is global (one per process) and holds the Python interpreter lock: each step
  calls into Python, about 1.5-1.8x the native step time, and rollout threads do not run it in
  parallel. Fine for prototyping a law, not for production sweeps.
* The force is ``k_t z + sigma2 v_r``: bristle damping (sigma1 ż) and the identification
  effects are not part of this path; a law function may use any field of ``params`` for ż.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Callable, Iterator

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from . import rig as rig_module
from ..params import FrictionParameters, ParameterError, RigParameters, default_friction

FRICTION_ACTUATOR = "friction"
FRICTION_SENSOR = "friction_state"
FORCE_SENSOR = "friction_force"
FRICTION_JOINT = "slider_on_table"


@dataclass(frozen=True)
class ContactParameters:
    """What a Python law sees besides (z, v_r): the friction parameters and the normal load."""

    friction: FrictionParameters
    normal_force_N: float

    @property
    def coulomb_level_N(self) -> float:
        """F_c = mu F_N."""
        return self.friction.friction_coefficient * self.normal_force_N

    @property
    def contact_stiffness_N_per_m(self) -> float:
        return self.friction.contact_stiffness_N_per_m


LawFunction = Callable[[float, float, ContactParameters], float]


def dahl_zdot(z: float, v_r: float, params: ContactParameters) -> float:
    """Dahl (1968): ż = v_r sgn(w)|w|^alpha, w = 1 - k_t z sgn(v_r)/F_c (docs/physics.md)."""
    fc = params.coulomb_level_N
    if v_r == 0.0 or fc <= 0.0:
        return 0.0
    w = 1.0 - params.friction.contact_stiffness_N_per_m * z * math.copysign(1.0, v_r) / fc
    # odd extension sgn(w)|w|^alpha: real for alpha < 1 and relaxes |F| > F_c back
    return v_r * math.copysign(abs(w) ** params.friction.alpha, w)


def remove_friction_element(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """Delete the native friction element (actuator, sensor, plugin instance) from a rig spec.

    The result is the bare rig: the same bodies, joints, drive and support motion, with no
    friction between slider and table. Returns the same spec.
    """
    spec.delete(spec.sensor(FRICTION_SENSOR))
    spec.delete(spec.actuator(FRICTION_ACTUATOR))
    for plugin in list(spec.plugins):
        if plugin.name == FRICTION_ACTUATOR:
            spec.delete(plugin)
    return spec


def bare_rig_spec(rig: RigParameters, *, timestep_s: float = rig_module.DEFAULT_TIMESTEP_S
                  ) -> mujoco.MjSpec:
    """The rig without any friction element (a base for other friction models)."""
    return remove_friction_element(
        rig_module.build_spec(rig, default_friction("dahl", rig), timestep_s))


def python_law_spec(rig: RigParameters, friction: FrictionParameters, *,
                    timestep_s: float = rig_module.DEFAULT_TIMESTEP_S,
                    act_early: bool = True) -> mujoco.MjSpec:
    """The rig with a ``general`` actuator (dyntype user, actdim 1, force -k_t z - sigma2 v_r).

    ``act_early=False`` gives MuJoCo's default order (force from z_n, then z_{n+1} from the old
    velocity), which pumps energy into a stuck contact: kept only to show that trap.
    """
    friction.validate()
    if friction.contact_stiffness_N_per_m <= 0:
        raise ParameterError("the Python-law path needs contact_stiffness_N_per_m > 0 "
                             "(F_F = k_t z)")
    if friction.bristle_damping_N_s_per_m != 0:
        raise ParameterError("the Python-law path has F_F = k_t z + sigma2 v_r; set "
                             "bristle_damping_N_s_per_m=0 or use the native plugin")
    spec = bare_rig_spec(rig, timestep_s=timestep_s)
    actuator = spec.add_actuator(name=FRICTION_ACTUATOR, target=FRICTION_JOINT,
                                 trntype=mujoco.mjtTrn.mjTRN_JOINT)
    actuator.dyntype = mujoco.mjtDyn.mjDYN_USER
    actuator.actdim = 1
    # actearly: the force of step n uses z_{n+1} = z_n + dt ż(z_n, v_n), so (z, v) advance as a
    # symplectic-Euler pair; with actearly="false" (z_n in the force) the stuck contact
    # oscillation gains energy and the mean force is 1 % low even at dt = 1e-6 s.
    actuator.actearly = act_early
    actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    actuator.gainprm[0] = -friction.contact_stiffness_N_per_m
    actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    actuator.biasprm[:3] = [0.0, 0.0, -friction.viscous_N_s_per_m]
    spec.add_sensor(name=FORCE_SENSOR, type=mujoco.mjtSensor.mjSENS_ACTUATORFRC,
                    objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname=FRICTION_ACTUATOR)
    return spec


@contextlib.contextmanager
def act_dyn_callback(law: LawFunction, params: ContactParameters) -> Iterator[None]:
    """Install ``law`` as MuJoCo's global ``mjcb_act_dyn`` for the block; always remove it.

    Every actuator with dyntype="user" in every model stepped in the block gets
    ``ż = law(z, v_r, params)`` with z its last activation and v_r its transmission velocity.
    The previous callback (usually none) is restored on exit, also after an exception.
    """
    def callback(m: mujoco.MjModel, d: mujoco.MjData, actuator_id: int) -> float:
        z = d.act[m.actuator_actadr[actuator_id] + m.actuator_actnum[actuator_id] - 1]
        return float(law(float(z), float(d.actuator_velocity[actuator_id]), params))

    previous = mujoco.get_mjcb_act_dyn()
    mujoco.set_mjcb_act_dyn(callback)
    try:
        yield
    finally:
        mujoco.set_mjcb_act_dyn(previous)


def simulate_python_law(rig: RigParameters, friction: FrictionParameters,
                        law: LawFunction = dahl_zdot, *, duration_s: float | None = None,
                        timestep_s: float = 1e-6, settle_time_s: float | None = None,
                        act_early: bool = True) -> rig_module.RigRun:
    """One run of the rig from rest with the friction law ``law`` in Python (see module doc)."""
    default_duration, default_settle = rig_module.default_times(rig, friction)
    duration = default_duration if duration_s is None else duration_s
    settle = default_settle if settle_time_s is None else settle_time_s
    if not (duration > 0 and math.isfinite(duration)):
        raise ParameterError(f"duration {duration!r} must be a positive number of seconds")
    model = python_law_spec(rig, friction, timestep_s=timestep_s, act_early=act_early).compile()
    data = mujoco.MjData(model)
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, full))
    mujoco.mj_getState(model, data, initial, full)
    nstep = int(round(duration / timestep_s))
    params = ContactParameters(friction=friction, normal_force_N=rig.normal_force_N)
    with act_dyn_callback(law, params):
        # nthread 0: the callback needs the interpreter lock anyway.
        state, sensordata = mj_rollout.rollout(model, data, initial[None], nstep=nstep)
    return _run_from_rollout(model, rig, friction, initial, state[0], sensordata[0], settle)


def _run_from_rollout(model: mujoco.MjModel, rig: RigParameters, friction: FrictionParameters,
                      initial: np.ndarray, state: np.ndarray, sensordata: np.ndarray,
                      settle_time_s: float) -> rig_module.RigRun:
    # Sensor row i is computed in step i (at t_i); state row i is after step i. With actearly
    # the force of step i uses the z after the step, so that z is the deflection of row i;
    # without, it uses the z before the step.
    sensors = {}
    for i in range(model.nsensor):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i)
        sensors[name] = sensordata[:, model.sensor_adr[i]]
    act_offset = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME |
                                     mujoco.mjtState.mjSTATE_QPOS | mujoco.mjtState.mjSTATE_QVEL)
    actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, FRICTION_ACTUATOR)
    act_index = act_offset + model.actuator_actadr[actuator]
    deflection = state[:, act_index]
    if not model.actuator_actearly[actuator]:
        deflection = np.concatenate([[initial[act_index]], deflection[:-1]])
    n = sensordata.shape[0]
    return rig_module.RigRun(
        rig=rig, friction=friction, timestep_s=model.opt.timestep, settle_time_s=settle_time_s,
        time_s=np.arange(n) * model.opt.timestep,
        slider_position_m=sensors["slider_position"],
        slider_velocity_m_per_s=sensors["slider_velocity"],
        slider_acceleration_m_per_s2=sensors["slider_acceleration"],
        support_position_m=sensors["table_position"],
        support_velocity_m_per_s=sensors["table_velocity"],
        relative_velocity_m_per_s=sensors["relative_velocity"],
        deflection_m=deflection,
        friction_force_N=-sensors[FORCE_SENSOR],
        drive_force_N=rig_module.drive_force_columns(model, rig, sensordata),
        normal_force_N=np.full(n, rig.normal_force_N),
        dynamometer_force_N=-rig.drive_chain_stiffness_N_per_m *
        sensors["drive_spring_extension"],
    )


__all__ = ["ContactParameters", "LawFunction", "dahl_zdot", "remove_friction_element",
           "bare_rig_spec", "python_law_spec", "act_dyn_callback", "simulate_python_law"]
