"""The rigs in MuJoCo, run on the native friction elements.

* ``rig``: the paper's rig (mjcf_models/rig/): built from parameters, run, summarized;
* ``planar``: the planar element from Python and the rig in the plane;
* ``steady``: runs until the mean drive force settles; ``sweep``: the master curve;
* ``python_law``: the rig with the native element replaced by a law written in Python.

(Nothing is imported here: ``import vibrofriction.rigs.rig`` loads only what it needs.)
"""
