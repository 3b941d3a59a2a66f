"""The rigs in MuJoCo, run on the native friction elements.

* ``rig``: the paper's rig (mjcf_models/rig/): run and summarized; ``rig_model``: the model
  it runs (built from parameters, the timestep rule, its sensors read as a ``RigRun``; ``rig``
  exports its names);
* ``planar``: the planar element from Python and the rig in the plane;
* ``steady``: runs until the mean drive force settles; ``periodic``: the periodic steady
  state by shooting (the orbit solved for, not waited for); ``sweep``: the master curve;
* ``python_law``: the rig with the native element replaced by a law written in Python.

(Nothing is imported here: ``import vibrofriction.rigs.rig`` loads only what it needs.)
"""
