#!/usr/bin/env python3
"""How the rig's mean drive force converges with the timestep under strong vibration.

The lab scenario of the synthetic records (LuGre, k_t 80 N/um, sigma1 600 N s/m, v_a 20 mm/s
at 4 kHz, v_d 1 mm/s, vibration from 20 ms): the vibration lowers the mean friction to ~3 % of
mu F_N, so the mean is a small difference of large alternating forces. Prints the plugin's
mean drive force after the transient against the scipy reference, with N steps a vibration
period (a grid that repeats every period: a lab's sample rate is usually a multiple of the
vibration frequency) and with N + 0.382 (the grid slides along the vibration's phase, the
timestep rule of rig.period_timestep). docs/physics.md quotes this.

    python scripts/check_strong_vibration_timestep.py [--duration 0.1]
"""
from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from vibrofriction.rigs import rig
from vibrofriction.data import synthetic
from vibrofriction.oracle.reference import simulate_reference

STEPS_PER_PERIOD = (25, 50, 100, 200)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=0.1, help="simulated time (s)")
    args = parser.parse_args()
    scenario = replace(synthetic.lab_scenario(None), duration_s=args.duration)
    r, f = scenario.rig, scenario.friction
    settled_from_s = args.duration / 2

    def mean_after(t: np.ndarray, force: np.ndarray) -> float:
        return float(np.mean(force[t >= settled_from_s]))

    ref = simulate_reference(r, f, args.duration, sample_dt_s=1e-6)
    t_ref = np.asarray(ref.time_s)
    reference = mean_after(t_ref, r.drive_stiffness_N_per_m *
                           (r.drive_velocity_m_per_s * t_ref - np.asarray(ref.slider_position_m)))
    transition_s = 2 * f.friction_coefficient * r.normal_force_N / \
        f.contact_stiffness_N_per_m / r.vibration_velocity_amplitude_m_per_s
    print(f"mean drive force from {1e3 * settled_from_s:g} ms; scipy reference "
          f"{reference:.5f} N; contact transition 2 mu F_N / (k_t v_a) = "
          f"{1e6 * transition_s:.1f} us")
    print("| steps per period | timestep (us) | steps per transition | plugin (N) | error |")
    print("|---|---|---|---|---|")
    for n in STEPS_PER_PERIOD:
        for steps in (float(n), n + rig.STEP_PHASE_SLIDE):
            dt = 1.0 / (r.vibration_frequency_Hz * steps)
            run = rig.simulate(r, f, timestep_s=dt, duration_s=args.duration)
            mean = mean_after(np.asarray(run.time_s), np.asarray(run.dynamometer_force_N))
            print(f"| {steps:g} | {1e6 * dt:.4g} | {transition_s / dt:.1f} | {mean:.5f} | "
                  f"{100 * (mean / reference - 1):+.2f} % |", flush=True)


if __name__ == "__main__":
    main()
