// Actuator plugin "vibrofriction.sampled_pd": a digital position controller sampled at
// sample_period and held in between (zero-order hold), as a machine's drive runs it:
//   at each sample t_k:  q_f,k = (q_k + q_{k-1}) / 2          (position averaged over 2 samples)
//                        u_k   = kv (kp (r_k - q_k) - (q_f,k - q_f,k-1) / T)   (V)
//   force = drive_gain * clamp(u, -saturation, saturation)                    (N, or N m)
// r_k = ctrl (the reference position), q_k = the transmission's length, T = sample_period.
// command_delay = 1 applies u_k one sample later (a controller that outputs at the next
// interrupt); 0 (default) applies it at once. This is the EMPS benchmark's controller (Janot,
// Gautier, Brunot 2019, eq. 6 and its Simulink model); its logged command equals the law at the
// same sample (mjcf_models/emps/README.md). The first sample after a reset starts the filter at
// rest (q_{k-1} = q_f,k-1 = q_k). State (plugin_state): held command, pending command, last
// sampled position, last filtered position, next sample time, started.
//   <actuator>
//     <plugin name="motor" joint="carriage" instance="controller"/>
//   </actuator>
#ifndef VIBROFRICTION_SAMPLED_PD_H_
#define VIBROFRICTION_SAMPLED_PD_H_

#include <utility>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"

namespace vibrofriction {

struct SampledPdConfig {
  double position_gain = 0.0;    // kp (1/s)
  double velocity_gain = 0.0;    // kv (command units per m/s)
  double drive_gain = 1.0;       // force per command unit (N/V)
  double saturation = 0.0;       // |u| limit (command units); 0: none
  double sample_period = 0.0;    // T (s)
  int command_delay = 0;         // samples (0 or 1)
  int actuator = -1;

  static bool FromModel(const mjModel* m, int instance, SampledPdConfig* config,
                        ReadScope scope = ReadScope::kAll);
};

class SampledPd {
 public:
  static constexpr char kName[] = "vibrofriction.sampled_pd";
  static constexpr int kStateSize = 6;
  explicit SampledPd(CachedConfig<SampledPdConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel* m, int instance) { return kStateSize; }
  void Compute(const mjModel* m, mjData* d, int instance);
  void Advance(const mjModel* m, mjData* d, int instance);

 private:
  // The state after this step's sample (if one is due at `time`); `state` is not changed.
  void Sampled(const mjModel* m, const mjData* d, const mjtNum* state, double time,
               mjtNum* next) const;
  double Force(double command) const;
  CachedConfig<SampledPdConfig> config_;
  // The state after this step's sample, as Compute applied it; Advance commits it.
  mjtNum next_[kStateSize] = {};
  bool computed_ = false;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_SAMPLED_PD_H_
