// Helpers shared by the vibrofriction engine plugins: strict config parsing, a per-model config
// fingerprint, and the response of one actuator transmission to a force over one step.
#ifndef VIBROFRICTION_PLUGIN_UTIL_H_
#define VIBROFRICTION_PLUGIN_UTIL_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

namespace vibrofriction {

// Reads a numeric attribute; the whole string must be a finite number. Returns false and
// warns (naming plugin, attribute, value and the fix) when it is not. Missing -> default.
bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double default_value, double* out);

// Raw config bytes of an instance: equal bytes <=> equal configuration. Rollout and batch can
// step one mjData with several models, so plugins compare this each step, not a model pointer.
std::string ConfigFingerprint(const mjModel* m, int instance);

// True when the instance's config bytes equal `fingerprint`; allocates nothing (called from
// every compute/advance callback).
bool ConfigUnchanged(const mjModel* m, int instance, const std::string& fingerprint);

// The single actuator backed by `instance`, or -1 (with a warning) if none or several.
int FindActuator(const mjModel* m, int instance, const char* plugin);

// Velocity of actuator output `out` for the current qvel (moment row times qvel). Used after
// integration, when mjData.actuator_velocity still holds the previous velocity.
double TransmissionVelocity(const mjModel* m, const mjData* d, int out);

// How actuator output `out` responds to a force over one semi-implicit Euler step:
// velocity_free is its velocity at the end of the step without this actuator's force, with
// every force known at this point (passive, bias, applied, actuators computed before this one);
// inverse_mass is J M^-1 J' so that v_next = velocity_free + timestep * inverse_mass * force.
struct StepResponse {
  double velocity_free = 0.0;
  double inverse_mass = 0.0;
};
StepResponse ComputeStepResponse(const mjModel* m, mjData* d, int out,
                                 std::vector<mjtNum>* scratch);

}  // namespace vibrofriction

#endif  // VIBROFRICTION_PLUGIN_UTIL_H_
