"""The installed MJCF models, and the vibrofriction plugins' configs set through MjSpec.

Every config a scene builder writes goes through here: its keys are checked against the one
table (``vocabulary.plugin_keys``), so a misspelt key is named with the plugin's keys before
MuJoCo compiles anything, and no builder writes ``<config key=...>`` text itself.
"""
from __future__ import annotations

import math
from typing import Mapping, Sequence
from xml.sax.saxutils import quoteattr

import mujoco
import numpy as np

from ..laws import package_file
from ..params import ParameterError
from ..vocabulary import ALL_PLUGINS, plugin_keys

# mjcf_models/ of the checkout, installed at the package's root
MJCF_DIR = package_file("mjcf_models")
PREFIX = "vibrofriction."


def _value_text(plugin: str, key: str, value: object) -> str:
    """An MJCF config value: a string as it is, a bool as true/false, a number as repr(float),
    a sequence of numbers space-separated."""
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    numbers = list(np.ravel(value)) if isinstance(value, (Sequence, np.ndarray)) else [value]
    try:
        floats = [float(x) for x in numbers]
    except (TypeError, ValueError):
        raise ParameterError(f"{PREFIX}{plugin} config {key}={value!r} is not a number, a list "
                             "of numbers, a bool or a string") from None
    if not all(math.isfinite(x) for x in floats):
        raise ParameterError(f"{PREFIX}{plugin} config {key}={value!r} is not finite")
    return " ".join(repr(x) for x in floats)


def plugin_config(plugin: str, config: Mapping[str, object]) -> dict[str, str]:
    """``config`` of ``vibrofriction.<plugin>`` as MJCF strings, every key one the table gives
    that plugin (ParameterError naming the key and the plugin's keys otherwise)."""
    name = plugin[len(PREFIX):] if plugin.startswith(PREFIX) else plugin
    if name not in ALL_PLUGINS:
        raise ParameterError(f"unknown plugin {plugin!r}; the plugins are "
                             f"{', '.join(PREFIX + p for p in ALL_PLUGINS)}")
    keys = plugin_keys(name)
    unknown = [key for key in config if key not in keys]
    if unknown:
        raise ParameterError(f"{PREFIX}{name} has no config key {unknown[0]!r}; its keys are "
                             f"{', '.join(keys)}")
    return {key: _value_text(name, key, value) for key, value in config.items()}


def add_plugin_instance(spec: mujoco.MjSpec, plugin: str, name: str,
                        config: Mapping[str, object], *,
                        body: str | None = None) -> mujoco.MjsPlugin:
    """Declare the instance ``name`` of ``vibrofriction.<plugin>`` in ``spec`` with ``config``
    (checked by ``plugin_config``); ``body``: the body it is attached to (a contact element's
    sliding part). An actuator plugin is attached by ``add_plugin_actuator``."""
    full = plugin if plugin.startswith(PREFIX) else PREFIX + plugin
    values = plugin_config(full, config)
    attached = spec.body(body) if body is not None else None
    if body is not None and attached is None:  # (checked first: a failing call adds nothing)
        raise ParameterError(f"{full} instance {name!r}: the model has no body {body!r}")
    spec.activate_plugin(full)
    instance = spec.add_plugin(name=name, plugin_name=full, active=True)
    instance.config = values
    if attached is not None:
        attached.plugin.name = name
        attached.plugin.active = True
    return instance


def add_plugin_actuator(spec: mujoco.MjSpec, instance: str, joint: str, *,
                        ctrlrange: tuple[float, float] | None = None) -> mujoco.MjsActuator:
    """An actuator named ``instance`` on ``joint`` driven by the plugin instance of that name
    (e.g. a ``vibrofriction.motion`` shaker), with ``ctrlrange`` when given."""
    actuator = spec.add_actuator(name=instance, trntype=mujoco.mjtTrn.mjTRN_JOINT, target=joint)
    actuator.plugin.name = instance
    actuator.plugin.active = True
    if ctrlrange is not None:
        actuator.ctrlrange = list(ctrlrange)
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    return actuator


def instance_xml(plugin: str, name: str, config: Mapping[str, object],
                 indent: str = "") -> str:
    """The ``<instance>`` element of ``vibrofriction.<plugin>`` with ``config`` (checked by
    ``plugin_config``), one ``<config>`` a line: the text a user pastes into a scene's
    ``<extension><plugin plugin="vibrofriction.<plugin>">``."""
    values = plugin_config(plugin, config)
    lines = [f"{indent}<instance name={quoteattr(name)}>"]
    lines += [f"{indent}  <config key={quoteattr(key)} value={quoteattr(value)}/>"
              for key, value in values.items()]
    lines.append(f"{indent}</instance>")
    return "\n".join(lines)


def set_plugin_config(spec: mujoco.MjSpec, name: str, config: dict[str, str]) -> None:
    """Replace the config of the plugin instance ``name`` in ``spec`` (a vibrofriction
    plugin's keys checked by ``plugin_config``)."""
    for plugin in spec.plugins:
        if plugin.name == name:
            if plugin.plugin_name.startswith(PREFIX):
                config = plugin_config(plugin.plugin_name, config)
            plugin.config = config
            return
    raise RuntimeError(f"MJCF model {spec.modelname!r} has no plugin instance named {name!r}")
