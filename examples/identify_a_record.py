"""Identify a friction law from a record by simulating the rig scene against it.

A record is made here by the simulator itself (as `vibrofriction simulate --csv` writes it;
use your own lab record in the dataset format instead), then identified with the same law.

    python examples/identify_a_record.py
"""
from vibrofriction.rigs import rig
from vibrofriction.commands.simulate import dataset_of
from vibrofriction.identify.simulation import identify_by_simulation
from vibrofriction.params import FrictionParameters, RigParameters


def main() -> None:
    setup = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3)
    truth = FrictionParameters(law="coulomb", friction_coefficient=0.21)
    run = rig.simulate(setup, truth, timestep_s=rig.recommended_timestep(setup),
                       duration_s=0.04)
    record = dataset_of(run, "example")  # columns, sidecar values, as a CSV would hold them
    result = identify_by_simulation(record, law="coulomb")
    print(f"mu {result.final.values['friction_coefficient']:.4f} (true 0.21), "
          f"effects selected: {', '.join(result.selected) or 'none'}, "
          f"{result.simulations} simulations")


if __name__ == "__main__":
    main()
