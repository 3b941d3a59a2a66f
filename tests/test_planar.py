"""The planar friction element vibrofriction.planar: exactly the 1D element when the motion
stays on one axis, the kinematic-limit laws of rigid Coulomb friction under longitudinal
(arcsin) and transverse (complete elliptic integral) vibration with a heavy body, isotropy,
and strict config validation."""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from vibrofriction.rigs import planar, rig as rig_module
from vibrofriction.params import FrictionParameters, ParameterError, RigParameters, default_friction

LAWS = ("coulomb", "dahl", "dupont", "lugre", "gms")


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("va", [0.0, 5e-3])
def test_planar_rig_along_x_is_the_1d_rig(law, va):
    """Same rig, same law, motion along x: the 1D element and the planar element agree to 1e-9
    (in fact bit for bit except Dupont's plastic Newton, a few ulp)."""
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=va)
    friction = default_friction(law, rig)
    one = rig_module.simulate(rig, friction, duration_s=0.06)
    two = planar.simulate_rig(rig, friction, duration_s=0.06)
    for a, b in ((one.drive_force_N, two.drive_force_N[:, 0]),
                 (one.friction_force_N, two.friction_force_N[:, 0]),
                 (one.deflection_m, two.deflection_m[:, 0])):
        scale = max(np.max(np.abs(a)), 1e-300)
        assert np.max(np.abs(a - b)) <= 1e-9 * scale
    assert np.all(two.slider_position_m[:, 1] == 0) and np.all(two.deflection_m[:, 1] == 0)


def _heavy(xi: float, law: str, va: float = 2e-2) -> tuple[RigParameters, FrictionParameters]:
    # Heavy body: m = 50 kg, so its velocity ripple mu F_N / (m omega) = 9e-6 m/s << V; drive
    # critically damped (h_d = 2 sqrt(k_d m)) to settle in 50 ms. f = 3.9 kHz (paper): 25.6
    # steps a period, so the sampling phase drifts and the sign changes average out.
    mass = 50.0
    rig = RigParameters(mass_kg=mass, drive_damping_N_s_per_m=2 * math.sqrt(1e6 * mass),
                        vibration_frequency_Hz=3900.0, vibration_velocity_amplitude_m_per_s=va,
                        drive_velocity_m_per_s=xi * va)
    return rig, default_friction(law, rig)


XIS = (0.1, 0.3, 0.7)


@pytest.fixture(scope="module")
def heavy_coulomb_runs():
    cases = []
    for xi in XIS:
        for drive_angle in (0.0, math.pi / 2):
            rig, friction = _heavy(xi, "coulomb")
            cases.append((rig, friction, 0.0, drive_angle))
    runs = planar.simulate_rigs(cases, duration_s=0.12, settle_time_s=0.07)
    return {(xi, angle): run for (xi, angle), run in
            zip([(x, a) for x in XIS for a in (0.0, math.pi / 2)], runs)}


@pytest.mark.parametrize("xi", XIS)
def test_transverse_vibration_follows_the_elliptic_law(heavy_coulomb_runs, xi):
    """Drive across the vibration: F/(mu F_N) = (2/pi) xi/sqrt(1+xi^2) K(1/(1+xi^2))."""
    run = heavy_coulomb_runs[(xi, math.pi / 2)]
    bound = run.friction.friction_coefficient * run.rig.normal_force_N
    ratio = run.mean_drive_force_N() / bound
    expected = float(planar.transverse_coulomb_ratio(xi))
    assert ratio[1] == pytest.approx(expected, rel=0.01)
    assert abs(ratio[0]) < 1e-3  # no mean force along the vibration


@pytest.mark.parametrize("xi", XIS)
def test_longitudinal_vibration_follows_the_arcsin_law(heavy_coulomb_runs, xi):
    """Drive along the vibration: F/(mu F_N) = (2/pi) arcsin(xi) (Storck et al. 2002)."""
    run = heavy_coulomb_runs[(xi, 0.0)]
    bound = run.friction.friction_coefficient * run.rig.normal_force_N
    ratio = run.mean_drive_force_N() / bound
    assert ratio[0] == pytest.approx(float(planar.longitudinal_coulomb_ratio(xi)), rel=0.02)
    assert ratio[1] == 0


def test_transverse_reduction_is_weaker_than_longitudinal():
    xi = np.array([0.05, 0.2, 0.5, 0.9])
    assert np.all(planar.transverse_coulomb_ratio(xi) > planar.longitudinal_coulomb_ratio(xi))
    # Large xi: both tend to 1; the transverse law as 1 - 1/(4 xi^2).
    assert planar.transverse_coulomb_ratio(50.0) == pytest.approx(1 - 1 / (4 * 50.0**2), abs=1e-6)
    assert planar.transverse_coulomb_ratio(0.0) == 0.0


def _kinematic_ratio(friction, xi, drive_angle, va=2e-2, f=3900.0, normal=55.2):
    n_per, periods = 400, 60
    t = np.arange(n_per * periods + 1) / (f * n_per)
    v = np.stack([xi * va * math.cos(drive_angle) - va * np.cos(2 * math.pi * f * t),
                  np.full_like(t, xi * va * math.sin(drive_angle))], axis=1)
    run = planar.run_planar_law(friction, t, v, normal_force_N=normal)
    half = t.size // 2
    mean = np.trapezoid(run.force_N[half:], t[half:], axis=0) / (t[-1] - t[half])
    return mean / (friction.friction_coefficient * normal)


@pytest.mark.parametrize("law", ("dahl", "dupont"))
def test_heavy_body_reproduces_the_kinematic_planar_law(law):
    """Elastic laws (eps = k_t u0 / (mu F_N) = 5.9 here): the dynamic heavy-body mean equals the
    law driven kinematically along v_r = V - u'(t), across and along the vibration."""
    cases = [(*_heavy(0.3, law), 0.0, angle) for angle in (0.0, math.pi / 2)]
    runs = planar.simulate_rigs(cases, duration_s=0.12, settle_time_s=0.07)
    for run, (_, friction, _, angle) in zip(runs, cases):
        bound = friction.friction_coefficient * run.rig.normal_force_N
        got = run.mean_drive_force_N() / bound
        want = _kinematic_ratio(friction, 0.3, angle)
        component = 0 if angle == 0 else 1
        assert got[component] == pytest.approx(want[component], rel=0.03)


def test_the_element_is_isotropic():
    """Rotating vibration and drive by 30 degrees rotates the mean force, nothing else."""
    rig, friction = _heavy(0.3, "dahl")
    cases = [(rig, friction, 0.0, math.pi / 2),
             (rig, friction, math.radians(30), math.radians(120))]
    a, b = planar.simulate_rigs(cases, duration_s=0.1, settle_time_s=0.05)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    fa = a.mean_drive_force_N()
    fb = b.mean_drive_force_N()
    rotated = np.array([c * fa[0] - s * fa[1], s * fa[0] + c * fa[1]])
    assert np.allclose(fb, rotated, rtol=0, atol=2e-3 * np.linalg.norm(fa))


@pytest.mark.parametrize("law", ("dahl", "dupont", "lugre"))
def test_force_stays_within_the_friction_bound_under_rotating_motion(law):
    """Circular relative motion (a worst case for a vector state): |F| <= F_s, and Dahl/LuGre
    settle at |F| -> mu F_N with the force opposing the motion."""
    friction = FrictionParameters(law=law, friction_coefficient=0.3, contact_stiffness_N_per_m=1e6)
    normal = 2.0
    omega, speed = 2 * math.pi * 50.0, 0.05
    t = np.linspace(0.0, 0.1, 20001)
    v = speed * np.stack([np.cos(omega * t), np.sin(omega * t)], axis=1)
    run = planar.run_planar_law(friction, t, v, normal_force_N=normal)
    magnitude = np.linalg.norm(run.force_N, axis=1)
    assert np.all(magnitude <= 0.3 * normal * (1 + 1e-9))
    if law != "dupont":
        assert magnitude[-1] == pytest.approx(0.3 * normal, rel=2e-3)
    cosine = np.sum(run.force_N[-1] * v[-1]) / (magnitude[-1] * speed)
    assert cosine > 0.99


@pytest.mark.parametrize("travel_over_z_max", (10.0, 1e3, 1e4, 1e5))
def test_dupont_turn_with_long_steps_ends_along_the_new_motion(travel_over_z_max):
    """Deflected along x, the contact slides along y for one step of many z_max (a robot
    timestep after a sharp turn): the plastic substeps must not throw the deflection across the
    motion (a trapezoid with substeps over 2 z_max flips it; backward Euler damps it)."""
    friction = FrictionParameters(law="dupont", friction_coefficient=0.3,
                                  contact_stiffness_N_per_m=1e6)
    normal = 2.0
    z_max = 0.3 * normal / 1e6
    speed = 0.01
    dt = travel_over_z_max * z_max / speed
    run = planar.run_planar_law(friction, np.array([0.0, dt]),
                                np.array([[0.0, speed], [0.0, speed]]), normal_force_N=normal,
                                initial_deflection_m=(0.85 * z_max, 0.0))
    z_along_x, z_along_y = run.deflection_m[1]
    assert abs(z_along_x) <= 0.85 * z_max  # never grows across the motion
    assert math.hypot(z_along_x, z_along_y) <= z_max * (1 + 1e-12)
    if travel_over_z_max >= 1e3:  # long past the transition: relaxed onto the new motion
        assert abs(z_along_x) < 1e-6 * z_max
        assert z_along_y == pytest.approx(z_max, rel=1e-6)


def test_one_axis_kinematic_law_matches_the_1d_law():
    from vibrofriction import laws
    for law in LAWS[:4]:  # (gms has no planar C API: tests/test_gms.py checks it in MuJoCo)
        friction = FrictionParameters(law=law, friction_coefficient=0.3,
                                      contact_stiffness_N_per_m=1e6, static_ratio=1.3,
                                      stribeck_velocity_m_per_s=2e-3,
                                      bristle_damping_N_s_per_m=20.0 if law != "dahl" else 0.0)
        t = np.linspace(0, 0.02, 4001)
        v1 = 0.01 * np.sin(2 * math.pi * 300 * t) + 2e-3
        one = laws.run_law(friction, t, v1, normal_force_N=2.0)
        two = planar.run_planar_law(friction, t, np.stack([v1, 0 * v1], axis=1),
                                    normal_force_N=2.0)
        assert np.allclose(two.force_N[:, 0], one.friction_force_N, rtol=0, atol=1e-9)
        assert np.all(two.force_N[:, 1] == 0)


# ---- Config validation ---------------------------------------------------------------------------

def _spec() -> mujoco.MjSpec:
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    return planar.build_rig_spec(rig, default_friction("dahl", rig))


def _configure(spec: mujoco.MjSpec, changes: dict) -> None:
    for plugin in spec.plugins:
        if plugin.name == "friction":
            config = dict(plugin.config)
            for key, value in changes.items():
                if value is None:
                    config.pop(key, None)
                else:
                    config[key] = value
            plugin.config = config


def _error(spec: mujoco.MjSpec) -> str:
    with pytest.raises(ValueError) as info:
        spec.compile()
    return str(info.value)


PLANAR_CASES = [
    ({"law": None}, "law", 'add <config key="law"'),
    ({"law": "Dahl"}, "law", "coulomb, dahl, dupont, lugre"),
    ({"mu": "-1"}, "mu", ">= 0"),
    ({"mu": "0.2 0.3"}, "mu", "plain number"),
    ({"normal": "-1"}, "normal", ">= 0"),
    ({"stiffness": "0"}, "stiffness", "> 0"),
    ({"breakaway": "1"}, "breakaway", "(0, 1)"),
    ({"static_ratio": "0.5"}, "static_ratio", ">= 1"),
    ({"normal_modulation": "1"}, "normal_modulation", "[0, 1)"),
    ({"normal_sensor": "nope"}, "normal_sensor", "names no sensor"),
    ({"contact_geom1": "slider"}, "contact_geom1", "name both geoms"),
    ({"contact_geom1": "slider", "contact_geom2": "nope"}, "contact_geom2", "names no geom"),
    ({"contact_geom1": "slider", "contact_geom2": "slider"}, "contact_geom1", "same geom"),
    ({"contact_geom1": "slider", "contact_geom2": "table", "normal_sensor": "drive_force_x"},
     "normal_sensor", "one source"),
]


@pytest.mark.parametrize("changes, attribute, fix", PLANAR_CASES,
                         ids=[f"{c[1]}-{i}" for i, c in enumerate(PLANAR_CASES)])
def test_invalid_planar_attribute_is_named(changes, attribute, fix):
    spec = _spec()
    _configure(spec, changes)
    message = _error(spec)
    assert "vibrofriction.planar" in message and f"'{attribute}'" in message and fix in message


def test_planar_needs_two_actuators_with_state():
    spec = _spec()
    spec.delete(spec.actuator("friction_y"))
    assert "exactly two" in _error(spec)
    spec = _spec()
    spec.actuator("friction_y").actdim = 0
    assert 'actdim="1"' in _error(spec)


def test_planar_rejects_non_orthogonal_joints():
    spec = _spec()
    spec.joint("slider_y").axis = [1.0, 1.0, 0.0]
    assert "not orthogonal" in _error(spec)


def test_planar_rejects_1d_only_effects():
    with pytest.raises(ParameterError, match="asymmetry"):
        planar.planar_config(FrictionParameters(asymmetry=0.1))


def test_the_rig_scenes_load_and_step_without_warnings():
    for path in (planar.PLANAR_RIG_PATH, planar.AVERAGED_RIG_PATH):
        model = mujoco.MjModel.from_xml_path(str(path))
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data, 200 if model.opt.timestep < 1e-4 else 50)
        assert all(w.number == 0 for w in data.warning), path.name
        assert np.all(np.isfinite(data.qvel))
