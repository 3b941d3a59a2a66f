"""Where a record starts: at rest, or in motion with the contact already sliding.

A record cut from a longer run (a held-out part, another lab's push) can start in motion. A
state law started there at z = 0 loads its bristles over the first deflection lengths of
travel, and its damping turns that loading into a force spike of sigma1 v (measured: a LuGre
fit on a push record cut at 0.64 m/s, a one-sample force of 1.9-4.7 kN, held-out errors of
500-970 %). Such a record starts at the law's steady sliding state at its first relative
velocity (``laws.steady_deflection_m``); a record at rest keeps the contact holding its load.
"""
from __future__ import annotations

import math

import numpy as np

from ..data.datasets import DERIVATIVE_HALF_WINDOW_SAMPLES, smoothed_derivative, white_noise_sd

# In motion: the start speed stands above its own noise by this many sd ...
MOTION_NOISE_SDS = 5.0
# ... and above this share of the record's typical (95th-percentile) speed: a body creeping
# from rest in a noise-free simulated record is not "sliding steadily".
MOTION_FRACTION_OF_TYPICAL = 0.1
# Samples of a measured velocity whose straight line gives the start speed.
START_SAMPLES = 8


def start_velocity(time_s: np.ndarray, position_m: np.ndarray,
                   velocity_m_per_s: np.ndarray | None) -> tuple[float, float]:
    """(velocity at the first sample, its standard error from the record's white noise): a
    straight line through the first samples of a measured velocity at the first sample (no
    bias under a constant acceleration), else the smoothed derivative of the position's."""
    if velocity_m_per_s is not None:
        v = np.asarray(velocity_m_per_s, dtype=float)
        k = min(START_SAMPLES, len(v))
        if k < 3:
            return float(v[0]), white_noise_sd(v)
        offsets = np.asarray(time_s[:k], dtype=float) - float(time_s[0])
        slope, intercept = np.polyfit(offsets, v[:k], 1)
        # a line's value at its end: sd sqrt(2 (2k - 1) / (k (k + 1))) sigma
        return float(intercept), white_noise_sd(v) * math.sqrt(2.0 * (2 * k - 1) / (k * (k + 1)))
    x = np.asarray(position_m, dtype=float)
    n = min(2 * DERIVATIVE_HALF_WINDOW_SAMPLES + 1, len(x))
    offsets = np.asarray(time_s[:n], dtype=float) - float(time_s[0])
    v0 = float(np.polyfit(offsets, x[:n], 1)[0])  # a straight line: its slope's sd is below
    dt = float(np.median(np.diff(time_s[:n])))
    # least-squares slope over n samples: sd sqrt(12 / (n (n^2 - 1))) sigma_x / dt
    return v0, white_noise_sd(x) * math.sqrt(12.0 / (n * (n * n - 1))) / dt


def typical_speed(time_s: np.ndarray, position_m: np.ndarray,
                  velocity_m_per_s: np.ndarray | None) -> float:
    """The 95th percentile of the body's speed over the record."""
    v = velocity_m_per_s if velocity_m_per_s is not None else \
        smoothed_derivative(np.asarray(position_m, dtype=float), time_s)
    return float(np.percentile(np.abs(v), 95))


def starts_in_motion(time_s: np.ndarray, position_m: np.ndarray,
                     velocity_m_per_s: np.ndarray | None) -> bool:
    """Whether the body is sliding at the first sample: its start speed stands clear of the
    noise and is a real share of the record's speeds."""
    v0, sd = start_velocity(time_s, position_m, velocity_m_per_s)
    typical = typical_speed(time_s, position_m, velocity_m_per_s)
    return abs(v0) > max(MOTION_NOISE_SDS * sd, MOTION_FRACTION_OF_TYPICAL * typical)


__all__ = ["starts_in_motion", "start_velocity", "typical_speed", "MOTION_NOISE_SDS",
           "MOTION_FRACTION_OF_TYPICAL"]
