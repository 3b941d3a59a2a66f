"""Stability of every law from dt = 1e-6 s to 1e-4 s, and the "z updated with the new velocity"
trap of docs/physics.md: a slider stuck on a vibrating table must not gain energy.

MuJoCo integrates act with the step's old velocity, which pumps energy into the stuck contact
oscillation; the plugin redoes the z update in `advance` with the new velocity (closed form).
The Python-callback path with MuJoCo's default ordering (actearly="false") shows the trap.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import PAPER_FRICTION_BOUND_N

from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import LAWS, RigParameters, default_friction
from vibrofriction.rigs.python_law import simulate_python_law


@pytest.mark.parametrize("timestep_s", [1e-6, 1e-5, 1e-4])
@pytest.mark.parametrize("law", LAWS)
def test_every_law_is_stable(law, timestep_s):
    """Paper rig at v_a = 3 and 20 mm/s: finite, bounded forces, a sensible mean. At 1e-4 s
    the 4 kHz vibration has only 2.5 steps a period and is aliased (the mean drive force comes
    out near -2.2 N: the sampled table ratchets the slider forward), so only boundedness is
    asked there."""
    rig = RigParameters()
    friction = default_friction(law, rig)
    cases = [(replace(rig, vibration_velocity_amplitude_m_per_s=va), friction)
             for va in (3e-3, 20e-3)]
    duration, _ = rig_module.default_times(*cases[0])
    for run in rig_module.simulate_many(cases, timestep_s=timestep_s, duration_s=duration):
        for name, series in run.columns().items():
            assert np.all(np.isfinite(series)), name
        assert np.all(np.isfinite(run.deflection_m))
        bound = PAPER_FRICTION_BOUND_N
        assert np.max(np.abs(run.drive_force_N)) < 1.5 * bound
        # |zdot| <= 2 |v_r|: LuGre's sigma1 zdot may exceed mu F_N; nothing may run away
        speed = np.max(np.abs(run.relative_velocity_m_per_s))
        assert np.max(np.abs(run.friction_force_N)) < \
            1.01 * bound + 2 * friction.bristle_damping_N_s_per_m * speed
        if law != "coulomb":
            z_bound = bound / friction.contact_stiffness_N_per_m
            assert np.max(np.abs(run.deflection_m)) <= z_bound * (1 + 1e-9)
        mean = run.summary().mean_drive_force_N
        assert abs(mean) < bound
        if timestep_s < 1e-4:  # the reduction is there at kappa >= 6
            assert 0 < mean < 0.3 * bound


def _stuck_rig() -> RigParameters:
    """v_a = 20 um/s: k_t u0 = 0.06 N << mu F_N = 11 N, the slider rides along elastically;
    the drive end hardly moves (1 nm/s), so the contact only oscillates. The table drives the
    contact above its 2 kHz resonance: a bounded forced response, unless energy is pumped in."""
    return RigParameters(vibration_velocity_amplitude_m_per_s=20e-6,
                         drive_velocity_m_per_s=1e-9)


def _contact_energy(run, stiffness_N_per_m: float) -> np.ndarray:
    """Kinetic energy relative to the table + contact spring energy (J)."""
    return (0.5 * run.rig.mass_kg * run.relative_velocity_m_per_s ** 2
            + 0.5 * stiffness_N_per_m * run.deflection_m ** 2)


def _quarter_maxima(energy: np.ndarray) -> list[float]:
    n = energy.size
    return [float(energy[k * n // 4:(k + 1) * n // 4].max()) for k in range(4)]


@pytest.mark.parametrize("timestep_s", [1e-6, 1e-5, 1e-4])
@pytest.mark.parametrize("law", ["dahl", "dupont", "lugre"])
def test_stuck_slider_on_vibrating_table_gains_no_energy(law, timestep_s):
    """Measured: Dahl and LuGre decay (hysteresis, sigma1), Dupont (purely elastic below
    breakaway) keeps its energy to 0.3 %."""
    rig = _stuck_rig()
    friction = default_friction(law, rig)
    run = rig_module.simulate(rig, friction, duration_s=0.05, timestep_s=timestep_s,
                              settle_time_s=0.01)
    energy = _contact_energy(run, friction.contact_stiffness_N_per_m)
    first, *_, last = _quarter_maxima(energy)
    assert last <= 1.003 * first
    u0 = rig.vibration_amplitude_m
    assert np.max(np.abs(run.deflection_m)) < 3 * u0  # forced response ~1.3 u0 + transient


@pytest.mark.parametrize("timestep_s", [1e-6, 1e-5, 1e-4])
def test_stuck_coulomb_slider_rides_with_the_table(timestep_s):
    run = rig_module.simulate(_stuck_rig(), default_friction("coulomb"), duration_s=0.02,
                              timestep_s=timestep_s, settle_time_s=0.01)
    rig = run.rig
    assert np.max(np.abs(run.relative_velocity_m_per_s[1:])) < 1e-12
    # the friction force only accelerates the slider with the table: m v_a w at most (after
    # the first step, which brings the slider from rest to the table's velocity v_a)
    table_force_N = rig.mass_kg * rig.vibration_velocity_amplitude_m_per_s * 2 * np.pi * 4000
    assert np.max(np.abs(run.friction_force_N[1:])) < 1.01 * table_force_N


def test_the_old_velocity_update_pumps_energy():
    """The trap itself, with the Python-callback path: MuJoCo's default order (force from z_n,
    z_{n+1} = z_n + dt zdot(z_n, v_n)) gains energy, 280-fold in 50 ms at dt = 1e-5 s; with
    actearly (a symplectic pair, as in the plugin) it decays like the plugin's."""
    rig = _stuck_rig()
    friction = default_friction("dahl", rig)
    energies = {}
    for act_early in (False, True):
        run = simulate_python_law(rig, friction, duration_s=0.05, timestep_s=1e-5,
                                  settle_time_s=0.01, act_early=act_early)
        energies[act_early] = _quarter_maxima(
            _contact_energy(run, friction.contact_stiffness_N_per_m))
    native = rig_module.simulate(rig, friction, duration_s=0.05, timestep_s=1e-5,
                                 settle_time_s=0.01)
    native_energy = _quarter_maxima(_contact_energy(native, friction.contact_stiffness_N_per_m))
    assert energies[False][-1] > 50 * native_energy[-1]
    assert energies[True][-1] <= energies[True][0]
    assert energies[True][-1] == pytest.approx(native_energy[-1], rel=0.02)
