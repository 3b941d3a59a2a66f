"""Closed-form anchors for vibration-reduced friction and the friction laws (docs/physics.md).

The kinematic ratios f = F_mean / (mu F_N) assume a heavy body moving exactly at the drive
velocity v_d over a support vibrating at velocity amplitude v_a (xi = v_d / v_a). A slider of
finite mass (the paper's 0.5 kg on a 2 kHz contact) departs from them; a heavy body (r^2 = m
w^2 / k_t >~ 20) reproduces them within a few per cent. Every function accepts scalars or numpy
arrays and returns a float for scalar input.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipk

from ..params import FrictionParameters, RigParameters


def _out(value: np.ndarray):
    return float(value) if np.ndim(value) == 0 else value


# --------------------------------------------------------------------------------------------
# Dimensionless groups


def xi(rig: RigParameters) -> float:
    """xi = v_d / v_a = 1/kappa_v (inf without vibration)."""
    va = rig.vibration_velocity_amplitude_m_per_s
    return abs(rig.drive_velocity_m_per_s) / va if va > 0 else math.inf


def epsilon(rig: RigParameters, friction: FrictionParameters) -> float:
    """epsilon = k_t u0 / (mu F_N): vibration amplitude over the elastic pre-slip length."""
    bound_N = friction.friction_coefficient * rig.normal_force_N
    if bound_N <= 0:
        return math.inf
    return friction.contact_stiffness_N_per_m * rig.vibration_amplitude_m / bound_N


def r_squared(rig: RigParameters, friction: FrictionParameters) -> float:
    """r^2 = m w^2 / k_t: (vibration over contact-resonance frequency)^2; large = heavy body."""
    w = 2 * math.pi * rig.vibration_frequency_Hz
    return rig.mass_kg * w * w / friction.contact_stiffness_N_per_m


# --------------------------------------------------------------------------------------------
# Kinematic mean-force ratios f = F_mean / (mu F_N)


def coulomb_kinematic_ratio(xi):
    """Rigid Coulomb, longitudinal vibration: f = (2/pi) arcsin(xi) for xi < 1, else 1.

    Littmann, Storck & Wallaschek, Arch. Appl. Mech. 71 (2001) 549-554; Storck et al.,
    Wear 253 (2002). A 20-fold reduction needs v_a >= 12.7 v_d.
    """
    x = np.asarray(xi, dtype=float)
    return _out(2 / np.pi * np.arcsin(np.clip(x, 0.0, 1.0)))


def transverse_kinematic_ratio(xi):
    """Rigid Coulomb, vibration in-plane perpendicular to sliding:
    f = (2/pi) xi/sqrt(1+xi^2) K(1/(1+xi^2)), K the complete elliptic integral with parameter m
    (scipy.special.ellipk convention). f -> 1 as xi -> inf and -> 0 (like xi ln(1/xi)) as xi -> 0.

    Mean of the x-component of mu F_N v_r/|v_r| with v_r = (v_d, v_a cos wt); Littmann,
    Storck & Wallaschek (2001); Teidelt, Starcevic & Popov, Tribol. Lett. 48 (2012) 51-62.
    """
    x = np.asarray(xi, dtype=float)
    m = 1 / (1 + x * x)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = 2 / np.pi * x * np.sqrt(m) * ellipk(m)
    f = np.where(x <= 0, 0.0, np.where(np.isinf(x), 1.0, f))
    return _out(f)


def jenkins_kinematic_ratio(epsilon):
    """Ideal elastic-plastic contact spring (Jenkins element), xi -> 0: f = max(0, 1 - epsilon).

    The static friction falls linearly with the vibration amplitude: Teidelt, Starcevic &
    Popov, Tribol. Lett. 48 (2012) 51-62 (Dahl alpha = 0; Dupont with z_ba -> z_max).
    """
    e = np.asarray(epsilon, dtype=float)
    return _out(np.maximum(0.0, 1 - e))


def dahl_vanishing_amplitude_ratio(xi, alpha: float = 1.0):
    """Dahl law in the limit epsilon -> 0: f = tanh(ln(P/N) / (2 alpha)) for xi < 1, else 1.

    N = 2(sqrt(1-xi^2) - xi arccos xi) and P = N + 2 pi xi are the relative sliding paths per
    period (times 1/u0) against and along the drive. With the force nearly constant over a
    period, no net drift of z requires P (1-f)^alpha = N (1+f)^alpha. The reduction does not
    vanish with the amplitude (Dahl/LuGre drift); alpha = 0 gives the Jenkins limit 1 (xi > 0).
    Dahl, J. Spacecraft 5 (1968); docs/physics.md.
    """
    if not alpha >= 0:
        raise ValueError(f"alpha={alpha!r} must be >= 0")
    x = np.clip(np.asarray(xi, dtype=float), 0.0, 1.0)
    n = 2 * (np.sqrt(1 - x * x) - x * np.arccos(x))
    p = n + 2 * np.pi * x
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.tanh(np.log(p / n) / (2 * alpha)) if alpha > 0 else np.where(x > 0, 1.0, 0.0)
    return _out(np.where(x >= 1, 1.0, f))


def dupont_vanishing_amplitude_ratio(breakaway_ratio):
    """Dupont elasto-plastic law, epsilon -> 0 and xi -> 0: f -> b = z_ba / z_ss.

    The force ratchets down only to the breakaway level: below it the contact is purely
    elastic and does not drift (Dupont, Hayward, Armstrong & Altpeter, IEEE TAC 47(5) 2002).
    """
    return _out(np.asarray(breakaway_ratio, dtype=float))


# --------------------------------------------------------------------------------------------
# Single-law curves


def dahl_virgin_loading(x, contact_stiffness: float, coulomb_force: float, alpha: float = 1.0):
    """Dahl force (N) after sliding a distance x (m) from the virgin state z = 0.

    dF/dx = sigma (1 - F/F_c)^alpha gives, with s = sigma |x| / F_c,
    F/F_c = 1 - exp(-s) for alpha = 1 and 1 - (1 + (alpha-1) s)^(-1/(alpha-1)) otherwise.
    For alpha < 1 the base reaches 0 at s = 1/(1-alpha): F = F_c is reached in finite distance
    and held (alpha = 0: linear elastic up to F_c). Odd in x. Dahl (1968); Bliman (1992).
    """
    x = np.asarray(x, dtype=float)
    s = contact_stiffness * np.abs(x) / coulomb_force
    if alpha == 1:
        ratio = -np.expm1(-s)
    else:  # clip: for alpha < 1 the base turns negative once F = F_c is reached
        ratio = 1 - np.maximum(1 + (alpha - 1) * s, 0.0) ** (1 / (1 - alpha))
    return _out(np.sign(x) * coulomb_force * np.clip(ratio, 0.0, 1.0))


def lugre_steady_state_force(v, sigma0: float, sigma2: float, Fc: float, Fs: float, vs: float):
    """LuGre steady-state force (N): sgn(v) g(v) + sigma2 v, g = F_c + (F_s-F_c) exp(-(v/v_s)^2).

    Independent of sigma0 (kept so every LuGre helper takes the same parameters). Canudas de
    Wit, Olsson, Astrom & Lischinsky, IEEE TAC 40(3) 1995: with their standard set 1.4951 N at
    0.1 mm/s, 1.1843 N at 1 mm/s, 1.0100 N at 2 mm/s.
    """
    v = np.asarray(v, dtype=float)
    g = Fc + (Fs - Fc) * np.exp(-((v / vs) ** 2))
    return _out(np.sign(v) * g + sigma2 * v)


def lugre_presliding_distance(fraction: float, sigma0: float, Fs: float) -> float:
    """Quasi-static LuGre presliding distance (m) from z = 0 to F = fraction * F_s.

    At v << v_s, dz/dx = 1 - sigma0 z / F_s, so x = (F_s/sigma0) ln(1/(1 - fraction)):
    44.9 um to 0.95 F_s with the standard set (Canudas de Wit et al. 1995).
    """
    if not 0 <= fraction < 1:
        raise ValueError(f"fraction={fraction!r} must lie in [0, 1)")
    return Fs / sigma0 * math.log(1 / (1 - fraction))


__all__ = [
    "xi", "epsilon", "r_squared", "coulomb_kinematic_ratio", "transverse_kinematic_ratio",
    "jenkins_kinematic_ratio", "dahl_vanishing_amplitude_ratio",
    "dupont_vanishing_amplitude_ratio", "dahl_virgin_loading", "lugre_steady_state_force",
    "lugre_presliding_distance",
]
