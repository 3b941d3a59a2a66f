// Sensor plugin "vibrofriction.lagged_tendon": a tendon's length seen through a first-order lag,
//   tau y' + y = L(t),  tau = time_constant (s; 0: no lag, y = L)
// A dynamometer built around a spring (the rig's drive spring) reads its extension through its
// signal conditioning; identification fits that lag when the record measures the drive force.
// The lag starts at rest on the length at the first step (like a sensor switched on long before
// the record starts) and, as the friction element's sensor_lag, is advanced exactly over each
// step by that step's value.
//   <sensor>
//     <plugin name="dynamometer_extension" plugin="vibrofriction.lagged_tendon">
//       <config key="tendon" value="drive_spring"/>
//       <config key="time_constant" value="8e-6"/>
//     </plugin>
//   </sensor>
#ifndef VIBROFRICTION_LAGGED_TENDON_H_
#define VIBROFRICTION_LAGGED_TENDON_H_

#include <utility>

#include <mujoco/mujoco.h>

#include "plugin_util.h"

namespace vibrofriction {

struct LaggedTendonConfig {
  int tendon = -1;
  double time_constant = 0.0;  // s

  static bool FromModel(const mjModel* m, int instance, LaggedTendonConfig* config);
};

class LaggedTendon {
 public:
  static constexpr char kName[] = "vibrofriction.lagged_tendon";
  static constexpr int kStateSize = 2;  // lagged length, started (0 before the first step)
  explicit LaggedTendon(CachedConfig<LaggedTendonConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  void Compute(const mjModel* m, mjData* d, int instance);
  void Advance(const mjModel* m, mjData* d, int instance);

 private:
  CachedConfig<LaggedTendonConfig> config_;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_LAGGED_TENDON_H_
