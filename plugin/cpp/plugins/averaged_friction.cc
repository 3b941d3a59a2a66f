#include "plugins/averaged_friction.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <utility>

#include "common/element_config.h"
#include "common/plugin_util.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the shared MJCF keys (element_config.h)


constexpr char kPlugin[] = "vibrofriction.averaged";

bool Reject(const char* attr, double value, const char* rule) {
  return RejectAttribute(kPlugin, attr, value, rule);
}

// Index i with grid[i] <= x < grid[i+1] (clamped to the last cell) and the weight of i+1;
// returns d weight / dx: one-sided at the grid's ends, 0 beyond them (clamped).
double Locate(const std::vector<double>& grid, double x, int* index, double* weight) {
  const int n = static_cast<int>(grid.size());
  if (x <= grid[0]) {
    *index = 0;
    *weight = 0.0;
    return x == grid[0] ? 1.0 / (grid[1] - grid[0]) : 0.0;
  }
  if (x >= grid[n - 1]) {
    *index = n - 2;
    *weight = 1.0;
    return x == grid[n - 1] ? 1.0 / (grid[n - 1] - grid[n - 2]) : 0.0;
  }
  const int i = static_cast<int>(std::upper_bound(grid.begin(), grid.end(), x) - grid.begin()) - 1;
  *index = i;
  *weight = (x - grid[i]) / (grid[i + 1] - grid[i]);
  return 1.0 / (grid[i + 1] - grid[i]);
}

}  // namespace

template <int N>
void AveragedVectorForce(const AveragedTable& table, const LawParameters& law,
                         const double axis[N], const double u[N], double normal_force,
                         double velocity_amplitude, double force[N]) {
  double along = 0.0;
  for (int i = 0; i < N; ++i) along += axis[i] * u[i];
  double across_dir[N], across = 0.0;
  for (int i = 0; i < N; ++i) {
    across_dir[i] = u[i] - along * axis[i];
    across += across_dir[i] * across_dir[i];
  }
  across = std::sqrt(across);
  const double xi = std::sqrt(along * along + across * across) / velocity_amplitude;
  const double angle = std::atan2(across, along);
  double f_along, f_across;
  table.Evaluate(xi, angle, &f_along, &f_across);
  const double level = law.friction_coefficient * std::max(normal_force, 0.0);
  for (int i = 0; i < N; ++i) {
    const double across_unit = across > 0 ? across_dir[i] / across : 0.0;
    force[i] = level * (f_along * axis[i] + f_across * across_unit) + law.viscous * u[i];
  }
}

template <int N>
bool AveragedVectorForceJacobian(const AveragedTable& table, const LawParameters& law,
                                 const double axis[N], const double u[N], double normal_force,
                                 double velocity_amplitude, double force[N],
                                 double jacobian[N * N]) {
  double along = 0.0;
  for (int i = 0; i < N; ++i) along += axis[i] * u[i];
  double e[N], across = 0.0;  // e: the unit vector of u's part across the axis
  for (int i = 0; i < N; ++i) {
    e[i] = u[i] - along * axis[i];
    across += e[i] * e[i];
  }
  across = std::sqrt(across);
  const double r2 = along * along + across * across, r = std::sqrt(r2);
  if (!(r > 1e-12 * velocity_amplitude)) return false;
  const double level = law.friction_coefficient * std::max(normal_force, 0.0);
  if (!(across > 1e-9 * r)) {
    // Along the axis (angle 0 or pi, where the across part vanishes): f_across / across tends
    // to (d across/d angle) / along in every direction across, so dF/du = level (axis
    // (d along/d xi) d xi/du' + (d across/d angle) / along (I - axis axis')) + sigma2 I; the
    // along part's kink across the axis (|angle| in a bilinear cell) is taken flat.
    const double angle = along > 0 ? 0.0 : kPi;
    double f_along, f_across, slope[4];
    table.Evaluate(r / velocity_amplitude, angle, &f_along, &f_across, slope);
    const double sign = along > 0 ? 1.0 : -1.0;
    const double bend = slope[3] / along;
    for (int i = 0; i < N; ++i) {
      force[i] = level * f_along * axis[i] + law.viscous * u[i];
      for (int j = 0; j < N; ++j) {
        jacobian[N * i + j] = level * (axis[i] * slope[0] * sign * axis[j] / velocity_amplitude +
                                       bend * ((i == j) - axis[i] * axis[j])) +
                              law.viscous * (i == j);
      }
    }
    return true;
  }
  for (int i = 0; i < N; ++i) e[i] /= across;
  const double xi = r / velocity_amplitude, angle = std::atan2(across, along);
  double f_along, f_across, slope[4];
  table.Evaluate(xi, angle, &f_along, &f_across, slope);
  // d xi/du = u / (r v_a); d angle/du = (along e - across axis) / r^2
  double d_xi[N], d_angle[N];
  for (int j = 0; j < N; ++j) {
    d_xi[j] = u[j] / (r * velocity_amplitude);
    d_angle[j] = (along * e[j] - across * axis[j]) / r2;
  }
  const double bend = f_across / across;  // d e/du = (I - axis axis' - e e') / across
  for (int i = 0; i < N; ++i) {
    force[i] = level * (f_along * axis[i] + f_across * e[i]) + law.viscous * u[i];
    for (int j = 0; j < N; ++j) {
      const double grad_along = slope[0] * d_xi[j] + slope[1] * d_angle[j];
      const double grad_across = slope[2] * d_xi[j] + slope[3] * d_angle[j];
      const double projector = (i == j) - axis[i] * axis[j] - e[i] * e[j];
      jacobian[N * i + j] = level * (axis[i] * grad_along + e[i] * grad_across +
                                     bend * projector) + law.viscous * (i == j);
    }
  }
  return true;
}

template <int N>
void SolveAveragedEndVelocity(const AveragedTable& table, const LawParameters& law,
                              const double axis[N], double normal_force,
                              double velocity_amplitude, const double B[N * N],
                              const double v_free[N], double u[N], double force[N]) {
  auto norm = [](const double x[N]) {
    double sum = 0.0;
    for (int i = 0; i < N; ++i) sum += x[i] * x[i];
    return std::sqrt(sum);
  };
  // R(u) = u + B F(u) - v_free, with F(u) in f
  auto residual = [&](const double x[N], double r[N], double f[N]) {
    AveragedVectorForce<N>(table, law, axis, x, normal_force, velocity_amplitude, f);
    for (int i = 0; i < N; ++i) {
      r[i] = x[i] - v_free[i];
      for (int j = 0; j < N; ++j) r[i] += B[N * i + j] * f[j];
    }
  };
  const double scale = velocity_amplitude + norm(v_free);
  const double tolerance = 1e-10 * scale;
  double r[N];
  residual(u, r, force);
  double r_norm = norm(r);
  for (int iter = 0; iter < 50 && r_norm > tolerance; ++iter) {
    double J[N * N], f_at_u[N], dF[N * N];
    if (AveragedVectorForceJacobian<N>(table, law, axis, u, normal_force, velocity_amplitude,
                                       f_at_u, dF)) {
      for (int i = 0; i < N; ++i) {  // dR/du = I + B dF/du
        for (int j = 0; j < N; ++j) {
          double sum = (i == j);
          for (int k = 0; k < N; ++k) sum += B[N * i + k] * dF[N * k + j];
          J[N * i + j] = sum;
        }
      }
    } else {  // at rest: a forward difference
      const double h = 1e-7 * (velocity_amplitude + norm(u));
      for (int col = 0; col < N; ++col) {
        double up[N], rp[N], fp[N];
        for (int i = 0; i < N; ++i) up[i] = u[i];
        up[col] += h;
        residual(up, rp, fp);
        for (int i = 0; i < N; ++i) J[N * i + col] = (rp[i] - r[i]) / h;
      }
    }
    double step[N], minus_r[N];
    for (int i = 0; i < N; ++i) minus_r[i] = -r[i];
    if (!SolveLinear<N>(J, minus_r, 1e-300, step)) {
      for (int i = 0; i < N; ++i) step[i] = minus_r[i];
    }
    double alpha = 1.0, trial[N], r_trial[N], f_trial[N], norm_trial = r_norm;
    for (int k = 0; k < 30; ++k, alpha *= 0.5) {
      for (int i = 0; i < N; ++i) trial[i] = u[i] + alpha * step[i];
      residual(trial, r_trial, f_trial);
      norm_trial = norm(r_trial);
      if (norm_trial < (1 - 1e-4 * alpha) * r_norm) break;
    }
    if (!(norm_trial < r_norm)) break;  // no progress: keep the best iterate
    for (int i = 0; i < N; ++i) {
      u[i] = trial[i];
      r[i] = r_trial[i];
      force[i] = f_trial[i];
    }
    r_norm = norm_trial;
    if (alpha * norm(step) <= 1e-15 * scale) break;
  }
}

template void AveragedVectorForce<2>(const AveragedTable&, const LawParameters&, const double*,
                                     const double*, double, double, double*);
template void AveragedVectorForce<3>(const AveragedTable&, const LawParameters&, const double*,
                                     const double*, double, double, double*);
template bool AveragedVectorForceJacobian<2>(const AveragedTable&, const LawParameters&,
                                             const double*, const double*, double, double,
                                             double*, double*);
template bool AveragedVectorForceJacobian<3>(const AveragedTable&, const LawParameters&,
                                             const double*, const double*, double, double,
                                             double*, double*);
template void SolveAveragedEndVelocity<2>(const AveragedTable&, const LawParameters&,
                                          const double*, double, double, const double*,
                                          const double*, double*, double*);
template void SolveAveragedEndVelocity<3>(const AveragedTable&, const LawParameters&,
                                          const double*, double, double, const double*,
                                          const double*, double*, double*);

void AveragedTable::Evaluate(double xi_value, double angle_value, double* f_along,
                             double* f_across, double slopes[4]) const {
  int i, j;
  double wi, wj;
  const double dwi = Locate(xi, xi_value, &i, &wi);
  const double dwj = Locate(angle, angle_value, &j, &wj);
  const int n = static_cast<int>(angle.size());
  auto blend = [&](const std::vector<double>& v, double* d_xi, double* d_angle) {
    const double v00 = v[i * n + j], v01 = v[i * n + j + 1];
    const double v10 = v[(i + 1) * n + j], v11 = v[(i + 1) * n + j + 1];
    const double a = v00 * (1 - wj) + v01 * wj;
    const double b = v10 * (1 - wj) + v11 * wj;
    if (d_xi) {
      *d_xi = (b - a) * dwi;
      *d_angle = ((v01 - v00) * (1 - wi) + (v11 - v10) * wi) * dwj;
    }
    return a * (1 - wi) + b * wi;
  };
  *f_along = blend(along, slopes ? &slopes[0] : nullptr, slopes ? &slopes[1] : nullptr);
  *f_across = blend(across, slopes ? &slopes[2] : nullptr, slopes ? &slopes[3] : nullptr);
}

bool ReadAveragedTable(const mjModel* m, int instance, const char* plugin,
                       double velocity_amplitude, AveragedTable* table) {
  AveragedTable& t = *table;
  if (!ReadNumberList(m, instance, plugin, kTableXi, &t.xi) ||
      !ReadNumberList(m, instance, plugin, kTableAngle, &t.angle) ||
      !ReadNumberList(m, instance, plugin, kTableAlong, &t.along) ||
      !ReadNumberList(m, instance, plugin, kTableAcross, &t.across)) {
    return false;
  }
  if (velocity_amplitude > 0) {
    const char* fix = "; generate the table with vibrofriction.robots.averaged.build_table";
    if (t.xi.size() < 2 || t.xi[0] != 0.0) {
      ConfigError("%s: attribute 'table_xi' needs at least 2 increasing values starting at 0%s",
                  plugin, fix);
      return false;
    }
    if (t.angle.size() < 2 || t.angle[0] != 0.0 || std::fabs(t.angle.back() - kPi) > 1e-6) {
      ConfigError("%s: attribute 'table_angle' needs at least 2 increasing values from 0 to pi "
                  "(rad)%s", plugin, fix);
      return false;
    }
    for (const std::vector<double>* grid : {&t.xi, &t.angle}) {
      for (size_t k = 1; k < grid->size(); ++k) {
        if (!((*grid)[k] > (*grid)[k - 1])) {
          ConfigError("%s: attribute '%s' is not strictly increasing at index %d%s", plugin,
                      grid == &t.xi ? kTableXi : kTableAngle, static_cast<int>(k), fix);
          return false;
        }
      }
    }
    const size_t cells = t.xi.size() * t.angle.size();
    if (t.along.size() != cells || t.across.size() != cells) {
      ConfigError("%s: attributes 'table_along' and 'table_across' need %d values each "
                  "(len(table_xi) x len(table_angle)), got %d and %d%s", plugin,
                  static_cast<int>(cells), static_cast<int>(t.along.size()),
                  static_cast<int>(t.across.size()), fix);
      return false;
    }
    for (size_t k = 0; k < cells; ++k) {
      if (std::fabs(t.along[k]) > 10 || std::fabs(t.across[k]) > 10) {
        ConfigError("%s: table value %g at index %d is not a force over mu F_N (|f| <= 10)%s",
                    plugin, std::fabs(t.along[k]) > 10 ? t.along[k] : t.across[k],
                    static_cast<int>(k), fix);
        return false;
      }
    }
  }
  // after the checks above: a table that is wrong in itself is named as such
  const char* checksum = mj_getPluginConfig(m, instance, kTableChecksum);
  if (checksum && checksum[0]) {
    bool hex16 = std::strlen(checksum) == 16;  // exactly 16 hex digits (no sign, no 0x)
    for (int k = 0; hex16 && k < 16; ++k) {
      hex16 = std::isxdigit(static_cast<unsigned char>(checksum[k])) != 0;
    }
    const unsigned long long stated = hex16 ? std::strtoull(checksum, nullptr, 16) : 0;
    const std::uint64_t actual = NumberListChecksum({&t.xi, &t.angle, &t.along, &t.across});
    if (!hex16 || stated != actual) {
      ConfigError("%s: attribute '%s'=\"%.40s\" is not the checksum of the table's values "
                  "(%016llx): the table was edited after it was made; make it again with "
                  "vibrofriction.robots.averaged.build_table, or remove '%s'", plugin,
                  kTableChecksum, checksum, static_cast<unsigned long long>(actual),
                  kTableChecksum);
      return false;
    }
  }
  return true;
}

bool ReadAveragedLaw(const mjModel* m, int instance, const char* plugin, LawParameters* law,
                     double* velocity_amplitude) {
  LawParameters& p = *law;
  p.law = Law::kCoulomb;
  if (!ReadNumber(m, instance, plugin, kMu, &p.friction_coefficient) ||
      !ReadNumber(m, instance, plugin, kViscous, &p.viscous) ||
      !ReadNumber(m, instance, plugin, kStaticRatio, &p.static_ratio) ||
      !ReadNumber(m, instance, plugin, kStribeckVelocity, &p.stribeck_velocity) ||
      !ReadNumber(m, instance, plugin, kVelocityAmplitude, velocity_amplitude)) {
    return false;
  }
  if (p.friction_coefficient < 0) {
    return RejectAttribute(plugin, kMu, p.friction_coefficient, "must be >= 0");
  }
  if (p.viscous < 0) return RejectAttribute(plugin, kViscous, p.viscous, "must be >= 0 (N s/m)");
  if (p.static_ratio < 1) {
    return RejectAttribute(plugin, kStaticRatio, p.static_ratio, "must be >= 1");
  }
  if (p.stribeck_velocity <= 0) {
    return RejectAttribute(plugin, kStribeckVelocity, p.stribeck_velocity, "must be > 0 (m/s)");
  }
  if (*velocity_amplitude < 0) {
    return RejectAttribute(plugin, kVelocityAmplitude, *velocity_amplitude,
                           "must be >= 0 (m/s), the vibration velocity amplitude the table was "
                           "made for (0: no vibration)");
  }
  return true;
}

bool AveragedConfig::FromModel(const mjModel* m, int instance, AveragedConfig* config,
                               ReadScope scope) {
  AveragedConfig c;
  LawParameters& p = c.coulomb;
  if (!ReadAveragedLaw(m, instance, kPlugin, &p, &c.velocity_amplitude) ||
      !ReadNumber(m, instance, kPlugin, kAxisAngle, &c.axis_angle)) {
    return false;
  }
  c.axis_cos = std::cos(c.axis_angle);
  c.axis_sin = std::sin(c.axis_angle);
  if (!ReadBool(m, instance, kPlugin, kUseCtrl, defaults::kUseCtrl, &c.use_ctrl)) return false;
  if (!ReadAveragedTable(m, instance, kPlugin, c.velocity_amplitude, &c.table)) return false;
  if (c.velocity_amplitude == 0 && c.use_ctrl) {
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

void AveragedFriction::Compute(const mjModel* m, mjData* d, int instance) {
  if (!RefreshOrZeroForces(config_, m, d, instance)) return;
  const int* out = config_->transmission.output;
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
    const double axis[2] = {config_->axis_cos, config_->axis_sin};
    double u[2] = {v[0], v[1]};
    SolveAveragedEndVelocity<2>(config_->table, config_->coulomb, axis, in.normal_force,
                                amplitude, response.B, response.v_free, u, force);
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
  RegisterElementPlugin<AveragedFriction, &AveragedConfig::FromModel>(
      kName, attributes::kAveraged, mjPLUGIN_ACTUATOR);
}

void RegisterPlanarPlugins() {
  PlanarFriction::RegisterPlugin();
  AveragedFriction::RegisterPlugin();
}

}  // namespace vibrofriction
