// Actuator plugin "vibrofriction.motion": drives its transmission along a prescribed motion
//   s(t) = s0 + velocity * t + (velocity_amplitude / omega) sin(omega t + phase),  omega = 2 pi f
// so that its velocity is  velocity + velocity_amplitude cos(omega t + phase).
// Used for the vibrating table (velocity = 0) and for the far end of the drive spring
// (velocity = v_d, no vibration). Each step it applies the force that puts the position on
// s(t + dt) at the end of a semi-implicit Euler step, given every force known when it runs
// (passive, bias, applied, built-in actuators and plugins declared before it). Forces computed
// after it (e.g. the friction element) act as a disturbance that it corrects one step later,
// so give the driven body a large apparent mass (armature) to keep that error negligible; the
// achieved motion is reported by ordinary joint sensors and checked by the tests.
// start_time (s): the vibration is off before it (a stage without vibration first) and
// ramp_periods its amplitude's build-up, (1 - cos(pi tau / T)) / 2 over T = ramp_periods / f
// (a shaker's; tau = t - start_time), so that neither the velocity nor the acceleration jumps.
// use_ctrl="true": ctrl scales the vibration amplitude (1 = as configured).
// displacement_from_ctrl="true": ctrl is the displacement from the reference length to reach
// at the end of the step (a measured motion replayed; identification drives the rig with it).
#ifndef VIBROFRICTION_SUPPORT_MOTION_H_
#define VIBROFRICTION_SUPPORT_MOTION_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"

namespace vibrofriction {

struct MotionConfig {
  double frequency = 0.0;           // f (Hz)
  double velocity_amplitude = 0.0;  // v_a (m/s or rad/s)
  double velocity = 0.0;            // constant drift velocity (m/s or rad/s)
  double phase = 0.0;               // (rad)
  double start_time = 0.0;          // vibration off before it (s)
  double ramp_periods = 0.0;        // amplitude build-up after start_time (vibration periods)
  bool use_ctrl = false;            // scale the amplitude by ctrl
  bool displacement_from_ctrl = false;  // ctrl = displacement at the end of the step (m or rad)
  int actuator = -1;
  int output = -1;

  static bool FromModel(const mjModel* m, int instance, MotionConfig* config,
                        ReadScope scope = ReadScope::kAll);
  // Prescribed displacement from the transmission's reference length at time t.
  double Displacement(double t, double amplitude_scale) const;
};

class SupportMotion {
 public:
  static constexpr char kName[] = "vibrofriction.motion";
  // From a validated config (SetPluginCallbacks builds one per plugin instance).
  explicit SupportMotion(CachedConfig<MotionConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel* m, int instance) { return 0; }
  void Compute(const mjModel* m, mjData* d, int instance);

 private:
  CachedConfig<MotionConfig> config_;
  StepResponseWorkspace response_workspace_;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_SUPPORT_MOTION_H_
