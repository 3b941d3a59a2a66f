#!/usr/bin/env python3
"""Benchmark of the robot-timestep (averaged) friction mode against the resolved simulation.

Source: vibrofriction.averaged (table from the resolved planar law), vibrofriction.planar (the
planar rig, mjcf_models/robots/planar_rig*.xml), vibrofriction.robots (the plate-push scene).
Prints, side by side:
  1. accuracy: mean friction (drive) force of the plate-push part (0.2 kg, Dahl, mu = 0.3) on the
     2 kHz plate (v_a = 50 mm/s), driven at V = xi v_a along 0, 45 and 90 degrees from the
     vibration: resolved rig at dt = 10 us (and 5 us: its own convergence) vs averaged rig at
     dt = 1 ms; the target is 3 %;
  2. cost: wall time per simulated second of the plate-push robot scene, resolved (dt = 10 us)
     vs averaged (dt = 1 and 2 ms), measured in one run; the target is 100x.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

import vibrofriction
from vibrofriction.rigs import planar
from vibrofriction.robots import scenes
from vibrofriction.params import RigParameters


def rig_case(xi: float, angle: float) -> tuple:
    mass = scenes.PART_MASS_KG
    stiffness = 2e3  # drive spring (N/m), critically damped: a compliant robot finger
    vib = scenes.PLATE_VIBRATION
    rig = RigParameters(mass_kg=mass, drive_stiffness_N_per_m=stiffness,
                        drive_damping_N_s_per_m=2 * math.sqrt(stiffness * mass),
                        drive_velocity_m_per_s=xi * vib.velocity_amplitude_m_per_s,
                        vibration_frequency_Hz=vib.frequency_Hz,
                        vibration_velocity_amplitude_m_per_s=vib.velocity_amplitude_m_per_s,
                        normal_force_N=mass * scenes.GRAVITY_M_PER_S2)
    return (rig, scenes.PLATE_PART_FRICTION, 0.0, angle)


def accuracy(xis, angles, table) -> list[dict]:
    cases = [rig_case(xi, a) for xi in xis for a in angles]
    kwargs = dict(duration_s=0.3, settle_time_s=0.2)
    resolved = planar.simulate_rigs(cases, timestep_s=1e-5, **kwargs)
    finer = planar.simulate_rigs(cases, timestep_s=5e-6, **kwargs)
    fast = planar.simulate_rigs(cases, timestep_s=1e-3, averaged_config=table.config(), **kwargs)
    bound = scenes.PLATE_PART_FRICTION.friction_coefficient * cases[0][0].normal_force_N
    rows = []
    for (rig, _, _, angle), a, b, c in zip(cases, resolved, finer, fast):
        fa, fb, fc = a.mean_drive_force_N(), b.mean_drive_force_N(), c.mean_drive_force_N()
        rows.append({
            "xi": rig.drive_velocity_m_per_s / rig.vibration_velocity_amplitude_m_per_s,
            "angle_deg": math.degrees(angle),
            "resolved_N": fa.tolist(), "resolved_half_dt_N": fb.tolist(),
            "averaged_N": fc.tolist(), "ratio_resolved": float(np.linalg.norm(fa) / bound),
            "error_pct": float(100 * np.linalg.norm(fc - fa) / np.linalg.norm(fa)),
            "resolved_convergence_pct": float(100 * np.linalg.norm(fb - fa) / np.linalg.norm(fa)),
        })
    return rows


def _scene_cost(name: str, timestep: float, seconds: float, repeats: int) -> float:
    vibrofriction.load()
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path(name)))
    spec.option.timestep = timestep
    model = spec.compile()
    plan = scenes.PushPlan()
    # The push phase (contact active), shifted to start at t = 0 after a settled approach.
    start = plan.push_start_s + 0.2
    nstep = int(round((start + seconds) / timestep))
    ctrl = scenes.push_controls(model, plan, nstep, 1.0)
    x, y, quill = plan.pusher(0.0)
    q1, q2 = scenes.scara_ik(x, y)
    state0 = scenes.initial_state(model, ctrl[0], {"shoulder": q1, "elbow": q2, "quill": quill})
    k0 = int(round(start / timestep))
    lead = scenes.run_scene(model, ctrl[:k0], state0)
    if lead.warnings:
        raise RuntimeError(f"MuJoCo warnings in {name}: {lead.warnings}")
    # Copies of the same push in one single-threaded rollout call, >= 10^4 steps, so that the
    # call's fixed overhead does not count.
    copies = max(1, int(math.ceil(1e4 / (ctrl.shape[0] - k0))))
    states = np.repeat(lead.state[-1][None], copies, axis=0)
    controls = np.repeat(ctrl[k0:][None], copies, axis=0)
    data = mujoco.MjData(model)
    best = math.inf
    for _ in range(repeats):
        start_wall = time.perf_counter()
        mj_rollout.rollout(model, data, states, controls)
        best = min(best, (time.perf_counter() - start_wall) / (copies * seconds))
        if any(w.number for w in data.warning):
            raise RuntimeError(f"MuJoCo warnings in {name}")
    return best


def cost(repeats: int, resolved_seconds: float) -> dict:
    # Interleave the measurements so that load from other processes hits both alike.
    resolved, avg1, avg2 = [], [], []
    for _ in range(repeats):
        resolved.append(_scene_cost("plate_push_resolved", 1e-5, resolved_seconds, 1))
        avg1.append(_scene_cost("plate_push_averaged", 1e-3, 1.5, 3))
        avg2.append(_scene_cost("plate_push_averaged", 2e-3, 1.5, 3))
    r, a1, a2 = min(resolved), min(avg1), min(avg2)
    return {"resolved_dt_s": 1e-5, "resolved_wall_per_sim_s": r,
            "averaged_1ms_wall_per_sim_s": a1, "averaged_2ms_wall_per_sim_s": a2,
            "speedup_1ms": r / a1, "speedup_2ms": r / a2}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer velocities, one repeat")
    parser.add_argument("--json", type=Path, help="write the numbers to this file")
    args = parser.parse_args(argv)
    xis = (0.1, 0.4, 1.0) if args.quick else (0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0, 1.5)
    angles = (0.0, math.pi / 2) if args.quick else (0.0, math.pi / 4, math.pi / 2)
    t0 = time.perf_counter()
    table = scenes.plate_push_table()
    print(f"table: {table.xi.size} x {table.angle_rad.size} points from the resolved "
          f"{table.friction.law} law in {time.perf_counter() - t0:.1f} s")
    rows = accuracy(xis, angles, table)
    print("\n1. Mean force, plate-push part on the 2 kHz plate (v_a = 50 mm/s), xi = V / v_a")
    print(f"{'xi':>5} {'angle':>5} {'resolved F/(mu F_N)':>20} {'averaged F/(mu F_N)':>20} "
          f"{'error %':>8} {'resolved dt/2 %':>15}")
    bound = scenes.PLATE_PART_FRICTION.friction_coefficient * scenes.PART_MASS_KG * 9.81
    for row in rows:
        a = np.linalg.norm(row["resolved_N"]) / bound
        b = np.linalg.norm(row["averaged_N"]) / bound
        print(f"{row['xi']:5.2f} {row['angle_deg']:5.0f} {a:20.4f} {b:20.4f} "
              f"{row['error_pct']:8.2f} {row['resolved_convergence_pct']:15.2f}")
    worst = max(row["error_pct"] for row in rows)
    print(f"largest error {worst:.2f} % (target 3 %)")
    numbers = cost(1 if args.quick else 3, 0.05 if args.quick else 0.15)
    print("\n2. Cost of one simulated second, plate-push robot scene (wall s per simulated s)")
    print(f"{'resolved, dt = 10 us':>24}: {numbers['resolved_wall_per_sim_s']:.4f}")
    print(f"{'averaged, dt = 1 ms':>24}: {numbers['averaged_1ms_wall_per_sim_s']:.5f}  "
          f"({numbers['speedup_1ms']:.0f}x lower)")
    print(f"{'averaged, dt = 2 ms':>24}: {numbers['averaged_2ms_wall_per_sim_s']:.5f}  "
          f"({numbers['speedup_2ms']:.0f}x lower)")
    print("target: 100x")
    if args.json:
        args.json.write_text(json.dumps({"accuracy": rows, "cost": numbers}, indent=1))
    return 0 if worst <= 3.0 else 1


if __name__ == "__main__":
    sys.exit(main())
