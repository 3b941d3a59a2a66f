"""The one-step response of the friction element (J M^-1 J', free velocity) when M changes.

The element keeps M^-1 J' between steps while the factorization of M is bitwise the same (the rig
of slide joints); on an arm whose inertia changes every step it must solve again. A rigid Coulomb
joint that must stay stuck shows it: its stick force is right only with this step's M.
"""
from __future__ import annotations

import mujoco
import numpy as np

import vibrofriction

ARM = """
<mujoco>
  <option timestep="1e-3" integrator="Euler"/>
  <extension>
    <plugin plugin="vibrofriction.friction">
      <instance name="wrist_friction">
        <config key="law" value="coulomb"/>
        <config key="mu" value="1"/>
        <config key="normal" value="100"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" mass="0.8"/>
        <body name="hand" pos="0.25 0 0">
          <joint name="wrist" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.15 0 0" size="0.02" mass="0.5"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <plugin name="wrist_friction" joint="wrist" instance="wrist_friction" actdim="1"/>
  </actuator>
</mujoco>
"""


def test_stuck_joint_stays_stuck_while_the_arm_inertia_changes():
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_string(ARM)
    data = mujoco.MjData(model)
    wrist = model.joint("wrist").dofadr[0]
    elbow = model.joint("elbow").qposadr[0]
    data.qpos[model.joint("wrist").qposadr[0]] = 0.4
    data.qvel[model.joint("shoulder").dofadr[0]] = 3.0  # the arm swings, the elbow folds
    elbow_angles, wrist_speeds = [], []
    for _ in range(1500):
        mujoco.mj_step(model, data)
        elbow_angles.append(data.qpos[elbow])
        wrist_speeds.append(data.qvel[wrist])
    assert np.ptp(elbow_angles) > 0.5  # M changed a lot over the run
    # Gravity and the swing need a few N m at the wrist, far below the 100 N m static level:
    # the wrist sticks exactly when the stick force used this step's inertia.
    assert np.max(np.abs(wrist_speeds)) < 1e-10
