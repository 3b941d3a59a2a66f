"""The friction laws from Python, through their one native implementation.

The laws are the plugin's C++ code (plugin/cpp/laws/friction_law.cc); this package binds it:

* ``_native``: loads the plugin library (the MuJoCo version check, the C API's ctypes structs);
* ``_mujoco_plugins``: the ``mujoco.plugins`` entry point, ``import mujoco`` registers the
  plugins (it imports nothing else of the package);
* ``run``: a law driven along a given relative-velocity history (``run_law``, re-exported here:
  ``from vibrofriction import laws; laws.run_law(...)``), and the checked C arrays and law
  parameters other elements' bindings (the planar one) pass to the C API.

What the rest of the package uses is exported here: ``load`` (the library, the plugins
registered), ``package_file`` and ``library_path`` (the installed files), the version check.

The MuJoCo models that use the laws are in ``vibrofriction.rigs`` and ``vibrofriction.robots``;
the independent scipy oracle (``vibrofriction.oracle``) imports nothing of this package.
"""
from ._mujoco_plugins import library_path, package_file
from ._native import MujocoVersionMismatch, check_mujoco_version, load
from .run import (LawRun, c_array, c_law_parameters, c_normal_argument, c_time_argument,
                  kinematic_mean_ratio, run_law, steady_deflection_m)

__all__ = ["LawRun", "run_law", "kinematic_mean_ratio", "steady_deflection_m", "load",
           "package_file", "library_path", "MujocoVersionMismatch", "check_mujoco_version",
           "c_array", "c_law_parameters", "c_normal_argument", "c_time_argument"]
