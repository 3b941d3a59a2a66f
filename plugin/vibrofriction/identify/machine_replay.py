"""A machine replayed in closed loop along a measured record: the EMPS and its controller.

A record whose sidecar names a bundled machine model (``"model": "emps"``) is replayed in that
scene (``mjcf_models/<model>/``), not in the vibrating rig. The scene holds the machine's own
controller (``vibrofriction.sampled_pd``), so the simulation runs the closed loop as the machine
did: the record's inputs are its ctrl, the prediction is what the record measured.

Inputs (record column -> actuator ctrl, held over each sample interval as a DAC holds them):

* ``reference_position_m`` -> ``motor`` (the controller's reference q_r; required);
* ``feedforward_force_N`` -> ``feedforward`` (a known force added at the drive);
* ``external_force_N`` -> ``external`` (a measured force on the body, not through the drive).

Outputs (record column -> scene sensor): ``position_m`` -> ``position``, ``velocity_m_per_s``
-> ``velocity``, ``drive_force_N`` -> ``motor_force`` + ``feedforward_force`` (the total force at
the drive), ``friction_force_N`` -> the friction element's force. Each is read at the step that
starts at the sample: the controller computes its command from the position sampled then (the
EMPS's logged command equals its law at the same sample).

Initial state: position measured, velocity a smoothing estimate, the contact's deflection at
equilibrium with the first drive force, the controller at rest (its filter started on the first
position). The fitted mass is the moving body's; the friction element's normal load is 1 N so
that ``friction_coefficient`` is the friction level in N.
"""
from __future__ import annotations


import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Mapping, Sequence

import mujoco
import numpy as np

from .. import sim
from ..laws import load
from ..rigs import rig as rig_module
from ..data.datasets import Dataset, smoothed_derivative
from ..errors import InputError
from ..params import FrictionParameters, RigParameters
from .model import modulation_not_applicable
from .start import start_velocity, starts_in_motion
from .replay import (SampleGrid, contact_at_rest, contact_sliding, grid_steps, noise_sd,
                     speed_quantiles, substeps_of_record, uniform_times)
from ..vocabulary import FRICTION_TERMS, MJCF_KEYS, NORMAL_LOAD_KEYS

# The friction keys a fitted law must not inherit from the scene: the lists (maps, gms
# elements) and the values that only shape them.
_LAW_LIST_KEYS = {t.mjcf_key for t in FRICTION_TERMS
                  if t.is_list or t.shapes in ("position_map_factors", "velocity_map_factors",
                                                     "time_map_factors")
                  or t.laws == ("gms",)}


# A scene says how a record maps onto it in MJCF custom text elements (kept in the model):
#   <custom>
#     <text name="vibrofriction:joint" data="carriage"/>   joint whose state the record starts
#     <text name="vibrofriction:body" data="carriage"/>    body whose mass is fitted
#     <text name="vibrofriction:damping" data="carriage"/> slide joint whose damping is fitted
#     <text name="vibrofriction:input:reference_position_m" data="motor"/>   column -> actuator ctrl
#     <text name="vibrofriction:output:position_m" data="position"/>        column -> sensor
#     <text name="vibrofriction:output:drive_force_N" data="motor_force + feedforward_force"/>
#   </custom>
# The friction element is the actuator named "friction" (a vibrofriction.friction instance); a
# vibrofriction.sampled_pd controller, if any, is found by its plugin.
TEXT_PREFIX = "vibrofriction:"
# (drive_force_N is an input of a scene driven open loop by its measured drive force, else an
# output: the controller's force)
INPUT_COLUMNS = ("reference_position_m", "feedforward_force_N", "external_force_N",
                 "drive_force_N")
OUTPUT_CHANNELS = ("position_m", "velocity_m_per_s", "drive_force_N", "friction_force_N")
FRICTION_ACTUATOR = "friction"
# sensors the replay adds to read the joint and the friction element
_PROBE_POSITION, _PROBE_VELOCITY, _PROBE_FRICTION = (
    "vibrofriction_position", "vibrofriction_velocity", "vibrofriction_friction")


def _loaded_scene(path: Path, where: str) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    """The user's scene, parsed and compiled (InputError with MuJoCo's message otherwise)."""
    if not Path(path).is_file():
        raise InputError(f"model {where} does not exist; name a bundled model "
                         f"({', '.join(sorted(BUNDLED))}) or an MJCF file")
    load()
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model = spec.compile()
    except Exception as exc:  # MuJoCo's parse and compile errors
        raise InputError(f"model {where} does not load: {exc}") from None
    return spec, model


def _mapping_texts(spec: mujoco.MjSpec, where: str) -> dict[str, str]:
    """The scene's ``vibrofriction:`` custom texts (key without the prefix -> data): known
    keys only, the joint and the body given."""
    texts = {t.name[len(TEXT_PREFIX):]: t.data.strip() for t in spec.texts
             if t.name.startswith(TEXT_PREFIX)}
    for key in texts:
        if key not in ("joint", "body", "damping", "description") and \
                key.partition(":")[0] not in ("input", "output"):
            raise InputError(f"model {where}: {TEXT_PREFIX}{key} is not a key of the mapping "
                             "(joint, body, damping, description, input:COLUMN, "
                             "output:COLUMN)")
    for key in ("joint", "body"):
        if key not in texts:
            raise InputError(
                f"model {where}: say which {key} the record's motion is, e.g. <custom><text "
                f"name=\"{TEXT_PREFIX}{key}\" data=\"NAME\"/></custom>")
    return texts


def _named(model: mujoco.MjModel, where: str, kind: str, obj: mujoco.mjtObj, value: str) -> str:
    """``value``, which a mapping text names, checked to be an object of that kind."""
    if mujoco.mj_name2id(model, obj, value) < 0:
        raise InputError(f"model {where}: {TEXT_PREFIX}{kind} names {value!r}, which "
                         f"is no {obj.name[6:].lower()} of the model")
    return value


def _mapped_columns(model: mujoco.MjModel, where: str, texts: Mapping[str, str]
                    ) -> tuple[dict[str, str], dict[str, tuple[str, ...]]]:
    """(record input column -> actuator, record output column -> the sensors whose sum it
    is) from the ``input:COLUMN`` and ``output:COLUMN`` texts."""
    inputs, outputs = {}, {}
    for key, value in texts.items():
        kind, _, column = key.partition(":")
        if kind == "input":
            if column not in INPUT_COLUMNS:
                raise InputError(f"model {where}: {TEXT_PREFIX}{key}: {column!r} is not an "
                                 f"input column; use one of {', '.join(INPUT_COLUMNS)}")
            inputs[column] = _named(model, where, key, mujoco.mjtObj.mjOBJ_ACTUATOR, value)
        elif kind == "output":
            if column not in OUTPUT_CHANNELS:
                raise InputError(f"model {where}: {TEXT_PREFIX}{key}: {column!r} is not an "
                                 f"output column; use one of {', '.join(OUTPUT_CHANNELS)}")
            outputs[column] = tuple(_named(model, where, key, mujoco.mjtObj.mjOBJ_SENSOR,
                                           v.strip()) for v in value.split("+"))
    return inputs, outputs


def _controller(spec: mujoco.MjSpec, model: mujoco.MjModel, where: str,
                inputs: Mapping[str, str]) -> tuple[str | None, str | None, str | None]:
    """(the sampled PD's instance, its actuator, the record column that drives it), or Nones;
    every vibrofriction actuator plugin must be a named instance (identification sets it by
    name)."""
    controller = controller_actuator = controller_input = None
    for i in range(model.nu):
        p = int(model.actuator_plugin[i])
        if p < 0:
            continue
        actuator = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i)
        instance = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, p)
        declared = next((q for q in spec.plugins if instance and q.name == instance), None)
        kind = declared.plugin_name if declared is not None else \
            (spec.actuator(actuator).plugin.plugin_name if actuator else "")
        if kind not in ("vibrofriction.sampled_pd", "vibrofriction.friction"):
            continue
        if not instance:  # configured inline: identification sets it by instance name
            raise InputError(f"model {where}: the {kind} plugin of actuator "
                             f"{actuator or i!r} has no instance name; declare it in "
                             "<extension><plugin><instance name=\"...\"> and reference it "
                             "with instance=\"...\"")
        if kind == "vibrofriction.sampled_pd":
            controller, controller_actuator = instance, actuator
            controller_input = next((c for c, a in inputs.items() if a == actuator), None)
    return controller, controller_actuator, controller_input


def _friction_plugin(model: mujoco.MjModel, where: str) -> int:
    """The plugin id behind the actuator FRICTION_ACTUATOR (InputError when there is none)."""
    friction = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, FRICTION_ACTUATOR)
    plugin = int(model.actuator_plugin[friction]) if friction >= 0 else -1
    if plugin < 0:
        raise InputError(f"model {where}: no actuator named {FRICTION_ACTUATOR!r} backed by a "
                         "vibrofriction.friction instance; the friction to identify is that "
                         "element")
    return plugin


def _friction_instance(spec: mujoco.MjSpec, model: mujoco.MjModel, where: str,
                       plugin: int) -> tuple[str, dict[str, str]]:
    """(the name, the config) of the vibrofriction.friction instance ``plugin`` behind the
    actuator FRICTION_ACTUATOR, whose normal load the record can drive."""
    instance = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, plugin)
    declared = next((p for p in spec.plugins if instance and p.name == instance), None)
    if declared is None or declared.plugin_name != "vibrofriction.friction":
        raise InputError(f"model {where}: the actuator {FRICTION_ACTUATOR!r} must be backed by "
                         "a named vibrofriction.friction instance (declared in <extension> "
                         "and referenced with instance=\"...\")")
    config = dict(declared.config)
    if config.get("normal_from_ctrl", "").strip() == "true":
        raise InputError(f"model {where}: the friction element takes its normal load from "
                         "its ctrl (normal_from_ctrl), which a machine record cannot drive "
                         "(its columns map to ctrl only through the model's "
                         "vibrofriction:input texts); give it a constant normal or a "
                         "normal_sensor")
    return instance, config


@dataclass(frozen=True)
class MachineScene:
    """A machine model: its file and the names identification relies on (read from the
    scene's own ``vibrofriction:`` custom texts)."""

    path: Path
    name: str
    body: str  # the moving body whose mass is fitted
    joint: str
    controller: str | None  # its vibrofriction.sampled_pd instance, if it has one
    controller_actuator: str | None
    controller_input: str | None  # the column the controller's actuator takes as ctrl
    inputs: dict[str, str]  # record column -> actuator whose ctrl it is
    outputs: dict[str, tuple[str, ...]]  # record column -> sensors whose sum predicts it
    friction_instance: str
    friction_config: dict[str, str]  # the scene's own config of the friction element
    description: str
    bundled: bool = False  # one of BUNDLED (its benchmark's published figures apply)
    damped_joint: str | None = None  # slide joint whose damping is fitted (optional)

    @classmethod
    def from_file(cls, path: Path, name: str | None = None) -> "MachineScene":
        """Read a scene's mapping; InputError naming what is missing and how to add it."""
        where = str(path)
        spec, model = _loaded_scene(path, where)
        texts = _mapping_texts(spec, where)
        joint = _named(model, where, "joint", mujoco.mjtObj.mjOBJ_JOINT, texts["joint"])
        body = _named(model, where, "body", mujoco.mjtObj.mjOBJ_BODY, texts["body"])
        damped = None
        if "damping" in texts:
            damped = _named(model, where, "damping", mujoco.mjtObj.mjOBJ_JOINT, texts["damping"])
            if model.joint(damped).type[0] != mujoco.mjtJoint.mjJNT_SLIDE:
                raise InputError(f"model {where}: {TEXT_PREFIX}damping names {damped!r}, which "
                                 "is not a slide joint; only a slide joint's damping (N s/m) "
                                 "is fitted")
        inputs, outputs = _mapped_columns(model, where, texts)
        friction_plugin = _friction_plugin(model, where)
        controller, controller_actuator, controller_input = _controller(spec, model, where,
                                                                        inputs)
        instance, config = _friction_instance(spec, model, where, friction_plugin)
        return cls(path=Path(path).resolve(), name=name or Path(path).stem, body=body,
                   joint=joint, controller=controller, controller_actuator=controller_actuator,
                   controller_input=controller_input, inputs=inputs, outputs=outputs,
                   friction_instance=instance, friction_config=config,
                   description=texts.get("description", spec.modelname or Path(path).stem),
                   bundled=name in BUNDLED, damped_joint=damped)

    @property
    def normal_load_given(self) -> bool:
        """Whether the scene sets the friction element's normal load (a constant, a sensor or
        contacts); else identification uses 1 N, so the fitted mu is the level in N."""
        normal = self.friction_config.get("normal", "").strip()
        return bool(self.friction_config.get("normal_sensor", "").strip() or
                    self.friction_config.get("contact_geom1", "").strip() or
                    (normal and _number(normal) != 0))

    @property
    def constant_normal_N(self) -> float | None:
        """The scene's normal load when it is a constant > 0 (no sensor, no contacts)."""
        if self.friction_config.get("normal_sensor", "").strip() or \
                self.friction_config.get("contact_geom1", "").strip():
            return None
        value = _number(self.friction_config.get("normal", ""))
        return value if value and value > 0 else None

    @property
    def required_inputs(self) -> tuple[str, ...]:
        """The controller's reference and the position the state starts from; force inputs
        left out are zero."""
        return tuple(c for c in (self.controller_input,) if c) + ("position_m",)


BUNDLED = {"emps": sim.MJCF_DIR / "emps" / "emps.xml"}
# Effects a machine record cannot have: no drive spring, the drive force is a logged command.
NOT_APPLICABLE = {
    "drive_damping": "a machine has no drive spring (its damping is viscous friction)",
    "backlash": "a machine has no drive spring whose play the rig's backlash models",
    "sensor_lag": "the drive force of a machine record is its controller's logged command",
    **modulation_not_applicable("the machine's support does not vibrate"),
}


def machine(model: str, where: str = "", base: Path | None = None) -> MachineScene:
    """The machine a sidecar's (or --model's) ``model`` names: a bundled one, or an MJCF file
    (relative to ``base``, the record's folder); InputError saying which exist otherwise."""
    if model in BUNDLED:
        return MachineScene.from_file(BUNDLED[model], model)
    if model.endswith(".xml"):
        path = Path(model)
        if not path.is_absolute() and base is not None:
            path = base / path  # a sidecar's path is relative to its record
        return MachineScene.from_file(path)
    raise InputError(f"{where + ': ' if where else ''}model {model!r} names no bundled model "
                     f"and no .xml file; use one of: {', '.join(sorted(BUNDLED))}, an MJCF "
                     "file, or leave it out for the vibrating rig")


@dataclass(frozen=True, eq=False)
class MachineReplay(SampleGrid):
    """A record set up for closed-loop replay in a machine scene (same interface as
    ``replay.RigReplay``)."""

    name: str
    scene: MachineScene
    time_s: np.ndarray
    substeps: int
    timestep_s: float
    control: np.ndarray  # (nstep, nu): each actuator's ctrl at each step
    measured: dict[str, np.ndarray]
    noise: dict[str, float]
    rig: RigParameters  # carries the mass (start value) and the unit normal load
    mass_known: bool
    initial_position_m: float
    initial_velocity_m_per_s: float
    initial_friction_N: float
    level_N: float  # friction level of a linear (Coulomb + viscous) fit: the start's scale
    velocity_scale_m_per_s: float
    inputs: dict[str, np.ndarray]  # record column -> samples (to rebuild finer controls)
    normal_force_known: bool = False
    vibrating: bool = False
    timestep_from_record: bool = False
    lagged_sensor: str = "friction"
    # the timestep scan judges the simulator's error in the fit's channel sd (see simulation.py)
    timestep_in_fit_weights: bool = True
    # the body slides at the first sample: the contact starts at its steady sliding state
    starts_in_motion: bool = False

    @property
    def sample_interval_s(self) -> float:
        return _sample_interval(self.time_s)

    @property
    def fitted_scene_values(self) -> tuple[str, ...]:
        """Named values of the scene identification fits with the friction (its mapping's
        ``damping`` joint)."""
        return ("joint_damping_N_s_per_m",) if self.scene.damped_joint else ()

    def fitted_rig(self, values: Mapping[str, float], mass_kg: float) -> RigParameters:
        """The rig values a machine scene takes: the mass (it has no drive spring, so no drive
        damping or backlash: NOT_APPLICABLE)."""
        return replace(self.rig, mass_kg=mass_kg)

    def model(self, rig: RigParameters, friction: FrictionParameters,
              scene_values: Mapping[str, float] | None = None,
              outputs: Sequence[str] | None = None) -> mujoco.MjModel:
        """The machine scene with these values (``outputs``: unused, its probes are few)."""
        return self.spec(rig, friction, scene_values=scene_values).compile()

    def spec(self, rig: RigParameters, friction: FrictionParameters,
             probes: bool = True, scene_values: Mapping[str, float] | None = None
             ) -> mujoco.MjSpec:
        """The machine scene with these values (``probes``: with the sensors identification
        reads; without, ``to_xml()`` writes the fitted scene as the user's, values changed;
        ``scene_values``: its named values, e.g. ``joint_damping_N_s_per_m``)."""
        load()
        friction.validate()
        scene = self.scene
        spec = mujoco.MjSpec.from_file(str(scene.path))
        spec.option.timestep = self.timestep_s
        spec.body(scene.body).mass = rig.mass_kg
        damping = (scene_values or {}).get("joint_damping_N_s_per_m")
        if damping is not None and scene.damped_joint:
            joint = spec.joint(scene.damped_joint)
            coefficients = np.array(joint.damping, dtype=float)  # (linear first)
            coefficients[0] = damping
            joint.damping = coefficients
        # The fitted friction replaces the scene's whole law: its list keys (maps, gms
        # elements), which an empty list leaves unwritten, must not survive from the scene.
        own = {k: v for k, v in scene.friction_config.items() if k not in _LAW_LIST_KEYS}
        config = {**own, **rig_module.friction_config(rig, friction)}
        config[MJCF_KEYS["normal_force_modulation_frequency_Hz"]] = repr(float(
            friction.normal_force_modulation_frequency_Hz))
        if scene.normal_load_given:  # the scene's normal load, as the scene sets it
            for key in NORMAL_LOAD_KEYS:
                if key in scene.friction_config:
                    config[key] = scene.friction_config[key]
                else:
                    config.pop(key, None)
        sim.set_plugin_config(spec, scene.friction_instance, config)
        # one deflection per element for law gms, one for every other law
        spec.actuator(FRICTION_ACTUATOR).actdim = len(friction.gms_stiffness_N_per_m) \
            if friction.law == "gms" else 1
        if scene.controller is not None:
            # The controller samples every `substeps` steps exactly: its period is the record's
            # sample interval, the one the timestep divides (a period that is not a whole
            # number of steps slips against the record's samples within seconds).
            controller = next(p for p in spec.plugins if p.name == scene.controller)
            sim.set_plugin_config(spec, scene.controller, {
                **dict(controller.config), "sample_period": repr(self.sample_interval_s)})
        if probes:
            for name, kind, objtype, target in (
                    (_PROBE_POSITION, mujoco.mjtSensor.mjSENS_JOINTPOS,
                     mujoco.mjtObj.mjOBJ_JOINT, scene.joint),
                    (_PROBE_VELOCITY, mujoco.mjtSensor.mjSENS_JOINTVEL,
                     mujoco.mjtObj.mjOBJ_JOINT, scene.joint),
                    (_PROBE_FRICTION, mujoco.mjtSensor.mjSENS_ACTUATORFRC,
                     mujoco.mjtObj.mjOBJ_ACTUATOR, FRICTION_ACTUATOR)):
                spec.add_sensor(name=name, type=kind, objtype=objtype, objname=target)
        return spec

    def initial_state(self, model: mujoco.MjModel, friction: FrictionParameters,
                      data: mujoco.MjData, initial_velocity_m_per_s: float | None = None
                      ) -> np.ndarray:
        mujoco.mj_resetData(model, data)
        joint = model.joint(self.scene.joint)
        data.qpos[joint.qposadr[0]] = self.initial_position_m
        data.qvel[joint.dofadr[0]] = self.initial_velocity_m_per_s \
            if initial_velocity_m_per_s is None else initial_velocity_m_per_s
        # The controller as it was running when the record starts: its filter on the motion
        # the first samples show (q_{-1} = q_0 - v_0 T), its next sample now.
        controller = -1 if self.scene.controller is None else \
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, self.scene.controller)
        if controller >= 0:
            # what the controller samples: its actuator's length (gear, another joint)
            mujoco.mj_fwdPosition(model, data)
            mujoco.mj_fwdVelocity(model, data)
            a = model.actuator(self.scene.controller_actuator).id
            T = self.sample_interval_s
            q0, v0 = float(data.actuator_length[a]), float(data.actuator_velocity[a])
            adr = model.plugin_stateadr[controller]
            # held, pending, last position, last filtered position, next sample time, started
            data.plugin_state[adr:adr + 6] = [0.0, 0.0, q0 - v0 * T, q0 - 1.5 * v0 * T,
                                              0.0, 1.0]
        if self.starts_in_motion:
            contact_sliding(model, data, friction, float(data.qvel[joint.dofadr[0]]),
                            self.rig.normal_force_N, self.initial_position_m)
        else:
            contact_at_rest(model, data, friction, self.initial_friction_N,
                            self.rig.normal_force_N)
        return sim.full_state(model, data)

    def outputs(self, model: mujoco.MjModel, rig: RigParameters, sensordata: np.ndarray,
                names: Sequence[str]) -> dict[str, np.ndarray]:
        def sensor(name: str) -> np.ndarray:
            return sim.sensor_columns(model, sensordata, name)

        mapped = self.scene.outputs
        out = {}
        for name in names:
            if name in mapped:
                out[name] = sum(sensor(n) for n in mapped[name])
            elif name in ("position_m", "relative_position_m"):
                out[name] = sensor(_PROBE_POSITION)
            elif name in ("velocity_m_per_s", "relative_velocity_m_per_s"):
                out[name] = sensor(_PROBE_VELOCITY)
            elif name == "friction_force_N":
                out[name] = -sensor(_PROBE_FRICTION)  # the element applies -F_F
            else:  # prepare_machine_replay refuses a measured channel the scene cannot give
                raise KeyError(name)
        return out

    def at_substeps(self, substeps: int) -> "MachineReplay":
        """The same record replayed with ``substeps`` MuJoCo steps a sample."""
        return replace(self, substeps=substeps, timestep_s=self.sample_interval_s / substeps,
                       control=_control(self.scene, self.inputs, len(self.time_s), substeps))

    def halved(self) -> "MachineReplay":
        return self.at_substeps(2 * self.substeps)

    @property
    def not_applicable(self) -> dict[str, str]:
        return dict(NOT_APPLICABLE)

    @property
    def sliding_speeds_m_per_s(self) -> tuple[float, ...]:
        """Quantiles of the joint's estimated speed (the fit's Stribeck level coordinate)."""
        return speed_quantiles(self.time_s, self.measured.get("position_m"),
                               self.velocity_scale_m_per_s)

    def start_levels(self, scan: Sequence[float]) -> tuple[float, list[float]]:
        """The friction level that scales the fit and the levels a start scan tries."""
        return self.level_N, [self.level_N * r for r in (0.5, 1.0, 2.0)]


# The benchmark's figures (EMPS description, eq. 11) are quoted from its simulation scripts,
# which leave out the first samples (the filters' start); the 50th sample on, as the issue
# that asked for them states.
PUBLISHED_FIRST_SAMPLE = 49


def closed_loop_errors(replay: MachineReplay, predicted: dict[str, np.ndarray]
                       ) -> dict[str, float]:
    """Relative errors (%) of the closed-loop simulation as the benchmark defines them,
    100 ||y - y_sim|| / ||y|| from the 50th sample: the total drive force, the position, and
    the velocity (the measured one a central difference of the position: for this figure
    only, never a prediction)."""
    def relerr(simulated: np.ndarray, measured: np.ndarray) -> float:
        a, b = simulated[PUBLISHED_FIRST_SAMPLE:], measured[PUBLISHED_FIRST_SAMPLE:]
        return float(100 * np.linalg.norm(a - b) / np.linalg.norm(b))

    out = {}
    if "drive_force_N" in replay.measured:
        out["force_relerr_pct"] = relerr(predicted["drive_force_N"],
                                         replay.measured["drive_force_N"])
    if "position_m" in replay.measured:
        position = replay.measured["position_m"]
        out["position_relerr_pct"] = relerr(predicted["position_m"], position)
        out["velocity_relerr_pct"] = relerr(predicted["velocity_m_per_s"],
                                            np.gradient(position, replay.time_s))
    return out


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _sample_interval(time_s: np.ndarray) -> float:
    """The record's mean sample interval (the EMPS's timestamps are quantized to 0.999984 or
    1.000024 ms, each within 32 ns of k x 1 ms: the mean is the clock)."""
    return float((time_s[-1] - time_s[0]) / (len(time_s) - 1))


def _control(scene: MachineScene, inputs: dict[str, np.ndarray], n: int,
             substeps: int) -> np.ndarray:
    load()
    model = mujoco.MjModel.from_xml_path(str(scene.path))  # (actuator ids only)
    nstep = grid_steps(n, substeps, None)
    control = np.zeros((nstep, model.nu))
    sample = np.minimum(np.arange(nstep) // substeps, n - 1)  # zero-order hold
    for column, actuator in scene.inputs.items():
        if column in inputs:
            control[:, model.actuator(actuator).id] = inputs[column][sample]
    return control


def prepare_machine_replay(dataset: Dataset, *, substeps: int | None = None) -> MachineReplay:
    """Set a record up for closed-loop replay in the machine its sidecar names."""
    where = str(dataset.source_path or dataset.name)
    base = dataset.source_path.parent if dataset.source_path is not None else None
    scene = machine(str(dataset.metadata.model), where, base)
    columns = dataset.columns
    for column in INPUT_COLUMNS:
        if column in columns and column not in scene.inputs and column not in scene.outputs:
            raise InputError(f"{where}: the record has {column}, which the model {scene.name} "
                             f"does not take; map it to an actuator: <custom><text name=\""
                             f"{TEXT_PREFIX}input:{column}\" data=\"ACTUATOR\"/></custom>")
    if "drive_force_N" in columns and "drive_force_N" not in scene.outputs and \
            "drive_force_N" not in scene.inputs:
        raise InputError(f"{where}: the record measures drive_force_N, which the model "
                         f"{scene.name} does not predict; name the sensors whose sum it is: "
                         f"<custom><text name=\"{TEXT_PREFIX}output:drive_force_N\" "
                         "data=\"SENSOR + SENSOR\"/></custom>")
    missing = [c for c in scene.required_inputs if c not in columns]
    if missing:
        raise InputError(f"{where}: the {dataset.metadata.model} model needs "
                         f"{', '.join(missing)} (its controller's reference and the position "
                         "its state starts from); the record lacks it (see "
                         "docs/dataset-format.md)")
    t, sample_dt = uniform_times(dataset, where, _sample_interval)
    measured = {c: np.asarray(columns[c], dtype=float) for c in OUTPUT_CHANNELS
                if c in columns and c not in scene.inputs}
    if not measured:
        raise InputError(f"{where}: the record has no output of the model {scene.name} to "
                         f"fit ({', '.join(c for c in OUTPUT_CHANNELS if c not in scene.inputs)}"
                         "); every column it has drives the model")
    substeps, from_record = substeps_of_record(dataset, sample_dt, substeps)
    substeps = int(substeps or 1)
    if not 1 <= substeps <= 64:
        raise InputError(f"substeps {substeps} must lie in 1..64")
    inputs = {c: np.asarray(columns[c], dtype=float) for c in scene.inputs if c in columns}
    position = np.asarray(dataset.position_m, dtype=float)
    velocity = np.asarray(dataset.velocity_m_per_s, dtype=float)
    # A linear inverse fit (force = M a + Fc sign(v) + Fv v + offset on smoothed derivatives)
    # gives the mass and the friction level the simulation starts from, nothing more.
    force = np.asarray(columns.get("drive_force_N", columns.get("friction_force_N")),
                       dtype=float)
    acceleration = smoothed_derivative(velocity, t)
    moving = np.abs(velocity) > 0.05 * float(np.max(np.abs(velocity)) or 1.0)
    a = np.column_stack([acceleration, np.sign(velocity), velocity, np.ones_like(t)])[moving]
    coef, *_ = np.linalg.lstsq(a, force[moving], rcond=None)
    mass_start = dataset.metadata.mass_kg or (float(coef[0]) if coef[0] > 0 else 1.0)
    level = abs(float(coef[1])) or float(np.mean(np.abs(force)))
    # The fit's scale of mu: the scene's constant load; 1 N otherwise (a load from a sensor
    # or contacts is simulated as the scene has it, but its size is not known here)
    normal = scene.constant_normal_N or 1.0
    rig = RigParameters(mass_kg=mass_start, normal_force_N=normal, drive_velocity_m_per_s=1.0)
    v_scale = math.sqrt(float(np.mean(velocity ** 2))) or 1e-3
    # the start's velocity: the measured velocity's first samples where there is one
    measured_velocity = velocity if "velocity_m_per_s" in columns else None
    velocity0 = start_velocity(t, position, measured_velocity)[0] \
        if measured_velocity is not None else float(smoothed_derivative(position[:32], t[:32])[0])
    return MachineReplay(
        name=dataset.name, scene=scene, time_s=t, substeps=substeps,
        timestep_s=sample_dt / substeps, control=_control(scene, inputs, len(t), substeps),
        measured=measured, noise={c: noise_sd(v) for c, v in measured.items()}, rig=rig,
        mass_known=dataset.metadata.mass_kg is not None,
        initial_position_m=float(position[0]),
        initial_velocity_m_per_s=velocity0,
        initial_friction_N=float(force[0]), level_N=level, velocity_scale_m_per_s=v_scale,
        inputs=inputs, timestep_from_record=from_record,
        normal_force_known=scene.constant_normal_N is not None,
        # (a load from a sensor or contacts is not known before the run: such a scene's
        # contact starts at rest, not at a steady state computed for 1 N)
        starts_in_motion=(scene.constant_normal_N is not None or not scene.normal_load_given)
        and starts_in_motion(t, position, measured_velocity))


__all__ = ["BUNDLED", "closed_loop_errors", "MachineReplay", "MachineScene", "machine", "prepare_machine_replay"]
