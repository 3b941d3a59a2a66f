#!/usr/bin/env python3
"""A linear vibratory feeder (100 Hz, 20 degree throw line) conveying three parts through the
planar friction element, with and without vibration.

Source: mjcf_models/robots/feeder.xml, vibrofriction.robots. Writes
docs/figures/robot_feeder.png (part trajectories; normal and friction force over a few periods)
and docs/figures/robot_feeder_frames.png (offscreen-rendered frames; skipped with the reason
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

from vibrofriction import robots  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--quick", action="store_true", help="1 s instead of 3 s")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    duration = 1.0 if args.quick else 3.0
    runs = {v: robots.run_feeder(vibration=v, duration_s=duration) for v in (True, False)}
    for vibration, run in runs.items():
        if run.warnings:
            print(f"MuJoCo warnings: {run.warnings}", file=sys.stderr)
            return 1
    on = runs[True]
    t = on.time_s
    half = t >= duration / 2
    print(f"{'part':>6} {'conveying speed, vibration (mm/s)':>34} {'drift, no vibration (mm)':>25}")
    for part in robots.FEEDER_PARTS:
        x = on.sensor(f"{part}_position")[:, 0]
        speed = np.polyfit(t[half], x[half], 1)[0]
        still = runs[False].sensor(f"{part}_position")[:, 0]
        print(f"{part:>6} {speed * 1e3:34.2f} {(still[-1] - still[0]) * 1e3:25.2e}")
    print(f"wall per simulated second: {on.wall_s / duration:.3f} s (dt = {on.model.opt.timestep:g} s)")

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for k, part in enumerate(robots.FEEDER_PARTS):
        for vibration, line in ((True, "-"), (False, ":")):
            run = runs[vibration]
            x = run.sensor(f"{part}_position")[:, 0]
            axes[0].plot(run.time_s[::10], 1e3 * x[::10], line, color=f"C{k}",
                         label=f"{part}{'' if vibration else ', no vibration'}")
    axes[0].set_xlabel("time (s)")
    axes[0].set_ylabel("part x along the track (mm)")
    axes[0].legend(fontsize=7)
    window = (t >= duration - 0.03)
    state = on.sensor("part1_friction")
    weight = robots.FEEDER_PART_MASS_KG * 9.81
    axes[1].plot(1e3 * (t[window] - t[window][0]), state[window, 6] / weight, label="F_N / m g")
    axes[1].plot(1e3 * (t[window] - t[window][0]),
                 state[window, 0] / (0.3 * weight), label="F_x / (mu m g)")
    axes[1].plot(1e3 * (t[window] - t[window][0]), on.sensor("track_x")[window] / 5.09e-5,
                 label="track x / u0 cos(beta)", color="0.6")
    axes[1].set_xlabel("time (ms), last 3 periods")
    axes[1].legend(fontsize=7, loc="lower right")
    fig.suptitle("Vibratory feeder, 100 Hz, throw angle 20 deg, Gamma = 0.7", fontsize=10)
    fig.tight_layout()
    path = args.out / "robot_feeder.png"
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")
    try:
        frames = robots.render_frames(on, [0.01, duration / 2, duration - 0.01], height=200,
                                      width=260)
    except robots.RenderingUnavailable as reason:
        print(f"frames skipped: {reason}")
        return 0
    path = args.out / "robot_feeder_frames.png"
    plt.imsave(path, np.concatenate(frames, axis=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
