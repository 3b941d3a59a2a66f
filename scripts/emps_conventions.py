"""The EMPS closed loop's simulator conventions and what each one changes.

1. Does the logged command equal the controller law at the same sample? The law
   u_k = kv (kp (q_r,k - q_k) - (q_f,k - q_f,k-1) / T), q_f the position averaged over two
   samples, evaluated on the logged positions with the command applied at once or a sample
   later, against the logged command vir.
2. The benchmark's published model (IDIM-LS: M, Fv, Fc, offset) simulated in closed loop in
   mjcf_models/emps with the plugin, under each convention: the controller's period the record's
   mean sample interval (the one the timestep divides) or its median (then the controller's
   samples slip against the record's), the command applied at once or one sample later, the
   saturation. Errors as the benchmark defines them (relerr from the 50th sample).

    python scripts/emps_conventions.py [../shared/data/emps/DATA_EMPS.mat] [--substeps 4]
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from vibrofriction import sim
from vibrofriction.data.convert import convert_emps
from vibrofriction.identify.machine_replay import MachineReplay, closed_loop_errors
from vibrofriction.identify.replay import Replayer
from vibrofriction.identify.replays import prepare_replay
from vibrofriction.params import FrictionParameters

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared/data/emps/DATA_EMPS.mat"
# EMPS description, section 3: the IDIM-LS estimates.
PUBLISHED = {"mass_kg": 95.1089, "viscous_N_s_per_m": 203.5034, "coulomb_N": 20.3935,
             "offset_N": -3.1648}


class Convention(MachineReplay):
    """The EMPS replay with the controller's sample period, delay or saturation overridden."""

    def spec(self, rig, friction, probes=True, scene_values=None) -> mujoco.MjSpec:
        spec = super().spec(rig, friction, probes, scene_values)
        controller = next(p for p in spec.plugins if p.name == self.scene.controller)
        sim.set_plugin_config(spec, self.scene.controller,
                                     {**dict(controller.config), **self.overrides})
        return spec


def logged_command_check(mat_path: Path) -> None:
    from scipy.io import loadmat
    mat = loadmat(mat_path)
    q, r, vir = (mat[k].ravel() for k in ("qm", "qg", "vir"))
    kp, kv = mat["kp"].item(), mat["kv"].item()
    t = mat["t"].ravel()
    T = float(np.median(np.diff(t)))
    filtered = np.r_[q[0], 0.5 * (q[1:] + q[:-1])]
    velocity = np.r_[0.0, np.diff(filtered) / T]
    law = kv * (kp * (r - q) - velocity)
    print("1. logged command vir against the controller law (rms over the record, from the "
          "10th sample)")
    print(f"   rms |vir| = {np.sqrt(np.mean(vir ** 2)):.4g} V, max |vir| = "
          f"{np.max(np.abs(vir)):.4g} V (saturation 10 V: never reached)")
    for delay in (0, 1):
        predicted = np.r_[np.full(delay, law[0]), law[:len(law) - delay]]
        e = (predicted - vir)[10:]
        print(f"   command applied {'at once' if delay == 0 else 'one sample later'}: rms "
              f"difference {np.sqrt(np.mean(e ** 2)):.4g} V, max {np.max(np.abs(e)):.4g} V")
    d = np.diff(t)
    print(f"   sample intervals: median {T * 1e3:.6f} ms, mean {np.mean(d) * 1e3:.6f} ms; "
          f"timestamps within {np.max(np.abs(t - t[0] - np.arange(len(t)) * np.mean(d))) * 1e9:.0f}"
          " ns of a uniform clock at the mean")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--substeps", type=int, default=4)
    args = parser.parse_args(argv)
    if not args.data.is_file():
        print(f"EMPS data not found at {args.data}; pass the path of DATA_EMPS.mat",
              file=sys.stderr)
        return 2
    logged_command_check(args.data)
    base = prepare_replay(convert_emps(args.data), substeps=args.substeps)
    friction = FrictionParameters(law="coulomb", friction_coefficient=PUBLISHED["coulomb_N"],
                                  viscous_N_s_per_m=PUBLISHED["viscous_N_s_per_m"],
                                  force_offset_N=PUBLISHED["offset_N"])
    rig = replace(base.rig, mass_kg=PUBLISHED["mass_kg"])
    median_s = float(np.median(np.diff(base.time_s)))
    conventions = [
        ("mean interval, at once, 10 V (chosen)", {}),
        (f"period {median_s * 1e3:.6f} ms (median interval)", {"sample_period": repr(median_s)}),
        ("command one sample later", {"command_delay": "1"}),
        ("no saturation", {"saturation": "0"}),
    ]
    print(f"\n2. published IDIM-LS model in closed loop (MuJoCo timestep "
          f"{base.timestep_s:.4g} s): relerr from the 50th sample")
    print(f"   {'convention':<40s} {'force':>9s} {'position':>10s} {'velocity':>10s}")
    extra = ("position_m", "velocity_m_per_s", "drive_force_N")
    for label, overrides in conventions:
        replay = Convention(**{f: getattr(base, f) for f in base.__dataclass_fields__})
        object.__setattr__(replay, "overrides", overrides)
        with Replayer(replay) as runner:
            predicted = runner.run([(rig, friction)], extra)[0]
        e = closed_loop_errors(replay, predicted)
        print(f"   {label:<40s} {e['force_relerr_pct']:8.3f} % {e['position_relerr_pct']:9.4f} % "
              f"{e['velocity_relerr_pct']:9.3f} %")
    print("   published (its Simulink simulation):       5.848 %    0.0138 %     0.229 %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
