// Sensor plugins reporting the state of a friction element, named by (one of) its actuators:
//   vibrofriction.friction_sensor  (vibrofriction.friction; 5 values: F_F, z, v_r, F_N, lagged F_F)
//   vibrofriction.planar_sensor    (vibrofriction.planar or vibrofriction.averaged; 7 values:
//                                   F_x, F_y, z_x, z_y, v_x, v_y, F_N)
//   <sensor>
//     <plugin name="contact_state" plugin="vibrofriction.friction_sensor">
//       <config key="actuator" value="friction"/>
//     </plugin>
//   </sensor>
// They are plugins of their own because MuJoCo runs mj_rnePostConstraint every step for any
// plugin with an acceleration-stage sensor capability, whether or not a sensor uses it: an
// element without its sensor costs nothing there.
#ifndef VIBROFRICTION_STATE_SENSOR_H_
#define VIBROFRICTION_STATE_SENSOR_H_

namespace vibrofriction {

void RegisterStateSensors();

}  // namespace vibrofriction

#endif  // VIBROFRICTION_STATE_SENSOR_H_
