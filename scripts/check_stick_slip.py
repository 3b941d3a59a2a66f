#!/usr/bin/env python3
"""Round trips of stick-slip records: the segmented replay and multiple shooting at work.

Each record is the rig without vibration (drive end at 1 mm/s, spring 1 N/um, 0.5 kg), made by
the plugin (`rig.simulate`, 20 us steps), with a Stribeck peak large enough that the slider
sticks and slips; only `time_s, drive_force_N, position_m, support_velocity_m_per_s` are kept
(`--noisy`: `synthetic.SensorNoise` on each of them too). Each is identified with its law and
the Stribeck curve declared; the table gives each law parameter's error, the drive force's
error over the whole record, where the baseline's start came from and the wall time.

    python scripts/check_stick_slip.py [--duration 0.2] [--cases lugre_a,dahl] [--noisy]
"""
from __future__ import annotations

import argparse
import time

from vibrofriction.rigs import rig
from vibrofriction.data import synthetic
from vibrofriction.commands.simulate import dataset_of
from vibrofriction.data.datasets import Dataset
from vibrofriction.identify.simulation import identify_by_simulation
from vibrofriction.params import FrictionParameters, RigParameters

RIG = RigParameters(vibration_velocity_amplitude_m_per_s=0.0, drive_velocity_m_per_s=1e-3)
TIMESTEP_S = 2e-5
CASES = {
    "lugre_a": FrictionParameters(law="lugre", friction_coefficient=0.2,
                                  contact_stiffness_N_per_m=80e6,
                                  bristle_damping_N_s_per_m=600.0, static_ratio=1.5,
                                  stribeck_velocity_m_per_s=3e-3),
    "lugre_b": FrictionParameters(law="lugre", friction_coefficient=0.17,
                                  contact_stiffness_N_per_m=55e6,
                                  bristle_damping_N_s_per_m=400.0, static_ratio=1.8,
                                  stribeck_velocity_m_per_s=2e-3),
    "lugre_c": FrictionParameters(law="lugre", friction_coefficient=0.25,
                                  contact_stiffness_N_per_m=120e6,
                                  bristle_damping_N_s_per_m=900.0, static_ratio=1.3,
                                  stribeck_velocity_m_per_s=1e-3),
    "dahl": FrictionParameters(law="dahl", friction_coefficient=0.17,
                               contact_stiffness_N_per_m=60e6, alpha=1.5, static_ratio=1.6,
                               stribeck_velocity_m_per_s=2e-3),
}
FIELDS = {"lugre": ("friction_coefficient", "contact_stiffness_N_per_m",
                    "bristle_damping_N_s_per_m", "static_ratio", "stribeck_velocity_m_per_s"),
          "dahl": ("friction_coefficient", "contact_stiffness_N_per_m", "alpha",
                   "static_ratio", "stribeck_velocity_m_per_s")}
COLUMNS = ("time_s", "drive_force_N", "position_m", "support_velocity_m_per_s")


def record(truth: FrictionParameters, duration_s: float, noisy: bool) -> Dataset:
    run = rig.simulate(RIG, truth, timestep_s=TIMESTEP_S, duration_s=duration_s)
    full = dataset_of(run, "stick_slip")
    out = Dataset(name=f"stick_slip_{truth.law}", metadata=full.metadata,
                  columns={c: full.columns[c] for c in COLUMNS})
    return synthetic.with_sensor_noise(out) if noisy else out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=0.2, help="record length (s)")
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    parser.add_argument("--noisy", action="store_true", help="sensor noise on every column")
    args = parser.parse_args()
    print("| case | selected | parameter errors | drive force relerr | baseline from | "
          "stick phases | wall s |")
    print("|---|---|---|---|---|---|---|")
    for name in args.cases.split(","):
        truth = CASES[name]
        started = time.monotonic()
        result = identify_by_simulation(record(truth, args.duration, args.noisy),
                                        law=truth.law, declared=("stribeck",))
        errors = ", ".join(
            f"{field} {100 * (result.final.values[field] / getattr(truth, field) - 1):+.3f} %"
            for field in FIELDS[truth.law])
        print(f"| {name} | {', '.join(result.selected) or 'nothing'} | {errors} | "
              f"{result.final.train.relerr_pct:.3g} % | {result.settings['baseline_start']} | "
              f"{result.settings['stick_phases']} | {time.monotonic() - started:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
