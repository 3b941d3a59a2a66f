#!/usr/bin/env python3
"""A vibratory bowl feeder at the robot's timestep: three parts climbing a helical track (two
turns, radius 100 mm, 20 mm a turn) with vibrofriction.contact_feeder's helix_pitch, against the
exact reference applied along the local track (vibrofriction.robots.bowl).

Writes mjcf_models/robots/bowl_feeder.xml (the map inlined; --write-scene), prints each part's
climbing speed at 1 and 2 ms against the reference, and writes docs/figures/robot_bowl.png (the
parts' paths and heights) and docs/figures/robot_bowl_frames.png (offscreen frames; skipped with
the reason when no EGL/OSMesa context can be made).
"""
from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import mujoco  # noqa: E402

import vibrofriction  # noqa: E402
from vibrofriction.robots import scenes  # noqa: E402
from vibrofriction.robots.bowl import (Bowl, bowl_map, bowl_scene_xml,  # noqa: E402
                                       helix_angle_of)

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "mjcf_models" / "robots" / "bowl_feeder.xml"
FIGURES = ROOT / "docs" / "figures"
BOWL = Bowl()
PARTS_AT_RAD = (0.3, 2.4, 4.5)
HEADER = """<!--
  A vibratory bowl feeder at the robot's timestep (1 ms), written by scripts/robot_bowl.py from
  vibrofriction.robots.bowl: a helical track (two turns at radius 100 mm, rising 20 mm a turn,
  36 flat segments a turn) on a still bowl; three 20 g parts, each a free body with
  vibrofriction.contact_feeder and helix_pitch: it conveys along the helix's upward tangent at
  the part, with the feeder map of the local track (Gamma 1.2 with gravity's part normal to the
  track, a 25 degree throw line, 50 Hz, mu 0.4).
-->
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-scene", action="store_true", help="rewrite bowl_feeder.xml")
    args = parser.parse_args()
    vibrofriction.load()
    reference = BOWL.reference_speed_m_per_s()
    if args.write_scene:
        SCENE.write_text(HEADER + bowl_scene_xml(BOWL, bowl_map(BOWL), parts_at_rad=PARTS_AT_RAD))
    text = SCENE.read_text()
    arc = math.hypot(BOWL.radius_m, BOWL.pitch_m / (2 * math.pi))
    print(f"reference climbing speed along the track: {reference * 1e3:.4f} mm/s")
    runs = {}
    for timestep in (1e-3, 2e-3):
        model = mujoco.MjModel.from_xml_string(text.replace('timestep="0.001"',
                                                            f'timestep="{timestep!r}"'))
        data = mujoco.MjData(model)
        parts = [model.body(f"part{i}").id for i in range(len(PARTS_AT_RAD))]
        times, angles, xyz, states = [], [], [], []
        start = time.process_time()
        for _ in range(round(4.0 / timestep)):
            mujoco.mj_step(model, data)
            times.append(data.time)
            angles.append([helix_angle_of(BOWL, data.xpos[b]) for b in parts])
            xyz.append(data.xpos[parts].copy())
        cpu = time.process_time() - start
        times, angles, xyz = np.array(times), np.unwrap(np.array(angles), axis=0), np.array(xyz)
        late = times > 1.0
        for k in range(len(parts)):
            speed = np.polyfit(times[late], angles[late, k], 1)[0] * arc
            print(f"dt {timestep * 1e3:g} ms part{k}: {speed * 1e3:.4f} mm/s "
                  f"({speed / reference - 1:+.2%}), climbed {(xyz[-1, k, 2] - xyz[0, k, 2]) * 1e3:.2f} mm")
        print(f"dt {timestep * 1e3:g} ms: {cpu / 4.0:.4f} s CPU per simulated second")
        runs[timestep] = (model, times, xyz)
    model, times, xyz = runs[1e-3]
    FIGURES.mkdir(parents=True, exist_ok=True)
    fig, (top, side) = plt.subplots(1, 2, figsize=(10, 4.2))
    phi = np.linspace(0, 2 * math.pi * BOWL.turns, 400)
    top.plot(BOWL.radius_m * np.cos(phi) * 1e3, BOWL.radius_m * np.sin(phi) * 1e3, color="0.7",
             lw=6, label="track")
    for k in range(xyz.shape[1]):
        top.plot(xyz[:, k, 0] * 1e3, xyz[:, k, 1] * 1e3, lw=2, label=f"part{k}")
        side.plot(times, (xyz[:, k, 2] - xyz[0, k, 2]) * 1e3, label=f"part{k}")
    side.plot(times, reference * times * math.sin(BOWL.helix_angle_rad) * 1e3, "k--",
              label="exact reference")
    top.set_aspect("equal")
    top.set_xlabel("x (mm)"), top.set_ylabel("y (mm)"), top.set_title("paths (1 ms), seen from above")
    side.set_xlabel("time (s)"), side.set_ylabel("height climbed (mm)")
    side.set_title("climbing (1 ms)"), side.legend()
    fig.tight_layout()
    fig.savefig(FIGURES / "robot_bowl.png", dpi=110)
    print(f"wrote {FIGURES / 'robot_bowl.png'}")
    try:
        renderer = scenes.make_renderer(model, 240, 320)
    except scenes.RenderingUnavailable as error:
        print(f"frames skipped: {error}")
        return
    data = mujoco.MjData(model)
    frames = []
    for t in (0.0, 2.0, 4.0):
        mujoco.mj_resetData(model, data)
        mujoco.mj_step(model, data, nstep=round(t / model.opt.timestep))
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera="overview")
        frames.append(renderer.render().copy())
    renderer.close()
    fig, axes = plt.subplots(1, len(frames), figsize=(3.3 * len(frames), 2.6))
    for ax, frame, t in zip(axes, frames, (0.0, 2.0, 4.0)):
        ax.imshow(frame), ax.set_title(f"t = {t:g} s"), ax.axis("off")
    fig.tight_layout()
    fig.savefig(FIGURES / "robot_bowl_frames.png", dpi=110)
    print(f"wrote {FIGURES / 'robot_bowl_frames.png'}")


if __name__ == "__main__":
    main()
