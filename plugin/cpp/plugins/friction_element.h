// Actuator (+ optional sensor) plugin "vibrofriction.friction": a dynamic friction element on one
// actuator transmission (a slide joint of a body relative to its support, or a fixed tendon
// x_body - x_support). The transmission velocity is the relative velocity v_r; the actuator
// applies -F_F. The deflection z is mjData.act[actadr] (declare actdim="1"); law gms keeps one
// per element in act (actdim = the number of elements) and their slip flags in plugin_state.
//
// The force of step n uses (z_n, v_n); after MuJoCo integrates the velocity, `advance` replaces z
// by the closed-form (Dahl, LuGre) or unconditionally stable (Dupont) update with the *new*
// velocity v_{n+1}: a symplectic-Euler pair that neither pumps energy into a stuck contact nor
// diverges at dt = 1e-4 s. act_dot stays 0 because z is not integrated by MuJoCo.
// That pair is stable only while k_t dt^2 J M^-1 J' < 4: a step that does not resolve the
// contact (k_t dt B >= 1 or sigma1 B >= 1, B = dt J M^-1 J'; a robot's joint
// friction at 1-2 ms) is taken implicitly instead, as the planar and contact elements' (the
// force of the deflection at the end of the step, with the end-of-step velocity solved from
// the one-step response; advance keeps that deflection).
#ifndef VIBROFRICTION_FRICTION_ELEMENT_H_
#define VIBROFRICTION_FRICTION_ELEMENT_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"

#include "common/element_config.h"
#include "laws/friction_law.h"

namespace vibrofriction {

struct FrictionConfig {
  LawParameters law;
  int actuator = -1;        // actuator id backed by the instance
  int output = -1;          // its force-output address
  int act_address = -1;     // z lives at act[act_address]
  NormalLoad normal;        // F_N from the config, a sensor or the contacts of two geoms
  int lag_state = 0;        // plugin_state offset of the lagged friction force
  int slip_state = 0;       // plugin_state offset of the gms elements' slip flags
  double sensor_lag = 0.0;  // first-order lag of the reported friction force (s)

  // Reads and validates every attribute (and, with ReadScope::kAll, the actuator); returns
  // false after recording the error, naming the attribute and the fix.
  static bool FromModel(const mjModel* m, int instance, FrictionConfig* config,
                        ReadScope scope = ReadScope::kAll);
};

class FrictionElement {
 public:
  static constexpr char kName[] = "vibrofriction.friction";
  // F_F, z (gms: sum k_i z_i / sum k_i), v_r, F_N (modulated), F_F lagged
  static constexpr int kSensorDim = 5;

  // From a validated config (SetPluginCallbacks builds one per plugin instance).
  explicit FrictionElement(CachedConfig<FrictionConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();

  void Compute(const mjModel* m, mjData* d, int instance);
  // Writes kSensorDim values of this element's state to `out` (vibrofriction.*_sensor).
  void WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* out);
  void Advance(const mjModel* m, mjData* d, int instance);
  static int StateSize(const mjModel* m, int instance);

 private:
  LawInput Input(const mjModel* m, const mjData* d, int instance, double velocity) const;
  double Deflection(const mjData* d) const;  // the sensor's z

  // A state law's step that does not resolve the contact: the force of the deflection at the
  // end of the step at the end-of-step velocity w solving w + B F(w) = v_free, where the
  // deflection follows the law's exact update at w (the level frozen at the step's start
  // speed). Writes the deflections (gms: and slip flags) after the step to implicit_next_.
  double ImplicitDeflectionForce(const mjModel* m, mjData* d, int instance, const LawInput& in,
                                 const StepResponse& response);

  CachedConfig<FrictionConfig> config_;
  StepResponseWorkspace response_workspace_;
  // This step was taken implicitly: advance takes implicit_next_ (and, gms, the flags).
  bool implicit_step_ = false;
  double implicit_next_[kMaxGmsElements] = {};
  double implicit_slipping_[kMaxGmsElements] = {};
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_FRICTION_ELEMENT_H_
