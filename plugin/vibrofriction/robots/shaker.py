"""Make a body of any scene vibrate along an axis: :func:`vibrate` edits an ``mujoco.MjSpec``.

The body is driven through the project's ``vibrofriction.motion`` plugin on a slide joint along
the axis (its velocity v_a cos(2 pi f t) along the axis, the position exactly on
(v_a / w) sin(w t) at every step; docs/interfaces.md, ``vibrofriction.motion``). Everything a
scene-level ``<default>`` class could change on the added joint and actuator is set explicitly,
so that no default breaks it:

* dm_control's ``<general ctrllimited="true"/>`` without a ``ctrlrange`` makes the bare shaker
  line fail to compile ("invalid control range"): the actuator has its own ctrlrange 0..1;
* a default ``forcerange`` would clip the shaker's force (the body stands still), a default
  ``gear`` would scale the amplitude, a default ``dyntype``/``actdim`` would add state, a
  joint's default ``armature="0"``, damping, limits, frictionloss or ``actuatorfrcrange``
  would change the joint: each is set on the element itself.

Gravity and the scene's contacts are unchanged: the shaker's force includes every force known
when it runs, and a body newly given a joint is kept out of contact with the bodies it was
welded to (``<exclude>`` pairs; welded bodies never collide in MuJoCo, a moving one would).
Keyframes get the new joint's coordinate (0) and the actuator's ctrl.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import InputError
from .. import sim
from ..laws import load
from ..params import ParameterError

MOTION_PLUGIN = "vibrofriction.motion"
# The apparent mass of a prescribed-motion body (docs/robots.md, the bundled scenes: the
# forces computed after the shaker, e.g. a contact's reaction, are corrected a step later and
# negligible against it).
DEFAULT_ARMATURE = 1e5
# Steps a vibration period below which the scene does not resolve the vibration (docs/robots.md:
# 25-50 at least).
MIN_STEPS_PER_PERIOD = 25
# Actuator plugins that must compute after the motion (plugins compute in declaration order):
# their force is a disturbance to the shaker otherwise, corrected a step later.
_AFTER_MOTION = ("vibrofriction.friction", "vibrofriction.planar", "vibrofriction.averaged",
                 "vibrofriction.sampled_pd")
_PARALLEL = 1 - 1e-9


@dataclass(frozen=True)
class VibratedBody:
    """What :func:`vibrate` did: the names it added or used."""

    body: str
    joint: str                 # the slide joint along the axis
    actuator: str              # the plugin actuator (ctrl index: model.actuator(actuator).id)
    instance: str              # the vibrofriction.motion instance
    joint_added: bool          # False: the body's own slide joint along the axis is driven
    excludes: tuple[tuple[str, str], ...] = ()  # contact excludes added (body pairs)
    notes: tuple[str, ...] = ()                 # what else was changed, one line each


def _number(name: str, value: object) -> float:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ParameterError(f"vibrate: {name}={value!r} is not a number") from None
    if not math.isfinite(number):
        raise ParameterError(f"vibrate: {name}={value!r} must be a finite number")
    return number


def _unit_axis(axis: object) -> np.ndarray:
    try:
        vector = np.asarray(axis, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        vector = np.zeros(0)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ParameterError(f"vibrate: axis={axis!r} must be three finite numbers, e.g. "
                             "axis=(1, 0, 0)")
    norm = float(np.linalg.norm(vector))
    if norm == 0:
        raise ParameterError("vibrate: axis=(0, 0, 0) has no direction; give the vibration "
                             "direction in the body's frame, e.g. axis=(1, 0, 0)")
    return vector / norm


def _limited(flag: mujoco.mjtLimited, bounds, spec: mujoco.MjSpec) -> bool:
    if flag == mujoco.mjtLimited.mjLIMITED_TRUE:
        return True
    return (flag == mujoco.mjtLimited.mjLIMITED_AUTO and bool(spec.compiler.autolimits)
            and bool(np.any(np.asarray(bounds) != 0)))


def _taken(spec: mujoco.MjSpec, kind: mujoco.mjtObj, name: str) -> bool:
    finder = {mujoco.mjtObj.mjOBJ_JOINT: spec.joint,
              mujoco.mjtObj.mjOBJ_ACTUATOR: spec.actuator}.get(kind)
    if finder is not None:
        return finder(name) is not None
    return any(p.name == name for p in spec.plugins)


def vibrate(spec: mujoco.MjSpec, body: str, *, axis=(1.0, 0.0, 0.0), frequency_Hz: float,
            velocity_amplitude_m_per_s: float, phase_rad: float = 0.0,
            start_time_s: float = 0.0, ramp_periods: float = 0.0, use_ctrl: bool = False,
            armature: float = DEFAULT_ARMATURE, name: str | None = None) -> VibratedBody:
    """Make ``body`` of ``spec`` vibrate along ``axis`` (in the body's frame, as a joint's axis;
    relative to its parent) at ``frequency_Hz`` with velocity amplitude
    ``velocity_amplitude_m_per_s``: its velocity along the axis is v_a cos(2 pi f t + phase).

    * A body welded to its parent (no joint) gets a slide joint along the axis
      (``{name}_vibration``) with ``armature`` (kg: the apparent mass that makes the other
      forces on it negligible), no damping, stiffness, friction loss or limits; its contacts
      with the bodies it was welded to stay off (``<exclude>`` pairs).
    * A body on one slide joint along the axis (either sense) keeps it: that joint is driven,
      its armature raised to ``armature`` if below, its actuator force limit removed (say so
      in ``notes``). A free joint, other joints, a joint already driven: refused, saying how.

    Adds the ``vibrofriction.motion`` instance and its plugin actuator (both ``{name}_shaker``)
    with ctrllimited, ctrlrange 0..1, forcelimited false, gear 1 and no dynamics set on the
    actuator itself. ``use_ctrl``: the actuator's ctrl (0..1) scales the amplitude (0 still, 1
    as given; ctrl starts at 0). ``start_time_s``/``ramp_periods``: the vibration starts then
    and builds up over that many periods. ``name`` defaults to the body's name. The spec's
    timestep must resolve the vibration (at least 25-50 steps a period; a warning says when
    not). Returns the names added; raises ``InputError`` (a ``ValueError``) naming the fix.
    """
    if not isinstance(spec, mujoco.MjSpec):
        raise InputError(f"vibrate: spec must be a mujoco.MjSpec, not {type(spec).__name__}; "
                         "e.g. mujoco.MjSpec.from_file(path)")
    unit = _unit_axis(axis)
    motion = _motion_config(frequency_Hz, velocity_amplitude_m_per_s, phase_rad, start_time_s,
                            ramp_periods, use_ctrl)
    apparent_mass = _number("armature", armature)
    if apparent_mass <= 0:
        raise ParameterError(f"vibrate: armature={armature!r} must be > 0 (kg)")
    target = _vibrated_body(spec, body)
    prefix = name if name is not None else body
    actuator_name = instance_name = f"{prefix}_shaker"
    for what, kind in (("an actuator", mujoco.mjtObj.mjOBJ_ACTUATOR),
                       ("a plugin instance", mujoco.mjtObj.mjOBJ_PLUGIN)):
        if _taken(spec, kind, actuator_name):
            raise InputError(f"vibrate: the scene already has {what} named {actuator_name!r} "
                             f"(body {body!r} vibrated already?); pass another name=...")

    load()  # the plugins are known to the compiler
    before = spec.compile()  # the scene as given: its coordinates and weld groups

    notes: list[str] = []
    joint_name, joint_added, gear = _driven_joint(spec, target, body, unit, apparent_mass,
                                                  prefix, notes)
    if joint_added:
        _add_slide_joint(target, joint_name, unit, apparent_mass)
    _add_shaker(spec, instance_name, actuator_name, joint_name, gear, motion)
    _declare_after_the_motion(spec, notes)

    excludes: list[tuple[str, str]] = []
    if joint_added:
        excludes = _keep_welded_contacts_off(spec, before, body, notes)
    _extend_keyframes(spec, before, body, joint_added, 1.0 if use_ctrl else 0.0)

    frequency = float(motion["frequency"])
    steps = 1.0 / (frequency * spec.option.timestep)
    if steps < MIN_STEPS_PER_PERIOD:
        warnings.warn(f"vibrate: the timestep {spec.option.timestep:g} s takes {steps:.3g} steps "
                      f"a period of {frequency:g} Hz; the vibration needs at least "
                      f"{MIN_STEPS_PER_PERIOD} (docs/robots.md): lower spec.option.timestep",
                      RuntimeWarning, stacklevel=2)
    return VibratedBody(body=body, joint=joint_name, actuator=actuator_name,
                        instance=instance_name, joint_added=joint_added,
                        excludes=tuple(excludes), notes=tuple(notes))


def _motion_config(frequency_Hz, velocity_amplitude_m_per_s, phase_rad, start_time_s,
                   ramp_periods, use_ctrl: bool) -> dict[str, str]:
    """The vibrofriction.motion config of the vibration, its numbers checked (vibrate's
    parameters: Hz, m/s, rad, s, periods)."""
    frequency = _number("frequency_Hz", frequency_Hz)
    if frequency <= 0:
        raise ParameterError(f"vibrate: frequency_Hz={frequency_Hz!r} must be > 0 (Hz)")
    amplitude = _number("velocity_amplitude_m_per_s", velocity_amplitude_m_per_s)
    if amplitude < 0:
        raise ParameterError(f"vibrate: velocity_amplitude_m_per_s={velocity_amplitude_m_per_s!r} "
                             "must be >= 0 (m/s; 0 keeps the body still)")
    phase = _number("phase_rad", phase_rad)
    start = _number("start_time_s", start_time_s)
    ramp = _number("ramp_periods", ramp_periods)
    if start < 0 or ramp < 0:
        raise ParameterError("vibrate: start_time_s and ramp_periods must be >= 0")
    if (start > 0 or ramp > 0) and amplitude == 0:
        raise ParameterError("vibrate: start_time_s and ramp_periods shape a vibration; give "
                             "velocity_amplitude_m_per_s > 0 or leave them out")
    config = {"frequency": repr(frequency), "velocity_amplitude": repr(amplitude)}
    if phase:
        config["phase"] = repr(phase)
    if start:
        config["start_time"] = repr(start)
    if ramp:
        config["ramp_periods"] = repr(ramp)
    if use_ctrl:
        config["use_ctrl"] = "true"
    return config


def _vibrated_body(spec: mujoco.MjSpec, body: str) -> mujoco.MjsBody:
    """The body ``vibrate`` drives: a named body of the scene that can move (not the world, not
    a mocap body), in a scene whose integrator vibrofriction.motion takes."""
    if not isinstance(body, str) or not body:
        raise InputError(f"vibrate: body={body!r} must be the name of a body of the scene")
    if body == spec.worldbody.name:
        raise InputError(f"vibrate: {body!r} is the world, which cannot move; put the support's "
                         "geoms in a body of their own and vibrate that")
    target = spec.body(body)
    if target is None:
        names = sorted(b.name for b in spec.bodies if b.name and b.name != spec.worldbody.name)
        shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
        raise InputError(f"vibrate: the scene has no body named {body!r}; its bodies: "
                         f"{shown or '(none)'}")
    if target.mocap:
        raise InputError(f"vibrate: body {body!r} is a mocap body (moved through mocap_pos, no "
                         "joints); vibrate a body fixed to it, or set its mocap_pos yourself")
    if spec.option.integrator == mujoco.mjtIntegrator.mjINT_RK4:
        raise InputError("vibrate: the scene's integrator is RK4, which vibrofriction.motion "
                         "refuses; set spec.option.integrator to implicitfast (or Euler, "
                         "implicit)")
    return target


def _driven_joint(spec: mujoco.MjSpec, target: mujoco.MjsBody, body: str, unit: np.ndarray,
                  apparent_mass: float, prefix: str,
                  notes: list[str]) -> tuple[str, bool, float]:
    """(joint name, whether it is to be added, the actuator's gear): a welded body gets a new
    slide joint; a body on one slide joint along ``unit`` keeps it, made fit to be driven
    (named, armature at least ``apparent_mass`` kg, no actuator force limit: said in
    ``notes``); anything else is refused, saying how to fix it."""
    joints = list(target.joints)
    if not joints:
        joint_name = f"{prefix}_vibration"
        if _taken(spec, mujoco.mjtObj.mjOBJ_JOINT, joint_name):
            raise InputError(f"vibrate: the scene already has a joint named {joint_name!r}; "
                             "pass another name=...")
        return joint_name, True, 1.0
    joint = joints[0]
    kinds = ", ".join(f"{j.name or '(unnamed)'} ({mujoco.mjtJoint(j.type).name[6:].lower()})"
                      for j in joints)
    if len(joints) == 1 and joint.type == mujoco.mjtJoint.mjJNT_FREE:
        raise InputError(
            f"vibrate: body {body!r} has a free joint (it is loose in the scene); delete it "
            f"to fix the body where it is and call vibrate again "
            f"(spec.delete(spec.body({body!r}).first_joint())), or vibrate the body it rests "
            "on")
    if len(joints) > 1 or joint.type != mujoco.mjtJoint.mjJNT_SLIDE:
        raise InputError(
            f"vibrate: body {body!r} moves on its joints {kinds}; vibrate drives a body fixed "
            "to its parent or on one slide joint along the axis: vibrate a child body "
            "welded to it (a <body> without joints inside it) instead")
    joint_axis = np.asarray(joint.axis, dtype=float)
    cosine = float(joint_axis @ unit) / float(np.linalg.norm(joint_axis))
    if abs(cosine) < _PARALLEL:
        raise InputError(
            f"vibrate: body {body!r} slides on joint {joint.name or '(unnamed)'} along "
            f"{tuple(float(x) for x in joint_axis)}, not along axis "
            f"{tuple(float(x) for x in unit)}; pass that joint's axis, or vibrate a child "
            "body welded to it")
    gear = 1.0 if cosine > 0 else -1.0  # the actuator's length runs along the axis
    for actuator in spec.actuators:
        if (joint.name and actuator.trntype == mujoco.mjtTrn.mjTRN_JOINT
                and actuator.target == joint.name):
            raise InputError(
                f"vibrate: joint {joint.name!r} of body {body!r} is already driven by "
                f"actuator {actuator.name or '(unnamed)'!r}; delete that actuator first "
                f"(spec.delete(spec.actuator({actuator.name!r}))) or drive it yourself")
    if not joint.name:
        joint_name = f"{prefix}_vibration"
        if _taken(spec, mujoco.mjtObj.mjOBJ_JOINT, joint_name):
            raise InputError(f"vibrate: body {body!r}'s slide joint has no name and "
                             f"{joint_name!r} is taken; name the joint or pass name=...")
        joint.name = joint_name
        notes.append(f"named body {body!r}'s slide joint {joint_name!r}")
    joint_name = joint.name
    if joint.armature < apparent_mass:
        notes.append(f"raised joint {joint_name!r}'s armature from {joint.armature:g} to "
                     f"{apparent_mass:g}")
        joint.armature = apparent_mass
    if _limited(joint.actfrclimited, joint.actfrcrange, spec):
        notes.append(f"removed joint {joint_name!r}'s actuatorfrcrange (it would clip the "
                     "shaker)")
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    return joint_name, False, gear


def _add_slide_joint(target: mujoco.MjsBody, joint_name: str, unit: np.ndarray,
                     apparent_mass: float) -> None:
    """A slide joint along ``unit`` with armature ``apparent_mass`` (kg) and nothing else:
    no damping, stiffness, friction loss, limits or gravity compensation."""
    added = target.add_joint()
    added.name = joint_name
    added.type = mujoco.mjtJoint.mjJNT_SLIDE
    added.axis = unit
    added.pos = [0.0, 0.0, 0.0]
    added.ref = 0.0
    added.armature = apparent_mass
    added.damping = np.zeros_like(np.asarray(added.damping, dtype=float))
    added.stiffness = np.zeros_like(np.asarray(added.stiffness, dtype=float))
    added.springref = 0.0
    added.frictionloss = 0.0
    added.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    added.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    added.margin = 0.0
    added.actgravcomp = 0


def _add_shaker(spec: mujoco.MjSpec, instance_name: str, actuator_name: str, joint_name: str,
                gear: float, config: dict[str, str]) -> None:
    """The vibrofriction.motion instance (its config checked against the table) and its
    plugin actuator on the joint: gear +-1, ctrl 0..1, no dynamics, gain, bias or limits."""
    spec.activate_plugin(MOTION_PLUGIN)  # what <extension><plugin plugin=...> does in MJCF
    instance = spec.add_plugin(name=instance_name, plugin_name=MOTION_PLUGIN, active=True)
    instance.config = sim.plugin_config(MOTION_PLUGIN, config)
    actuator = spec.add_actuator()
    actuator.name = actuator_name
    actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
    actuator.target = joint_name
    actuator.gear = [gear, 0.0, 0.0, 0.0, 0.0, 0.0]
    actuator.dyntype = mujoco.mjtDyn.mjDYN_NONE
    actuator.dynprm = np.zeros_like(np.asarray(actuator.dynprm, dtype=float))
    actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    gain = np.zeros_like(np.asarray(actuator.gainprm, dtype=float))
    gain[0] = 1.0
    actuator.gainprm = gain
    actuator.biastype = mujoco.mjtBias.mjBIAS_NONE
    actuator.biasprm = np.zeros_like(np.asarray(actuator.biasprm, dtype=float))
    actuator.actdim = -1
    actuator.actearly = 0
    actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.ctrlrange = [0.0, 1.0]
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    actuator.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
    actuator.damping = np.zeros_like(np.asarray(actuator.damping, dtype=float))
    actuator.armature = 0.0
    actuator.delay = 0.0
    actuator.nsample = 0
    actuator.plugin = instance


def _declare_after_the_motion(spec: mujoco.MjSpec, notes: list[str]) -> None:
    """Plugins compute in declaration order: the actuator elements go after the motion."""
    for plugin in [p for p in spec.plugins if p.plugin_name in _AFTER_MOTION and p.name]:
        declared = (plugin.name, plugin.plugin_name, plugin.active, dict(plugin.config))
        spec.delete(plugin)
        moved = spec.add_plugin(name=declared[0], plugin_name=declared[1], active=declared[2])
        moved.config = declared[3]
        notes.append(f"declared {declared[1]} instance {declared[0]!r} after the shaker (plugins "
                     "compute in declaration order)")


def _keep_welded_contacts_off(spec: mujoco.MjSpec, before: mujoco.MjModel, body: str,
                              notes: list[str]) -> list[tuple[str, str]]:
    """Exclude contacts between the bodies that the new joint sets moving and the bodies they
    were welded to: MuJoCo never collides welded bodies, so they did not touch before."""
    target = before.body(body).id
    root = before.body_weldid[target]
    group = [b for b in range(before.nbody) if before.body_weldid[b] == root]

    def below_target(b: int) -> bool:
        while b > 0 and b != target:
            b = before.body_parentid[b]
        return b == target

    moving = [b for b in group if below_target(b)]
    still = [b for b in group if not below_target(b)]
    has_geoms = before.body_geomnum > 0
    pairs = []
    for a in moving:
        for b in still:
            if not (has_geoms[a] and has_geoms[b]):
                continue
            name_a, name_b = before.body(a).name, before.body(b).name
            if not (name_a and name_b):
                notes.append(f"could not exclude contacts between bodies {a} and {b} (unnamed); "
                             "name them and add <exclude body1=... body2=.../>")
                continue
            spec.add_exclude(bodyname1=name_a, bodyname2=name_b)
            pairs.append((name_a, name_b))
    return pairs


def _extend_keyframes(spec: mujoco.MjSpec, before: mujoco.MjModel, body: str,
                      joint_added: bool, ctrl: float) -> None:
    """Give each keyframe that lists coordinates or controls the new ones (a joint at its
    reference, the shaker's ctrl)."""
    target = before.body(body).id
    later = [j for j in range(before.njnt) if before.jnt_bodyid[j] > target]
    qpos_at = int(before.jnt_qposadr[later[0]]) if later else before.nq
    dof_at = int(before.jnt_dofadr[later[0]]) if later else before.nv
    for key in spec.keys:
        if joint_added and len(key.qpos) == before.nq:
            key.qpos = np.insert(np.asarray(key.qpos, dtype=float), qpos_at, 0.0)
        if joint_added and len(key.qvel) == before.nv:
            key.qvel = np.insert(np.asarray(key.qvel, dtype=float), dof_at, 0.0)
        if len(key.ctrl) == before.nu:
            key.ctrl = np.append(np.asarray(key.ctrl, dtype=float), ctrl)
