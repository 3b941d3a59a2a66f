"""N parts on a vibratory feeder plate, many environments at once (MuJoCo Warp, batched).

A gym-style vectorized environment: each of ``nworld`` worlds is the flexible-feeder plate of
``vibrofriction.robots.scenes.feeder_plate_scene`` (``parts`` free 30 g parts, the
``vibrofriction.contact_feeder`` element at 1 ms), stepped together by
``vibrofriction.batched.BatchedTwin``. The action is a horizontal force per part (a pusher, a
policy's output), applied through ``xfrc_applied``; the observation is each part's position and
velocity; the reward is the mean conveying speed. The worlds differ in their friction
coefficient across the track (``mu``): domain randomization, one batch.

Needs the optional extra: pip install 'vibrofriction[batched]'. Runs on Warp's CPU device
without a GPU (slowly: docs/batched.md has the numbers).

    python examples/batched_feeder_env.py [--worlds 16] [--parts 4] [--steps 200]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


class BatchedFeederEnv:
    """reset() -> obs (nworld, parts, 6); step(action (nworld, parts, 2)) -> obs, reward
    (nworld,), done (nworld,)."""

    def __init__(self, nworld: int, parts: int, *, seed: int = 0, episode_steps: int = 500):
        import warp as wp
        from vibrofriction.batched import BatchedTwin
        from vibrofriction.robots.scenes import feeder_plate_scene
        wp.config.quiet = True
        self._wp = wp
        self.twin = BatchedTwin(feeder_plate_scene(parts), nworld)
        self.nworld, self.parts = nworld, parts
        self.episode_steps = episode_steps
        model = self.twin.model
        self._bodies = [model.body(f"part{k}").id for k in range(parts)]
        self._qveladr = [model.jnt_dofadr[model.body_jntadr[b]] for b in self._bodies]
        self._initial = {name: self.twin.numpy(name).copy() for name in ("qpos", "qvel")}
        rng = np.random.default_rng(seed)
        self.mu = rng.uniform(0.25, 0.35, size=(nworld, 1)).repeat(parts, axis=1)
        self.twin.set_parameter("mu", self.mu)
        self._t = 0

    def _obs(self) -> np.ndarray:
        xpos = self.twin.numpy("xpos")[:, self._bodies]
        qvel = self.twin.numpy("qvel")
        vel = np.stack([qvel[:, a:a + 3] for a in self._qveladr], axis=1)
        return np.concatenate([xpos, vel], axis=-1)

    def reset(self) -> np.ndarray:
        wp = self._wp
        for name, values in self._initial.items():
            wp.copy(getattr(self.twin.data, name),
                    wp.array(values, dtype=float, device=self.twin.device))
        self.twin.import_plugin_state(None)
        self._t = 0
        return self._obs()

    def step(self, action: np.ndarray):
        wp = self._wp
        xfrc = self.twin.numpy("xfrc_applied")
        xfrc[:, self._bodies, :2] = action
        wp.copy(self.twin.data.xfrc_applied,
                wp.array(xfrc, dtype=wp.spatial_vector, device=self.twin.device))
        self.twin.step()
        self._t += 1
        obs = self._obs()
        reward = obs[:, :, 3].mean(axis=1)  # conveying speed along the track (x)
        done = np.full(self.nworld, self._t >= self.episode_steps)
        return obs, reward, done


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=16)
    parser.add_argument("--parts", type=int, default=4)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args(argv)
    from vibrofriction.batched import unavailable_reason
    reason = unavailable_reason()
    if reason is not None:
        print(f"skipped: {reason}")
        return 0
    import time
    env = BatchedFeederEnv(args.worlds, args.parts)
    env.reset()
    env.step(np.zeros((args.worlds, args.parts, 2)))  # the first step compiles the kernels
    env.reset()
    start = time.perf_counter()
    reward = np.zeros(args.worlds)
    for _ in range(args.steps):  # no push: the feeder alone conveys the parts
        _, reward, _ = env.step(np.zeros((args.worlds, args.parts, 2)))
    wall = time.perf_counter() - start
    print(f"{args.worlds} worlds x {args.parts} parts, {args.steps} steps of 1 ms in "
          f"{wall:.1f} s ({args.worlds * args.steps / wall:.0f} world-steps/s)")
    print(f"conveying speed after {args.steps} ms: {reward.mean() * 1e3:.3f} mm/s "
          f"(min {reward.min() * 1e3:.3f}, max {reward.max() * 1e3:.3f} over the worlds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
