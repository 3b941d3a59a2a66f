"""The MuJoCo plumbing that the rigs, the robot scenes and identification share.

Below ``rigs``, ``robots`` and ``identify``, above the laws' binding: nothing here knows the
paper's rig or a friction law.

* ``models``: where the installed MJCF models are (``MJCF_DIR``) and a plugin instance's
  config set in an MjSpec (``set_plugin_config``);
* ``recording``: a model's state as ``mujoco.rollout`` starts from it (``full_state``,
  ``initial_state``) and its sensors' columns in sensordata (``sensor_slices``,
  ``sensor_columns``);
* ``threads``: how many CPUs this process may use (``cpu_count``), the default of every pool.
"""
from .models import MJCF_DIR, set_plugin_config
from .recording import full_state, initial_state, sensor_columns, sensor_slices
from .threads import cpu_count

__all__ = ["MJCF_DIR", "set_plugin_config", "full_state", "initial_state",
           "sensor_columns", "sensor_slices", "cpu_count"]
