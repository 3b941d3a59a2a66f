"""Add the friction element to your own MJCF scene: a block on a plate, pulled by a motor.

The element is an actuator plugin on the block's slide joint; its contact deflection z is the
actuator's activation (simulation state), and the friction sensor reports F_F, z, v, F_N.
Pulled below the friction level mu F_N, the block moves by the contact's pre-sliding
(Dahl) deflection: micrometres, not a slide.

    python examples/add_friction_to_your_scene.py
"""
import mujoco

import vibrofriction

SCENE = """
<mujoco model="block on a plate">
  <option timestep="1e-5" integrator="Euler"/>
  <extension>
    <plugin plugin="vibrofriction.friction">
      <instance name="block_friction">
        <config key="law" value="dahl"/>
        <config key="mu" value="0.2"/>
        <config key="normal" value="50"/>        <!-- N -->
        <config key="stiffness" value="8e7"/>    <!-- N/m -->
      </instance>
    </plugin>
    <plugin plugin="vibrofriction.friction_sensor"/>
  </extension>
  <worldbody>
    <body name="block">
      <joint name="block_on_plate" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.02 0.02 0.01" mass="0.5"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="pull" joint="block_on_plate"/>
    <plugin name="friction" joint="block_on_plate" instance="block_friction" actdim="1"/>
  </actuator>
  <sensor>
    <plugin name="friction_state" plugin="vibrofriction.friction_sensor">
      <config key="actuator" value="friction"/>
    </plugin>
  </sensor>
</mujoco>
"""


def main() -> None:
    vibrofriction.load()  # registers the plugins (a plain `import mujoco` does too, installed)
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("pull").id] = 5.0  # N, below mu F_N = 10 N
    for _ in range(20000):  # 0.2 s
        mujoco.mj_step(model, data)
    friction, z = data.sensordata[0], data.sensordata[1]
    print(f"pulled with 5 N for 0.2 s: block at {1e6 * data.qpos[0]:.3f} um, "
          f"friction {friction:.3f} N, deflection z {1e6 * z:.4f} um")


if __name__ == "__main__":
    main()
