#!/usr/bin/env python3
"""A real arm (dm_control's Kinova Jaco) with the drop-in elements: it sets a part on a
vibrating inclined plate and picks a part off a vibratory feeder, with and without vibration,
resolved (dt 10 us) and at its own 1 ms (vibrofriction.robots.robot_arm).

Prints, for the four runs: the placed part's speed down the slope against the heavy-body value
(v_a sin(pi/2 tan(theta)/mu)), where the first feeder part ends (the tray, or still on the
track), and the wall time per simulated second. Writes docs/figures/robot_arm.png (the placed
part's travel down the slope and the first feeder part's travel along the track, the four runs)
and docs/figures/robot_arm_frames.png (offscreen frames of the 1 ms run with vibration; skipped
with the reason where no EGL/OSMesa context can be made). Needs dm-control
(`pip install 'vibrofriction[robots]'`). About 1.5 minutes (the resolved runs).

    .venv/bin/python scripts/robot_arm.py [--quick] [--out DIR]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from vibrofriction.robots import robot_arm, scenes  # noqa: E402
from vibrofriction.params import ParameterError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def slope_travel(run) -> np.ndarray:
    """The placed part's travel down the slope (m), from its position at 5 s (once set down)."""
    p = run.sensor("plate_part_position")
    tilt = robot_arm.CELL_PLATE_TILT_RAD
    along = p[:, 0] * math.cos(tilt) - p[:, 2] * math.sin(tilt)
    k = int(np.searchsorted(run.time_s, 5.0))
    return along - along[min(k, len(along) - 1)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--quick", action="store_true", help="the 1 ms runs only")
    args = parser.parse_args(argv)
    try:
        robot_arm.jaco_model_dir()
    except ParameterError as reason:
        print(reason, file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    modes = ("robot",) if args.quick else ("robot", "resolved")
    runs = {}
    for mode in modes:
        for vibration in (True, False):
            run = robot_arm.run_cell(mode, vibration)
            if run.warnings:
                print(f"MuJoCo warnings ({mode}, vibration {vibration}): {run.warnings}",
                      file=sys.stderr)
                return 1
            runs[mode, vibration] = run
    expected = robot_arm.plate_creep_velocity_m_per_s()
    print(f"heavy-body creep down the {math.degrees(robot_arm.CELL_PLATE_TILT_RAD):.0f} deg "
          f"slope: {expected * 1e3:.2f} mm/s")
    print(f"{'mode':<9} {'vibration':>9} {'dt (s)':>7} {'down the slope (mm/s)':>22} "
          f"{'feeder part 0 ends':>22} {'wall s per sim. s':>18}")
    for (mode, vibration), run in runs.items():
        t = run.time_s
        late = t >= 6.0
        speed = np.polyfit(t[late], slope_travel(run)[late], 1)[0]
        end = run.sensor("feeder_part0_position")[-1]
        tray = np.hypot(end[0] - robot_arm.TRAY_CENTRE[0], end[1] - robot_arm.TRAY_CENTRE[1])
        where = "in the tray" if tray < 0.08 else f"at x = {end[0]:.3f} m"
        print(f"{mode:<9} {'on' if vibration else 'off':>9} {run.model.opt.timestep:7.0e} "
              f"{speed * 1e3:22.2f} {where:>22} {run.wall_s / t[-1]:18.3f}")
    if ("resolved", True) in runs:
        ratio = runs["resolved", True].wall_s / runs["robot", True].wall_s
        print(f"the 1 ms run costs {ratio:.0f}x less wall time than the resolved one")

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
    for (mode, vibration), run in runs.items():
        style = "-" if mode == "robot" else "--"
        color = "C3" if vibration else "C7"
        label = f"{'1 ms' if mode == 'robot' else 'resolved 10 us'}, vibration " \
                f"{'on' if vibration else 'off'}"
        axes[0].plot(run.time_s, 1e3 * slope_travel(run), style, color=color, label=label)
        x = run.sensor("feeder_part0_position")[:, 0]
        axes[1].plot(run.time_s, 1e3 * (x - x[0]), style, color=color, label=label)
    t = np.linspace(5.0, robot_arm.DURATION_S, 2)
    axes[0].plot(t, 1e3 * expected * (t - 5.0), ":", color="k", label="heavy-body creep")
    axes[0].set_xlim(4.5, robot_arm.DURATION_S)
    axes[0].set_xlabel("time (s)")
    axes[0].set_ylabel("placed part, travel down the slope (mm)")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("time (s)")
    axes[1].set_ylabel("feeder part 0, travel along x (mm)")
    axes[1].set_title("conveyed to the stop, picked at 6.9 s, dropped in the tray", fontsize=8)
    fig.suptitle("Kinova Jaco (dm_control) with vibrofriction.contact / contact_averaged / "
                 "contact_feeder", fontsize=10)
    fig.tight_layout()
    path = args.out / "robot_arm.png"
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")
    try:
        frames = scenes.render_frames(runs["robot", True], (1.8, 3.6, 7.0, 9.9))
    except scenes.RenderingUnavailable as reason:
        print(f"frames skipped: {reason}")
        return 0
    path = args.out / "robot_arm_frames.png"
    plt.imsave(path, np.concatenate(frames, axis=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
