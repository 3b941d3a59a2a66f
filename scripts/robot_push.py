#!/usr/bin/env python3
"""A SCARA arm pushes a part across a vibrating plate, with and without vibration, resolved
(dt = 10 us) and at the robot's timestep (dt = 1 ms, averaged friction).

Source: mjcf_models/robots/plate_push*.xml, vibrofriction.robots. Writes
docs/figures/robot_push.png (trajectories, forces) and docs/figures/robot_push_frames.png
(offscreen-rendered frames; skipped with the reason when no EGL/OSMesa context can be made).
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

from vibrofriction.robots import scenes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def period_mean(run: scenes.SceneRun, series: np.ndarray) -> np.ndarray:
    """Moving mean over one vibration period (resolved runs), for plotting."""
    n = max(1, int(round(1 / (scenes.PLATE_VIBRATION.frequency_Hz * run.model.opt.timestep))))
    if n == 1:
        return series
    kernel = np.ones(n) / n
    return np.convolve(series, kernel, mode="same")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--quick", action="store_true",
                        help="resolved runs over the first 1.2 s only")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    plan = scenes.PushPlan()
    runs = {}
    for mode in ("averaged", "resolved"):
        for vibration in (True, False):
            duration = 1.2 if (args.quick and mode == "resolved") else plan.duration_s
            run = scenes.run_push(mode, vibration=vibration, plan=plan, duration_s=duration)
            if run.warnings:
                print(f"MuJoCo warnings in {mode} run: {run.warnings}", file=sys.stderr)
                return 1
            runs[(mode, vibration)] = run
    window = (plan.push_start_s + 0.3, min(plan.push_end_s, 1.2 if args.quick else 1e9))
    print(f"push at {plan.speed_m_per_s * 1e3:g} mm/s along the vibration (xi = "
          f"{plan.speed_m_per_s / scenes.PLATE_VIBRATION.velocity_amplitude_m_per_s:.2f}); "
          f"mean push force {window[0]:.1f}-{window[1]:.1f} s:")
    print(f"{'mode':>9} {'vibration':>9} {'dt (s)':>8} {'push (N)':>9} {'part x end (mm)':>15} "
          f"{'wall per sim s':>14}")
    for (mode, vibration), run in runs.items():
        mask = (run.time_s >= window[0]) & (run.time_s < window[1])
        push = run.sensor("push_force")[mask].mean()
        x_end = run.sensor("part_position")[-1, 0] * 1e3
        print(f"{mode:>9} {'on' if vibration else 'off':>9} {run.model.opt.timestep:8.0e} "
              f"{push:9.4f} {x_end:15.2f} {run.wall_s / run.time_s[-1]:14.4f}")

    fig, axes = plt.subplots(2, 2, figsize=(9, 5.6), sharex=True)
    styles = {("averaged", True): ("C0", "-", "averaged, vibration"),
              ("averaged", False): ("C1", "-", "averaged, no vibration"),
              ("resolved", True): ("k", ":", "resolved, vibration"),
              ("resolved", False): ("0.5", ":", "resolved, no vibration")}
    for key, run in runs.items():
        color, line, label = styles[key]
        t = run.time_s
        stride = max(1, len(t) // 4000)
        pos = run.sensor("part_position")
        axes[0, 0].plot(t[::stride], 1e3 * pos[::stride, 0], line, color=color, label=label)
        push = period_mean(run, run.sensor("push_force"))
        axes[0, 1].plot(t[::stride], push[::stride], line, color=color)
        friction = period_mean(run, run.sensor("part_friction")[:, 0])
        axes[1, 0].plot(t[::stride], friction[::stride], line, color=color)
        torque = period_mean(run, run.sensor("shoulder_torque"))
        axes[1, 1].plot(t[::stride], torque[::stride], line, color=color)
    pusher = runs[("averaged", True)].sensor("pusher_position")
    axes[0, 0].plot(runs[("averaged", True)].time_s, 1e3 * pusher[:, 0], color="0.8", lw=3,
                    zorder=0, label="pusher")
    bound = scenes.PLATE_PART_FRICTION.friction_coefficient * scenes.PART_MASS_KG * 9.81
    for ax in (axes[0, 1], axes[1, 0]):
        ax.axhline(bound, color="0.7", lw=0.8, ls="--")
    axes[0, 0].set_ylabel("part x (mm)")
    axes[0, 1].set_ylabel("push force (N, period mean)")
    axes[1, 0].set_ylabel("friction F_x on part (N, period mean)")
    axes[1, 1].set_ylabel("shoulder torque (N m, period mean)")
    for ax in axes[1]:
        ax.set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=7, loc="upper left")
    fig.suptitle("SCARA pushing a 0.2 kg part on a plate vibrating at 2 kHz, v_a = 50 mm/s",
                 fontsize=10)
    fig.tight_layout()
    path = args.out / "robot_push.png"
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")

    try:
        run = runs[("averaged", True)]
        frames = scenes.render_frames(run, [0.05, plan.push_start_s, 1.6, plan.duration_s - 0.05],
                                      height=200, width=260)
    except scenes.RenderingUnavailable as reason:
        print(f"frames skipped: {reason}")
        return 0
    strip = np.concatenate(frames, axis=1)
    path = args.out / "robot_push_frames.png"
    plt.imsave(path, strip)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
