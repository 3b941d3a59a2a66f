#include "common/element_config.h"

#include <cmath>
#include <cstring>
#include <vector>

#include "common/plugin_util.h"

namespace vibrofriction {

using namespace keys;  // NOLINT: the MJCF keys read here

bool RejectAttribute(const char* plugin, const char* attr, double value, const char* rule) {
  return ConfigError("%s: attribute '%s'=\"%g\" %s", plugin, attr, value, rule);
}

// The gms elements: stiffnesses (required), weights (default equal shares; they must sum to 1)
// and the relaxation time, checked by MakeGmsElements (friction_law.h, as the C API's lists).
static bool ReadGmsElements(const mjModel* m, int instance, const char* plugin, GmsElements* out) {
  std::vector<double> stiffness, weight;
  if (!ReadNumberList(m, instance, plugin, kGmsStiffness, &stiffness) ||
      !ReadNumberList(m, instance, plugin, kGmsWeight, &weight)) {
    return false;
  }
  const int count = static_cast<int>(stiffness.size());
  if (!weight.empty() && static_cast<int>(weight.size()) != count && count >= 1 &&
      count <= kMaxGmsElements) {
    return ConfigError("%s: 'gms_weight' has %d values and 'gms_stiffness' %d; give one weight "
                       "(share of the friction level) per element, or none for equal shares",
                       plugin, static_cast<int>(weight.size()), count);
  }
  GmsElements read;  // (the relaxation time as read; the lists are checked below)
  if (!ReadNumber(m, instance, plugin, kGmsRelaxationTime, &read.relaxation_time)) {
    return false;
  }
  const ListCheck check = MakeGmsElements(stiffness.data(), weight.empty() ? nullptr
                                          : weight.data(), count, read.relaxation_time, out);
  switch (check.problem) {
    case ListProblem::kNone:
      return true;
    case ListProblem::kCount:
      return ConfigError("%s: law gms needs 'gms_stiffness', the elements' stiffnesses (N/m), 1 "
                         "to %d values separated by spaces (it has %d), e.g. gms_stiffness=\"4e7 "
                         "2e7 1e7\"", plugin, kMaxGmsElements, count);
    case ListProblem::kStiffness:
      return RejectAttribute(plugin, kGmsStiffness, check.value, "has a value <= 0; each "
                             "element's stiffness must be > 0 (N/m)");
    case ListProblem::kWeight:
      return RejectAttribute(plugin, kGmsWeight, check.value, "has a value <= 0; each element's "
                             "share of the level must be > 0");
    case ListProblem::kWeightSum:
      return RejectAttribute(plugin, kGmsWeight, check.value, "sums to this; the elements' shares "
                             "of the friction level must sum to 1");
    case ListProblem::kRelaxation:
      return RejectAttribute(plugin, kGmsRelaxationTime, check.value,
                             "must be >= 0 (s; 0: a slipping element is at its level at once)");
    default:  // (non-finite values: ReadNumberList and ReadNumber refuse them first)
      return ConfigError("%s: the gms element lists are invalid", plugin);
  }
}

bool ReadLevelMap(const mjModel* m, int instance, const char* plugin, const char* knots_key,
                  const char* factors_key, const char* period_key, bool nonnegative_knots,
                  LevelMap* out) {
  std::vector<double> knots, factors;
  if (!ReadNumberList(m, instance, plugin, knots_key, &knots) ||
      !ReadNumberList(m, instance, plugin, factors_key, &factors)) {
    return false;
  }
  double period = 0.0;
  if (period_key && !ReadNumber(m, instance, plugin, period_key, &period)) return false;
  if (knots.size() != factors.size()) {
    return ConfigError("%s: '%s' has %d values and '%s' %d; give one factor per knot", plugin,
                       knots_key, static_cast<int>(knots.size()), factors_key,
                       static_cast<int>(factors.size()));
  }
  const ListCheck check = MakeLevelMap(knots.data(), factors.data(),
                                       static_cast<int>(knots.size()), period, nonnegative_knots,
                                       out);
  switch (check.problem) {
    case ListProblem::kNone:
      return true;
    case ListProblem::kCount:
      return ConfigError("%s: '%s' has %d knots; a map takes at most %d", plugin, knots_key,
                         static_cast<int>(knots.size()), kMaxMapKnots);
    case ListProblem::kPeriod:
      return RejectAttribute(plugin, period_key ? period_key : knots_key, check.value,
                             "must be >= 0 (0: not periodic)");
    case ListProblem::kFactor:
      return RejectAttribute(plugin, factors_key, check.value, "has a factor <= -1; each must be "
                             "> -1 (the level times 1 + factor stays positive)");
    case ListProblem::kNegativeKnot:
      return RejectAttribute(plugin, knots_key, check.value,
                             std::strcmp(knots_key, kTimeMapKnots) == 0
                                 ? "has a knot < 0; the knots are times t >= 0 (s)"
                                 : "has a knot < 0; the knots are speeds |v| >= 0");
    case ListProblem::kOrder:
      return ConfigError("%s: the knots of '%s' must increase%s", plugin, knots_key,
                         period > 0 ? " and lie within one period" : "");
    default:  // (non-finite values: ReadNumberList and ReadNumber refuse them first)
      return ConfigError("%s: the map '%s' is invalid", plugin, knots_key);
  }
}

int GmsElementCount(const mjModel* m, int instance) {
  const char* law_name = mj_getPluginConfig(m, instance, kLaw);
  Law law;
  if (!law_name || !ParseLaw(law_name, &law) || law != Law::kGms) return 0;
  const char* text = mj_getPluginConfig(m, instance, kGmsStiffness);
  if (!text) return 0;
  // (count only: ReadLawParameters reports a bad list)
  int count = 0;
  for (const char* c = text; *c;) {
    while (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r') ++c;
    if (!*c) break;
    ++count;
    while (*c && *c != ' ' && *c != '\t' && *c != '\n' && *c != '\r') ++c;
  }
  return count <= kMaxGmsElements ? count : 0;
}

bool ReadLawParameters(const mjModel* m, int instance, const char* plugin, LawParameters* out,
                       bool takes_gms) {
  LawParameters p = *out;
  const char* law_name = mj_getPluginConfig(m, instance, kLaw);
  if (law_name == nullptr || law_name[0] == '\0') {
    ConfigError("%s: attribute 'law' is missing; add <config key=\"law\" value=\"dahl\"/> "
                "(one of coulomb, dahl, dupont, lugre%s)", plugin, takes_gms ? ", gms" : "");
    return false;
  }
  if (!ParseLaw(law_name, &p.law)) {
    ConfigError("%s: attribute 'law'=\"%s\" is not a friction law; use one of coulomb, dahl, "
                "dupont, lugre%s", plugin, law_name, takes_gms ? ", gms" : "");
    return false;
  }
  if (p.law == Law::kGms && !takes_gms) {
    ConfigError("%s: law 'gms' (generalized Maxwell-slip) is taken by vibrofriction.friction "
                "and vibrofriction.planar only; use dahl, lugre or dupont here", plugin);
    return false;
  }
  // (each default: the table's, vocabulary.h)
  if (!ReadNumbers(m, instance, plugin, {
      {kMu, &p.friction_coefficient},
      {kStiffness, &p.contact_stiffness},
      {kAlpha, &p.alpha},
      {kBreakaway, &p.breakaway_ratio},
      {kSigma1, &p.bristle_damping},
      {kViscous, &p.viscous},
      {kStaticRatio, &p.static_ratio},
      {kStribeckVelocity, &p.stribeck_velocity},
      {kNormalModulation, &p.normal_modulation},
      {kModulationFrequency, &p.normal_modulation_frequency},
      {kModulationPhase, &p.normal_modulation_phase},
      })) {
    return false;
  }
  if (p.friction_coefficient < 0) {
    return RejectAttribute(plugin, kMu, p.friction_coefficient, "must be >= 0");
  }
  if (p.law == Law::kGms) {
    if (!ReadGmsElements(m, instance, plugin, &p.gms)) return false;
    if (p.bristle_damping != 0) {
      return RejectAttribute(plugin, kSigma1, p.bristle_damping,
                             "is not a gms parameter (its elements have no bristle damping); "
                             "remove sigma1, or use viscous for a damping in sliding");
    }
  }
  if (HasDeflection(p.law) && p.law != Law::kGms && p.contact_stiffness <= 0) {
    return RejectAttribute(plugin, kStiffness, p.contact_stiffness,
                           "must be > 0 (N/m), e.g. 8e7 for 80 N/um");
  }
  if (p.alpha < 0) {
    return RejectAttribute(plugin, kAlpha, p.alpha, "must be >= 0 (1 is Dahl's usual value)");
  }
  if (!(p.breakaway_ratio > 0 && p.breakaway_ratio < 1)) {
    return RejectAttribute(plugin, kBreakaway, p.breakaway_ratio, "must lie in (0, 1), e.g. 0.7");
  }
  if (p.bristle_damping < 0) {
    return RejectAttribute(plugin, kSigma1, p.bristle_damping, "must be >= 0 (N s/m)");
  }
  if (p.viscous < 0) return RejectAttribute(plugin, kViscous, p.viscous, "must be >= 0 (N s/m)");
  if (p.static_ratio < 1) {
    return RejectAttribute(plugin, kStaticRatio, p.static_ratio, "must be >= 1");
  }
  if (p.stribeck_velocity <= 0) {
    return RejectAttribute(plugin, kStribeckVelocity, p.stribeck_velocity, "must be > 0 (m/s)");
  }
  if (!(p.normal_modulation >= 0 && p.normal_modulation < 1)) {
    return RejectAttribute(plugin, kNormalModulation, p.normal_modulation, "must lie in [0, 1)");
  }
  if (p.normal_modulation_frequency < 0) {
    return RejectAttribute(plugin, kModulationFrequency, p.normal_modulation_frequency,
                           "must be >= 0 (Hz)");
  }
  *out = p;
  return true;
}

bool NormalLoad::FromModel(const mjModel* m, int instance, const char* plugin, ReadScope scope,
                           NormalLoad* out) {
  NormalLoad n;
  double component = 0.0;
  if (!ReadNumber(m, instance, plugin, kNormal, &n.normal) ||
      !ReadNumber(m, instance, plugin, kNormalGain, &n.gain) ||
      !ReadNumber(m, instance, plugin, kNormalComponent, &component)) {
    return false;
  }
  if (n.normal < 0) return RejectAttribute(plugin, kNormal, n.normal, "must be >= 0 (N)");
  const char* sensor_name = mj_getPluginConfig(m, instance, kNormalSensor);
  const char* geom1 = mj_getPluginConfig(m, instance, kContactGeom1);
  const char* geom2 = mj_getPluginConfig(m, instance, kContactGeom2);
  const bool has_sensor = sensor_name && sensor_name[0];
  const bool has_geom1 = geom1 && geom1[0];
  const bool has_geom2 = geom2 && geom2[0];
  if (has_sensor && (has_geom1 || has_geom2)) {
    ConfigError("%s: attributes 'normal_sensor' and 'contact_geom1/2' are both set; use one "
                "source for the normal load", plugin);
    return false;
  }
  if (has_sensor) {
    n.sensor = mj_name2id(m, mjOBJ_SENSOR, sensor_name);
    if (n.sensor < 0) {
      ConfigError("%s: attribute 'normal_sensor'=\"%s\" names no sensor; give the sensor that "
                  "measures the normal load a name and use it here", plugin, sensor_name);
      return false;
    }
    n.component = static_cast<int>(component);
    // (sensor_dim is known once the model is complete)
    if (n.component != component || n.component < 0 ||
        (scope == ReadScope::kAll && n.component >= m->sensor_dim[n.sensor])) {
      return RejectAttribute(plugin, kNormalComponent, component,
                    "must be a whole number below the sensor's dimension");
    }
    // A sensor that never reads below 0 (a touch sensor, a joint or tendon limit's force):
    // with no constant part, a negative gain makes F_N <= 0 at every step, as for contact geoms.
    if (scope == ReadScope::kAll && n.normal == 0 && n.gain < 0) {
      const int type = m->sensor_type[n.sensor];
      const char* kind = type == mjSENS_TOUCH            ? "a touch sensor"
                         : type == mjSENS_JOINTLIMITFRC  ? "a joint limit's force"
                         : type == mjSENS_TENDONLIMITFRC ? "a tendon limit's force"
                                                         : nullptr;
      if (kind) {
        return ConfigError("%s: attribute 'normal_gain'=\"%g\" with normal=\"0\" makes the load "
                           "negative at every step: normal_sensor '%s' is %s, never below 0; "
                           "the gain must be > 0 (or give a constant normal that the sensor's "
                           "reading lowers)", plugin, n.gain, sensor_name, kind);
      }
    }
  }
  if (has_geom1 != has_geom2) {
    ConfigError("%s: only one of 'contact_geom1' and 'contact_geom2' is set; name both geoms "
                "whose contact carries the normal load", plugin);
    return false;
  }
  if (has_geom1) {
    n.geom1 = mj_name2id(m, mjOBJ_GEOM, geom1);
    n.geom2 = mj_name2id(m, mjOBJ_GEOM, geom2);
    if (n.geom1 < 0 || n.geom2 < 0) {
      ConfigError("%s: attribute '%s'=\"%s\" names no geom; use the name of a geom of the "
                  "sliding body and of its support", plugin,
                  n.geom1 < 0 ? kContactGeom1 : kContactGeom2, n.geom1 < 0 ? geom1 : geom2);
      return false;
    }
    if (n.geom1 == n.geom2) {
      ConfigError("%s: 'contact_geom1' and 'contact_geom2' name the same geom \"%s\"; name the "
                  "body's geom and the support's geom", plugin, geom1);
      return false;
    }
    // A contact pushes (its normal force is >= 0): with no constant part, a negative gain
    // makes F_N <= 0 at every step, a contact that never carries friction.
    if (n.normal == 0 && n.gain < 0) {
      return RejectAttribute(plugin, kNormalGain, n.gain,
                             "with normal=\"0\" makes the load of the contact (>= 0) negative "
                             "at every step; the gain must be > 0 (or give a constant normal)");
    }
  }
  *out = n;
  return true;
}

int NormalLoad::StateSize(const mjModel* m, int instance) {
  const char* geom1 = mj_getPluginConfig(m, instance, kContactGeom1);
  return geom1 && geom1[0] ? 1 : 0;
}

double NormalLoad::Value(const mjModel* m, const mjData* d, const mjtNum* state) const {
  double value = normal;
  if (sensor >= 0) value += gain * d->sensordata[m->sensor_adr[sensor] + component];
  if (geom1 >= 0) value += gain * state[0];
  if (ctrl >= 0) {  // this step's: ctrl is set before the step (within ctrlrange, as MuJoCo's)
    double u = d->ctrl[ctrl];
    if (m->actuator_ctrllimited[ctrl] && !(m->opt.disableflags & mjDSBL_CLAMPCTRL)) {
      u = std::min(std::max(u, m->actuator_ctrlrange[2 * ctrl]), m->actuator_ctrlrange[2 * ctrl + 1]);
    }
    value += gain * u;
  }
  return value;
}

void NormalLoad::Update(const mjModel* m, const mjData* d, mjtNum* state) const {
  if (geom1 < 0) return;
  double total = 0.0;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool match = (c.geom[0] == geom1 && c.geom[1] == geom2) ||
                       (c.geom[0] == geom2 && c.geom[1] == geom1);
    if (!match || c.efc_address < 0) continue;
    mjtNum wrench[6];
    mj_contactForce(m, d, i, wrench);
    total += wrench[0];  // normal component, >= 0 (pushing)
  }
  state[0] = total;
}

}  // namespace vibrofriction
