// Actuator (+ optional sensor) plugin "vibrofriction.planar": isotropic dynamic friction of a
// body sliding in a plane over its (possibly vibrating) support. ONE instance backs TWO
// actuators, declared in order x then y, each on a transmission that measures the body's motion
// relative to the support along one of two orthogonal in-plane directions (slide joints of the
// body inside the support body, or fixed tendons). Each actuator has actdim="1": the deflection
// vector z = (z_x, z_y) is (act[x], act[y]). Law gms: actdim = its number of elements on both,
// element i's z = (act[x + i], act[y + i]), its slip flag in plugin_state.
//
// With v = (v_x, v_y) the relative velocity (the two transmission velocities):
//   dahl    dz/dt = |v| |e|^(alpha-1) e,   e = v/|v| - z/z_c,  z_c = g(|v|) / k_t
//   lugre   dz/dt = v - |v| z / z_g(|v|),  z_g = g(|v|) / k_t
//   dupont  dz/dt = v - a(|z|) |v| z / z_max(|v|), a = 0 unless z.v > 0 (loading) and |z| > z_ba
//   F = k_t z + sigma1 dz/dt + sigma2 v;    the actuators apply -F.
//   gms     elements i with z_i following v while stuck, |k_i z_i| held at weight_i g(|v|) while
//           slipping (friction_law.h, AdvanceGms); F = sum k_i z_i + sigma2 v
//   coulomb F = g(|v|) u/|u| + sigma2 v with u the end-of-step velocity (time-stepping, maximal
//           dissipation), or the force that stops the body within the step when |F| <= F_s.
// Each law reduces exactly to the 1D law of vibrofriction.friction when v and z lie on one axis.
// Step order as vibrofriction.friction: the force of step n uses (z_n, v_n); `advance` updates z
// in closed form (Dahl, LuGre) or unconditionally stably (Dupont) with the new velocity v_{n+1}.
// A step that does not resolve the deflection dynamics (k_t dt lambda_max(B) >= 1, B the
// transmissions' response) is taken implicitly instead: the force of the deflection at the end
// of the step, solved with the end-of-step velocity (VectorImplicitDeflectionForce,
// GmsImplicitDeflectionForce), and that deflection kept.
//
// Normal load F_N = normal + normal_gain * (sensor value | contact normal force between
// contact_geom1 and contact_geom2). Both the sensor and the contact force are those of the
// previous step (the actuators are computed before the constraint solve); the contact force is
// summed over every contact between the two geoms in `advance` and kept in plugin_state.
#ifndef VIBROFRICTION_PLANAR_FRICTION_H_
#define VIBROFRICTION_PLANAR_FRICTION_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"

#include "common/element_config.h"
#include "laws/friction_law.h"

namespace vibrofriction {


// The two actuators of a planar instance and their outputs, checked for orthogonality.
struct PlanarTransmission {
  int actuator[2] = {-1, -1};
  int output[2] = {-1, -1};
  static bool FromModel(const mjModel* m, int instance, const char* plugin, bool need_state,
                        PlanarTransmission* out);
};

// A planar element's config made current for this step (CachedConfig::Refresh); when it
// cannot be read, the element's two forces are zeroed (no force from a bad config) and false
// returned. Both planar elements (planar, averaged) begin their Compute with it.
template <class Config>
bool RefreshOrZeroForces(CachedConfig<Config>& config, const mjModel* m, mjData* d,
                         int instance) {
  if (config.Refresh(m, instance)) return true;
  const int* out = config->transmission.output;
  if (out[0] >= 0) d->actuator_force[out[0]] = 0;
  if (out[1] >= 0) d->actuator_force[out[1]] = 0;
  return false;
}

// Response of the two transmissions to their forces over one semi-implicit Euler step:
// v_next = v_free + B f, B = dt J M^-1 J' (row-major 2x2), every force known at this point
// (passive, bias, applied, actuators other than these two) and the previous step's constraint
// force (contacts, limits, equalities: the current one is solved after the actuators) included
// in v_free. In steady contact (a part pushed by a robot) the two agree and the implicit
// friction solve is unbiased; when a contact appears or breaks the estimate lags one step.
struct PlanarResponse {
  double v_free[2] = {0.0, 0.0};
  double B[4] = {0.0, 0.0, 0.0, 0.0};
};
void ComputePlanarResponse(const mjModel* m, mjData* d, const int output[2],
                           std::vector<mjtNum>* scratch, PlanarResponse* response);

struct PlanarConfig {
  LawParameters law;
  NormalLoad normal;
  PlanarTransmission transmission;
  int act_address[2] = {-1, -1};
  int slip_state = 0;  // plugin_state offset of the gms elements' slip flags

  static bool FromModel(const mjModel* m, int instance, PlanarConfig* config,
                        ReadScope scope = ReadScope::kAll);
};

// The fewest steps a vibration period that the elements resolving the vibration (friction,
// planar, contact) accept at compile time: below it the vibration is not simulated but
// aliased (at 2 steps a period a sine is sampled at its zeros), and the averaged elements are
// the ones for such a timestep.
inline constexpr double kMinStepsPerPeriod = 10.0;

// Refuses a vibration that the element resolves but the model's timestep cannot: a
// vibrofriction.motion actuator with a vibration (frequency > 0, velocity_amplitude != 0) on one
// of the kinematic trees `trees` (dof_treeid values; -1 matches every tree), or the law's
// normal-load modulation, at fewer than kMinStepsPerPeriod steps a period. Records one line
// naming the timestep, the frequency and the fix (`fix`: the element that averages the
// vibration; null: none, a smaller timestep only) and returns false.
bool CheckVibrationResolved(const mjModel* m, const char* plugin, const std::vector<int>& trees,
                            const LawParameters& law, const char* fix);

class PlanarFriction {
 public:
  static constexpr char kName[] = "vibrofriction.planar";
  // F_x, F_y, z_x, z_y, v_x, v_y, F_N (modulated, unclamped: < 0 when the load lifts off)
  static constexpr int kSensorDim = 7;

  // From a validated config (SetPluginCallbacks builds one per plugin instance).
  explicit PlanarFriction(CachedConfig<PlanarConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel* m, int instance) {
    return NormalLoad::StateSize(m, instance) + GmsElementCount(m, instance);
  }

  void Compute(const mjModel* m, mjData* d, int instance);
  // Writes kSensorDim values of this element's state to `out` (vibrofriction.*_sensor).
  void WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* out);
  void Advance(const mjModel* m, mjData* d, int instance);

 private:
  LawInput Input(const mjModel* m, const mjData* d, int instance) const;
  // The gms elements' deflections, interleaved z[2 i + axis] (act holds each axis's together).
  void GatherGms(const mjData* d, double* z) const;

  CachedConfig<PlanarConfig> config_;
  std::vector<mjtNum> scratch_;
  // A step taken implicitly (k_t dt lambda_max(B) >= kUnresolvedDeflection): the deflections
  // after it, interleaved z[2 i + axis], and the gms slip flags, which advance takes.
  bool implicit_step_ = false;
  double implicit_next_[2 * kMaxGmsElements] = {};
  double implicit_slipping_[kMaxGmsElements] = {};
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_PLANAR_FRICTION_H_
