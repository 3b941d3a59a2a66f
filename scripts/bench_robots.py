#!/usr/bin/env python3
"""Parts on a flexible-feeder plate: the feeder map at the robot's 1 ms against the resolved
drop-in element at 10 us, side by side in one run, for 1 to 50 parts.

The plate moves like the feeder scenes' track (100 Hz, 20 deg throw line, Gamma 0.7; parts 30 g,
mu 0.3; vibrofriction.robots.scenes.FEEDER). Map: the plate still, each part a free body with
`vibrofriction.contact_feeder` (scenes.feeder_plate_scene(mode="map")). Resolved: the plate
vibrating through two `vibrofriction.motion` shakers, each part with `vibrofriction.contact`,
rigid Coulomb. For each part count: the CPU time of the stepping thread per simulated second
(one mj_step loop, best of `--rounds`), its growth per part, and the parts' mean conveying
speed against the exact reference (vibrofriction.oracle.feeder_reference). MuJoCo's soft contact, not
the element, sets the resolved run's error (docs/physics.md). Writes the cost against the parts
to docs/figures/robot_scaling.png (--out). Not a test: the ratios are the result.

    .venv/bin/python scripts/bench_robots.py [--parts 1 5 10 25 50] [--rounds 2] [--quick]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib
import mujoco
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import vibrofriction
from vibrofriction.robots import scenes

ROOT = Path(__file__).resolve().parents[1]


def _run(xml: str, duration_s: float, rounds: int) -> tuple[float, float, dict[str, int]]:
    """(CPU s per simulated s, mean conveying speed over the run's second half, warnings)."""
    model = mujoco.MjModel.from_xml_string(xml)
    steps = int(round(duration_s / model.opt.timestep))
    parts = [model.body(i).id for i in range(model.nbody) if model.body(i).name.startswith("part")]
    best, speed, warnings = np.inf, np.nan, {}
    for _ in range(rounds):
        data = mujoco.MjData(model)
        half = steps // 2
        start = time.thread_time()
        for k in range(steps):
            mujoco.mj_step(model, data)
            if k == half:
                x_half, t_half = data.xpos[parts, 0].copy(), data.time
        best = min(best, (time.thread_time() - start) / duration_s)
        speed = float(np.mean(data.xpos[parts, 0] - x_half) / (data.time - t_half))
        warnings = {mujoco.mjtWarning(i).name: int(data.warning[i].number)
                    for i in range(len(data.warning)) if data.warning[i].number}
    return best, speed, warnings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", type=int, nargs="+", default=[1, 5, 10, 25, 50])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--quick", action="store_true",
                        help="shorter runs (0.4 s map, 0.05 s resolved): costs only roughly")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    args = parser.parse_args(argv)
    if any(n < 1 for n in args.parts) or args.rounds < 1:
        parser.error("--parts and --rounds need positive integers")
    vibrofriction.load()
    feeder_map = scenes.feeder_map()
    exact = feeder_map.conveying_velocity_m_per_s
    map_s, resolved_s = (0.4, 0.05) if args.quick else (1.0, 0.3)
    print(f"exact conveying speed {exact * 1e3:.4f} mm/s; map {map_s} s at 1 ms, resolved "
          f"{resolved_s} s at 10 us simulated, best of {args.rounds}")
    print(f"{'parts':>5} {'map CPU s/sim s':>16} {'resolved':>10} {'ratio':>7} "
          f"{'map speed err':>14} {'resolved err':>13}")
    rows = []
    for n in args.parts:
        mapped = _run(scenes.feeder_plate_scene(n, mode="map", feeder_map_=feeder_map), map_s,
                      args.rounds)
        resolved = _run(scenes.feeder_plate_scene(n, mode="resolved"), resolved_s, args.rounds)
        for name, result in (("map", mapped), ("resolved", resolved)):
            if result[2]:
                print(f"MuJoCo warnings ({name}, {n} parts): {result[2]}")
                return 1
        rows.append((n, mapped[0], resolved[0]))
        print(f"{n:5d} {mapped[0]:16.4f} {resolved[0]:10.3f} {resolved[0] / mapped[0]:6.0f}x "
              f"{100 * (mapped[1] / exact - 1):+13.3f}% {100 * (resolved[1] / exact - 1):+12.2f}%")
    if len(rows) >= 2:
        n = np.log([r[0] for r in rows])
        for label, k in (("map", 1), ("resolved", 2)):
            slope = np.polyfit(n, np.log([r[k] for r in rows]), 1)[0]
            per_part = (rows[-1][k] - rows[0][k]) / (rows[-1][0] - rows[0][0])
            print(f"{label}: cost grows as parts^{slope:.2f}; {per_part * 1e3:.2f} ms CPU per "
                  "simulated second per added part")
        fig, ax = plt.subplots(figsize=(5, 3.4))
        parts = [r[0] for r in rows]
        ax.loglog(parts, [r[2] for r in rows], "o--", label="resolved: contact, plate vibrating, dt 10 us")
        ax.loglog(parts, [r[1] for r in rows], "s-", label="feeder map: contact_feeder, dt 1 ms")
        ax.axhline(1.0, color="0.6", lw=0.8)
        ax.text(parts[0], 1.15, "real time", fontsize=7, color="0.4")
        ax.set_xlabel("parts on the feeder plate")
        ax.set_ylabel("CPU s per simulated s")
        ax.legend(fontsize=7)
        ax.set_title("Flexible feeder, 100 Hz, Gamma 0.7 (scripts/bench_robots.py)", fontsize=8)
        fig.tight_layout()
        args.out.mkdir(parents=True, exist_ok=True)
        path = args.out / "robot_scaling.png"
        fig.savefig(path, dpi=80)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
