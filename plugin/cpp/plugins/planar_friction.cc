#include "plugins/planar_friction.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "c_api/c_api.h"
#include "common/element_config.h"
#include "common/plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the shared MJCF keys


constexpr char kPlugin[] = "vibrofriction.planar";

// World direction of a slide joint's axis at the reference configuration.
void ReferenceAxis(const mjModel* m, int joint, double axis[3]) {
  double quat[4] = {1, 0, 0, 0};
  for (int body = m->jnt_bodyid[joint]; body > 0; body = m->body_parentid[body]) {
    double q[4];
    mju_mulQuat(q, m->body_quat + 4 * body, quat);
    mju_copy4(quat, q);
  }
  mju_rotVecQuat(axis, m->jnt_axis + 3 * joint, quat);
}

}  // namespace

// ---- NormalLoad ----------------------------------------------------------------------------------

// ---- PlanarTransmission --------------------------------------------------------------------------

bool PlanarTransmission::FromModel(const mjModel* m, int instance, const char* plugin,
                                   bool need_state, PlanarTransmission* out) {
  PlanarTransmission t;
  int count = 0;
  for (int i = 0; i < m->nactuator; ++i) {
    if (m->actuator_plugin[i] != instance) continue;
    if (count < 2) t.actuator[count] = i;
    ++count;
  }
  if (count != 2) {
    ConfigError("%s: the instance backs %d actuator(s); it needs exactly two, declared x then y: "
                "<plugin joint=\"body_x\" instance=\"..\" actdim=\"1\"/> and the same for y",
                plugin, count);
    return false;
  }
  for (int k = 0; k < 2; ++k) {
    const int a = t.actuator[k];
    if (need_state && m->actuator_actnum[a] < 1) {
      ConfigError("%s: actuator %d has no state for the deflection z; add actdim=\"1\" to both "
                  "actuator plugin elements", plugin, a);
      return false;
    }
    t.output[k] = m->actuator_outadr[a];
    const int type = m->actuator_trntype[a];
    if (type != mjTRN_JOINT && type != mjTRN_TENDON) {
      ConfigError("%s: actuator %d must act on a slide joint or a fixed tendon (the body's motion "
                  "relative to its support)", plugin, a);
      return false;
    }
    if (type == mjTRN_JOINT && m->jnt_type[m->actuator_trnid[2 * a]] != mjJNT_SLIDE) {
      ConfigError("%s: actuator %d acts on a joint that is not a slide joint; use the body's "
                  "slide joints along x and y", plugin, a);
      return false;
    }
  }
  const double gear0 = m->actuator_gear[6 * t.output[0]];
  const double gear1 = m->actuator_gear[6 * t.output[1]];
  if (std::fabs(std::fabs(gear0) - std::fabs(gear1)) > 1e-12 * (std::fabs(gear0) + 1)) {
    ConfigError("%s: the two actuators have different gear (%g, %g); isotropic friction needs "
                "equal gear (leave gear at 1)", plugin, gear0, gear1);
    return false;
  }
  if (m->actuator_trntype[t.actuator[0]] == mjTRN_JOINT &&
      m->actuator_trntype[t.actuator[1]] == mjTRN_JOINT) {
    double axis0[3], axis1[3];
    ReferenceAxis(m, m->actuator_trnid[2 * t.actuator[0]], axis0);
    ReferenceAxis(m, m->actuator_trnid[2 * t.actuator[1]], axis1);
    const double cosine = mju_dot3(axis0, axis1) / (mju_norm3(axis0) * mju_norm3(axis1));
    if (std::fabs(cosine) > 1e-6) {
      ConfigError("%s: the two slide joints are not orthogonal (cos = %g); give them "
                  "perpendicular in-plane axes, e.g. axis=\"1 0 0\" and axis=\"0 1 0\"", plugin,
                  cosine);
      return false;
    }
  }
  *out = t;
  return true;
}

// ---- Step response -------------------------------------------------------------------------------

void ComputePlanarResponse(const mjModel* m, mjData* d, const int output[2],
                           std::vector<mjtNum>* scratch, PlanarResponse* response) {
  const int nv = m->nv;
  scratch->assign(5 * nv, 0.0);
  mjtNum* force = scratch->data();
  mjtNum* rows = force + nv;           // J' of the two outputs
  mjtNum* response_rows = force + 3 * nv;  // M^-1 J'
  // qfrc_constraint still holds the previous step's constraint force (contacts, limits): with
  // it, a part held or pushed by another body sees that push in its friction solve.
  for (int i = 0; i < nv; ++i) {
    force[i] = d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_applied[i] + d->qfrc_constraint[i];
  }
  for (int j = 0; j < m->nout; ++j) {
    if (j == output[0] || j == output[1] || d->actuator_force[j] == 0) continue;
    const int adr = d->moment_rowadr[j];
    for (int k = 0; k < d->moment_rownnz[j]; ++k) {
      force[d->moment_colind[adr + k]] += d->actuator_moment[adr + k] * d->actuator_force[j];
    }
  }
  for (int col = 0; col < 2; ++col) {
    const int adr = d->moment_rowadr[output[col]];
    for (int k = 0; k < d->moment_rownnz[output[col]]; ++k) {
      rows[col * nv + d->moment_colind[adr + k]] = d->actuator_moment[adr + k];
    }
  }
  // Two solves, M^-1 J': M is symmetric, so J M^-1 force = (M^-1 J') . force.
  mj_solveM(m, d, response_rows, rows, 2);
  const double dt = m->opt.timestep;
  for (int col = 0; col < 2; ++col) {
    const mjtNum* response_row = response_rows + col * nv;
    double acceleration_free = 0.0;
    for (int i = 0; i < nv; ++i) acceleration_free += response_row[i] * force[i];
    response->v_free[col] = d->actuator_velocity[output[col]] + dt * acceleration_free;
    for (int r = 0; r < 2; ++r) {
      const int adr = d->moment_rowadr[output[r]];
      double value = 0.0;
      for (int k = 0; k < d->moment_rownnz[output[r]]; ++k) {
        value += d->actuator_moment[adr + k] * response_row[d->moment_colind[adr + k]];
      }
      response->B[2 * r + col] = dt * value;
    }
  }
  // Symmetrize (J M^-1 J' is symmetric up to rounding).
  const double offdiag = 0.5 * (response->B[1] + response->B[2]);
  response->B[1] = response->B[2] = offdiag;
}

// ---- A vibration the timestep cannot resolve -----------------------------------------------------

bool CheckVibrationResolved(const mjModel* m, const char* plugin, const std::vector<int>& trees,
                            const LawParameters& law, const char* fix) {
  const double dt = m->opt.timestep;
  auto refuse = [&](double frequency, const char* source) {
    return ConfigError("%s: %s vibrates at %g Hz and the timestep is %g s, %.3g steps a period: "
                       "this element resolves the vibration and needs at least %g; use %s%sa "
                       "timestep of at most %.3g s", plugin, source, frequency, dt,
                       1.0 / (frequency * dt), kMinStepsPerPeriod, fix ? fix : "",
                       fix ? ", or " : "", 1.0 / (kMinStepsPerPeriod * frequency));
  };
  if (law.normal_modulation != 0 && law.normal_modulation_frequency > 0 &&
      law.normal_modulation_frequency * dt * kMinStepsPerPeriod > 1.0) {
    return refuse(law.normal_modulation_frequency, "the normal load (normal_modulation)");
  }
  std::vector<int> moved;
  for (int a = 0; a < m->nactuator; ++a) {
    const int instance = m->actuator_plugin[a];
    if (instance < 0) continue;
    const mjpPlugin* plugin_type = mjp_getPluginAtSlot(m->plugin[instance]);
    if (!plugin_type || !plugin_type->name ||
        std::strcmp(plugin_type->name, "vibrofriction.motion") != 0) {
      continue;
    }
    const char* frequency_text = mj_getPluginConfig(m, instance, "frequency");
    const char* amplitude_text = mj_getPluginConfig(m, instance, "velocity_amplitude");
    if (!frequency_text || !amplitude_text) continue;
    const double frequency = std::strtod(frequency_text, nullptr);
    const double amplitude = std::strtod(amplitude_text, nullptr);
    if (!(frequency > 0) || amplitude == 0 || !(frequency * dt * kMinStepsPerPeriod > 1.0)) {
      continue;
    }
    moved.clear();
    TransmissionTrees(m, a, &moved);
    bool shares = false;
    for (int x : moved) {
      for (int y : trees) shares = shares || x == y || x < 0 || y < 0;
    }
    if (!shares) continue;
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, a);
    const std::string source = std::string("the support (vibrofriction.motion on actuator '") +
                               (name ? name : "(unnamed)") + "')";
    return refuse(frequency, source.c_str());
  }
  return true;
}

// ---- PlanarConfig --------------------------------------------------------------------------------

bool PlanarConfig::FromModel(const mjModel* m, int instance, PlanarConfig* config,
                             ReadScope scope) {
  PlanarConfig c;
  LawParameters& p = c.law;
  if (!ReadLawParameters(m, instance, kPlugin, &p, /*takes_gms=*/true)) return false;
  if (!NormalLoad::FromModel(m, instance, kPlugin, scope, &c.normal)) return false;
  if (!CheckIntegrator(m, kPlugin)) return false;
  p.normal_force = c.normal.normal;
  c.slip_state = NormalLoad::StateSize(m, instance);
  if (scope == ReadScope::kAttributes) return true;  // the actuators' fields are not set yet
  if (!PlanarTransmission::FromModel(m, instance, kPlugin, /*need_state=*/true, &c.transmission)) {
    return false;
  }
  if (p.law == Law::kGms) {
    for (int k = 0; k < 2; ++k) {
      const int actdim = m->actuator_actnum[c.transmission.actuator[k]];
      if (actdim != p.gms.count) {
        ConfigError("%s: the %c actuator has actdim=\"%d\"; law gms keeps one deflection per "
                    "element on each axis and gms_stiffness names %d: write actdim=\"%d\" on "
                    "both actuators", kPlugin, k == 0 ? 'x' : 'y', actdim, p.gms.count,
                    p.gms.count);
        return false;
      }
    }
  } else {
    for (int k = 0; k < 2; ++k) {
      const int actdim = m->actuator_actnum[c.transmission.actuator[k]];
      if (actdim != 1) {
        ConfigError("%s: the %c actuator has actdim=\"%d\"; law %s keeps %s: write "
                    "actdim=\"1\" on both actuators", kPlugin, k == 0 ? 'x' : 'y', actdim,
                    LawName(p.law), HasDeflection(p.law) ? "one deflection per axis, (z_x, z_y) "
                                                           "in act"
                                                         : "one (unused) state per axis");
        return false;
      }
    }
  }
  for (int k = 0; k < 2; ++k) c.act_address[k] = m->actuator_actadr[c.transmission.actuator[k]];
  std::vector<int> trees;
  for (int k = 0; k < 2; ++k) TransmissionTrees(m, c.transmission.actuator[k], &trees);
  if (!CheckVibrationResolved(m, kPlugin, trees, p, "vibrofriction.averaged (the vibration "
                              "averaged out, for robot timesteps)")) {
    return false;
  }
  *config = c;
  return true;
}

// ---- PlanarFriction ------------------------------------------------------------------------------

LawInput PlanarFriction::Input(const mjModel* m, const mjData* d, int instance) const {
  LawInput in;
  in.time = d->time;
  in.normal_force = config_->normal.Value(m, d, d->plugin_state + m->plugin_stateadr[instance]);
  return in;
}

void PlanarFriction::Compute(const mjModel* m, mjData* d, int instance) {
  if (!RefreshOrZeroForces(config_, m, d, instance)) return;
  const int* out = config_->transmission.output;
  const LawParameters& p = config_->law;
  LawInput in = Input(m, d, instance);
  const double v[2] = {d->actuator_velocity[out[0]], d->actuator_velocity[out[1]]};
  in.velocity = std::hypot(v[0], v[1]);
  double force[2];
  implicit_step_ = false;
  if (HasDeflection(p.law)) {
    // A step that does not resolve the contact's deflection dynamics, k_t dt lambda_max(B) >=
    // kUnresolvedDeflection (friction_law.h), is taken implicitly; the explicit force of the
    // step's start deflection would chatter (stable only below 4).
    PlanarResponse response;
    ComputePlanarResponse(m, d, out, &scratch_, &response);
    double stiffness = p.contact_stiffness;
    if (p.law == Law::kGms) {
      stiffness = 0.0;  // the elements stick in parallel
      for (int i = 0; i < p.gms.count; ++i) stiffness += p.gms.stiffness[i];
    }
    const double dt = m->opt.timestep;
    // A bristle damping the step does not resolve, sigma1 lambda_max(B) >= 1, too: the
    // trapezoidal damping of the resolved path (PlanarImplicitStateForce) keeps a velocity that
    // flips sign each step there, and the bristles' rate follows it (on a plate vibrating past
    // the slip limit, LuGre with sigma1 1e4 N s/m on a 1 kg part crept 23 % (1 ms) and 43 %
    // (2 ms) short of the resolved creep; now 5.8 % and 11 %). The viscous term is linear: the
    // trapezoidal rule keeps it right at any step.
    const double lambda = LargestEigenvalue<2>(response.B);
    if (stiffness * dt * lambda >= kUnresolvedDeflection ||
        p.bristle_damping * lambda >= kUnresolvedDeflection) {
      LawInput mid = in;  // the deflection's update over the step, as advance takes it
      mid.time = in.time + 0.5 * dt;
      double end[2];
      if (p.law == Law::kGms) {
        double z[2 * kMaxGmsElements];
        GatherGms(d, z);
        const mjtNum* slipping =
            d->plugin_state + m->plugin_stateadr[instance] + config_->slip_state;
        double flags[kMaxGmsElements];
        for (int i = 0; i < p.gms.count; ++i) flags[i] = slipping[i];
        GmsImplicitDeflectionForce<2>(p, mid, z, flags, response.v_free, response.B, dt, force,
                                      end, implicit_next_, implicit_slipping_);
      } else {
        const double z[2] = {d->act[config_->act_address[0]], d->act[config_->act_address[1]]};
        VectorImplicitDeflectionForce<2>(p, mid, z, response.v_free, response.B, dt, force, end,
                                         implicit_next_);
      }
      implicit_step_ = true;
      d->actuator_force[out[0]] = -force[0];
      d->actuator_force[out[1]] = -force[1];
      return;
    }
  }
  if (p.law == Law::kGms) {
    double z[2 * kMaxGmsElements];
    GatherGms(d, z);
    if (p.viscous == 0) {
      GmsElementForce<2>(p, z, force);
    } else {
      PlanarResponse response;
      ComputePlanarResponse(m, d, out, &scratch_, &response);
      GmsImplicitForce<2>(p, z, v, response.v_free, response.B, force);
    }
    d->actuator_force[out[0]] = -force[0];
    d->actuator_force[out[1]] = -force[1];
    return;
  }
  const double z[2] = {d->act[config_->act_address[0]], d->act[config_->act_address[1]]};
  if (HasDeflection(p.law) && p.bristle_damping == 0 && p.viscous == 0) {
    PlanarStateForce(p, in, v, z, force);
  } else if (HasDeflection(p.law)) {
    // Damping terms at the end-of-step velocity, as the 1D element (ImplicitStateForce).
    PlanarResponse response;
    ComputePlanarResponse(m, d, out, &scratch_, &response);
    PlanarImplicitStateForce(p, in, v, z, response.v_free, response.B, force);
  } else {
    PlanarResponse response;
    ComputePlanarResponse(m, d, out, &scratch_, &response);
    PlanarStickSlipForce(p, in, v, response.v_free, response.B, force);
  }
  d->actuator_force[out[0]] = -force[0];
  d->actuator_force[out[1]] = -force[1];
}

void PlanarFriction::WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* sensor) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) {
    mju_zero(sensor, kSensorDim);
    return;
  }
  const int* out = config_->transmission.output;
  const LawInput in = Input(m, d, instance);
  const LawParameters& p = config_->law;
  sensor[0] = -d->actuator_force[out[0]];
  sensor[1] = -d->actuator_force[out[1]];
  if (p.law == Law::kGms) {
    double z[2 * kMaxGmsElements];
    GatherGms(d, z);
    GmsEquivalentDeflection<2>(p, z, sensor + 2);
  } else {
    const bool state = HasDeflection(p.law);
    sensor[2] = state ? d->act[config_->act_address[0]] : 0.0;
    sensor[3] = state ? d->act[config_->act_address[1]] : 0.0;
  }
  sensor[4] = d->actuator_velocity[out[0]];
  sensor[5] = d->actuator_velocity[out[1]];
  sensor[6] = ModulatedNormalLoad(config_->law, in);  // < 0: lifted off, the law uses 0
}

void PlanarFriction::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  // This step's contacts give the normal load of the next step (and of this z update, as the
  // sensor input does in vibrofriction.friction).
  config_->normal.Update(m, d, d->plugin_state + m->plugin_stateadr[instance]);
  if (!HasDeflection(config_->law.law)) return;
  if (implicit_step_) {
    // The deflection the step's force was computed with (VectorImplicitDeflectionForce).
    const int count = config_->law.law == Law::kGms ? config_->law.gms.count : 1;
    for (int i = 0; i < count; ++i) {
      d->act[config_->act_address[0] + i] = implicit_next_[2 * i];
      d->act[config_->act_address[1] + i] = implicit_next_[2 * i + 1];
    }
    if (config_->law.law == Law::kGms) {
      mjtNum* slipping = d->plugin_state + m->plugin_stateadr[instance] + config_->slip_state;
      for (int i = 0; i < count; ++i) slipping[i] = implicit_slipping_[i];
    }
    return;
  }
  const double dt = m->opt.timestep;
  const int* out = config_->transmission.output;
  LawInput in = Input(m, d, instance);
  in.time = d->time - 0.5 * dt;  // mid-step: time has already advanced
  const double v[2] = {TransmissionVelocity(m, d, out[0]), TransmissionVelocity(m, d, out[1])};
  if (config_->law.law == Law::kGms) {
    double z[2 * kMaxGmsElements];
    GatherGms(d, z);
    AdvanceGms<2>(config_->law, in, v, z,
                  d->plugin_state + m->plugin_stateadr[instance] + config_->slip_state, dt);
    for (int i = 0; i < config_->law.gms.count; ++i) {
      d->act[config_->act_address[0] + i] = z[2 * i];
      d->act[config_->act_address[1] + i] = z[2 * i + 1];
    }
    return;
  }
  double z[2] = {d->act[config_->act_address[0]], d->act[config_->act_address[1]]};
  AdvancePlanarDeflection(config_->law, in, v, z, dt);
  d->act[config_->act_address[0]] = z[0];
  d->act[config_->act_address[1]] = z[1];
}

void PlanarFriction::GatherGms(const mjData* d, double* z) const {
  for (int i = 0; i < config_->law.gms.count; ++i) {
    z[2 * i] = d->act[config_->act_address[0] + i];
    z[2 * i + 1] = d->act[config_->act_address[1] + i];
  }
}

void PlanarFriction::RegisterPlugin() {
  RegisterElementPlugin<PlanarFriction, &PlanarConfig::FromModel>(
      kName, attributes::kPlanar, mjPLUGIN_ACTUATOR);
}

}  // namespace vibrofriction

// ---- C API: the planar law along a prescribed velocity history (vibrofriction/rigs/planar.py) ---

extern "C" {

// Declared in c_api.h (exported). Force i uses (z_i, v_i); z_{i+1} advances over [t_i, t_{i+1}]
// with the input at t_{i+1}.
int vf_run_planar_law(const vf_law_parameters* params, int n, const double* time,
                      const double* vx, const double* vy, const double* normal_force, double z0x,
                      double z0y, double* fx, double* fy, double* zx, double* zy) {
  using namespace vibrofriction;
  if (!params || n < 0 || !time || !vx || !vy || !fx || !fy || !zx || !zy) return -1;
  if (params->law < 0 || params->law > 3) return -1;  // (gms: no kinematic planar driver)
  if (params->asymmetry != 0 || params->ripple != 0 || params->force_offset != 0 ||
      params->contact_play != 0) {
    return -1;
  }
  const LawParameters p = LawFromStruct(*params);  // (the refused effects are 0)
  auto input = [&](int i) {
    LawInput in;
    in.time = time[i];
    in.normal_force = normal_force ? normal_force[i] : p.normal_force;
    in.velocity = std::hypot(vx[i], vy[i]);
    return in;
  };
  const bool state = HasDeflection(p.law);
  double z[2] = {state ? z0x : 0.0, state ? z0y : 0.0};
  for (int i = 0; i < n; ++i) {
    const LawInput in = input(i);
    const double v[2] = {vx[i], vy[i]};
    double force[2];
    zx[i] = z[0];
    zy[i] = z[1];
    if (state) {
      PlanarStateForce(p, in, v, z, force);
    } else {
      PlanarKinematicCoulombForce(p, in, v, force);
    }
    fx[i] = force[0];
    fy[i] = force[1];
    if (state && i + 1 < n) {
      const double v_next[2] = {vx[i + 1], vy[i + 1]};
      AdvancePlanarDeflection(p, input(i + 1), v_next, z, time[i + 1] - time[i]);
    }
  }
  return 0;
}

}  // extern "C"
