#!/usr/bin/env python3
"""Steps per second against batch size: the batched twin (MuJoCo Warp, vibrofriction.batched)
next to mujoco.rollout with the C++ plugins, on the same scene, measured side by side in one run.

    scripts/bench_batched.py [--scene feeder_map | plate:N] [--batches 1,10,100,1000]
                             [--seconds 1.5] [--threads T] [--device cpu]

Prints, per batch size, world-steps per second (one world advanced by one timestep) of each
and their ratio (batched / rollout). The device is Warp's default unless --device names one:
on a machine without a GPU, Warp's CPU device. The GPU measurement is for a session with a
device (docs/batched.md).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np


def _scene(name: str):
    from vibrofriction.robots.scenes import feeder_plate_scene, scene_path
    if name.startswith("plate:"):
        return feeder_plate_scene(int(name.split(":")[1]))
    return str(scene_path(name))


def _rollout_rate(xml_or_path, nworld: int, nstep: int, threads: int) -> float:
    import mujoco
    from mujoco import rollout
    import vibrofriction
    vibrofriction.load()
    model = (mujoco.MjModel.from_xml_string(xml_or_path) if "<mujoco" in xml_or_path
             else mujoco.MjModel.from_xml_path(xml_or_path))
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    state = np.empty(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data, state, kind)
    states = np.tile(state, (nworld, 1))
    control = np.zeros((nworld, nstep, model.nu))
    datas = [mujoco.MjData(model) for _ in range(threads)]
    with rollout.Rollout(nthread=threads) as runner:
        runner.rollout(model, datas, states[:1], control[:1, :2], nstep=2)  # warm up
        start = time.perf_counter()
        runner.rollout(model, datas, states, control, nstep=nstep)
        wall = time.perf_counter() - start
    return nworld * nstep / wall


def _twin_rate(xml_or_path, nworld: int, nstep: int, device) -> tuple[float, str]:
    import warp as wp
    from vibrofriction.batched import BatchedTwin
    twin = BatchedTwin(xml_or_path, nworld, device=device)
    twin.step(2)  # compiles the kernels for this model
    wp.synchronize_device(twin.device)
    start = time.perf_counter()
    twin.step(nstep)
    wp.synchronize_device(twin.device)
    wall = time.perf_counter() - start
    return nworld * nstep / wall, str(twin.device)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="feeder_map",
                        help="a robot scene name (feeder_map) or plate:N (N parts on a plate)")
    parser.add_argument("--batches", default="1,10,100,1000")
    parser.add_argument("--seconds", type=float, default=1.5,
                        help="about how long each measurement runs")
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1,
                        help="mujoco.rollout's threads (default: every core)")
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    args = parser.parse_args(argv)
    from vibrofriction.batched import unavailable_reason
    reason = unavailable_reason()
    if reason is not None:
        print(f"skipped: {reason}")
        return 0
    import warp as wp
    wp.config.quiet = True
    scene = _scene(args.scene)
    batches = [int(b) for b in args.batches.split(",")]
    # a first pass of few steps sizes each measurement to about --seconds
    print(f"scene {args.scene}; mujoco.rollout with the C++ plugins on {args.threads} threads; "
          f"batched twin on MuJoCo Warp")
    print(f"{'worlds':>7} | {'batched world-steps/s':>22} | {'rollout world-steps/s':>22} | "
          f"{'batched / rollout':>17} | device")
    for nworld in batches:
        probe, device = _twin_rate(scene, nworld, 3, args.device)
        twin_steps = max(3, int(args.seconds * probe / nworld))
        twin, device = _twin_rate(scene, nworld, twin_steps, args.device)
        probe = _rollout_rate(scene, nworld, 20, args.threads)
        cpp_steps = max(20, int(args.seconds * probe / nworld))
        cpp = _rollout_rate(scene, nworld, cpp_steps, args.threads)
        print(f"{nworld:>7} | {twin:>22,.0f} | {cpp:>22,.0f} | {twin / cpp:>17.3f} | {device}",
              flush=True)
    print("GPU: not measured here (no device in this run); run this script where Warp has a "
          "CUDA device.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
