"""``vibrofriction view SCENE``: a scene in MuJoCo's own interactive viewer.

SCENE is an MJCF file, or the name of a bundled scene (``rig`` or ``rig-LAW``, ``emps``, a
complete robot scene's file name without ``.xml``). The plugins are registered first, so any scene that
uses them opens; ``python -m mujoco.viewer --mjcf=SCENE`` does the same through the package's
``mujoco.plugins`` entry point.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ..errors import InputError

ROBOT_SCENES = ("feeder", "plate_push_resolved", "plate_push_averaged", "planar_rig_resolved",
                "planar_rig_averaged")
HELP = "open a scene (an MJCF file or a bundled scene's name) in MuJoCo's interactive viewer"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the view command's options to its argparse parser."""
    parser.add_argument("scene", metavar="SCENE",
                        help="an MJCF file, or a bundled scene: " + ", ".join(bundled_names()))


def bundled_scenes() -> dict[str, Path]:
    """Bundled scene name -> its MJCF file: ``rig`` (the Dahl rig), ``rig-LAW``, ``emps`` and
    the complete robot scenes (``ROBOT_SCENES``)."""
    from ..sim import MJCF_DIR
    scenes = {"rig": MJCF_DIR / "rig" / "scene_dahl.xml", "emps": MJCF_DIR / "emps" / "emps.xml"}
    scenes.update({f"rig-{p.stem[len('scene_'):]}": p
                   for p in sorted((MJCF_DIR / "rig").glob("scene_*.xml"))})
    # (the robots folder's other files are parts that the Python scene builders complete)
    scenes.update({name: MJCF_DIR / "robots" / f"{name}.xml" for name in ROBOT_SCENES})
    return scenes


def bundled_names() -> list[str]:
    """The names of the bundled scenes, as SCENE accepts them."""
    return list(bundled_scenes())


def scene_file(name: str) -> Path:
    """The file SCENE names; InputError saying what exists otherwise."""
    path = Path(name)
    if path.suffix == ".xml":
        if not path.is_file():
            raise InputError(f"scene {name} does not exist")
        return path
    scenes = bundled_scenes()
    if name not in scenes:
        raise InputError(f"{name!r} is no MJCF file (.xml) and no bundled scene; use one of: "
                         f"{', '.join(scenes)}")
    return scenes[name]


def has_display() -> bool:
    """Whether an interactive window can open (an X or Wayland display; other systems have
    one unless they say otherwise)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def run(args: argparse.Namespace) -> int:
    """Run the view command on parsed arguments; return the exit status."""
    import mujoco

    from ..laws import load
    path = scene_file(args.scene)
    load()
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:  # MuJoCo's parse and compile errors
        raise InputError(f"scene {path} does not load: {exc}") from None
    if not has_display():
        raise InputError(f"scene {path} loads ({model.nbody - 1} bodies, {model.nplugin} plugin "
                         "instances) but there is no display to open the viewer on (DISPLAY "
                         "is not set); run it on a desktop, or render offscreen with "
                         "mujoco.Renderer")
    import mujoco.viewer
    mujoco.viewer.launch(model)
    return 0
