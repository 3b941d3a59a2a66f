// Sensor plugin "vibrofriction.lagged_tendon": a tendon's length seen through a first-order lag,
//   tau y' + y = L(t),  tau = time_constant (s; 0: no lag, y = L)
// With beyond_deadband="true", L is the tendon's displacement outside its spring's rest range
// (MuJoCo's springlength="low high", tendon_lengthspring): the extension a dynamometer in a
// spring with backlash reads (0 while the play is open).
// A dynamometer built around a spring (the rig's drive spring) reads its extension through its
// signal conditioning; identification fits that lag when the record measures the drive force.
// The lag starts at rest on the length at the first step (like a sensor switched on long before
// the record starts); it is exact for a length linear between steps (first-order hold), so the
// reading tends to the length itself as tau -> 0.
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

#include "common/plugin_util.h"

namespace vibrofriction {

struct LaggedTendonConfig {
  int tendon = -1;
  double time_constant = 0.0;  // s
  bool beyond_deadband = false;  // read the displacement outside the spring's rest range

  static bool FromModel(const mjModel* m, int instance, LaggedTendonConfig* config,
                        ReadScope scope = ReadScope::kAll);
};

class LaggedTendon {
 public:
  static constexpr char kName[] = "vibrofriction.lagged_tendon";
  // lagged length, the length at the last step, started (0 before the first step)
  static constexpr int kStateSize = 3;
  explicit LaggedTendon(CachedConfig<LaggedTendonConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel* m, int instance) { return kStateSize; }
  void Compute(const mjModel* m, mjData* d, int instance);
  void Advance(const mjModel* m, mjData* d, int instance);

 private:
  // The length read: the tendon's, or its displacement outside its spring's rest range.
  double Length(const mjModel* m, const mjData* d) const;
  // The reading at this step: the lag advanced from the last step to this step's length.
  double Reading(const mjModel* m, const mjData* d, const mjtNum* state) const;
  CachedConfig<LaggedTendonConfig> config_;
  InstanceSensors sensors_;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_LAGGED_TENDON_H_
