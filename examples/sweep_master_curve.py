"""The paper's master curve in a few lines: the drive force with the table vibrating, over the
vibration velocity amplitude, relative to the drive force without vibration.

    python examples/sweep_master_curve.py
"""
from vibrofriction.params import RigParameters, default_friction
from vibrofriction.rigs.sweep import sweep


def main() -> None:
    rig = RigParameters()  # the paper's rig: 4 kHz, v_d = 0.5 mm/s, F_N = 55.2 N
    # each point is its periodic steady state, solved for (method "auto": by shooting, 10-30x
    # cheaper than waiting for it; a run until its mean drive force settles where no orbit is
    # found); a fixed short run can stop in the transient: 0.676 at kappa 1.5 after 40 ms,
    # where the steady value is 0.77. (Near the contact resonance orbits can coexist: there
    # method "transient", the default, gives the one reached from rest.)
    result = sweep(rig, default_friction("dahl", rig), [0.75e-3, 3e-3, 20e-3], progress=False,
                   method="auto")
    print(f"static drive force {result['static_drive_force_N']:.3f} N")
    for point in result["points"]:
        print(f"v_a {1e3 * point['vibration_velocity_amplitude_m_per_s']:5.2f} mm/s "
              f"(kappa {point['kappa']:4.1f}): F_dv/F_ds = {point['ratio']:.3f}, "
              f"friction changes sign: {point['sign_change']}, "
              + (f"converged ({point['method']})" if point["converged"] else
                 f"NOT converged ({point['method']}: {point['method_note']})"))
    if not result["all_converged"]:
        print("some points did not settle: run them longer (max_duration_s)")


if __name__ == "__main__":
    main()
