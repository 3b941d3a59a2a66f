// What every friction element (vibrofriction.friction, .planar, .averaged) reads from MJCF:
// the shared config keys, the law and its parameters, and the normal load.
#ifndef VIBROFRICTION_ELEMENT_CONFIG_H_
#define VIBROFRICTION_ELEMENT_CONFIG_H_

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"
#include "laws/friction_law.h"

namespace vibrofriction {

// MJCF config keys shared by the friction elements (README maps each to its Python name).
namespace keys {
inline constexpr char kLaw[] = "law";
inline constexpr char kMu[] = "mu";
inline constexpr char kNormal[] = "normal";
inline constexpr char kNormalSensor[] = "normal_sensor";
inline constexpr char kNormalGain[] = "normal_gain";
inline constexpr char kNormalComponent[] = "normal_component";
inline constexpr char kContactGeom1[] = "contact_geom1";
inline constexpr char kContactGeom2[] = "contact_geom2";
inline constexpr char kNormalFromCtrl[] = "normal_from_ctrl";  // vibrofriction.friction
inline constexpr char kStiffness[] = "stiffness";
inline constexpr char kAlpha[] = "alpha";
inline constexpr char kBreakaway[] = "breakaway";
inline constexpr char kSigma1[] = "sigma1";
inline constexpr char kViscous[] = "viscous";
inline constexpr char kStaticRatio[] = "static_ratio";
inline constexpr char kStribeckVelocity[] = "stribeck_velocity";
inline constexpr char kNormalModulation[] = "normal_modulation";
inline constexpr char kModulationFrequency[] = "modulation_frequency";
inline constexpr char kModulationPhase[] = "modulation_phase";
// law gms (vibrofriction.friction and .planar)
inline constexpr char kGmsStiffness[] = "gms_stiffness";
inline constexpr char kGmsWeight[] = "gms_weight";
inline constexpr char kGmsRelaxationTime[] = "gms_relaxation_time";
// level maps (vibrofriction.friction)
inline constexpr char kPositionMapKnots[] = "position_map_knots";
inline constexpr char kPositionMapFactors[] = "position_map_factors";
inline constexpr char kPositionMapPeriod[] = "position_map_period";
inline constexpr char kVelocityMapKnots[] = "velocity_map_knots";
inline constexpr char kVelocityMapFactors[] = "velocity_map_factors";
inline constexpr char kTimeMapKnots[] = "time_map_knots";
inline constexpr char kTimeMapFactors[] = "time_map_factors";
// the averaged elements' vibration and table (vibrofriction.averaged, .contact_averaged)
inline constexpr char kVelocityAmplitude[] = "velocity_amplitude";
inline constexpr char kTableXi[] = "table_xi";
inline constexpr char kTableAngle[] = "table_angle";
inline constexpr char kTableAlong[] = "table_along";
inline constexpr char kTableAcross[] = "table_across";
// FNV-1a of the four lists' numbers (NumberListChecksum): lets the per-step config check skip them
inline constexpr char kTableChecksum[] = "table_checksum";
// the lists the checksum stands for, in its order
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
