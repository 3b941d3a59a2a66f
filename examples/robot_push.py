"""A SCARA arm pushes a part across a vibrating plate, at the robot's 1 ms timestep (the
vibration averaged into the part's friction), with and without the vibration.

    python examples/robot_push.py
"""
import numpy as np

from vibrofriction.robots import scenes


def main() -> None:
    for vibration in (False, True):
        run = scenes.run_push("averaged", vibration=vibration)
        part = run.sensor("part_position")
        push = run.sensor("push_force")
        print(f"vibration {'on ' if vibration else 'off'}: part moved "
              f"{1e3 * float(np.linalg.norm(part[-1, :2] - part[0, :2])):.1f} mm, peak push "
              f"force {float(push.max()):.2f} N ({run.wall_s:.2f} s wall)")


if __name__ == "__main__":
    main()
