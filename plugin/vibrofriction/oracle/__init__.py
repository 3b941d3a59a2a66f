"""The independent oracle: what the native laws are checked against, written without them.

* ``reference``: the rig as ODEs integrated by scipy, with the laws written again in Python;
* ``analytic``: closed-form limits (rigid Coulomb, kinematic averages);
* ``feeder_reference``: the exact event-driven motion of a part on a vibratory feeder.

None of these imports the native laws (``vibrofriction.laws``) or a MuJoCo model of them, not
even through another module: tests/test_layout.py checks it.
"""
