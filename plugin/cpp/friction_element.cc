#include "friction_element.h"

#include <cmath>
#include <cstdint>
#include <utility>

#include "plugin_util.h"

namespace vibrofriction {
namespace {

// MJCF config keys (README maps each to its Python name).
constexpr char kLaw[] = "law";
constexpr char kMu[] = "mu";
constexpr char kNormal[] = "normal";
constexpr char kNormalSensor[] = "normal_sensor";
constexpr char kNormalGain[] = "normal_gain";
constexpr char kNormalComponent[] = "normal_component";
constexpr char kStiffness[] = "stiffness";
constexpr char kAlpha[] = "alpha";
constexpr char kBreakaway[] = "breakaway";
constexpr char kSigma1[] = "sigma1";
constexpr char kViscous[] = "viscous";
constexpr char kStaticRatio[] = "static_ratio";
constexpr char kStribeckVelocity[] = "stribeck_velocity";
constexpr char kAsymmetry[] = "asymmetry";
constexpr char kRipple[] = "ripple";
constexpr char kRippleWavelength[] = "ripple_wavelength";
constexpr char kRipplePhase[] = "ripple_phase";
constexpr char kNormalModulation[] = "normal_modulation";
constexpr char kModulationFrequency[] = "modulation_frequency";
constexpr char kModulationPhase[] = "modulation_phase";
constexpr char kForceOffset[] = "force_offset";
constexpr char kSensorLag[] = "sensor_lag";

const char* const kAttributes[] = {
    kLaw, kMu, kNormal, kNormalSensor, kNormalGain, kNormalComponent, kStiffness, kAlpha,
    kBreakaway, kSigma1, kViscous, kStaticRatio, kStribeckVelocity, kAsymmetry, kRipple,
    kRippleWavelength, kRipplePhase, kNormalModulation, kModulationFrequency, kModulationPhase,
    kForceOffset, kSensorLag};

constexpr char kPlugin[] = "vibrofriction.friction";

// Warns with the attribute, its value, the rule and a fix; returns false.
bool Reject(const char* attr, double value, const char* rule) {
  mju_warning("%s: attribute '%s'=\"%g\" %s", kPlugin, attr, value, rule);
  return false;
}

struct NumberSpec {
  const char* attr;
  double* target;
  double default_value;
};

}  // namespace

bool FrictionConfig::FromModel(const mjModel* m, int instance, FrictionConfig* config) {
  FrictionConfig c;
  LawParameters& p = c.law;

  const char* law_name = mj_getPluginConfig(m, instance, kLaw);
  if (law_name == nullptr || law_name[0] == '\0') {
    mju_warning("%s: attribute 'law' is missing; add <config key=\"law\" value=\"dahl\"/> "
                "(one of coulomb, dahl, dupont, lugre)", kPlugin);
    return false;
  }
  if (!ParseLaw(law_name, &p.law)) {
    mju_warning("%s: attribute 'law'=\"%s\" is not a friction law; use one of coulomb, dahl, "
                "dupont, lugre", kPlugin, law_name);
    return false;
  }

  double normal_component = 0.0;
  const NumberSpec numbers[] = {
      {kMu, &p.friction_coefficient, 0.2},
      {kNormal, &p.normal_force, 0.0},
      {kNormalGain, &c.normal_gain, 1.0},
      {kNormalComponent, &normal_component, 0.0},
      {kStiffness, &p.contact_stiffness, 8e7},
      {kAlpha, &p.alpha, 1.0},
      {kBreakaway, &p.breakaway_ratio, 0.7},
      {kSigma1, &p.bristle_damping, 0.0},
      {kViscous, &p.viscous, 0.0},
      {kStaticRatio, &p.static_ratio, 1.0},
      {kStribeckVelocity, &p.stribeck_velocity, 1e-3},
      {kAsymmetry, &p.asymmetry, 0.0},
      {kRipple, &p.ripple, 0.0},
      {kRippleWavelength, &p.ripple_wavelength, 1e-3},
      {kRipplePhase, &p.ripple_phase, 0.0},
      {kNormalModulation, &p.normal_modulation, 0.0},
      {kModulationFrequency, &p.normal_modulation_frequency, 0.0},
      {kModulationPhase, &p.normal_modulation_phase, 0.0},
      {kForceOffset, &p.force_offset, 0.0},
      {kSensorLag, &c.sensor_lag, 0.0},
  };
  for (const NumberSpec& spec : numbers) {
    if (!ReadNumber(m, instance, kPlugin, spec.attr, spec.default_value, spec.target)) {
      return false;
    }
  }

  if (p.friction_coefficient < 0) return Reject(kMu, p.friction_coefficient, "must be >= 0");
  if (p.normal_force < 0) return Reject(kNormal, p.normal_force, "must be >= 0 (N)");
  if (HasDeflection(p.law) && p.contact_stiffness <= 0) {
    return Reject(kStiffness, p.contact_stiffness, "must be > 0 (N/m), e.g. 8e7 for 80 N/um");
  }
  if (p.alpha < 0) return Reject(kAlpha, p.alpha, "must be >= 0 (1 is Dahl's usual value)");
  if (!(p.breakaway_ratio > 0 && p.breakaway_ratio < 1)) {
    return Reject(kBreakaway, p.breakaway_ratio, "must lie in (0, 1), e.g. 0.7");
  }
  if (p.bristle_damping < 0) return Reject(kSigma1, p.bristle_damping, "must be >= 0 (N s/m)");
  if (p.viscous < 0) return Reject(kViscous, p.viscous, "must be >= 0 (N s/m)");
  if (p.static_ratio < 1) return Reject(kStaticRatio, p.static_ratio, "must be >= 1");
  if (p.stribeck_velocity <= 0) {
    return Reject(kStribeckVelocity, p.stribeck_velocity, "must be > 0 (m/s)");
  }
  if (!(p.asymmetry > -1 && p.asymmetry < 1)) {
    return Reject(kAsymmetry, p.asymmetry, "must lie in (-1, 1)");
  }
  if (!(p.ripple >= 0 && p.ripple < 1)) return Reject(kRipple, p.ripple, "must lie in [0, 1)");
  if (p.ripple_wavelength <= 0) {
    return Reject(kRippleWavelength, p.ripple_wavelength, "must be > 0 (m)");
  }
  if (!(p.normal_modulation >= 0 && p.normal_modulation < 1)) {
    return Reject(kNormalModulation, p.normal_modulation, "must lie in [0, 1)");
  }
  if (p.normal_modulation_frequency < 0) {
    return Reject(kModulationFrequency, p.normal_modulation_frequency, "must be >= 0 (Hz)");
  }
  if (c.sensor_lag < 0) return Reject(kSensorLag, c.sensor_lag, "must be >= 0 (s)");

  const char* sensor_name = mj_getPluginConfig(m, instance, kNormalSensor);
  if (sensor_name != nullptr && sensor_name[0] != '\0') {
    c.normal_sensor = mj_name2id(m, mjOBJ_SENSOR, sensor_name);
    if (c.normal_sensor < 0) {
      mju_warning("%s: attribute 'normal_sensor'=\"%s\" names no sensor; give the sensor that "
                  "measures the normal load a name and use it here", kPlugin, sensor_name);
      return false;
    }
    c.normal_component = static_cast<int>(normal_component);
    if (c.normal_component != normal_component || c.normal_component < 0 ||
        c.normal_component >= m->sensor_dim[c.normal_sensor]) {
      return Reject(kNormalComponent, normal_component,
                    "must be a whole number below the sensor's dimension");
    }
  }

  c.actuator = FindActuator(m, instance, kPlugin);
  if (c.actuator < 0) return false;
  if (m->actuator_actnum[c.actuator] < 1) {
    mju_warning("%s: the actuator has no state for the deflection z; add actdim=\"1\" to the "
                "actuator plugin element", kPlugin);
    return false;
  }
  c.output = m->actuator_outadr[c.actuator];
  c.act_address = m->actuator_actadr[c.actuator];
  *config = c;
  return true;
}

FrictionElement::FrictionElement(FrictionConfig config, std::string fingerprint)
    : config_(&FrictionConfig::FromModel, std::move(config), std::move(fingerprint)) {}

std::unique_ptr<FrictionElement> FrictionElement::Create(const mjModel* m, int instance) {
  FrictionConfig config;
  if (!FrictionConfig::FromModel(m, instance, &config)) return nullptr;
  return std::unique_ptr<FrictionElement>(
      new FrictionElement(config, ConfigFingerprint(m, instance)));
}

LawInput FrictionElement::Input(const mjModel* m, const mjData* d, double velocity) const {
  LawInput in;
  in.velocity = velocity;
  in.position = d->actuator_length[config_->output];
  in.time = d->time;
  in.normal_force = config_->law.normal_force;
  if (config_->normal_sensor >= 0) {
    const mjtNum value = d->sensordata[m->sensor_adr[config_->normal_sensor] +
                                       config_->normal_component];
    in.normal_force += config_->normal_gain * value;
  }
  return in;
}

void FrictionElement::Compute(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance)) {
    d->actuator_force[config_->output] = 0;
    return;
  }
  const LawParameters& p = config_->law;
  const LawInput in = Input(m, d, d->actuator_velocity[config_->output]);
  double friction;
  if (HasDeflection(p.law)) {
    friction = StateForce(p, in, d->act[config_->act_address]);
  } else {
    // Rigid Coulomb: the force that stops the transmission within this step, if admissible.
    const StepResponse response = ComputeStepResponse(m, d, config_->output, &scratch_);
    const double stick_force =
        response.inverse_mass > 0
            ? response.velocity_free / (m->opt.timestep * response.inverse_mass)
            : 0.0;
    friction = StickSlipForce(p, in, stick_force);
  }
  d->actuator_force[config_->output] = -friction;
}

void FrictionElement::ComputeSensor(const mjModel* m, mjData* d, int instance) {
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] != instance) continue;
    mjtNum* out = d->sensordata + m->sensor_adr[s];
    if (!config_.Refresh(m, instance, /*later_in_step=*/true)) {
      mju_zero(out, kSensorDim);
      continue;
    }
    const LawInput in = Input(m, d, d->actuator_velocity[config_->output]);
    const double friction = -d->actuator_force[config_->output];
    out[0] = friction;
    out[1] = HasDeflection(config_->law.law) ? d->act[config_->act_address] : 0.0;
    out[2] = in.velocity;
    out[3] = CoulombLevel(config_->law, in, 0) /
             (config_->law.friction_coefficient > 0 ? config_->law.friction_coefficient : 1.0);
    out[4] = config_->sensor_lag > 0 ? d->plugin_state[m->plugin_stateadr[instance]] : friction;
  }
}

void FrictionElement::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  const double dt = m->opt.timestep;
  if (config_->sensor_lag > 0) {
    // Exact first-order lag over the step, driven by this step's force.
    mjtNum* lagged = d->plugin_state + m->plugin_stateadr[instance];
    const double friction = -d->actuator_force[config_->output];
    *lagged += (friction - *lagged) * -std::expm1(-dt / config_->sensor_lag);
  }
  if (!HasDeflection(config_->law.law)) return;
  // z update with the velocity *after* this step's integration (see header).
  LawInput in = Input(m, d, TransmissionVelocity(m, d, config_->output));
  in.time = d->time - 0.5 * dt;  // mid-step: time has already advanced
  in.position += 0.5 * dt * in.velocity;
  mjtNum* z = d->act + config_->act_address;
  *z = AdvanceDeflection(config_->law, in, *z, dt);
}

int FrictionElement::StateSize(const mjModel* m, int instance) {
  double lag = 0.0;
  const char* text = mj_getPluginConfig(m, instance, kSensorLag);
  if (text && text[0]) lag = std::strtod(text, nullptr);
  return lag > 0 ? 1 : 0;
}

void FrictionElement::RegisterPlugin() {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = kName;
  plugin.capabilityflags |= mjPLUGIN_ACTUATOR | mjPLUGIN_SENSOR;
  plugin.nattribute = sizeof(kAttributes) / sizeof(kAttributes[0]);
  plugin.attributes = kAttributes;
  plugin.needstage = mjSTAGE_ACC;
  plugin.nstate = FrictionElement::StateSize;
  plugin.nsensordata = +[](const mjModel* m, int instance, int sensor_id) {
    return FrictionElement::kSensorDim;
  };
  SetInstanceLifecycle<FrictionElement>(&plugin);
  plugin.reset = +[](const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
    // The lagged force starts at 0 like the deflection; nothing else to reset.
    const int n = FrictionElement::StateSize(m, instance);
    for (int i = 0; i < n; ++i) plugin_state[i] = 0;
  };
  plugin.compute = +[](const mjModel* m, mjData* d, int instance, int capability_bit) {
    auto* element = InstanceOf<FrictionElement>(d, instance);
    if (capability_bit & mjPLUGIN_ACTUATOR) element->Compute(m, d, instance);
    if (capability_bit & mjPLUGIN_SENSOR) element->ComputeSensor(m, d, instance);
  };
  plugin.advance = +[](const mjModel* m, mjData* d, int instance) {
    InstanceOf<FrictionElement>(d, instance)->Advance(m, d, instance);
  };
  mjp_registerPlugin(&plugin);
}

}  // namespace vibrofriction
