"""A Gymnasium-style environment around a robot scene with vibration-assisted friction.

`PlatePushEnv` follows Gymnasium's `reset()` / `step(action)` protocol (observation, reward,
terminated, truncated, info) without depending on it: the action is the pusher's velocity
command in the plane and the plate's vibration gate (0..1); the reward is the part's progress
along x less the pushing effort (the pusher's contact force times the step), so a policy gains
by switching the vibration on: it lowers the force needed to move the part. Wrap it with `gymnasium.Env` and `spaces.Box` if you train with Gymnasium.

    python examples/gym_style_env.py
"""
import mujoco
import numpy as np

from vibrofriction.robots import scenes


EFFORT_WEIGHT_M_PER_N_S = 1e-3  # reward lost per N s of pushing, in m of progress


class PlatePushEnv:
    """The plate-push scene at the robot's timestep (averaged friction)."""

    def __init__(self, steps_per_action: int = 10, max_steps: int = 200):
        self.model = scenes.load_model("plate_push_averaged")
        self.data = mujoco.MjData(self.model)
        self.steps_per_action = steps_per_action
        self.max_steps = max_steps
        self.actuator = {name: self.model.actuator(name).id for name in (
            "shoulder", "elbow", "quill", "part_friction_x")}
        self.plan = scenes.PushPlan()

    def _observation(self) -> np.ndarray:
        part = self.data.sensor("part_position").data[:2]
        pusher = self.data.sensor("pusher_position").data[:2]
        return np.concatenate([part, pusher]).astype(np.float64)

    def reset(self, seed: int | None = None):
        x, y, _ = self.plan.pusher(self.plan.push_start_s)  # pusher at the part, lowered
        q1, q2 = scenes.scara_ik(x, y)
        ctrl0 = np.zeros(self.model.nu)
        ctrl0[[self.actuator["shoulder"], self.actuator["elbow"]]] = q1, q2
        state = scenes.initial_state(self.model, ctrl0, {"shoulder": q1, "elbow": q2})
        mujoco.mj_setState(self.model, self.data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        mujoco.mj_forward(self.model, self.data)  # the sensors of the reset state
        self.target = np.array([x, y])
        self.steps = 0
        return self._observation(), {}

    def step(self, action):
        velocity, gate = np.asarray(action[:2], dtype=float), float(np.clip(action[2], 0, 1))
        before = self.data.sensor("part_position").data[0]
        dt = self.model.opt.timestep * self.steps_per_action
        self.target = self.target + velocity * dt
        q1, q2 = scenes.scara_ik(*self.target)
        self.data.ctrl[self.actuator["shoulder"]] = q1
        self.data.ctrl[self.actuator["elbow"]] = q2
        self.data.ctrl[self.actuator["quill"]] = 0.0
        self.data.ctrl[self.actuator["part_friction_x"]] = gate
        mujoco.mj_step(self.model, self.data, nstep=self.steps_per_action)
        self.steps += 1
        push_N = float(self.data.sensor("push_force").data[0])
        progress_m = float(self.data.sensor("part_position").data[0] - before)
        reward = progress_m - EFFORT_WEIGHT_M_PER_N_S * push_N * dt
        info = {"push_force_N": push_N, "progress_m": progress_m}
        return self._observation(), reward, False, self.steps >= self.max_steps, info


def main() -> None:
    env = PlatePushEnv()
    for gate in (0.0, 1.0):
        env.reset()
        total_reward, forces, truncated = 0.0, [], False
        while not truncated:
            _, reward, _, truncated, info = env.step([0.03, 0.0, gate])  # push at 30 mm/s
            total_reward += reward
            forces.append(info["push_force_N"])
        moved = float(env.data.sensor("part_position").data[0] - env.plan.part_xy_m[0])
        print(f"vibration gate {gate:.0f}: part moved {1e3 * moved:.1f} mm, mean push force "
              f"{np.mean(forces):.2f} N, return {1e3 * total_reward:.2f} mm")


if __name__ == "__main__":
    main()
