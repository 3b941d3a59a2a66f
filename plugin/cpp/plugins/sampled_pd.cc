#include "plugins/sampled_pd.h"

#include <algorithm>
#include <cmath>

#include "common/element_config.h"  // RejectAttribute
#include "common/plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the MJCF keys (vocabulary.h)
constexpr char kPlugin[] = "vibrofriction.sampled_pd";

// plugin_state slots
enum : int { kHeld, kPending, kLastPosition, kLastFiltered, kNextSample, kStarted };

}  // namespace

// Every check holds while compiling (names, options, actuator_plugin): the scope does not matter.
bool SampledPdConfig::FromModel(const mjModel* m, int instance, SampledPdConfig* config,
                                ReadScope /*scope*/) {
  SampledPdConfig c;
  double delay = 0.0;
  if (!ReadNumber(m, instance, kPlugin, kPositionGain, &c.position_gain) ||
      !ReadNumber(m, instance, kPlugin, kVelocityGain, &c.velocity_gain) ||
      !ReadNumber(m, instance, kPlugin, kDriveGain, &c.drive_gain) ||
      !ReadNumber(m, instance, kPlugin, kSaturation, &c.saturation) ||
      !ReadNumber(m, instance, kPlugin, kSamplePeriod, &c.sample_period) ||
      !ReadNumber(m, instance, kPlugin, kCommandDelay, &delay)) {
    return false;
  }
  if (c.position_gain < 0) {
    return RejectAttribute(kPlugin, kPositionGain, c.position_gain, "must be >= 0 (1/s)");
  }
  if (c.velocity_gain <= 0) {
    return RejectAttribute(kPlugin, kVelocityGain, c.velocity_gain,
                           "must be > 0 (command per m/s), e.g. 243.45 for the EMPS");
  }
  if (c.drive_gain <= 0) {
    return RejectAttribute(kPlugin, kDriveGain, c.drive_gain, "must be > 0 (N per command unit)");
  }
  if (c.saturation < 0) {
    return RejectAttribute(kPlugin, kSaturation, c.saturation, "must be >= 0 (0: no limit)");
  }
  if (m->opt.integrator == mjINT_RK4) {
    return ConfigError("%s: the RK4 integrator evaluates the controller at intermediate stages; "
                       "use integrator=\"Euler\" or \"implicitfast\" (the controller samples "
                       "once a step)", kPlugin);
  }
  // (a relative tolerance: a timestep written to MJCF with 6 digits may round up past it)
  if (c.sample_period < m->opt.timestep * (1 - 1e-5)) {
    return RejectAttribute(kPlugin, kSamplePeriod, c.sample_period,
                           "must be at least the model's timestep (s), e.g. 1e-3");
  }
  if (delay != 0 && delay != 1) {
    return RejectAttribute(kPlugin, kCommandDelay, delay, "must be 0 or 1 (samples)");
  }
  c.command_delay = static_cast<int>(delay);
  c.actuator = FindActuator(m, instance, kPlugin);
  if (c.actuator < 0) return false;
  *config = c;
  return true;
}

double SampledPd::Force(double command) const {
  const double limit = config_->saturation;
  if (limit > 0) command = std::clamp(command, -limit, limit);
  return config_->drive_gain * command;
}

void SampledPd::Sampled(const mjModel* m, const mjData* d, const mjtNum* state, double time,
                        mjtNum* next) const {
  mju_copy(next, state, kStateSize);
  const int a = config_->actuator;
  const double q = d->actuator_length[m->actuator_outadr[a]];
  if (next[kStarted] == 0) {  // at rest before the first sample
    next[kLastPosition] = next[kLastFiltered] = q;
    next[kNextSample] = time;
    next[kStarted] = 1;
  }
  // due within half a step of the sample time (the sample period need not be a whole
  // number of steps; the next sample time is kept exact, not re-based on the step)
  if (time < next[kNextSample] - 0.5 * m->opt.timestep) return;
  const double T = config_->sample_period;
  const double filtered = 0.5 * (q + next[kLastPosition]);
  const double velocity = (filtered - next[kLastFiltered]) / T;
  const double u = config_->velocity_gain *
                   (config_->position_gain * (d->ctrl[m->actuator_ctrladr[a]] - q) - velocity);
  if (config_->command_delay == 0) {
    next[kHeld] = u;
  } else {
    next[kHeld] = next[kPending];
    next[kPending] = u;
  }
  next[kLastPosition] = q;
  next[kLastFiltered] = filtered;
  next[kNextSample] += T;
}

void SampledPd::Compute(const mjModel* m, mjData* d, int instance) {
  const int a = config_->actuator;
  computed_ = false;
  if (!config_.Refresh(m, instance)) {
    d->actuator_force[m->actuator_outadr[a]] = 0;
    return;
  }
  Sampled(m, d, d->plugin_state + m->plugin_stateadr[instance], d->time, next_);
  computed_ = true;
  d->actuator_force[m->actuator_outadr[a]] = Force(next_[kHeld]);
}

void SampledPd::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  if (!computed_) {
    // no compute this step (should not happen in mj_step): evaluate it here; actuator_length
    // and ctrl are still the step's, time has been advanced by one step
    Sampled(m, d, state, d->time - m->opt.timestep, next_);
  }
  // the state that gave this step's force, exactly (no second decision on "due")
  mju_copy(state, next_, kStateSize);
  computed_ = false;
}

void SampledPd::RegisterPlugin() {
  RegisterElementPlugin<SampledPd, &SampledPdConfig::FromModel>(
      kName, attributes::kSampledPd, mjPLUGIN_ACTUATOR);
}

}  // namespace vibrofriction
