#include "plugins/lagged_tendon.h"

#include <cmath>

#include "common/element_config.h"  // RejectAttribute
#include "common/plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the MJCF keys (vocabulary.h)
constexpr char kPlugin[] = "vibrofriction.lagged_tendon";

}  // namespace

// Every check holds while compiling (tendon names are set): the scope does not matter.
bool LaggedTendonConfig::FromModel(const mjModel* m, int instance, LaggedTendonConfig* config,
                                   ReadScope /*scope*/) {
  LaggedTendonConfig c;
  const char* name = mj_getPluginConfig(m, instance, kTendon);
  if (name == nullptr || name[0] == '\0') {
    ConfigError("%s: attribute 'tendon' is missing; name the tendon whose length it reads, "
                "e.g. <config key=\"tendon\" value=\"drive_spring\"/>", kPlugin);
    return false;
  }
  c.tendon = mj_name2id(m, mjOBJ_TENDON, name);
  if (c.tendon < 0) {
    ConfigError("%s: attribute 'tendon'=\"%s\" names no tendon of the model", kPlugin, name);
    return false;
  }
  if (!ReadNumber(m, instance, kPlugin, kTimeConstant, &c.time_constant)) return false;
  if (c.time_constant < 0) {
    return RejectAttribute(kPlugin, kTimeConstant, c.time_constant, "must be >= 0 (s)");
  }
  if (!ReadBool(m, instance, kPlugin, kBeyondDeadband, defaults::kBeyondDeadband,
                &c.beyond_deadband)) {
    return false;
  }
  *config = c;
  return true;
}

void LaggedTendon::Compute(const mjModel* m, mjData* d, int instance) {
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const bool valid = config_.Refresh(m, instance);
  for (int s : sensors_.Of(m, instance)) {
    mjtNum* out = d->sensordata + m->sensor_adr[s];
    *out = valid ? Reading(m, d, state) : 0.0;
  }
}

double LaggedTendon::Length(const mjModel* m, const mjData* d) const {
  const int tendon = config_->tendon;
  const double length = d->ten_length[tendon];
  if (!config_->beyond_deadband) return length;
  // MuJoCo's own rest range (springlength "low high"): what its spring force acts on
  const double low = m->tendon_lengthspring[2 * tendon];
  const double high = m->tendon_lengthspring[2 * tendon + 1];
  return length > high ? length - high : length < low ? length - low : 0.0;
}

double LaggedTendon::Reading(const mjModel* m, const mjData* d, const mjtNum* state) const {
  const double length = Length(m, d);
  if (config_->time_constant <= 0 || state[2] == 0) return length;
  return FirstOrderLagStep(state[0], state[1], length, m->opt.timestep, config_->time_constant);
}

void LaggedTendon::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  // This step's reading (ten_length is still the step's: integration does not update it).
  state[0] = Reading(m, d, state);
  state[1] = Length(m, d);
  state[2] = 1;
}

void LaggedTendon::RegisterPlugin() {
  RegisterElementPlugin<LaggedTendon, &LaggedTendonConfig::FromModel, 1, mjSTAGE_POS>(
      kName, attributes::kLaggedTendon, mjPLUGIN_SENSOR);
}

}  // namespace vibrofriction
