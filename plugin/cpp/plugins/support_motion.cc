#include "plugins/support_motion.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>

#include "common/plugin_util.h"
#include "vocabulary.h"  // generated from vibrofriction/vocabulary.py

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the MJCF keys (vocabulary.h)
constexpr char kPlugin[] = "vibrofriction.motion";
constexpr double kPi = 3.14159265358979323846;

}  // namespace

bool MotionConfig::FromModel(const mjModel* m, int instance, MotionConfig* config,
                             ReadScope scope) {
  MotionConfig c;
  if (!ReadNumber(m, instance, kPlugin, kFrequency, &c.frequency) ||
      !ReadNumber(m, instance, kPlugin, kVelocityAmplitude, &c.velocity_amplitude) ||
      !ReadNumber(m, instance, kPlugin, kVelocity, &c.velocity) ||
      !ReadNumber(m, instance, kPlugin, kPhase, &c.phase) ||
      !ReadNumber(m, instance, kPlugin, kStartTime, &c.start_time) ||
      !ReadNumber(m, instance, kPlugin, kRampPeriods, &c.ramp_periods)) {
    return false;
  }
  if (!ReadBool(m, instance, kPlugin, kUseCtrl, defaults::kUseCtrl, &c.use_ctrl)) return false;
  if (!ReadBool(m, instance, kPlugin, kDisplacementFromCtrl, defaults::kDisplacementFromCtrl,
                &c.displacement_from_ctrl)) {
    return false;
  }
  if (c.displacement_from_ctrl &&
      (c.frequency != 0 || c.velocity_amplitude != 0 || c.velocity != 0 || c.phase != 0 ||
       c.use_ctrl || c.start_time != 0 || c.ramp_periods != 0)) {
    ConfigError("%s: displacement_from_ctrl=\"true\" takes the whole motion from ctrl; remove "
                "frequency, velocity_amplitude, velocity, phase, use_ctrl, start_time and "
                "ramp_periods", kPlugin);
    return false;
  }
  if (c.frequency < 0) {
    ConfigError("%s: attribute 'frequency'=\"%g\" must be >= 0 (Hz)", kPlugin, c.frequency);
    return false;
  }
  if (c.velocity_amplitude < 0) {
    ConfigError("%s: attribute 'velocity_amplitude'=\"%g\" must be >= 0 (m/s)", kPlugin,
                c.velocity_amplitude);
    return false;
  }
  if (c.start_time < 0 || c.ramp_periods < 0) {
    ConfigError("%s: attribute '%s'=\"%g\" must be >= 0", kPlugin,
                c.start_time < 0 ? kStartTime : kRampPeriods,
                c.start_time < 0 ? c.start_time : c.ramp_periods);
    return false;
  }
  if ((c.start_time > 0 || c.ramp_periods > 0) && c.velocity_amplitude == 0) {
    ConfigError("%s: start_time and ramp_periods shape a vibration; set velocity_amplitude "
                "and frequency, or remove them", kPlugin);
    return false;
  }
  if (c.velocity_amplitude > 0 && c.frequency == 0) {
    ConfigError("%s: velocity_amplitude is set but frequency is 0; set frequency (Hz)", kPlugin);
    return false;
  }
  if (!CheckIntegrator(m, kPlugin)) return false;
  c.actuator = FindActuator(m, instance, kPlugin);
  if (c.actuator < 0) return false;
  if (scope == ReadScope::kAttributes) return true;  // the actuator's fields are not set yet
  c.output = m->actuator_outadr[c.actuator];
  *config = c;
  return true;
}

double MotionConfig::Displacement(double t, double amplitude_scale) const {
  double s = velocity * t;
  const double tau = t - start_time;  // time since the vibration started
  if (frequency > 0 && velocity_amplitude > 0 && tau > 0) {
    const double omega = 2 * kPi * frequency;
    const double ramp_time = ramp_periods / frequency;
    const double envelope =
        tau < ramp_time ? 0.5 * (1.0 - std::cos(kPi * tau / ramp_time)) : 1.0;
    s += amplitude_scale * envelope * velocity_amplitude / omega *
         (std::sin(omega * tau + phase) - std::sin(phase));
  }
  return s;
}

void SupportMotion::Compute(const mjModel* m, mjData* d, int instance) {
  const int out = config_->output;
  if (!config_.Refresh(m, instance)) {
    d->actuator_force[out] = 0;
    return;
  }
  const double dt = m->opt.timestep;
  // Position target at the end of the step; the semi-implicit position update
  // s_{n+1} = s_n + dt v_{n+1} then lands on it (no drift in position or phase).
  double target;
  if (config_->displacement_from_ctrl) {  // a recorded motion replayed step by step
    target = m->actuator_length0[out] + d->ctrl[m->actuator_ctrladr[config_->actuator]];
  } else {
    const double scale =
        config_->use_ctrl ? d->ctrl[m->actuator_ctrladr[config_->actuator]] : 1.0;
    target = m->actuator_length0[out] + config_->Displacement(d->time + dt, scale);
  }
  const double velocity_target = (target - d->actuator_length[out]) / dt;
  const StepResponse response = ComputeStepResponse(m, d, out, &response_workspace_);
  d->actuator_force[out] = response.inverse_mass > 0
                               ? (velocity_target - response.velocity_free) /
                                     (dt * response.inverse_mass)
                               : 0.0;
}

void SupportMotion::RegisterPlugin() {
  RegisterElementPlugin<SupportMotion, &MotionConfig::FromModel>(
      kName, attributes::kMotion, mjPLUGIN_ACTUATOR);
}

}  // namespace vibrofriction
