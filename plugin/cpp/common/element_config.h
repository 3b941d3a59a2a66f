// What every friction element (vibrofriction.friction, .planar, .averaged) reads from MJCF:
// the shared config keys, the law and its parameters, and the normal load.
#ifndef VIBROFRICTION_ELEMENT_CONFIG_H_
#define VIBROFRICTION_ELEMENT_CONFIG_H_

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"
#include "laws/friction_law.h"
#include "vocabulary.h"  // generated from vibrofriction/vocabulary.py

namespace vibrofriction {

// The MJCF config keys (keys::k<Key>), their defaults (defaults::k<Key>), ranges and the keys
// each plugin takes (attributes::k<Plugin>) come from the one table, vibrofriction/vocabulary.py,
// through the header the build generates from it (plugin/build_hooks/vocabulary_header.py).
namespace keys {
// the averaged table's lists, in the order of its checksum (NumberListChecksum), which lets the
// per-step config check skip them (table_checksum)
inline constexpr const char* kTableLists[] = {kTableXi, kTableAngle, kTableAlong, kTableAcross};
}  // namespace keys

// Records the error "<plugin>: attribute '<attr>'="<value>" <rule>" and returns false.
bool RejectAttribute(const char* plugin, const char* attr, double value, const char* rule);

// Reads `law` and the parameters every law shares (mu, stiffness, alpha, breakaway, sigma1,
// viscous, static_ratio, stribeck_velocity, normal_modulation, modulation_frequency,
// modulation_phase), strictly parsed and range-checked, and with `takes_gms` law gms and its
// elements (gms_stiffness, gms_weight, gms_relaxation_time); an element without takes_gms
// refuses law gms. On a bad value records the error, naming the attribute and the fix, and
// returns false. Leaves the other fields of *p as they are.
bool ReadLawParameters(const mjModel* m, int instance, const char* plugin, LawParameters* p,
                       bool takes_gms = false);

// Reads a level map: the knots and factors lists (both or neither, at most kMaxMapKnots, knots
// increasing, factors > -1) and, with a period key, the period (>= 0; > 0: periodic, the knots
// within one period); nonnegative_knots for a map over the speed or the time. Records the error
// naming the attribute and returns false on a bad value.
bool ReadLevelMap(const mjModel* m, int instance, const char* plugin, const char* knots_key,
                  const char* factors_key, const char* period_key, bool nonnegative_knots,
                  LevelMap* out);

// The number of gms elements the config declares (the count of gms_stiffness values; 0 for
// another law or a bad list): the element's state size, known before the model is complete.
int GmsElementCount(const mjModel* m, int instance);

// The normal load F_N = normal + normal_gain * (sensor value, or the normal force of the
// contacts between contact_geom1 and contact_geom2). Sensors of the acceleration stage and
// contact forces are the previous step's values: the constraint solve runs after actuation.
struct NormalLoad {
  double normal = 0.0;   // constant part (N)
  double gain = 1.0;     // multiplies the sensor value or the contact force
  int sensor = -1;       // sensor id, -1: none
  int component = 0;     // component of that sensor
  int geom1 = -1;        // contact normal force between geom1 and geom2, -1: none
  int geom2 = -1;
  int ctrl = -1;         // this ctrl index (normal_from_ctrl: the element's own actuator's), -1: none

  // Reads normal, normal_gain, normal_sensor, normal_component, contact_geom1, contact_geom2.
  static bool FromModel(const mjModel* m, int instance, const char* plugin, ReadScope scope,
                        NormalLoad* out);
  static int StateSize(const mjModel* m, int instance);  // 1 when contact geoms are named
  bool UsesContacts() const { return geom1 >= 0; }
  // F_N before modulation; `state` is this load's slot in the instance's plugin_state.
  double Value(const mjModel* m, const mjData* d, const mjtNum* state) const;
  // Stores the normal force of this step's contacts (call from advance).
  void Update(const mjModel* m, const mjData* d, mjtNum* state) const;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_ELEMENT_CONFIG_H_
