"""Robots with vibration-assisted friction, resolved or at the robot's timestep.

* ``scenes``: the robot scenes of mjcf_models/robots/ (plate push, vibratory feeder): build, run,
  render;
* ``robot_arm``: a real arm (dm_control's Kinova Jaco) in a cell with a feeder and a plate;
* ``averaged``: the averaged element's tables (the planar law averaged over the vibration);
* ``feeder_map``: the feeder element's map, made from the exact feeder reference;
* ``bowl``: bowl feeders, parts climbing a helical track (contact_feeder with helix_pitch);
* ``shaker``: :func:`vibrate`, which makes a body of any ``MjSpec`` vibrate along an axis.

(Only ``vibrate`` is imported here; the rest: ``from vibrofriction.robots import scenes``.)
"""
from .shaker import VibratedBody, vibrate

__all__ = ["VibratedBody", "vibrate"]
