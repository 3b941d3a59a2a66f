#include "plugins/friction_element.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include "common/element_config.h"
#include "common/plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the shared MJCF keys (element_config.h)

// Keys of this element only.


constexpr char kPlugin[] = "vibrofriction.friction";

}  // namespace

// The element acts along one coordinate: a slide joint (N, m), a hinge (N m, rad: joint
// friction of an arm), or a fixed tendon of such joints, with a non-zero gear. A ball or free
// joint, a spatial tendon or a site is refused naming the fix.
static bool CheckTransmission(const mjModel* m, int actuator) {
  const int id = m->actuator_trnid[2 * actuator];
  switch (m->actuator_trntype[actuator]) {
    case mjTRN_JOINT:
    case mjTRN_JOINTINPARENT:
      if (m->jnt_type[id] != mjJNT_SLIDE && m->jnt_type[id] != mjJNT_HINGE) {
        ConfigError("%s: the actuator's joint '%s' is a ball or free joint; the element acts "
                    "along one coordinate: put it on a slide or hinge joint (or a fixed tendon), "
                    "and use vibrofriction.planar for a body sliding in a plane", kPlugin,
                    mj_id2name(m, mjOBJ_JOINT, id) ? mj_id2name(m, mjOBJ_JOINT, id) : "");
        return false;
      }
      break;
    case mjTRN_TENDON:
      for (int w = m->tendon_adr[id]; w < m->tendon_adr[id] + m->tendon_num[id]; ++w) {
        if (m->wrap_type[w] != mjWRAP_JOINT) {
          ConfigError("%s: the actuator's tendon '%s' is not a fixed tendon; write the relative "
                      "motion as <fixed> over slide (or hinge) joints",
                      kPlugin, mj_id2name(m, mjOBJ_TENDON, id) ? mj_id2name(m, mjOBJ_TENDON, id)
                                                              : "");
          return false;
        }
      }
      break;
    default:
      ConfigError("%s: the actuator's transmission must be a slide or hinge joint or a fixed "
                  "tendon (joint=\"...\" or tendon=\"...\"), not a site, body or crank", kPlugin);
      return false;
  }
  if (m->actuator_gear[6 * actuator] == 0) {
    ConfigError("%s: the actuator's gear is 0, so the element sees no motion and applies no "
                "force; leave gear at 1", kPlugin);
    return false;
  }
  return true;
}

static bool SharesTree(const mjModel* m, int a, int b) {
  std::vector<int> ta, tb;
  TransmissionTrees(m, a, &ta);
  TransmissionTrees(m, b, &tb);
  for (int x : ta) {
    for (int y : tb) {
      if (x == y || x < 0 || y < 0) return true;
    }
  }
  return false;
}

bool FrictionConfig::FromModel(const mjModel* m, int instance, FrictionConfig* config,
                               ReadScope scope) {
  FrictionConfig c;
  LawParameters& p = c.law;
  if (!ReadLawParameters(m, instance, kPlugin, &p, /*takes_gms=*/true)) return false;
  if (!NormalLoad::FromModel(m, instance, kPlugin, scope, &c.normal)) return false;
  p.normal_force = c.normal.normal;

  // (each default: the table's, vocabulary.h)
  if (!ReadNumbers(m, instance, kPlugin, {
      {kAsymmetry, &p.asymmetry},
      {kRipple, &p.ripple},
      {kRippleWavelength, &p.ripple_wavelength},
      {kRipplePhase, &p.ripple_phase},
      {kForceOffset, &p.force_offset},
      {kContactPlay, &p.contact_play},
      {kSensorLag, &c.sensor_lag},
      })) {
    return false;
  }
  if (!ReadLevelMap(m, instance, kPlugin, kPositionMapKnots, kPositionMapFactors,
                    kPositionMapPeriod, /*nonnegative_knots=*/false, &p.position_map) ||
      !ReadLevelMap(m, instance, kPlugin, kVelocityMapKnots, kVelocityMapFactors, nullptr,
                    /*nonnegative_knots=*/true, &p.velocity_map) ||
      !ReadLevelMap(m, instance, kPlugin, kTimeMapKnots, kTimeMapFactors, nullptr,
                    /*nonnegative_knots=*/true, &p.time_map)) {
    return false;
  }
  if (!(p.asymmetry > -1 && p.asymmetry < 1)) {
    return RejectAttribute(kPlugin, kAsymmetry, p.asymmetry, "must lie in (-1, 1)");
  }
  if (!(p.ripple >= 0 && p.ripple < 1)) {
    return RejectAttribute(kPlugin, kRipple, p.ripple, "must lie in [0, 1)");
  }
  if (p.ripple_wavelength <= 0) {
    return RejectAttribute(kPlugin, kRippleWavelength, p.ripple_wavelength, "must be > 0 (m)");
  }
  if (p.contact_play < 0) {
    return RejectAttribute(kPlugin, kContactPlay, p.contact_play, "must be >= 0 (m)");
  }
  if (p.contact_play > 0 && !TakesContactPlay(p.law)) {
    return RejectAttribute(kPlugin, kContactPlay, p.contact_play,
                           "is a play before the bristles, which law coulomb and law gms do not "
                           "have; use law dahl, dupont or lugre, or remove contact_play");
  }
  if (c.sensor_lag < 0) {
    return RejectAttribute(kPlugin, kSensorLag, c.sensor_lag, "must be >= 0 (s)");
  }
  if (!CheckIntegrator(m, kPlugin)) return false;
  // plugin_state: [contact normal force (if contact geoms)] [lagged friction (if sensor_lag)]
  // [gms elements' slip flags]
  c.lag_state = NormalLoad::StateSize(m, instance);
  c.slip_state = c.lag_state + (c.sensor_lag > 0 ? 1 : 0);
  const int deflections = p.law == Law::kGms ? p.gms.count : 1;

  c.actuator = FindActuator(m, instance, kPlugin);
  if (c.actuator < 0) return false;
  bool from_ctrl = false;
  if (!ReadBool(m, instance, kPlugin, kNormalFromCtrl, defaults::kNormalFromCtrl, &from_ctrl)) {
    return false;
  }
  if (from_ctrl) {
    if (c.normal.sensor >= 0 || c.normal.UsesContacts()) {
      ConfigError("%s: 'normal_from_ctrl' and '%s' are both set; use one source for the "
                  "normal load", kPlugin, c.normal.sensor >= 0 ? kNormalSensor : kContactGeom1);
      return false;
    }
    // F_N = normal + normal_gain * ctrl of the element's own actuator (a measured load
    // replayed step by step: no sensor stage between, so no step of delay)
    c.normal.ctrl = m->actuator_ctrladr[c.actuator];
  }
  if (scope == ReadScope::kAttributes) return true;  // the actuator's fields are not set yet
  if (from_ctrl && m->actuator_ctrllimited[c.actuator]) {
    // Within the ctrlrange the load is largest at one of its ends: <= 0 there, the element
    // never carries friction.
    const double lo = m->actuator_ctrlrange[2 * c.actuator];
    const double hi = m->actuator_ctrlrange[2 * c.actuator + 1];
    const double largest = c.normal.normal + std::max(c.normal.gain * lo, c.normal.gain * hi);
    if (!(largest > 0)) {
      return ConfigError("%s: attribute 'normal_gain'=\"%g\" with normal=\"%g\" and the "
                         "actuator's ctrlrange [%g, %g] makes the load %g N at most, <= 0 at "
                         "every step; give a gain and normal for which some ctrl of the range "
                         "gives F_N = normal + normal_gain ctrl > 0", kPlugin, c.normal.gain,
                         c.normal.normal, lo, hi, largest);
    }
  }
  if (m->actuator_actnum[c.actuator] < 1) {
    ConfigError("%s: the actuator has no state for the deflection z; add actdim=\"%d\" to the "
                "actuator plugin element", kPlugin, deflections);
    return false;
  }
  if (m->actuator_actnum[c.actuator] != deflections) {
    if (p.law == Law::kGms) {
      ConfigError("%s: actdim=\"%d\"; law gms keeps one deflection per element and "
                  "gms_stiffness names %d: write actdim=\"%d\"", kPlugin,
                  m->actuator_actnum[c.actuator], deflections, deflections);
    } else {
      ConfigError("%s: actdim=\"%d\"; the element keeps one deflection z: write actdim=\"1\"",
                  kPlugin, m->actuator_actnum[c.actuator]);
    }
    return false;
  }
  if (!CheckTransmission(m, c.actuator)) return false;
  // Forces computed after the element are not known to its stick solve: a prescribed motion
  // (vibrofriction.motion) computed after it, on a body tree the element's transmission shares,
  // would be a disturbance the element ignores.
  for (int j = instance + 1; j < m->nplugin; ++j) {
    const mjpPlugin* other = mjp_getPluginAtSlot(m->plugin[j]);
    if (!other || !other->name || std::strcmp(other->name, "vibrofriction.motion") != 0) continue;
    for (int a = 0; a < m->nactuator; ++a) {
      if (m->actuator_plugin[a] != j || !SharesTree(m, a, c.actuator)) continue;
      const char* name = mj_id2name(m, mjOBJ_PLUGIN, j);
      ConfigError("%s: a vibrofriction.motion plugin (%s%s%s) on the same body tree is computed "
                  "after this friction element; declare it as a named <extension> instance "
                  "before the friction element's (its force must be known to the element's "
                  "stick solve)", kPlugin, name ? "instance '" : "inline", name ? name : "",
                  name ? "'" : "");
      return false;
    }
  }
  c.output = m->actuator_outadr[c.actuator];
  c.act_address = m->actuator_actadr[c.actuator];
  *config = c;
  return true;
}

namespace {

// The root w of h(w) = w + B F(w) - v_free for a force F(w) that does not decrease with w
// (it may jump: a play's face): regula falsi (Illinois) on the bracket between v_free and
// v_free - B F(v_free), where h changes sign, to the last bit. Returns the force consistent with
// the root, (v_free - w) / B within F's values on either side of it (a jump's middle: the force
// that stops the motion there), and leaves force_of's last state at w in place.
template <class ForceOf>
double SolveScalarImplicit(double v_free, double B, ForceOf force_of, double* root) {
  const double f_free = force_of(v_free);
  if (f_free == 0.0) {
    *root = v_free;
    return 0.0;
  }
  double lo = v_free, hi = v_free - B * f_free;
  double h_lo = B * f_free, h_hi = 0.0;
  double f_lo = f_free, f_hi = force_of(hi);
  h_hi = hi + B * f_hi - v_free;
  if (lo > hi) {
    std::swap(lo, hi);
    std::swap(h_lo, h_hi);
    std::swap(f_lo, f_hi);
  }
  // h(lo) <= 0 <= h(hi) for a non-decreasing F
  if (h_lo >= 0 || h_hi <= 0) {
    const bool at_lo = std::fabs(h_lo) <= std::fabs(h_hi);
    *root = at_lo ? lo : hi;
    force_of(*root);
    return at_lo ? f_lo : f_hi;
  }
  int side = 0;
  for (int k = 0; k < 200; ++k) {
    double w = (lo * h_hi - hi * h_lo) / (h_hi - h_lo);
    if (!(w > lo && w < hi)) w = 0.5 * (lo + hi);
    if (w <= lo || w >= hi) break;  // the bracket is two neighbouring doubles
    const double f = force_of(w);
    const double h = w + B * f - v_free;
    if (h == 0) {
      *root = w;
      return f;
    }
    if (h < 0) {
      lo = w, h_lo = h, f_lo = f;
      if (side == -1) h_hi *= 0.5;  // Illinois: the stale end's value halved
      side = -1;
    } else {
      hi = w, h_hi = h, f_hi = f;
      if (side == +1) h_lo *= 0.5;
      side = +1;
    }
    if (hi - lo <= 4 * std::numeric_limits<double>::epsilon() * std::max(std::fabs(lo),
                                                                         std::fabs(hi))) {
      break;
    }
  }
  *root = 0.5 * (lo + hi);
  force_of(*root);
  return std::clamp((v_free - *root) / B, std::min(f_lo, f_hi), std::max(f_lo, f_hi));
}

// The transmission's inverse weight at qpos0 (m->dof_invweight0, tendon_invweight0) times
// gear^2: the cheap estimate that keeps the lean path lean where a step resolves the contact.
double InverseWeight0(const mjModel* m, int actuator) {
  const int id = m->actuator_trnid[2 * actuator];
  const double gear = m->actuator_gear[6 * actuator];
  switch (m->actuator_trntype[actuator]) {
    case mjTRN_JOINT:
    case mjTRN_JOINTINPARENT:
      return gear * gear * m->dof_invweight0[m->jnt_dofadr[id]];
    case mjTRN_TENDON:
      return gear * gear * m->tendon_invweight0[id];
    default:
      return 0.0;
  }
}

}  // namespace

double FrictionElement::ImplicitDeflectionForce(const mjModel* m, mjData* d, int instance,
                                                const LawInput& in,
                                                const StepResponse& response) {
  const LawParameters& p = config_->law;
  const double dt = m->opt.timestep;
  const double B = dt * response.inverse_mass;
  const LawParameters q = LevelAtSpeed(p, in.velocity);
  LawInput at = in;  // the deflection's update over the step, as advance takes it
  at.time = in.time + 0.5 * dt;
  double w = 0.0;
  if (p.law == Law::kGms) {
    const int count = p.gms.count;
    const double* z = d->act + config_->act_address;
    const mjtNum* slipping = d->plugin_state + m->plugin_stateadr[instance] + config_->slip_state;
    auto force_of = [&](double velocity) {
      for (int i = 0; i < count; ++i) {
        implicit_next_[i] = z[i];
        implicit_slipping_[i] = slipping[i];
      }
      LawInput step = at;
      step.velocity = velocity;
      step.position = in.position + 0.5 * dt * velocity;
      AdvanceGms<1>(q, step, &velocity, implicit_next_, implicit_slipping_, dt);
      double f = 0.0;
      GmsElementForce<1>(q, implicit_next_, &f);
      return f + q.viscous * velocity + q.force_offset;
    };
    return SolveScalarImplicit(response.velocity_free, B, force_of, &w);
  }
  // A deflection beyond what the level holds (the load or the level fell) is taken at the
  // level, as the vector elements' step takes it.
  double z = d->act[config_->act_address];
  const double elastic = ElasticDeflection(q, z);
  const double limit = CoulombLevel(q, in, elastic > 0 ? 1.0 : -1.0) / q.contact_stiffness;
  if (std::fabs(elastic) > limit) z += (elastic > 0 ? limit : -limit) - elastic;
  const double start = ElasticDeflection(q, z);
  auto force_of = [&](double velocity) {
    LawInput step = at;
    step.velocity = velocity;
    step.position = in.position + 0.5 * dt * velocity;
    implicit_next_[0] = AdvanceDeflection(q, step, z, dt);
    if (PlayOpen(q, implicit_next_[0], velocity)) return q.force_offset;
    const double after = ElasticDeflection(q, implicit_next_[0]);
    return q.contact_stiffness * after + q.bristle_damping * (after - start) / dt +
           q.viscous * velocity + q.force_offset;
  };
  return SolveScalarImplicit(response.velocity_free, B, force_of, &w);
}

LawInput FrictionElement::Input(const mjModel* m, const mjData* d, int instance,
                                double velocity) const {
  LawInput in;
  in.velocity = velocity;
  in.position = d->actuator_length[config_->output];
  in.time = d->time;
  in.normal_force = config_->normal.Value(m, d, d->plugin_state + m->plugin_stateadr[instance]);
  return in;
}

void FrictionElement::Compute(const mjModel* m, mjData* d, int instance) {
  implicit_step_ = false;
  if (!config_.Refresh(m, instance)) {
    d->actuator_force[config_->output] = 0;
    return;
  }
  const LawParameters& p = config_->law;
  const double velocity = d->actuator_velocity[config_->output];
  if (HasDeflection(p.law)) {
    // A step that does not resolve the contact (k_t dt B or sigma1 B >= 1, B = dt J M^-1 J')
    // is taken implicitly. The response is computed only where the inverse weight at
    // qpos0 says the step may be one (within a factor 10): resolved steps keep their path.
    double stiffness = p.contact_stiffness;
    if (p.law == Law::kGms) {
      stiffness = 0.0;
      for (int i = 0; i < p.gms.count; ++i) stiffness += p.gms.stiffness[i];
    }
    const double dt = m->opt.timestep;
    const double damping = p.bristle_damping;  // (the viscous term: trapezoidal, right at any step)
    const double weight = InverseWeight0(m, config_->actuator);
    if (10 * (stiffness * dt + damping) * dt * weight >= kUnresolvedDeflection || !(weight > 0)) {
      const StepResponse response =
          ComputeStepResponse(m, d, config_->output, &response_workspace_);
      const double B = dt * response.inverse_mass;
      if (stiffness * dt * B >= kUnresolvedDeflection || damping * B >= kUnresolvedDeflection) {
        const LawInput in = Input(m, d, instance, velocity);
        implicit_step_ = true;
        d->actuator_force[config_->output] = -ImplicitDeflectionForce(m, d, instance, in,
                                                                      response);
        return;
      }
    }
  }
  if (p.law == Law::kGms) {
    const double* z = d->act + config_->act_address;
    double friction = 0.0;
    if (p.viscous == 0) {
      GmsElementForce<1>(p, z, &friction);
      friction += p.force_offset;
    } else {
      const StepResponse response =
          ComputeStepResponse(m, d, config_->output, &response_workspace_);
      const double B = m->opt.timestep * response.inverse_mass;
      GmsImplicitForce<1>(p, z, &velocity, &response.velocity_free, &B, &friction);
    }
    d->actuator_force[config_->output] = -friction;
    return;
  }
  const double z = d->act[config_->act_address];
  if (HasDeflection(p.law) && p.bristle_damping == 0 && p.viscous == 0 && p.contact_play == 0) {
    // The common case, kept lean: no level, no input needed.
    d->actuator_force[config_->output] = -UndampedStateForce(p, velocity, z);
    return;
  }
  const LawInput in = Input(m, d, instance, velocity);
  double friction;
  if (HasDeflection(p.law)) {
    // Damping terms at the end-of-step velocity (see ImplicitStateForce).
    const StepResponse response = ComputeStepResponse(m, d, config_->output, &response_workspace_);
    friction = ImplicitStateForce(p, in, z, response.velocity_free,
                                  m->opt.timestep * response.inverse_mass, m->opt.timestep);
  } else {
    // Rigid Coulomb: the force that stops the transmission within this step, if admissible.
    const StepResponse response = ComputeStepResponse(m, d, config_->output, &response_workspace_);
    const double stick_force =
        response.inverse_mass > 0
            ? response.velocity_free / (m->opt.timestep * response.inverse_mass)
            : 0.0;
    friction = StickSlipForce(p, in, stick_force);
  }
  d->actuator_force[config_->output] = -friction;
}

void FrictionElement::WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* out) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) {
    mju_zero(out, kSensorDim);
    return;
  }
  const LawInput in = Input(m, d, instance, d->actuator_velocity[config_->output]);
  const double friction = -d->actuator_force[config_->output];
  out[0] = friction;
  out[1] = Deflection(d);
  out[2] = in.velocity;
  out[3] = ModulatedNormalLoad(config_->law, in);  // < 0: lifted off, the law uses 0
  out[4] = config_->sensor_lag > 0
               ? d->plugin_state[m->plugin_stateadr[instance] + config_->lag_state]
               : friction;
}

void FrictionElement::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  const double dt = m->opt.timestep;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  if (config_->normal.UsesContacts()) {
    config_->normal.Update(m, d, state);  // this step's contact force, for the next step
  }
  if (config_->sensor_lag > 0) {
    // Exact first-order lag over the step, driven by this step's force.
    mjtNum* lagged = state + config_->lag_state;
    const double friction = -d->actuator_force[config_->output];
    *lagged = FirstOrderLagStep(*lagged, friction, friction, dt, config_->sensor_lag);
  }
  if (!HasDeflection(config_->law.law)) return;
  mjtNum* z = d->act + config_->act_address;
  if (implicit_step_) {  // the deflection the step's force was computed with
    const bool gms = config_->law.law == Law::kGms;
    for (int i = 0; i < (gms ? config_->law.gms.count : 1); ++i) {
      z[i] = implicit_next_[i];
      if (gms) state[config_->slip_state + i] = implicit_slipping_[i];
    }
    return;
  }
  // z update with the velocity *after* this step's integration (see header).
  LawInput in = Input(m, d, instance, TransmissionVelocity(m, d, config_->output));
  in.time = d->time - 0.5 * dt;  // mid-step: time has already advanced
  in.position += 0.5 * dt * in.velocity;
  if (config_->law.law == Law::kGms) {
    AdvanceGms<1>(config_->law, in, &in.velocity, z, state + config_->slip_state, dt);
    return;
  }
  *z = AdvanceDeflection(config_->law, in, *z, dt);
}

double FrictionElement::Deflection(const mjData* d) const {
  const LawParameters& p = config_->law;
  if (!HasDeflection(p.law)) return 0.0;
  const mjtNum* z = d->act + config_->act_address;
  if (p.law != Law::kGms) return z[0];
  double deflection;
  GmsEquivalentDeflection<1>(p, z, &deflection);
  return deflection;
}

int FrictionElement::StateSize(const mjModel* m, int instance) {
  double lag = 0.0;
  const char* text = mj_getPluginConfig(m, instance, kSensorLag);
  if (text && text[0]) lag = std::strtod(text, nullptr);
  return NormalLoad::StateSize(m, instance) + (lag > 0 ? 1 : 0) + GmsElementCount(m, instance);
}

void FrictionElement::RegisterPlugin() {
  RegisterElementPlugin<FrictionElement, &FrictionConfig::FromModel>(
      kName, attributes::kFriction, mjPLUGIN_ACTUATOR);
}

}  // namespace vibrofriction
