"""vibrofriction: dynamic friction with vibrating supports as MuJoCo engine plugins.

Where things live:
  friction laws ........ plugin/cpp/friction_law.cc (one implementation; Python calls it via laws.py)
  MuJoCo plugins ....... plugin/cpp/friction_element.cc, support_motion.cc
  the paper's rig ...... mjcf_models/rig/ and vibrofriction/rig.py
  scipy oracle ......... vibrofriction/reference.py, analytic limits in analytic.py
  identification ....... vibrofriction/identify/ (machines in closed loop: machine_replay.py,
                         mjcf_models/emps/)
"""
from .laws._native import MujocoVersionMismatch, check_mujoco_version, load
from .params import (LAWS, FrictionParameters, ParameterError, RigParameters, default_friction)

__version__ = "0.1.0"

__all__ = ["load", "check_mujoco_version", "MujocoVersionMismatch", "LAWS", "FrictionParameters",
           "RigParameters", "ParameterError", "default_friction", "__version__"]
