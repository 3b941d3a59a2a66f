"""``import mujoco`` registers the vibrofriction plugins.

``register`` is the package's entry point in the group ``mujoco.plugins`` (pyproject.toml),
which mujoco's ``__init__`` calls at its end. It loads the plugin library and nothing else: it
may run while ``import vibrofriction`` is itself half done (that import imports mujoco), so it
uses no other module of the package but the generated ``build_info``. (Importing it runs the
package's ``__init__`` and that of ``vibrofriction.laws`` inside mujoco's unfinished import: keep
both light, with no module that needs mujoco fully imported at its top level.)
``vibrofriction.load()`` loads the same file by the same absolute path: MuJoCo's second
``dlopen`` of it registers nothing again.
"""
from __future__ import annotations

from pathlib import Path

LIBRARY_NAME = "libvibrofriction_plugin.so"
# The MuJoCo versions the sources build and pass against (pyproject.toml's build requirement).
SUPPORTED_MUJOCO = ">=3.17,<4.1"


def package_file(name: str) -> Path:
    """Absolute path of ``name`` at the root of the installed package: in the first of the
    package's folders that holds it (an editable install's package spans the source folder
    and the installed one, where the build put the library and the models), else in the
    first folder."""
    import sys

    folders = [Path(p).resolve() for p in sys.modules[__name__.split(".")[0]].__path__]
    return next((f / name for f in folders if (f / name).exists()), folders[0] / name)


def library_path() -> Path:
    """Absolute path of the plugin library at the root of the installed package."""
    return package_file(LIBRARY_NAME)


def version_mismatch(compiled: str, runtime: str) -> str | None:
    """The message for a MuJoCo other than the one the library was compiled against."""
    if compiled == runtime:
        return None
    return (f"vibrofriction was compiled against MuJoCo {compiled} but MuJoCo {runtime} is "
            f"installed; install mujoco=={compiled}, or rebuild vibrofriction against "
            f"{runtime} (supported: {SUPPORTED_MUJOCO}): echo mujoco=={runtime} > c.txt && "
            "PIP_CONSTRAINT=c.txt PIP_BUILD_CONSTRAINT=c.txt pip install --force-reinstall "
            "--no-cache-dir .")


def register() -> None:
    """Load the plugin library into MuJoCo (mujoco turns an exception here into a warning)."""
    import mujoco  # (mid-import when mujoco calls this: its functions are already defined)

    from .. import build_info

    message = version_mismatch(build_info.MUJOCO_VERSION, mujoco.mj_versionString())
    if message:
        raise ImportError(message)
    path = library_path()
    if not path.is_file():
        raise ImportError(f"vibrofriction plugin library not found at {path}; reinstall the "
                          "package (pip install .)")
    mujoco.mj_loadPluginLibrary(str(path))
