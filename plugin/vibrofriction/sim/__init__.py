"""The MuJoCo plumbing that the rigs, the robot scenes and identification share.

Below ``rigs``, ``robots`` and ``identify``, above the laws' binding: nothing here knows the
paper's rig or a friction law.

* ``models``: where the installed MJCF models are (``MJCF_DIR``), and the plugins' configs
  through MjSpec, their keys checked against the one table: ``add_plugin_instance``,
  ``add_plugin_actuator``, ``set_plugin_config``; ``instance_xml`` for the text a user pastes;
* ``recording``: a model's state as ``mujoco.rollout`` starts from it (``full_state``,
  ``initial_state``) and its sensors' columns in sensordata (``sensor_slices``,
  ``sensor_columns``);
* ``threads``: how many CPUs this process may use (``cpu_count``), the default of every pool.
"""
from .models import (MJCF_DIR, add_plugin_actuator, add_plugin_instance, instance_xml,
                     plugin_config, set_plugin_config)
from .recording import full_state, initial_state, sensor_columns, sensor_slices
from .threads import cpu_count

__all__ = ["MJCF_DIR", "add_plugin_actuator", "add_plugin_instance", "instance_xml",
           "plugin_config", "set_plugin_config", "full_state", "initial_state",
           "sensor_columns", "sensor_slices", "cpu_count"]
