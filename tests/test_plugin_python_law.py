"""The Python-callback path (vibrofriction.rigs.python_law): the rig with the native friction element
replaced by a general actuator with dyntype="user" whose zdot comes from a Python function via
MuJoCo's mjcb_act_dyn. It must match the native plugin and always remove its callback.

Measured (mean drive force, Python Dahl vs native Dahl, dt = 1e-6 s): +0.06 % at v_a 0.75 mm/s,
-0.03 % at 3 mm/s.
"""
from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import ParameterError, RigParameters, default_friction
from vibrofriction.rigs.python_law import (ContactParameters, act_dyn_callback, bare_rig_spec,
                                           dahl_zdot, python_law_spec, simulate_python_law)


@pytest.mark.parametrize("va", [0.75e-3, 3e-3])
def test_python_dahl_matches_native_plugin(va):
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=va)
    friction = default_friction("dahl", rig)
    duration, _ = rig_module.default_times(rig, friction)  # the same fixed run for both
    python = simulate_python_law(rig, friction, dahl_zdot, timestep_s=1e-6, duration_s=duration)
    native = rig_module.simulate(rig, friction, timestep_s=1e-6, duration_s=duration)
    assert python.summary().mean_drive_force_N == pytest.approx(
        native.summary().mean_drive_force_N, rel=0.01)
    assert python.summary().sign_change is native.summary().sign_change
    # through breakaway the traces coincide (before the subharmonic of 0.75 mm/s sets in)
    early = python.time_s < 0.02
    assert np.max(np.abs(python.friction_force_N[early] - native.friction_force_N[early])) \
        < 0.01 * 11.04
    # the run's z is the one in its force: F_F = k_t z
    np.testing.assert_allclose(python.deflection_m * friction.contact_stiffness_N_per_m,
                               python.friction_force_N, rtol=1e-12, atol=1e-12)


def test_dahl_zdot_is_dahls_law():
    params = ContactParameters(friction=default_friction("dahl"), normal_force_N=55.2)
    zc = params.coulomb_level_N / params.contact_stiffness_N_per_m
    assert dahl_zdot(0.0, 1e-3, params) == 1e-3
    assert dahl_zdot(zc, 1e-3, params) == 0.0
    assert dahl_zdot(zc / 2, -1e-3, params) == pytest.approx(-1.5e-3)
    assert dahl_zdot(zc / 2, 0.0, params) == 0.0
    half = ContactParameters(replace(params.friction, alpha=0.5), 55.2)
    assert dahl_zdot(0.75 * zc, 2e-3, half) == pytest.approx(1e-3)
    assert dahl_zdot(1.2 * zc, 1e-3, half) < 0  # |F| > F_c relaxes back, no NaN
    assert math.isfinite(dahl_zdot(1.2 * zc, 1e-3, half))


def test_callback_is_removed_after_the_block_and_after_an_error():
    def law(z, v_r, params):
        raise RuntimeError("law failed")

    params = ContactParameters(default_friction("dahl"), 55.2)
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    model = python_law_spec(rig, default_friction("dahl"), timestep_s=1e-5).compile()
    data = mujoco.MjData(model)
    with pytest.raises(RuntimeError, match="law failed"):
        with act_dyn_callback(law, params):
            assert mujoco.get_mjcb_act_dyn() is not None
            mujoco.mj_step(model, data)
    assert mujoco.get_mjcb_act_dyn() is None
    with act_dyn_callback(dahl_zdot, params):
        mujoco.mj_step(model, data)
    assert mujoco.get_mjcb_act_dyn() is None


def test_a_custom_law_runs_in_the_rig():
    """A purely elastic contact (zdot = v_r, never slips): the drive spring and the contact
    spring load in series, so the force passes mu F_N without limit."""
    def elastic(z, v_r, params):
        return v_r

    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    run = simulate_python_law(rig, default_friction("dahl"), elastic, duration_s=0.02,
                              timestep_s=1e-5, settle_time_s=0.01)
    assert np.all(np.isfinite(run.friction_force_N))
    assert np.max(np.abs(run.friction_force_N)) > 11.04  # no Coulomb limit in this law
    for act_early in (True, False):  # both orders report the z of the force
        run = simulate_python_law(rig, default_friction("dahl"), elastic, duration_s=0.005,
                                  timestep_s=1e-5, settle_time_s=0.001, act_early=act_early)
        np.testing.assert_allclose(run.deflection_m * 8e7, run.friction_force_N, rtol=1e-12,
                                   atol=1e-12)


def test_spec_replaces_the_element():
    rig = RigParameters()
    spec = python_law_spec(rig, default_friction("dahl"), timestep_s=1e-5)
    model = spec.compile()
    actuator = model.actuator("friction")
    assert actuator.dyntype[0] == mujoco.mjtDyn.mjDYN_USER
    assert model.actuator_actnum[actuator.id] == 1 and model.actuator_actearly[actuator.id]
    assert actuator.gainprm[0] == -8e7
    assert model.nplugin == 3  # the two motions and the dynamometer sensor, no friction
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, "friction") == -1
    bare = bare_rig_spec(rig).compile()
    assert bare.na == 0 and bare.nu == 3


def test_unsupported_parameters_are_refused():
    rig = RigParameters()
    with pytest.raises(ParameterError, match="bristle_damping"):
        python_law_spec(rig, default_friction("lugre", rig))
