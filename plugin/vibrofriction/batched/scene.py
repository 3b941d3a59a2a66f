"""The batched twin's scene: the robot-timestep elements read from a scene's MJCF plugin config,
and the same scene without the plugins (MuJoCo Warp runs no engine plugin).

Pure MuJoCo and NumPy (no Warp): the elements' configs are read from the MjSpec exactly as
the C++ plugins read them (``plugin/cpp/plugins/contact_friction.cc``: the same keys, defaults
and tables), after the scene has compiled once with the plugins loaded, so every config the
C++ plugin refuses is refused here with the plugin's own message. The chain dofs, the geom
pairs the element acts over and their condim follow ``ContactConfig::ReadPair``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..params import ParameterError
from ..vocabulary import KEY_DEFAULTS, plugin_keys

AVERAGED = "vibrofriction.contact_averaged"
FEEDER = "vibrofriction.contact_feeder"
SENSOR = "vibrofriction.contact_sensor"
BATCHED = (AVERAGED, FEEDER)
# plugin_state of one instance (ContactState in contact_friction.h)
STATE_SIZE = 16
# the sensor's values (vibrofriction.contact_sensor): force (3, world), moment about n, z_t (3),
# theta, F_N, the sliding speed |u|
SENSOR_SIZE = 10
# the per-(world, element) parameters a batch may vary (config keys of the elements)
PARAMETERS = ("mu", "viscous", "static_ratio", "stribeck_velocity", "velocity_amplitude",
              "torsion_radius", "helix_pitch")


@dataclass
class Element:
    """One contact_averaged or contact_feeder instance, as its C++ config reads it."""

    name: str                 # the instance's name
    plugin: str               # AVERAGED or FEEDER
    body: str                 # the sliding body (its <plugin instance=.../>)
    support: str              # config `support`
    parameters: dict[str, float]   # PARAMETERS, with the C++ defaults
    axis: np.ndarray          # config `axis`, normalized (the support's frame)
    support_geom: tuple[str, ...] = ()
    # contact_averaged: the table (over mu F_N) on the grid of xi = |u|/v_a and the angle
    xi: np.ndarray = field(default_factory=lambda: np.zeros(0))
    angle: np.ndarray = field(default_factory=lambda: np.zeros(0))
    along: np.ndarray = field(default_factory=lambda: np.zeros(0))    # (n_xi * n_angle)
    across: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # contact_feeder: the map
    map_velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    map_force: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def feeder(self) -> bool:
        return self.plugin == FEEDER


@dataclass
class TwinScene:
    """The scene without plugins and its elements (in the order of the original model's
    plugin instances, so ``state`` rows follow ``MjData.plugin_state``)."""

    spec: mujoco.MjSpec
    model: mujoco.MjModel            # compiled from spec: no plugins
    elements: list[Element]
    plugin_stateadr: list[int]       # each element's address in the original plugin_state
    sensors: dict[str, str]          # contact_sensor name -> the element's instance name


def _numbers(text: str, key: str, name: str) -> np.ndarray:
    try:
        return np.array([float(t) for t in text.split()], dtype=float)
    except ValueError:
        raise ParameterError(f"{name}: attribute '{key}'=\"{text[:40]}\" is not a list of "
                             "numbers") from None


def _number(config: dict, key: str, default: float, name: str) -> float:
    text = config.get(key, "")
    if not text.strip():
        return default
    values = _numbers(text, key, name)
    if values.size != 1:
        raise ParameterError(f"{name}: attribute '{key}' needs one number")
    return float(values[0])


def _element(name: str, plugin: str, config: dict, body: str) -> Element:
    # the table's default of each key the plugin takes; a key it does not take keeps that
    # (neutral) default. The feeder's mu has none: the element refuses a config without it.
    takes = plugin_keys(plugin[len("vibrofriction."):])
    parameters = {key: _number(config, key, 0.0 if (key, plugin) == ("mu", FEEDER)
                               else KEY_DEFAULTS[key], name) if key in takes
                  else KEY_DEFAULTS[key] for key in PARAMETERS}
    axis = _numbers(config["axis"], "axis", name) if config.get("axis", "").strip() \
        else np.array([1.0, 0.0, 0.0])
    element = Element(name=name, plugin=plugin, body=body, support=config.get("support", ""),
                      parameters=parameters, axis=axis / np.linalg.norm(axis),
                      support_geom=tuple(config.get("support_geom", "").split()))
    if plugin == AVERAGED:
        for key in ("xi", "angle", "along", "across"):
            text = config.get(f"table_{key}", "")
            setattr(element, key, _numbers(text, f"table_{key}", name) if text.strip()
                    else np.zeros(0))
        if element.xi.size < 2:  # no vibration, no table: rigid Coulomb (a dummy grid)
            element.xi, element.angle = np.array([0.0, 1.0]), np.array([0.0, math.pi])
            element.along, element.across = np.zeros(4), np.zeros(4)
    else:
        element.map_velocity = _numbers(config["map_velocity"], "map_velocity", name)
        element.map_force = _numbers(config["map_force"], "map_force", name)
    return element


def load_spec(scene) -> mujoco.MjSpec:
    """An MjSpec from an MJCF path, MJCF text or an MjSpec (copied: the caller's is kept)."""
    from ..laws import load
    load()  # the C++ plugins: the scene compiles once with them (their checks)
    if isinstance(scene, mujoco.MjSpec):
        return scene.copy()
    if isinstance(scene, Path) or (isinstance(scene, str) and "<mujoco" not in scene):
        return mujoco.MjSpec.from_file(str(scene))
    return mujoco.MjSpec.from_string(scene)


def twin_scene(scene) -> TwinScene:
    """The batched twin of ``scene`` (MJCF path or text, or an MjSpec): its contact_averaged
    and contact_feeder elements with their configs, and the same scene with the plugin
    instances, their bodies' ``<plugin instance>`` lines and the contact_sensor plugin sensors
    removed (everything else unchanged: the same MJCF). Other plugins are refused by name."""
    spec = load_spec(scene)
    original = spec.compile()  # the C++ plugins' checks (a bad config is refused here)
    instances = {p.name: p for p in spec.plugins if p.name}
    # a sensor's own instance is unnamed, without plugin_name here (the sensor has it)
    others = {p.plugin_name for p in spec.plugins
              if p.plugin_name and p.plugin_name not in BATCHED + (SENSOR,)}
    others |= {s.plugin.plugin_name for s in spec.sensors
               if s.type == mujoco.mjtSensor.mjSENS_PLUGIN and s.plugin.plugin_name != SENSOR}
    others = sorted(others)
    if others:
        raise ParameterError(
            f"batched twin: the scene uses {', '.join(others)}, which the batched elements do "
            f"not cover (only {AVERAGED} and {FEEDER}, at robot timesteps); the resolved elements "
            "need the vibration resolved, use them with mujoco.rollout")
    bodies = {b.plugin.name: b.name for b in spec.bodies
              if b.plugin is not None and b.plugin.active and b.plugin.name}
    order = [mujoco.mj_id2name(original, mujoco.mjtObj.mjOBJ_PLUGIN, i)
             for i in range(original.nplugin)]
    elements, stateadr = [], []
    for index, name in enumerate(order):
        plugin = instances.get(name or "")
        if plugin is None or plugin.plugin_name not in BATCHED:
            continue
        elements.append(_element(name, plugin.plugin_name, dict(plugin.config), bodies[name]))
        stateadr.append(int(original.plugin_stateadr[index]))
    sensors = {}
    for sensor in list(spec.sensors):
        if sensor.type == mujoco.mjtSensor.mjSENS_PLUGIN:
            body = dict(sensor.plugin.config).get("body", "") if sensor.plugin else ""
            owner = {e.body: e.name for e in elements}.get(body)
            if owner is not None:
                sensors[sensor.name] = owner
            spec.delete(sensor)
    for body in spec.bodies:
        if body.plugin is not None and body.plugin.active:
            body.plugin.active = False
            body.plugin.name = ""
    for plugin in list(spec.plugins):
        spec.delete(plugin)
    model = spec.compile()
    return TwinScene(spec=spec, model=model, elements=elements, plugin_stateadr=stateadr,
                     sensors=sensors)


# ---- what the element acts over (ContactConfig::ReadPair) ------------------------------------------

def chain(model: mujoco.MjModel, body: int, support: int) -> tuple[list[int], list[float]]:
    """The dofs that move the body (+1) or the support (-1); a dof of both is left out."""
    dofs: list[int] = []
    signs: list[float] = []
    for k, start in enumerate((body, support)):
        b = start
        while b > 0 and model.body_dofnum[b] == 0:
            b = model.body_parentid[b]
        if b <= 0:
            continue
        i = model.body_dofadr[b] + model.body_dofnum[b] - 1
        while i >= 0:
            sign = 1.0 if k == 0 else -1.0
            if i in dofs:
                signs[dofs.index(i)] += sign
            else:
                dofs.append(int(i))
                signs.append(sign)
            i = model.dof_parentid[i]
    kept = [(d, s) for d, s in zip(dofs, signs) if s != 0.0]
    return [d for d, _ in kept], [s for _, s in kept]


def surface_pairs(model: mujoco.MjModel, element: Element) -> list[tuple[int, int]]:
    """(geom of the body, geom of the support's surface) pairs: the contacts the element sums.
    The C++ plugin has checked their condim (1) when the scene compiled with it."""
    body = model.body(element.body).id
    support = model.body(element.support).id
    surface = {model.geom(name).id for name in element.support_geom}
    pairs = []
    for g1 in np.flatnonzero(model.geom_bodyid == body):
        for g2 in np.flatnonzero(model.geom_bodyid == support):
            if surface and g2 not in surface:
                continue
            pairs.append((int(g1), int(g2)))
    return pairs


def colors(model: mujoco.MjModel, chains: list[list[int]]) -> list[int]:
    """A color per element such that no two elements of one color move a common kinematic
    tree: their rows of J M^-1 J' then come from one solve with M (M is block-diagonal over
    trees). Greedy, in order."""
    trees = [{int(model.dof_treeid[d]) for d in dofs} for dofs in chains]
    color: list[int] = []
    for k, mine in enumerate(trees):
        taken = {color[j] for j in range(k) if trees[j] & mine}
        c = 0
        while c in taken:
            c += 1
        color.append(c)
    return color


__all__ = ["AVERAGED", "BATCHED", "Element", "FEEDER", "PARAMETERS", "SENSOR", "SENSOR_SIZE",
           "STATE_SIZE", "TwinScene", "chain", "colors", "load_spec", "surface_pairs",
           "twin_scene"]
