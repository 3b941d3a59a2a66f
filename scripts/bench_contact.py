#!/usr/bin/env python3
"""The drop-in element at robot timesteps against the resolved one, side by side in one run.

A 1 kg box on a plate, pushed along the vibration at half its friction level. Resolved:
`vibrofriction.contact` (Dahl, mu 0.2, 1 N/nm) on the plate vibrating at 1 kHz, 20 mm/s, at
dt = 10 us. Averaged: `vibrofriction.contact_averaged` with the table of that law and vibration,
the plate still, at 1 and 2 ms. For each: the part's mean creep velocity, and the CPU time of the
stepping thread per simulated second (one rollout call, best of `--rounds`: 1 s simulated
resolved, 20 s averaged, so that the averaged element's one-time reading of its table when an
MjData is made, printed apart, does not weigh on a short run). Not a test: the ratios are the
result.

    .venv/bin/python scripts/bench_contact.py [--rounds 3]
"""
from __future__ import annotations

import argparse
import functools
import time

import mujoco
import numpy as np
from mujoco import rollout

import vibrofriction
from vibrofriction.robots.averaged import Vibration, build_table
from vibrofriction.params import FrictionParameters

MU, GRAVITY, PUSH_FRACTION = 0.2, 9.81, 0.5
RESOLVED_S, AVERAGED_S = 1.0, 20.0  # simulated per rollout
PART = """
    <body name="part" pos="0 0 0.06">
      <freejoint/>
      <geom name="part" type="box" size="0.05 0.05 0.05" mass="1" condim="1"/>
      <plugin instance="part_friction"/>
    </body>"""


def resolved_scene() -> str:
    return f"""<mujoco>
  <option timestep="1e-5" integrator="implicitfast"/>
  <extension>
    <plugin plugin="vibrofriction.contact"><instance name="part_friction">
      <config key="law" value="dahl"/> <config key="mu" value="{MU}"/>
      <config key="stiffness" value="1e9"/> <config key="support" value="plate"/>
    </instance></plugin>
    <plugin plugin="vibrofriction.motion"><instance name="shaker">
      <config key="frequency" value="1000"/> <config key="velocity_amplitude" value="0.02"/>
    </instance></plugin>
  </extension>
  <worldbody>
    <body name="plate">
      <joint name="plate_x" type="slide" axis="1 0 0" armature="1e5"/>
      <geom name="plate" type="box" size="1 1 0.01" mass="10" condim="1"/>
    </body>{PART}
  </worldbody>
  <actuator><plugin joint="plate_x" instance="shaker"/></actuator>
</mujoco>"""


@functools.lru_cache(maxsize=None)
def _table():
    friction = FrictionParameters(law="dahl", friction_coefficient=MU,
                                  contact_stiffness_N_per_m=1e9)
    return build_table(friction, Vibration(1000.0, 0.02), GRAVITY)


def averaged_scene(timestep_s: float) -> str:
    table = _table()
    keys = "".join(f'<config key="{k}" value="{v}"/>'
                   for k, v in table.contact_config("plate").items())
    return f"""<mujoco>
  <option timestep="{timestep_s}" integrator="implicitfast"/>
  <extension><plugin plugin="vibrofriction.contact_averaged">
    <instance name="part_friction">{keys}</instance></plugin></extension>
  <worldbody>
    <body name="plate"><geom name="plate" type="box" size="1 1 0.01" mass="10" condim="1"/></body>
    {PART}
  </worldbody>
</mujoco>"""


def run(text: str, rounds: int, duration_s: float) -> tuple[float, float, float]:
    """Mean creep velocity over the second half, CPU seconds per simulated second, and the CPU
    seconds to make an MjData (the plugins read their config there)."""
    model = mujoco.MjModel.from_xml_string(text)
    begin = time.thread_time()
    data = mujoco.MjData(model)
    setup = time.thread_time() - begin
    steps = round(duration_s / model.opt.timestep)
    part = model.body("part").id
    data.xfrc_applied[part, 0] = PUSH_FRACTION * MU * GRAVITY
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    start = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, start, spec)
    # the push as rollout's control: xfrc_applied, the same every step
    push = np.tile(data.xfrc_applied.ravel(), (steps, 1))
    xfrc = mujoco.mjtState.mjSTATE_XFRC_APPLIED.value
    best = float("inf")
    for _ in range(rounds):
        fresh = mujoco.MjData(model)
        begin = time.thread_time()
        state, _ = rollout.rollout(model, fresh, start, push, control_spec=xfrc)
        best = min(best, time.thread_time() - begin)
    x = state[0, :, 1 + model.jnt_qposadr[model.body_jntadr[part]]]
    t = (np.arange(steps) + 1) * model.opt.timestep
    half = steps // 2
    return float(np.polyfit(t[half:], x[half:], 1)[0]), best / duration_s, setup


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    vibrofriction.load()
    v_ref, cpu_ref, _ = run(resolved_scene(), args.rounds, RESOLVED_S)
    print(f"resolved, dt 10 us: creep {v_ref * 1e3:.4f} mm/s, {cpu_ref:.3f} s CPU per simulated s")
    for dt in (1e-3, 2e-3):
        v, cpu, setup = run(averaged_scene(dt), args.rounds, AVERAGED_S)
        print(f"averaged, dt {dt * 1e3:g} ms: creep {v * 1e3:.4f} mm/s ({(v / v_ref - 1) * 100:+.2f} % "
              f"of resolved), {cpu * 1e3:.2f} ms CPU per simulated s: {cpu_ref / cpu:.0f}x cheaper; "
              f"making an MjData (reading the table) {setup * 1e3:.2f} ms once")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
