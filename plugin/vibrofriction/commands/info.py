"""``vibrofriction info``: what is installed, and the plugins MuJoCo knows from it.

Prints (or writes with ``--json FILE``) the versions (vibrofriction, the installed MuJoCo, the
MuJoCo the plugin library was built against), the library's path, whether the ``mujoco.plugins``
entry point is installed (a plain ``import mujoco`` registers the plugins), and each
``vibrofriction.*`` plugin with its kind and its MJCF config attributes, read from MuJoCo's own
plugin registry.
"""
from __future__ import annotations

import argparse
import ctypes
from importlib.metadata import entry_points
from typing import Any

import mujoco

from .. import __version__, build_info
from ..laws import MujocoVersionMismatch, library_path, load
from .common import write_json

HELP = ("show the versions, the plugin library and the plugins with their MJCF attributes "
        "(from MuJoCo's plugin registry)")
ENTRY_POINT = "vibrofriction.laws._mujoco_plugins:register"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the info command's options to its argparse parser."""
    parser.add_argument("--json", dest="json_path", default=None, metavar="FILE",
                        help="write the same as JSON to FILE")


class _Plugin(ctypes.Structure):
    # The leading fields of mjpPlugin (mujoco/mjplugin.h), the only ones read here.
    _fields_ = [("name", ctypes.c_char_p), ("nattribute", ctypes.c_int),
                ("attributes", ctypes.POINTER(ctypes.c_char_p)),
                ("capabilityflags", ctypes.c_int)]


_KINDS = {mujoco.mjtPluginCapabilityBit.mjPLUGIN_ACTUATOR: "actuator",
          mujoco.mjtPluginCapabilityBit.mjPLUGIN_SENSOR: "sensor",
          mujoco.mjtPluginCapabilityBit.mjPLUGIN_PASSIVE: "passive"}


def registered_plugins() -> list[dict[str, Any]]:
    """Every vibrofriction plugin in MuJoCo's registry: name, kinds, attributes."""
    library = load()  # (its symbol lookup reaches libmujoco's mjp_* functions)
    library.mjp_pluginCount.restype = ctypes.c_int
    library.mjp_getPluginAtSlot.restype = ctypes.POINTER(_Plugin)
    library.mjp_getPluginAtSlot.argtypes = [ctypes.c_int]
    out = []
    for slot in range(library.mjp_pluginCount()):
        plugin = library.mjp_getPluginAtSlot(slot).contents
        name = plugin.name.decode()
        if not name.startswith("vibrofriction."):
            continue
        out.append({"name": name,
                    "kinds": [kind for bit, kind in _KINDS.items()
                              if plugin.capabilityflags & int(bit)],
                    "attributes": [plugin.attributes[i].decode()
                                   for i in range(plugin.nattribute)]})
    return out


def info() -> dict[str, Any]:
    """What is installed; the plugins only where the library loads (a MuJoCo other than the
    one it was built against is reported as ``error``, with the versions that show why)."""
    try:
        plugins, error = registered_plugins(), None
    except MujocoVersionMismatch as exc:
        plugins, error = [], str(exc)
    return {
        "versions": {"vibrofriction": __version__, "mujoco": mujoco.__version__,
                     "mujoco_built_against": build_info.MUJOCO_VERSION},
        "library": str(library_path()),
        # (declared by the installed package; it loads the library at `import mujoco`)
        "entry_point_installed": any(ep.value == ENTRY_POINT
                                     for ep in entry_points(group="mujoco.plugins")),
        "plugins": plugins,
        "error": error,
    }


def run(args: argparse.Namespace) -> int:
    """Run the info command on parsed arguments; return the exit status."""
    payload = info()
    if args.json_path is not None:
        write_json(args.json_path, payload)
        return 0
    versions = payload["versions"]
    print(f"vibrofriction {versions['vibrofriction']}, MuJoCo {versions['mujoco']} (plugin "
          f"built against {versions['mujoco_built_against']})")
    print(f"library: {payload['library']}")
    print("import mujoco registers the plugins: " + (
        "yes (entry point in mujoco.plugins)" if payload["entry_point_installed"] else
        "no (a source tree: the entry point comes with pip install .); vibrofriction.load() "
        "registers them"))
    if payload["error"]:
        print(f"the plugins cannot load: {payload['error']}")
    for plugin in payload["plugins"]:
        print(f"{plugin['name']} ({', '.join(plugin['kinds'])}): "
              f"{', '.join(plugin['attributes']) or 'no attributes'}")
    return 0
