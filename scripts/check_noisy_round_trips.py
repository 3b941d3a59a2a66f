#!/usr/bin/env python3
"""Round trips of noisy `simulate` records, and where their error comes from.

For each law, the 60 ms rig record of the round-trip tests (v_a = 1.5 mm/s, the issue's
parameters) gets `synthetic.SensorNoise` on every column (`synthetic.with_sensor_noise`), the
support's measured motion included, and is identified by simulation with the same law: all
columns, and only `time_s, drive_force_N, position_m, support_velocity_m_per_s`. Prints the
selections and each law parameter's error in percent and in standard errors. With
--outputs-only the support's motion stays noise-free (noise on the outputs only): the
difference is what the noise on the inputs costs (errors in variables).

    python scripts/check_noisy_round_trips.py [--laws dahl,lugre] [--outputs-only]
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

from vibrofriction.rigs import rig
from vibrofriction.data import synthetic
from vibrofriction.commands.simulate import dataset_of
from vibrofriction.data.datasets import Dataset
from vibrofriction.identify.simulation import identify_by_simulation
from vibrofriction.params import FrictionParameters, RigParameters

RIG = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3)
DURATION_S = 0.06
LAWS = {  # (truth, declared, parameters checked): as tests/test_identify_simulation.py
    "coulomb": (FrictionParameters(law="coulomb", friction_coefficient=0.21), (),
                ("friction_coefficient",)),
    "dupont": (FrictionParameters(law="dupont", friction_coefficient=0.19,
                                  contact_stiffness_N_per_m=70e6, breakaway_ratio=0.6), (),
               ("friction_coefficient", "contact_stiffness_N_per_m", "breakaway_ratio")),
    "lugre": (FrictionParameters(law="lugre", friction_coefficient=0.22,
                                 contact_stiffness_N_per_m=90e6, static_ratio=1.3,
                                 stribeck_velocity_m_per_s=2e-3,
                                 bristle_damping_N_s_per_m=1265.0), ("stribeck",),
              ("friction_coefficient", "contact_stiffness_N_per_m", "static_ratio",
               "stribeck_velocity_m_per_s", "bristle_damping_N_s_per_m")),
    "dahl": (FrictionParameters(law="dahl", friction_coefficient=0.17,
                                contact_stiffness_N_per_m=60e6, alpha=1.5), (),
             ("friction_coefficient", "contact_stiffness_N_per_m", "alpha")),
}
POSITION_ONLY = ("time_s", "drive_force_N", "position_m", "support_velocity_m_per_s")
SUPPORT_COLUMNS = ("support_position_m", "support_velocity_m_per_s")


def noisy_record(law: str, columns: tuple[str, ...] | None, outputs_only: bool) -> Dataset:
    truth = LAWS[law][0]
    run = rig.simulate(RIG, truth, timestep_s=rig.recommended_timestep(RIG),
                       duration_s=DURATION_S)
    clean = dataset_of(run, law)
    if columns is not None:
        clean = Dataset(name=clean.name, columns={c: clean.columns[c] for c in columns},
                        metadata=clean.metadata)
    noisy = synthetic.with_sensor_noise(clean)
    if outputs_only:  # the support's motion as the simulator made it
        noisy = replace(noisy, columns={c: clean.columns[c] if c in SUPPORT_COLUMNS else v
                                        for c, v in noisy.columns.items()})
    return noisy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", default=",".join(LAWS), help="comma-separated laws")
    parser.add_argument("--outputs-only", action="store_true",
                        help="noise on the measured outputs only, not on the support's motion")
    args = parser.parse_args()
    print("| law | columns | selected | parameter errors (% and standard errors) | wall s |")
    print("|---|---|---|---|---|")
    for law in args.laws.split(","):
        truth, declared, names = LAWS[law]
        for label, columns in (("all", None), ("position-only", POSITION_ONLY)):
            started = time.monotonic()
            result = identify_by_simulation(noisy_record(law, columns, args.outputs_only),
                                            law=law, declared=declared)
            errors = []
            for name in names:
                value, true = result.final.values[name], getattr(truth, name)
                sd = result.standard_errors.get(name)
                errors.append(f"{name} {100 * (value / true - 1):+.2f} %" +
                              (f" ({(value - true) / sd:+.1f} se)" if sd else ""))
            print(f"| {law} | {label} | {', '.join(result.selected) or 'nothing'} | "
                  f"{'; '.join(errors)} | {time.monotonic() - started:.0f} |", flush=True)


if __name__ == "__main__":
    main()
