"""The friction laws from Python, through their one native implementation.

The laws are the plugin's C++ code (plugin/cpp/laws/friction_law.cc); this package binds it:

* ``_native``: loads the plugin library (the MuJoCo version check, the C API's ctypes structs);
* ``_mujoco_plugins``: the ``mujoco.plugins`` entry point, ``import mujoco`` registers the
  plugins (it imports nothing else of the package);
* ``run``: a law driven along a given relative-velocity history (``run_law``, re-exported here:
  ``from vibrofriction import laws; laws.run_law(...)``).

The MuJoCo models that use the laws are in ``vibrofriction.rigs`` and ``vibrofriction.robots``;
the independent scipy oracle (``vibrofriction.oracle``) imports nothing of this package.
"""
from .run import LawRun, kinematic_mean_ratio, run_law, steady_deflection_m

__all__ = ["LawRun", "run_law", "kinematic_mean_ratio", "steady_deflection_m"]
