"""A real arm with the drop-in elements: the Kinova Jaco of dm_control (its MJCF and meshes,
`pip install vibrofriction[robots]`) picks a part off a vibratory feeder and places another on
a vibrating inclined plate, with and without vibration, resolved or at the robot's timestep.

The cell (world frame, the arm's base at the origin):
* a linear vibratory feeder along x at y = -0.36 m (CELL_FEEDER: 50 Hz, 25 deg throw line,
  Gamma 0.9, mu 0.3): its parts convey to an end stop, where the arm picks the first and drops it
  into a tray;
* a plate tilted 10 deg about y, vibrating along its slope at 500 Hz, 20 mm/s (CELL_PLATE_*):
  the arm takes a part from a pedestal and sets it on the plate. Without vibration the part
  holds (tan 10 deg < mu = 0.3); with vibration it creeps downhill at the heavy-body value,
  v_a sin(pi/2 tan(theta)/mu) (the longitudinal arcsin law).

Modes: ``resolved`` (the track and the plate vibrate through vibrofriction.motion shakers, the
parts carry vibrofriction.contact, rigid Coulomb, dt 10 us) and ``robot`` (both still at the
arm's 1 ms: vibrofriction.contact_feeder with the feeder's map, vibrofriction.contact_averaged
with the plate's table). Without vibration: the shakers' ctrl at 0 (resolved), the elements'
law without vibration (robot: rigid Coulomb with stick). Each part has one support: the
feeder parts the track, the plate part the plate; elsewhere (tray, pedestal, fingers) MuJoCo's
own friction holds them (their geoms' condim 1 gives way to the other geom's 3 or 4).

The arm follows joint-space waypoints from damped least-squares IK (position and orientation of
the hand's grip site), with gravity compensation and position servos; the fingers close by
position servos. The plan is the same in every run, so the runs differ only by the friction.
"""
from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from .. import sim
from ..laws import load
from .averaged import AveragedTable, Vibration, build_table
from .feeder_map import FeederMap, build_map
from ..oracle.feeder_reference import Feeder
from ..params import FrictionParameters, ParameterError
from .scenes import SceneRun, run_scene
from .scenes import initial_state as robots_initial_state

GRAVITY_M_PER_S2 = 9.81
MODES = ("resolved", "robot")
TIMESTEP_S = {"resolved": 1e-5, "robot": 1e-3}

CELL_FEEDER = Feeder.from_throw_number(0.9, math.radians(25.0), 50.0, 0.3)
CELL_PART_HALF_M = 0.02  # 40 mm cubes
CELL_PART_MASS_KG = 0.1
CELL_PART_TORSION_RADIUS_M = 0.765 * CELL_PART_HALF_M  # the uniform square face's arm
CELL_PLATE_TILT_RAD = math.radians(10.0)
CELL_PLATE_FRICTION = FrictionParameters(law="coulomb", friction_coefficient=0.3)
CELL_PLATE_VIBRATION = Vibration(frequency_Hz=500.0, velocity_amplitude_m_per_s=0.02)
DURATION_S = 10.0

# layout (m): the track's centre and half length, the stop, the plate, the pedestal, the tray
TRACK_CENTRE = (0.30, -0.36, 0.10)
TRACK_HALF = (0.15, 0.012, 0.005)  # narrower than the parts: the fingertips pass beside it
PLATE_CENTRE = (0.32, 0.34, 0.10)
PLATE_HALF = (0.16, 0.08, 0.005)
PEDESTAL_TOP = (0.45, 0.08, 0.10)
TRAY_CENTRE = (0.0, -0.45, 0.02)
FEEDER_PART_START_X = (0.37, 0.30, 0.23)
STOP_HALF_M = 0.005


def jaco_model_dir() -> Path:
    """dm_control's Kinova Jaco MJCF and meshes (dm_control/third_party/kinova)."""
    spec = importlib.util.find_spec("dm_control")
    if spec is None or not spec.submodule_search_locations:
        raise ParameterError("the arm scenes use the Kinova Jaco model that dm_control ships; "
                             "install it with: pip install 'vibrofriction[robots]' (or "
                             "pip install dm-control)")
    path = Path(list(spec.submodule_search_locations)[0]) / "third_party" / "kinova"
    if not (path / "jaco_arm.xml").is_file():
        raise ParameterError(f"dm_control at {path.parent.parent} has no "
                             "third_party/kinova/jaco_arm.xml; reinstall dm-control >= 1.0.50")
    return path


@lru_cache(maxsize=1)
def cell_feeder_map() -> FeederMap:
    """The map of the cell's vibratory feeder (CELL_FEEDER), which its parts'
    vibrofriction.contact_feeder elements use in mode robot with vibration; made once
    (reference runs), then cached."""
    return build_map(CELL_FEEDER)


@lru_cache(maxsize=1)
def cell_plate_table() -> AveragedTable:
    """The averaged law of the plate part (CELL_PLATE_FRICTION under CELL_PLATE_VIBRATION) at
    its normal load on the tilted plate, m g cos(tilt) (N), for its vibrofriction.contact_averaged
    element in mode robot; made once, then cached."""
    load_N = CELL_PART_MASS_KG * GRAVITY_M_PER_S2 * math.cos(CELL_PLATE_TILT_RAD)
    return build_table(CELL_PLATE_FRICTION, CELL_PLATE_VIBRATION, load_N)


def plate_creep_velocity_m_per_s() -> float:
    """Heavy-body rigid Coulomb creep down the vibrating slope: v_a sin(pi/2 tan(theta)/mu)."""
    ratio = math.tan(CELL_PLATE_TILT_RAD) / CELL_PLATE_FRICTION.friction_coefficient
    return CELL_PLATE_VIBRATION.velocity_amplitude_m_per_s * math.sin(math.pi / 2 * ratio)


def _add_elements(spec: mujoco.MjSpec, mode: str, vibration: bool) -> None:
    """The cell's friction elements and shakers, through MjSpec and the table (sim): the
    feeder's parts, the plate's part, then (resolved) the vibrating supports' motions and their
    actuators, in that order."""
    f = CELL_FEEDER
    coulomb = {"law": "coulomb", "mu": repr(f.friction_coefficient)}
    radius = {"torsion_radius": repr(CELL_PART_TORSION_RADIUS_M)}
    feeder_parts = [f"feeder_part{k}" for k in range(len(FEEDER_PART_START_X))]
    for part in feeder_parts:
        if mode == "robot" and vibration:
            sim.add_plugin_instance(spec, "contact_feeder", f"{part}_friction",
                                    cell_feeder_map().contact_config(
                                        "track", axis=(1.0, 0.0, 0.0),
                                        torsion_radius_m=CELL_PART_TORSION_RADIUS_M), body=part)
        else:
            sim.add_plugin_instance(spec, "contact", f"{part}_friction",
                                    {**coulomb, "support": "track", **radius}, body=part)
    if mode == "robot":
        config = cell_plate_table().contact_config("plate", axis=(1.0, 0.0, 0.0),
                                                   torsion_radius_m=CELL_PART_TORSION_RADIUS_M)
        if not vibration:
            config["velocity_amplitude"] = "0"  # the law without vibration: rigid Coulomb
        sim.add_plugin_instance(spec, "contact_averaged", "plate_part_friction", config,
                                body="plate_part")
    else:
        sim.add_plugin_instance(spec, "contact", "plate_part_friction",
                                {**coulomb, "support": "plate", **radius}, body="plate_part")
    if mode != "resolved":
        return
    v_a = f.amplitude_m * f.omega
    vib = CELL_PLATE_VIBRATION
    for name, frequency, amplitude in (
            ("track_x", f.frequency_Hz, v_a * math.cos(f.throw_angle_rad)),
            ("track_z", f.frequency_Hz, v_a * math.sin(f.throw_angle_rad)),
            ("plate_shaker", vib.frequency_Hz, vib.velocity_amplitude_m_per_s)):
        sim.add_plugin_instance(spec, "motion", name, {
            "frequency": repr(frequency), "velocity_amplitude": repr(amplitude),
            "use_ctrl": "true"})
    for name, joint in (("track_x", "track_x"), ("track_z", "track_z"),
                        ("plate_shaker", "plate_slope")):
        sim.add_plugin_actuator(spec, name, joint, ctrlrange=(0.0, 1.0))


def _world_xml(mode: str, vibration: bool) -> str:
    """The cell's bodies, geoms and sensors (its friction elements and shakers:
    ``_add_elements``)."""
    h = CELL_PART_HALF_M
    feeder_parts = [f"feeder_part{k}" for k in range(len(FEEDER_PART_START_X))]
    shaking = mode == "resolved"
    track_joints = ('<joint name="track_x" type="slide" axis="1 0 0" armature="1e5"/>'
                    '<joint name="track_z" type="slide" axis="0 0 1" armature="1e5"/>'
                    if shaking else "")
    plate_joint = ('<joint name="plate_slope" type="slide" axis="1 0 0" armature="1e5"/>'
                   if shaking else "")
    tc, th = TRACK_CENTRE, TRACK_HALF
    stop_x = tc[0] + th[0] - 0.01  # the stop's face
    pc, ph = PLATE_CENTRE, PLATE_HALF
    pt = PEDESTAL_TOP
    tray = TRAY_CENTRE
    parts = "".join(
        f'<body name="{p}" pos="{x!r} {tc[1]!r} {tc[2] + th[2] + h - 1e-4!r}"><freejoint/>'
        f'<geom name="{p}" class="part"/></body>'
        for p, x in zip(feeder_parts, FEEDER_PART_START_X))
    sensors = "".join(f'<framepos name="{p}_position" objtype="body" objname="{p}"/>'
                      for p in (*feeder_parts, "plate_part"))
    return f"""<mujoco model="vibrofriction arm cell ({mode}, vibration {'on' if vibration else 'off'})">
  <compiler angle="radian"/>
  <option timestep="{TIMESTEP_S[mode]!r}" integrator="implicitfast"/>
  <default>
    <default class="part"><geom type="box" size="{h!r} {h!r} {h!r}" mass="{CELL_PART_MASS_KG!r}"
      condim="1" rgba="0.2 0.5 0.85 1"/></default>
    <default class="fixture"><geom type="box" condim="3" rgba="0.55 0.55 0.6 1"/></default>
  </default>
  <worldbody>
    <light pos="0.3 0 1.5" dir="0 0 -1" diffuse="0.8 0.8 0.8"/>
    <camera name="overview" pos="1.25 0.0 0.85" xyaxes="0 1 0 -0.55 0 0.84"/>
    <geom name="floor" type="plane" size="2 2 0.01" rgba="0.85 0.85 0.82 1"/>
    <body name="track" pos="{tc[0]!r} {tc[1]!r} {tc[2]!r}">{track_joints}
      <geom name="track" type="box" size="{th[0]!r} {th[1]!r} {th[2]!r}" condim="1"
        rgba="0.6 0.62 0.68 1" mass="3"/>
    </body>
    <geom name="track_stand" class="fixture" pos="{tc[0]!r} {tc[1]!r} {(tc[2] - th[2] - 0.001) / 2!r}"
      size="{th[0]!r} {th[1]!r} {(tc[2] - th[2] - 0.001) / 2!r}" contype="0" conaffinity="0"/>
    <geom name="stop" type="box" pos="{stop_x + STOP_HALF_M!r} {tc[1]!r} {tc[2] + th[2] + 0.01!r}"
      size="{STOP_HALF_M!r} 0.01 0.01" condim="1" rgba="0.8 0.3 0.2 1"/>
    <body name="plate" pos="{pc[0]!r} {pc[1]!r} {pc[2]!r}" euler="0 {CELL_PLATE_TILT_RAD!r} 0">
      {plate_joint}
      <geom name="plate" type="box" size="{ph[0]!r} {ph[1]!r} {ph[2]!r}" condim="1"
        rgba="0.62 0.6 0.55 1" mass="3"/>
    </body>
    <geom name="plate_stand" class="fixture" pos="{pc[0]!r} {pc[1]!r} 0.04" size="0.05 0.05 0.04"
      contype="0" conaffinity="0"/>
    <geom name="pedestal" class="fixture" pos="{pt[0]!r} {pt[1]!r} {pt[2] / 2!r}"
      size="0.012 0.012 {pt[2] / 2!r}"/>
    <body name="plate_part" pos="{pt[0]!r} {pt[1]!r} {pt[2] + h - 1e-4!r}"><freejoint/>
      <geom name="plate_part" class="part" rgba="0.85 0.45 0.2 1"/></body>
    {parts}
    <geom name="tray" class="fixture" pos="{tray[0]!r} {tray[1]!r} {tray[2]!r}"
      size="0.08 0.08 {tray[2]!r}"/>
    <frame name="mount"/>
  </worldbody>
  <sensor>{sensors}</sensor>
</mujoco>"""


ARM_JOINTS = tuple(f"jaco/joint_{k}" for k in range(1, 7))
FINGER_JOINTS = tuple(f"jaco/hand/finger_{k}" for k in range(1, 4))
GRIP_SITE = "jaco/hand/gripsite"
HAND_BODY = "jaco/hand/hand"
FINGERS_OPEN, FINGERS_CLOSED = 0.15, 1.2
GRASP_ABOVE_CENTRE_M = 0.015


def build_model(mode: str = "robot", vibration: bool = True) -> mujoco.MjModel:
    """The cell with the arm attached (arm servos first: 6 joints, then the 3 fingers)."""
    if mode not in MODES:
        raise ParameterError(f"unknown arm cell mode {mode!r}; use one of {', '.join(MODES)}")
    kinova = jaco_model_dir()
    load()
    arm = mujoco.MjSpec.from_file(str(kinova / "jaco_arm.xml"))
    hand = mujoco.MjSpec.from_file(str(kinova / "jaco_hand.xml"))
    arm.site("wristsite").attach_body(hand.body("hand"), "hand/", "")
    world = mujoco.MjSpec.from_string(_world_xml(mode, vibration))
    _add_elements(world, mode, vibration)
    world.frame("mount").attach_body(arm.body("b_base"), "jaco/", "")
    for body in world.bodies:
        if body.name.startswith("jaco/"):
            body.gravcomp = 1.0  # the arm's own weight is compensated (as its drives do)
    for joint, kp, damping in ([(j, 1500.0, 100.0) for j in ARM_JOINTS[:3]] +
                               [(j, 500.0, 30.0) for j in ARM_JOINTS[3:]] +
                               [(j, 5.0, 0.25) for j in FINGER_JOINTS]):
        servo = world.add_actuator()
        servo.name = joint.replace("jaco/", "").replace("hand/", "") + "_servo"
        servo.target = joint
        servo.trntype = mujoco.mjtTrn.mjTRN_JOINT
        servo.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        servo.gainprm[0] = kp
        servo.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        servo.biasprm[:3] = [0.0, -kp, -damping]
    return world.compile()


@dataclass(frozen=True)
class Waypoint:
    """One waypoint of the arm's plan: at ``time_s`` (s) the grip site at ``grip_position_m``
    (world frame, m), the fingers' joint target (rad) and the hand's pitch about y (rad)."""

    time_s: float
    grip_position_m: tuple[float, float, float]
    fingers: float         # finger joint target (rad)
    tilt_rad: float = 0.0  # hand pitched about y (to set a part down flat on the slope)


def plan() -> list[Waypoint]:
    """Pick the plate part off the pedestal, set it on the plate, retract; pick the first feeder
    part at the stop, drop it into the tray; retract. The grip site GRASP_ABOVE_CENTRE_M above
    the part's centre (the closing fingertips reach below the site: lower, they strike the
    support)."""
    h = CELL_PART_HALF_M
    g = GRASP_ABOVE_CENTRE_M
    pt, pc = PEDESTAL_TOP, PLATE_CENTRE
    ped = (pt[0], pt[1], pt[2] + h + g)
    tilt = CELL_PLATE_TILT_RAD
    # the plate's surface above its centre, the part's centre a half side along the normal
    normal = PLATE_HALF[2] + h + g + 0.002  # along the plate's normal, 2 mm clear
    place = (pc[0] + normal * math.sin(tilt), pc[1], pc[2] + normal * math.cos(tilt))
    tc, th = TRACK_CENTRE, TRACK_HALF
    stop = (tc[0] + th[0] - 0.01 - h, tc[1], tc[2] + th[2] + h + g)  # a part against the stop
    tray = (TRAY_CENTRE[0], TRAY_CENTRE[1], 2 * TRAY_CENTRE[2] + h + 0.03)
    up = 0.12
    o, c = FINGERS_OPEN, FINGERS_CLOSED

    def above(p, dz=up):
        return (p[0], p[1], p[2] + dz)
    return [
        Waypoint(0.0, above(ped), o), Waypoint(0.5, above(ped), o), Waypoint(1.1, ped, o),
        Waypoint(1.4, ped, o), Waypoint(1.9, ped, c), Waypoint(2.2, ped, c),
        Waypoint(2.7, above(ped), c), Waypoint(3.4, above(place), c, tilt),
        Waypoint(3.9, place, c, tilt), Waypoint(4.1, place, c, tilt),
        Waypoint(4.5, place, o, tilt), Waypoint(4.9, above(place), o, tilt),
        Waypoint(5.6, above(stop), o), Waypoint(6.1, stop, o), Waypoint(6.4, stop, o),
        Waypoint(6.9, stop, c), Waypoint(7.2, stop, c), Waypoint(7.7, above(stop), c),
        Waypoint(8.6, tray, c), Waypoint(9.0, tray, o), Waypoint(9.4, above(tray), o),
        Waypoint(DURATION_S, above(tray), o),
    ]


def _hand_rotation(tilt_rad: float) -> np.ndarray:
    """The hand's frame: its z axis up (the fingers point down), pitched by tilt about y."""
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def solve_ik(model: mujoco.MjModel, position, rotation: np.ndarray, q_start: np.ndarray,
             iterations: int = 400) -> np.ndarray:
    """Arm joint angles that put the grip site at `position` with the hand at `rotation`:
    damped least squares from q_start, limited joints clamped to their ranges."""
    data = mujoco.MjData(model)
    qadr = [model.joint(j).qposadr[0] for j in ARM_JOINTS]
    dofs = [model.joint(j).dofadr[0] for j in ARM_JOINTS]
    limits = [(model.jnt_limited[model.joint(j).id], model.jnt_range[model.joint(j).id])
              for j in ARM_JOINTS]
    site, hand = model.site(GRIP_SITE).id, model.body(HAND_BODY).id
    target = np.asarray(position, dtype=float)
    data.qpos[qadr] = q_start
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for _ in range(iterations):
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        current = data.xmat[hand].reshape(3, 3)
        position_error = target - data.site_xpos[site]
        rotation_error = 0.5 * sum(np.cross(current[:, k], rotation[:, k]) for k in range(3))
        if np.linalg.norm(position_error) < 1e-6 and np.linalg.norm(rotation_error) < 1e-5:
            return data.qpos[qadr].copy()
        mujoco.mj_jacSite(model, data, jacp, jacr, site)
        J = np.vstack([jacp[:, dofs], jacr[:, dofs]])
        error = np.concatenate([position_error, rotation_error])
        step = np.clip(J.T @ np.linalg.solve(J @ J.T + 1e-3 * np.eye(6), error), -0.2, 0.2)
        q = data.qpos[qadr] + step
        for k, (limited, (low, high)) in enumerate(limits):
            if limited:
                q[k] = min(max(q[k], low + 1e-3), high - 1e-3)
        data.qpos[qadr] = q
    raise ParameterError(f"arm IK: no solution for the grip site at {tuple(target)} "
                         f"(left {np.linalg.norm(position_error):.2g} m off)")


# an elbow-up start that reaches the cell's stations without crossing a joint limit
HOME_Q = np.array([-0.204, 2.707, 4.935, 2.854, 1.069, -0.491])


def controls(model: mujoco.MjModel, waypoints: list[Waypoint] | None = None) -> np.ndarray:
    """ctrl (steps x nu) of the plan: the arm's joint targets, smooth between waypoints
    (IK at each waypoint from the previous one), the fingers', and the shakers' gate at 1."""
    waypoints = plan() if waypoints is None else waypoints
    q = HOME_Q
    joints = []
    for w in waypoints:
        q = solve_ik(model, w.grip_position_m, _hand_rotation(w.tilt_rad), q)
        joints.append(q)
    times = np.array([w.time_s for w in waypoints])
    fingers = np.array([w.fingers for w in waypoints])
    steps = int(round(waypoints[-1].time_s / model.opt.timestep))
    t = np.arange(steps) * model.opt.timestep
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    s = np.clip((t - times[k]) / (times[k + 1] - times[k]), 0.0, 1.0)
    s = s * s * (3 - 2 * s)  # smoothstep: zero velocity at every waypoint
    joints = np.array(joints)
    ctrl = np.zeros((steps, model.nu))
    names = [model.actuator(i).name for i in range(model.nu)]
    for j, joint in enumerate(ARM_JOINTS):
        column = names.index(joint.replace("jaco/", "") + "_servo")
        ctrl[:, column] = joints[k, j] + s * (joints[k + 1, j] - joints[k, j])
    for joint in FINGER_JOINTS:
        column = names.index(joint.replace("jaco/hand/", "") + "_servo")
        ctrl[:, column] = fingers[k] + s * (fingers[k + 1] - fingers[k])
    for shaker in ("track_x", "track_z", "plate_shaker"):
        if shaker in names:
            ctrl[:, names.index(shaker)] = 1.0
    return ctrl


def initial_state(model: mujoco.MjModel, ctrl0: np.ndarray) -> np.ndarray:
    """The arm at the plan's first waypoint, fingers open; everything else as the model has it."""
    first = plan()[0]
    q = solve_ik(model, first.grip_position_m, _hand_rotation(first.tilt_rad), HOME_Q)
    joints = {**dict(zip(ARM_JOINTS, q)), **{j: FINGERS_OPEN for j in FINGER_JOINTS}}
    return robots_initial_state(model, ctrl0, joints)


def run_cell(mode: str = "robot", vibration: bool = True, *,
             duration_s: float = DURATION_S) -> SceneRun:
    """The plan, natively (scenes.run_scene in chunks of 10 ms, so that a resolved run keeps
    little memory); sensors and states every millisecond."""
    model = build_model(mode, vibration)
    ctrl = controls(model)[:int(round(duration_s / model.opt.timestep))]
    if not vibration:
        names = [model.actuator(i).name for i in range(model.nu)]
        for shaker in ("track_x", "track_z", "plate_shaker"):
            if shaker in names:
                ctrl[:, names.index(shaker)] = 0.0
    every = max(1, int(round(1e-3 / model.opt.timestep)))
    return run_scene(model, ctrl, initial_state(model, ctrl[0]), keep_every=every,
                     chunk_steps=10 * every)


__all__ = ["CELL_FEEDER", "CELL_PART_MASS_KG", "CELL_PLATE_FRICTION", "CELL_PLATE_TILT_RAD",
           "CELL_PLATE_VIBRATION", "DURATION_S", "MODES", "Waypoint", "build_model",
           "cell_feeder_map", "cell_plate_table", "controls", "jaco_model_dir", "plan",
           "plate_creep_velocity_m_per_s", "run_cell", "solve_ik"]
