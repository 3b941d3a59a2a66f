#include "friction_law.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace vibrofriction {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Sign(double x) { return (x > 0) - (x < 0); }

// Dahl: |w| after time with d|w|/dt = -(|v|/z_c) |w|^alpha, lambda = |v| dt / z_c.
// One formula for every alpha >= 0 (log1p form stays accurate as alpha -> 1); for alpha < 1
// |w| reaches 0 in finite time and stays there.
double DecayDahlBase(double w_abs, double alpha, double lambda) {
  if (w_abs <= 0) return 0.0;
  if (std::fabs(alpha - 1.0) < 1e-12) return w_abs * std::exp(-lambda);
  const double q = (alpha - 1.0) * lambda * std::pow(w_abs, alpha - 1.0);
  if (q <= -1.0) return 0.0;
  return w_abs * std::exp(-std::log1p(q) / (alpha - 1.0));
}

// Dupont's a(z, v) along the direction of motion: zeta = sgn(v) z.
double DupontShape(double zeta, double z_ba, double z_max) {
  if (zeta <= z_ba) return 0.0;  // elastic, includes unloading (zeta < 0)
  if (zeta >= z_max) return 1.0;
  return 0.5 * std::sin(kPi * (zeta - 0.5 * (z_max + z_ba)) / (z_max - z_ba)) + 0.5;
}

double DupontShapeSlope(double zeta, double z_ba, double z_max) {
  if (zeta <= z_ba || zeta >= z_max) return 0.0;
  const double width = z_max - z_ba;
  return 0.5 * kPi / width * std::cos(kPi * (zeta - 0.5 * (z_max + z_ba)) / width);
}

// One backward-Euler step of d(zeta)/dt = speed (1 - a(zeta) zeta / z_max) on [z_ba, z_max].
// The right-hand side decreases in zeta, so the root is unique and lies in [zeta0, z_max]:
// safeguarded Newton never leaves that bracket.
double DupontPlasticStep(double zeta0, double speed_dt, double z_ba, double z_max) {
  auto residual = [&](double zeta) {
    return zeta - zeta0 - speed_dt * (1.0 - DupontShape(zeta, z_ba, z_max) * zeta / z_max);
  };
  double lo = zeta0, hi = z_max, zeta = zeta0;
  for (int iter = 0; iter < 50; ++iter) {
    const double r = residual(zeta);
    if (std::fabs(r) <= 1e-14 * z_max) break;
    if (r < 0) lo = zeta; else hi = zeta;
    const double a = DupontShape(zeta, z_ba, z_max);
    const double slope = 1.0 + speed_dt * (DupontShapeSlope(zeta, z_ba, z_max) * zeta + a) / z_max;
    double next = zeta - r / slope;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    zeta = next;
    if (hi - lo <= 1e-15 * z_max) break;
  }
  return zeta;
}

double AdvanceDupont(const LawParameters& p, const LawInput& in, double z, double dt) {
  const double v = in.velocity;
  const double s = Sign(v);
  const double speed = std::fabs(v);
  const double z_max = StribeckLevel(p, in) / p.contact_stiffness;
  const double z_ba = p.breakaway_ratio * CoulombLevel(p, in, s) / p.contact_stiffness;
  if (z_max <= 0) return 0.0;
  double zeta = s * z;
  double time_left = dt;
  // Exact elastic segment up to the breakaway deflection.
  if (zeta < z_ba) {
    const double t_elastic = (z_ba - zeta) / speed;
    if (t_elastic >= time_left) return s * (zeta + speed * time_left);
    zeta = z_ba;
    time_left -= t_elastic;
  }
  // Beyond z_max, a = 1 and the equation is linear: exact exponential relaxation.
  if (zeta >= z_max) {
    return s * (z_max + (zeta - z_max) * std::exp(-speed * time_left / z_max));
  }
  // Plastic segment: backward-Euler substeps, enough to resolve the sine transition.
  const double travel = speed * time_left;
  const int substeps = std::clamp(static_cast<int>(std::ceil(20.0 * travel / (z_max - z_ba))), 1, 64);
  const double speed_dt = travel / substeps;
  for (int i = 0; i < substeps; ++i) zeta = DupontPlasticStep(zeta, speed_dt, z_ba, z_max);
  return s * zeta;
}

}  // namespace

double CoulombLevel(const LawParameters& p, const LawInput& in, double direction) {
  double normal = in.normal_force;
  if (p.normal_modulation != 0) {
    normal *= 1.0 + p.normal_modulation *
                        std::sin(2 * kPi * p.normal_modulation_frequency * in.time +
                                 p.normal_modulation_phase);
  }
  double level = p.friction_coefficient * std::max(normal, 0.0);
  if (direction > 0) level *= 1.0 + p.asymmetry;
  if (direction < 0) level *= 1.0 - p.asymmetry;
  if (p.ripple != 0) {
    level *= 1.0 + p.ripple * std::sin(2 * kPi * in.position / p.ripple_wavelength + p.ripple_phase);
  }
  return level;
}

double StribeckLevel(const LawParameters& p, const LawInput& in) {
  const double coulomb = CoulombLevel(p, in, Sign(in.velocity));
  if (p.static_ratio == 1.0) return coulomb;
  const double ratio = in.velocity / p.stribeck_velocity;
  return coulomb * (1.0 + (p.static_ratio - 1.0) * std::exp(-ratio * ratio));
}

double DeflectionRate(const LawParameters& p, const LawInput& in, double z) {
  const double v = in.velocity;
  if (v == 0) return 0.0;
  const double s = Sign(v);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = CoulombLevel(p, in, s) / p.contact_stiffness;
      if (z_c <= 0) return 0.0;
      const double w = 1.0 - s * z / z_c;
      return v * Sign(w) * std::pow(std::fabs(w), p.alpha);
    }
    case Law::kLuGre: {
      const double z_g = StribeckLevel(p, in) / p.contact_stiffness;
      if (z_g <= 0) return 0.0;
      return v - std::fabs(v) * z / z_g;
    }
    case Law::kDupont: {
      const double z_max = StribeckLevel(p, in) / p.contact_stiffness;
      if (z_max <= 0) return 0.0;
      const double z_ba = p.breakaway_ratio * CoulombLevel(p, in, s) / p.contact_stiffness;
      const double zeta = s * z;
      return v * (1.0 - DupontShape(zeta, z_ba, z_max) * zeta / z_max);
    }
    case Law::kCoulomb:
      return 0.0;
  }
  return 0.0;
}

double AdvanceDeflection(const LawParameters& p, const LawInput& in, double z, double dt) {
  const double v = in.velocity;
  if (!HasDeflection(p.law)) return 0.0;
  if (v == 0 || dt <= 0) return z;
  const double s = Sign(v);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = CoulombLevel(p, in, s) / p.contact_stiffness;
      if (z_c <= 0) return 0.0;  // no normal load: no friction, no deflection
      const double w0 = 1.0 - s * z / z_c;
      const double w1 = Sign(w0) * DecayDahlBase(std::fabs(w0), p.alpha, std::fabs(v) * dt / z_c);
      return s * z_c * (1.0 - w1);
    }
    case Law::kLuGre: {
      const double z_g = StribeckLevel(p, in) / p.contact_stiffness;
      if (z_g <= 0) return 0.0;
      const double z_ss = s * z_g;
      return z_ss + (z - z_ss) * std::exp(-std::fabs(v) * dt / z_g);
    }
    case Law::kDupont:
      return AdvanceDupont(p, in, z, dt);
    case Law::kCoulomb:
      return 0.0;
  }
  return z;
}

double StateForce(const LawParameters& p, const LawInput& in, double z) {
  return p.contact_stiffness * z + p.bristle_damping * DeflectionRate(p, in, z) +
         p.viscous * in.velocity + p.force_offset;
}

double StickSlipForce(const LawParameters& p, const LawInput& in, double stick_force) {
  const double needed = stick_force - p.force_offset;
  const double direction = Sign(needed);
  LawInput at_rest = in;
  at_rest.velocity = 0.0;
  const double static_level = p.static_ratio * CoulombLevel(p, at_rest, direction);
  if (std::fabs(needed) <= static_level) return stick_force;
  // Kinetic level in the direction of sliding, with the Stribeck curve at the current speed.
  double kinetic = CoulombLevel(p, in, direction);
  if (p.static_ratio != 1.0) {
    const double ratio = in.velocity / p.stribeck_velocity;
    kinetic *= 1.0 + (p.static_ratio - 1.0) * std::exp(-ratio * ratio);
  }
  return direction * kinetic + p.viscous * in.velocity + p.force_offset;
}

double KinematicCoulombForce(const LawParameters& p, const LawInput& in) {
  return Sign(in.velocity) * StribeckLevel(p, in) + p.viscous * in.velocity + p.force_offset;
}

bool ParseLaw(const char* name, Law* law) {
  if (!name) return false;
  static const struct { const char* name; Law law; } kNames[] = {
      {"coulomb", Law::kCoulomb}, {"dahl", Law::kDahl}, {"dupont", Law::kDupont},
      {"lugre", Law::kLuGre}};
  for (const auto& entry : kNames) {
    if (std::strcmp(name, entry.name) == 0) {
      *law = entry.law;
      return true;
    }
  }
  return false;
}

const char* LawName(Law law) {
  switch (law) {
    case Law::kCoulomb: return "coulomb";
    case Law::kDahl: return "dahl";
    case Law::kDupont: return "dupont";
    case Law::kLuGre: return "lugre";
  }
  return "unknown";
}

}  // namespace vibrofriction
