"""A rig record from a generator of its own: scipy's LSODA on the rig's equations, Dahl friction
written out here, the support vibrating in stages with rests between -- none of the package's
models (plugin, oracle, ``data.synthetic``) is used to make it. Identification's speed must hold
on records the project did not make (issue 39: such a record did not finish in 25 min).

    python scripts/staged_vibration_record.py --out staged.csv [--duration 0.42]

The rig: slider m on a table whose displacement is u(t) = a(t) sin(2 pi f t), a(t) rising and
falling as (1 - cos)/2 over ramps; the drive spring k_d whose far end moves at v_d; Dahl
friction F = sigma0 z, dz/dt = v_r (1 - sigma0 z sgn(v_r) / (mu F_N)) (alpha 1), v_r = x' - u'.
Measured: the drive spring's force, the slider's position (1 nm noise), the support's
velocity (a vibrometer, 20 um/s noise), at 100 kHz.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from vibrofriction.data.datasets import Dataset, DatasetMetadata, write_dataset

MASS_KG = 0.8
DRIVE_STIFFNESS_N_PER_M = 1.2e5
DRIVE_VELOCITY_M_PER_S = 1.0e-3
FREQUENCY_HZ = 3900.0
NORMAL_N = 40.0
MU = 0.25
CONTACT_STIFFNESS_N_PER_M = 5.0e7
SAMPLE_RATE_HZ = 100e3
# (start s, end s, velocity amplitude m/s) of each vibration stage; rests between them
STAGES = ((0.05, 0.14, 6e-3), (0.19, 0.28, 12e-3), (0.33, 0.40, 3e-3))
RAMP_S = 0.01


def envelope(t: float) -> float:
    for start, end, amplitude in STAGES:
        if start <= t <= end:
            rise = min(1.0, (t - start) / RAMP_S, (end - t) / RAMP_S)
            return amplitude * 0.5 * (1.0 - math.cos(math.pi * max(rise, 0.0)))
    return 0.0


def support(t: float) -> tuple[float, float]:
    """(displacement, velocity) of the table: a(t) sin(w t) with a's slope included."""
    w = 2 * math.pi * FREQUENCY_HZ
    h = 1e-7
    a = envelope(t) / w  # displacement amplitude
    da = (envelope(t + h) - envelope(t - h)) / (2 * h) / w
    return a * math.sin(w * t), a * w * math.cos(w * t) + da * math.sin(w * t)


def rhs(t: float, y: np.ndarray) -> list[float]:
    x, v, z = y
    _, u_dot = support(t)
    v_r = v - u_dot
    level = MU * NORMAL_N
    dz = v_r * (1.0 - CONTACT_STIFFNESS_N_PER_M * z * math.copysign(1.0, v_r) / level)
    spring = DRIVE_STIFFNESS_N_PER_M * (DRIVE_VELOCITY_M_PER_S * t - x)
    return [v, (spring - CONTACT_STIFFNESS_N_PER_M * z) / MASS_KG, dz]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="CSV path (sidecar beside it)")
    parser.add_argument("--duration", type=float, default=0.42)
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args(argv)
    t = np.arange(int(round(args.duration * SAMPLE_RATE_HZ))) / SAMPLE_RATE_HZ
    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="LSODA",
                    rtol=1e-9, atol=[1e-13, 1e-10, 1e-14], max_step=2e-6)
    if not sol.success:
        print(sol.message, file=sys.stderr)
        return 1
    x, _, _ = sol.y
    rng = np.random.default_rng(args.seed)
    spring = DRIVE_STIFFNESS_N_PER_M * (DRIVE_VELOCITY_M_PER_S * t - x)
    u_dot = np.array([support(ti)[1] for ti in t.tolist()])
    columns = {"time_s": t, "drive_force_N": spring + 2e-3 * rng.standard_normal(t.size),
               "position_m": x + 1e-9 * rng.standard_normal(t.size),
               "support_velocity_m_per_s": u_dot + 20e-6 * rng.standard_normal(t.size)}
    meta = DatasetMetadata(
        description="staged vibration, Dahl, scipy LSODA (scripts/staged_vibration_record.py)",
        mass_kg=MASS_KG, drive_stiffness_N_per_m=DRIVE_STIFFNESS_N_PER_M,
        drive_velocity_m_per_s=DRIVE_VELOCITY_M_PER_S, vibration_frequency_Hz=FREQUENCY_HZ,
        normal_force_N=NORMAL_N, sample_rate_Hz=SAMPLE_RATE_HZ)
    write_dataset(Dataset(name=args.out.stem, columns=columns, metadata=meta), args.out)
    print(f"wrote {args.out}: {t.size} samples, slider travel {x[-1] * 1e3:.3f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
