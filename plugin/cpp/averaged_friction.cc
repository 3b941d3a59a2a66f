#include "averaged_friction.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>

#include "element_config.h"
#include "plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the shared MJCF keys (element_config.h)

constexpr char kVelocityAmplitude[] = "velocity_amplitude";
constexpr char kAxisAngle[] = "axis_angle";
constexpr char kUseCtrl[] = "use_ctrl";
constexpr char kTableXi[] = "table_xi";
constexpr char kTableAngle[] = "table_angle";
constexpr char kTableAlong[] = "table_along";
constexpr char kTableAcross[] = "table_across";

const char* const kAttributes[] = {
    kMu, kNormal, kNormalSensor, kNormalGain, kNormalComponent, kContactGeom1, kContactGeom2,
    kViscous, kStaticRatio, kStribeckVelocity, kVelocityAmplitude, kAxisAngle, kUseCtrl,
    kTableXi, kTableAngle, kTableAlong, kTableAcross};

constexpr char kPlugin[] = "vibrofriction.averaged";

bool Reject(const char* attr, double value, const char* rule) {
  return RejectAttribute(kPlugin, attr, value, rule);
}

// Index i with grid[i] <= x < grid[i+1] (clamped to the last cell) and the weight of i+1.
void Locate(const std::vector<double>& grid, double x, int* index, double* weight) {
  const int n = static_cast<int>(grid.size());
  if (x <= grid[0]) {
    *index = 0;
    *weight = 0.0;
    return;
  }
  if (x >= grid[n - 1]) {
    *index = n - 2;
    *weight = 1.0;
    return;
  }
  const int i = static_cast<int>(std::upper_bound(grid.begin(), grid.end(), x) - grid.begin()) - 1;
  *index = i;
  *weight = (x - grid[i]) / (grid[i + 1] - grid[i]);
}

struct SolveContext {
  const AveragedFriction* element;
  double normal_force;
  double velocity_amplitude;
};

// Residual R(u) = u + B F(u) - v_free.
void Residual(const SolveContext& c, const double B[4], const double v_free[2], const double u[2],
              double r[2]) {
  double f[2];
  c.element->Force(u, c.normal_force, c.velocity_amplitude, f);
  r[0] = u[0] + B[0] * f[0] + B[1] * f[1] - v_free[0];
  r[1] = u[1] + B[2] * f[0] + B[3] * f[1] - v_free[1];
}

// Newton with a forward-difference Jacobian and backtracking on |R|; u in/out. The law is
// monotone and Lipschitz (piecewise bilinear), so a few iterations reach 1e-10 v_a.
void SolveEndVelocity(const SolveContext& c, const double B[4], const double v_free[2],
                      double u[2]) {
  const double scale = c.velocity_amplitude + std::hypot(v_free[0], v_free[1]);
  const double tolerance = 1e-10 * scale;
  double r[2];
  Residual(c, B, v_free, u, r);
  double norm = std::hypot(r[0], r[1]);
  for (int iter = 0; iter < 50 && norm > tolerance; ++iter) {
    const double h = 1e-7 * (c.velocity_amplitude + std::hypot(u[0], u[1]));
    double J[4];
    for (int col = 0; col < 2; ++col) {
      double up[2] = {u[0], u[1]}, rp[2];
      up[col] += h;
      Residual(c, B, v_free, up, rp);
      J[col] = (rp[0] - r[0]) / h;
      J[2 + col] = (rp[1] - r[1]) / h;
    }
    const double det = J[0] * J[3] - J[1] * J[2];
    double step[2];
    if (std::fabs(det) > 1e-300) {
      step[0] = -(J[3] * r[0] - J[1] * r[1]) / det;
      step[1] = -(J[0] * r[1] - J[2] * r[0]) / det;
    } else {
      step[0] = -r[0];
      step[1] = -r[1];
    }
    double alpha = 1.0, trial[2], r_trial[2], norm_trial = norm;
    for (int k = 0; k < 30; ++k, alpha *= 0.5) {
      trial[0] = u[0] + alpha * step[0];
      trial[1] = u[1] + alpha * step[1];
      Residual(c, B, v_free, trial, r_trial);
      norm_trial = std::hypot(r_trial[0], r_trial[1]);
      if (norm_trial < (1 - 1e-4 * alpha) * norm) break;
    }
    if (!(norm_trial < norm)) break;  // no progress: keep the best iterate
    u[0] = trial[0];
    u[1] = trial[1];
    r[0] = r_trial[0];
    r[1] = r_trial[1];
    norm = norm_trial;
    if (alpha * std::hypot(step[0], step[1]) <= 1e-15 * scale) break;
  }
}

}  // namespace

void AveragedTable::Evaluate(double xi_value, double angle_value, double* f_along,
                             double* f_across) const {
  int i, j;
  double wi, wj;
  Locate(xi, xi_value, &i, &wi);
  Locate(angle, angle_value, &j, &wj);
  const int n = static_cast<int>(angle.size());
  auto blend = [&](const std::vector<double>& v) {
    const double a = v[i * n + j] * (1 - wj) + v[i * n + j + 1] * wj;
    const double b = v[(i + 1) * n + j] * (1 - wj) + v[(i + 1) * n + j + 1] * wj;
    return a * (1 - wi) + b * wi;
  };
  *f_along = blend(along);
  *f_across = blend(across);
}

bool AveragedConfig::FromModel(const mjModel* m, int instance, AveragedConfig* config,
                               ReadScope scope) {
  AveragedConfig c;
  LawParameters& p = c.coulomb;
  p.law = Law::kCoulomb;
  if (!ReadNumber(m, instance, kPlugin, kMu, 0.2, &p.friction_coefficient) ||
      !ReadNumber(m, instance, kPlugin, kViscous, 0.0, &p.viscous) ||
      !ReadNumber(m, instance, kPlugin, kStaticRatio, 1.0, &p.static_ratio) ||
      !ReadNumber(m, instance, kPlugin, kStribeckVelocity, 1e-3, &p.stribeck_velocity) ||
      !ReadNumber(m, instance, kPlugin, kVelocityAmplitude, 0.0, &c.velocity_amplitude) ||
      !ReadNumber(m, instance, kPlugin, kAxisAngle, 0.0, &c.axis_angle)) {
    return false;
  }
  if (p.friction_coefficient < 0) return Reject(kMu, p.friction_coefficient, "must be >= 0");
  if (p.viscous < 0) return Reject(kViscous, p.viscous, "must be >= 0 (N s/m)");
  if (p.static_ratio < 1) return Reject(kStaticRatio, p.static_ratio, "must be >= 1");
  if (p.stribeck_velocity <= 0) {
    return Reject(kStribeckVelocity, p.stribeck_velocity, "must be > 0 (m/s)");
  }
  c.axis_cos = std::cos(c.axis_angle);
  c.axis_sin = std::sin(c.axis_angle);
  if (c.velocity_amplitude < 0) {
    return Reject(kVelocityAmplitude, c.velocity_amplitude,
                  "must be >= 0 (m/s), the vibration velocity amplitude the table was made for");
  }
  if (!ReadBool(m, instance, kPlugin, kUseCtrl, false, &c.use_ctrl)) return false;
  AveragedTable& t = c.table;
  if (!ReadNumberList(m, instance, kPlugin, kTableXi, &t.xi) ||
      !ReadNumberList(m, instance, kPlugin, kTableAngle, &t.angle) ||
      !ReadNumberList(m, instance, kPlugin, kTableAlong, &t.along) ||
      !ReadNumberList(m, instance, kPlugin, kTableAcross, &t.across)) {
    return false;
  }
  if (c.velocity_amplitude > 0) {
    const char* fix = "; generate the table with vibrofriction.averaged.build_table";
    if (t.xi.size() < 2 || t.xi[0] != 0.0) {
      ConfigError("%s: attribute 'table_xi' needs at least 2 increasing values starting at 0%s",
                  kPlugin, fix);
      return false;
    }
    if (t.angle.size() < 2 || t.angle[0] != 0.0 || std::fabs(t.angle.back() - kPi) > 1e-6) {
      ConfigError("%s: attribute 'table_angle' needs at least 2 increasing values from 0 to pi "
                  "(rad)%s", kPlugin, fix);
      return false;
    }
    for (const std::vector<double>* grid : {&t.xi, &t.angle}) {
      for (size_t k = 1; k < grid->size(); ++k) {
        if (!((*grid)[k] > (*grid)[k - 1])) {
          ConfigError("%s: attribute '%s' is not strictly increasing at index %d%s", kPlugin,
                      grid == &t.xi ? kTableXi : kTableAngle, static_cast<int>(k), fix);
          return false;
        }
      }
    }
    const size_t cells = t.xi.size() * t.angle.size();
    if (t.along.size() != cells || t.across.size() != cells) {
      ConfigError("%s: attributes 'table_along' and 'table_across' need %d values each "
                  "(len(table_xi) x len(table_angle)), got %d and %d%s", kPlugin,
                  static_cast<int>(cells), static_cast<int>(t.along.size()),
                  static_cast<int>(t.across.size()), fix);
      return false;
    }
    for (size_t k = 0; k < cells; ++k) {
      if (std::fabs(t.along[k]) > 10 || std::fabs(t.across[k]) > 10) {
        ConfigError("%s: table value %g at index %d is not a force over mu F_N (|f| <= 10)%s",
                    kPlugin, std::fabs(t.along[k]) > 10 ? t.along[k] : t.across[k],
                    static_cast<int>(k), fix);
        return false;
      }
    }
  } else if (c.use_ctrl) {
    return Reject(kVelocityAmplitude, c.velocity_amplitude,
                  "must be > 0 when use_ctrl is true (ctrl scales it)");
  }
  if (!NormalLoad::FromModel(m, instance, kPlugin, scope, &c.normal)) return false;
  if (!CheckIntegrator(m, kPlugin)) return false;
  p.normal_force = c.normal.normal;
  if (scope == ReadScope::kAttributes) return true;  // the actuators' fields are not set yet
  if (!PlanarTransmission::FromModel(m, instance, kPlugin, /*need_state=*/false, &c.transmission)) {
    return false;
  }
  *config = c;
  return true;
}

void AveragedFriction::Force(const double u[2], double normal_force, double velocity_amplitude,
                             double force[2]) const {
  const double c = config_->axis_cos, s = config_->axis_sin;
  const double along = c * u[0] + s * u[1];
  const double across = -s * u[0] + c * u[1];
  const double xi = std::hypot(along, across) / velocity_amplitude;
  const double angle = std::atan2(std::fabs(across), along);
  double f_along, f_across;
  config_->table.Evaluate(xi, angle, &f_along, &f_across);
  if (across < 0) f_across = -f_across;  // mirror symmetry about the vibration axis
  const double level = config_->coulomb.friction_coefficient * std::max(normal_force, 0.0);
  force[0] = level * (c * f_along - s * f_across) + config_->coulomb.viscous * u[0];
  force[1] = level * (s * f_along + c * f_across) + config_->coulomb.viscous * u[1];
}

void AveragedFriction::Compute(const mjModel* m, mjData* d, int instance) {
  const int* out = config_->transmission.output;
  if (!config_.Refresh(m, instance)) {
    if (out[0] >= 0) d->actuator_force[out[0]] = 0;
    if (out[1] >= 0) d->actuator_force[out[1]] = 0;
    return;
  }
  double amplitude = config_->velocity_amplitude;
  if (config_->use_ctrl) {
    amplitude *= std::max(0.0, d->ctrl[m->actuator_ctrladr[config_->transmission.actuator[0]]]);
  }
  LawInput in;
  in.time = d->time;
  in.normal_force = config_->normal.Value(m, d, d->plugin_state + m->plugin_stateadr[instance]);
  const double v[2] = {d->actuator_velocity[out[0]], d->actuator_velocity[out[1]]};
  in.velocity = std::hypot(v[0], v[1]);
  PlanarResponse response;
  ComputePlanarResponse(m, d, out, &scratch_, &response);
  double force[2];
  if (amplitude > 0) {
    const SolveContext context{this, in.normal_force, amplitude};
    double u[2] = {v[0], v[1]};
    SolveEndVelocity(context, response.B, response.v_free, u);
    Force(u, in.normal_force, amplitude, force);
  } else {
    PlanarStickSlipForce(config_->coulomb, in, v, response.v_free, response.B, force);
  }
  d->actuator_force[out[0]] = -force[0];
  d->actuator_force[out[1]] = -force[1];
}

void AveragedFriction::WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* sensor) {
  mju_zero(sensor, kSensorDim);
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  const int* out = config_->transmission.output;
  sensor[0] = -d->actuator_force[out[0]];
  sensor[1] = -d->actuator_force[out[1]];
  sensor[4] = d->actuator_velocity[out[0]];
  sensor[5] = d->actuator_velocity[out[1]];
  sensor[6] = config_->normal.Value(m, d, d->plugin_state + m->plugin_stateadr[instance]);
}

void AveragedFriction::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  config_->normal.Update(m, d, d->plugin_state + m->plugin_stateadr[instance]);
}

void AveragedFriction::RegisterPlugin() {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = kName;
  plugin.capabilityflags |= mjPLUGIN_ACTUATOR;
  plugin.nattribute = sizeof(kAttributes) / sizeof(kAttributes[0]);
  plugin.attributes = kAttributes;
  SetPluginCallbacks<AveragedFriction, &AveragedConfig::FromModel>(&plugin);
  mjp_registerPlugin(&plugin);
}

void RegisterPlanarPlugins() {
  PlanarFriction::RegisterPlugin();
  AveragedFriction::RegisterPlugin();
}

}  // namespace vibrofriction
