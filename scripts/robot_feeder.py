#!/usr/bin/env python3
"""A linear vibratory feeder (100 Hz, 20 degree throw line) conveying three parts: resolved
(feeder.xml, the planar element at its 10 us and at 0.1 ms) and at the robot's 1 ms with the feeder
map (feeder_map.xml, vibrofriction.contact_feeder), against the exact event-driven reference.

Source: mjcf_models/robots/feeder.xml, feeder_map.xml, vibrofriction.robots. Prints each
scene's conveying speed against the reference and its wall time per simulated second. Writes
docs/figures/robot_feeder.png (part trajectories; normal and friction force over a few periods;
the map) and docs/figures/robot_feeder_frames.png (offscreen-rendered frames; skipped with the reason
when no EGL/OSMesa context can be made).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import mujoco  # noqa: E402

from vibrofriction.robots import scenes  # noqa: E402
from vibrofriction.oracle.feeder_reference import set_down_travel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _resolved_at(timestep_s: float, duration_s: float) -> scenes.SceneRun:
    """feeder.xml with its timestep changed (the contact's solref stays)."""
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path("feeder")))
    spec.option.timestep = timestep_s
    model = spec.compile()
    nstep = int(round(duration_s / timestep_s))
    ctrl = np.zeros((nstep, model.nu))
    for name in ("shaker_x", "shaker_z"):
        ctrl[:, model.actuator(name).id] = 1.0
    return scenes.run_scene(model, ctrl, keep_every=max(1, int(round(1e-4 / timestep_s))))


def _speed(run: scenes.SceneRun, duration: float) -> float:
    """The parts' mean conveying speed over the second half (m/s)."""
    late = run.time_s >= duration / 2
    return float(np.mean([np.polyfit(run.time_s[late], run.sensor(f"{p}_position")[late, 0], 1)[0]
                          for p in scenes.FEEDER_PARTS]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--quick", action="store_true", help="1 s instead of 3 s")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    duration = 1.0 if args.quick else 3.0
    runs = {v: scenes.run_feeder(vibration=v, duration_s=duration) for v in (True, False)}
    coarse = _resolved_at(1e-4, duration)
    mapped = scenes.run_feeder(mode="map", duration_s=duration)
    for run in (*runs.values(), coarse, mapped):
        if run.warnings:
            print(f"MuJoCo warnings: {run.warnings}", file=sys.stderr)
            return 1
    feeder_map = scenes.feeder_map()
    feeder = scenes.FEEDER
    exact = feeder_map.conveying_velocity_m_per_s
    on = runs[True]
    t = on.time_s
    print(f"exact reference (vibrofriction.oracle.feeder_reference): {exact * 1e3:.4f} mm/s "
          f"(Gamma {feeder.throw_number:.2f}, throw angle "
          f"{np.degrees(feeder.throw_angle_rad):.0f} deg, mu {feeder.friction_coefficient})")
    print(f"{'scene':<36} {'dt (s)':>7} {'speed (mm/s)':>12} {'vs exact':>9} "
          f"{'wall per sim. s':>16}")
    rows = [("feeder.xml, resolved (planar)", on), ("feeder.xml at dt 0.1 ms", coarse),
            ("feeder_map.xml, map (contact_feeder)", mapped)]
    for name, run in rows:
        speed = _speed(run, duration)
        print(f"{name:<36} {run.model.opt.timestep:7.0e} {speed * 1e3:12.4f} "
              f"{100 * (speed / exact - 1):+8.2f}% {run.wall_s / duration:15.4f}s")
    still = runs[False]
    drift = max(abs(still.sensor(f"{p}_position")[-1, 0] - still.sensor(f"{p}_position")[0, 0])
                for p in scenes.FEEDER_PARTS)
    print(f"without vibration (resolved): the parts move {drift * 1e3:.2e} mm")
    print(f"cost, map at 1 ms over resolved at 10 us: "
          f"{on.wall_s / mapped.wall_s:.0f}x less wall time per simulated second "
          "(one run each; scripts/bench_robots.py measures the cost)")

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.4))
    period = 1 / feeder.frequency_Hz
    ends = np.arange(1, int(duration / period) + 1) * period
    reference = set_down_travel(feeder, ends.size)
    axes[0].plot(ends, 1e3 * reference, color="k", lw=3, alpha=0.3,
                 label="exact reference (period ends)")
    for run, label, style in ((on, "resolved, dt 10 us", "C0-"), (coarse, "resolved, dt 0.1 ms",
                                                                    "C2--"),
                              (mapped, "map, dt 1 ms", "C3:"), (still, "no vibration", "C7-")):
        x = run.sensor("part1_position")[:, 0]
        axes[0].plot(run.time_s, 1e3 * (x - x[0]), style, label=label)
    axes[0].set_xlabel("time (s)")
    axes[0].set_ylabel("part1 travel along the track (mm)")
    axes[0].legend(fontsize=7)
    window = (t >= duration - 0.03)
    state = on.sensor("part1_friction")
    weight = scenes.FEEDER_PART_MASS_KG * 9.81
    axes[1].plot(1e3 * (t[window] - t[window][0]), state[window, 6] / weight, label="F_N / m g")
    axes[1].plot(1e3 * (t[window] - t[window][0]),
                 state[window, 0] / (0.3 * weight), label="F_x / (mu m g)")
    axes[1].plot(1e3 * (t[window] - t[window][0]), on.sensor("track_x")[window] / 5.09e-5,
                 label="track x / u0 cos(beta)", color="0.6")
    axes[1].set_xlabel("time (ms), last 3 periods, resolved")
    axes[1].legend(fontsize=7, loc="lower right")
    unit = feeder.along_velocity_amplitude
    axes[2].plot(feeder_map.velocity_m_per_s / unit,
                 feeder_map.force_ratio / feeder.friction_coefficient, "C3.-", ms=3)
    axes[2].axhline(0, color="0.7", lw=0.8)
    axes[2].plot([exact / unit], [0], "ko", label="conveying velocity")
    axes[2].set_xlabel("part's mean velocity on the track / (A w cos beta)")
    axes[2].set_ylabel("mean friction / (mu m g)")
    axes[2].set_title("the feeder map (from the exact reference)", fontsize=9)
    axes[2].legend(fontsize=7)
    fig.suptitle("Vibratory feeder, 100 Hz, throw angle 20 deg, Gamma = 0.7", fontsize=10)
    fig.tight_layout()
    path = args.out / "robot_feeder.png"
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")
    try:
        frames = scenes.render_frames(on, [0.01, duration / 2, duration - 0.01], height=200,
                                      width=260)
    except scenes.RenderingUnavailable as reason:
        print(f"frames skipped: {reason}")
        return 0
    path = args.out / "robot_feeder_frames.png"
    plt.imsave(path, np.concatenate(frames, axis=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
