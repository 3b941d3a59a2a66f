"""The installed MJCF models, and plugin configs set through MjSpec."""
from __future__ import annotations

import mujoco

from ..laws import package_file

# mjcf_models/ of the checkout, installed at the package's root
MJCF_DIR = package_file("mjcf_models")


def set_plugin_config(spec: mujoco.MjSpec, name: str, config: dict[str, str]) -> None:
    """Replace the config of the plugin instance ``name`` in ``spec``."""
    for plugin in spec.plugins:
        if plugin.name == name:
            plugin.config = config
            return
    raise RuntimeError(f"MJCF model {spec.modelname!r} has no plugin instance named {name!r}")
