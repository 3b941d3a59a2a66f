"""vibrofriction: dynamic friction with vibrating supports as MuJoCo engine plugins.

Where things live (docs/DEVELOPING.md has the layout):
  friction laws ........ plugin/cpp/laws/friction_law.cc (one implementation); from Python
                         through vibrofriction/laws/ (laws.run_law)
  MuJoCo plugins ....... plugin/cpp/plugins/ (friction_element.cc, support_motion.cc, ...)
  parameters ........... vibrofriction/params.py, the table in vocabulary.py
  the paper's rig ...... mjcf_models/rig/ and vibrofriction/rigs/rig.py (its model:
                         rig_model.py; planar, steady, sweep)
  MuJoCo plumbing ...... vibrofriction/sim/ (model folder, state, sensors, plugin configs,
                         thread counts: what rigs, robots and identify share)
  robots ............... mjcf_models/robots/ and vibrofriction/robots/ (scenes, averaged tables,
                         feeder map, the Jaco cell)
  scipy oracle ......... vibrofriction/oracle/reference.py, analytic limits in oracle/analytic.py
                         (none of the native laws: tests/test_layout.py)
  records .............. vibrofriction/data/ (format, converters, synthetic records)
  identification ....... vibrofriction/identify/ (machines in closed loop: machine_replay.py,
                         mjcf_models/emps/)
  the paper study ...... vibrofriction/study/
  command line ......... vibrofriction/cli.py and commands/ (the top layer)
"""
from .laws import MujocoVersionMismatch, check_mujoco_version, load
from .params import (LAWS, FrictionParameters, ParameterError, RigParameters, default_friction)

__version__ = "0.1.0"

__all__ = ["load", "check_mujoco_version", "MujocoVersionMismatch", "LAWS", "FrictionParameters",
           "RigParameters", "ParameterError", "default_friction", "__version__"]
