#include "laws/friction_law.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace vibrofriction {
namespace {

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

// Plastic part of Dupont's law along the travel s = |v| t: d(zeta)/ds = f(zeta),
// f = 1 - a(zeta) zeta / z_max, decreasing from 1 at z_ba to 0 at z_max (and below 0 beyond).
struct DupontPlastic {
  double z_ba, z_max, mid, phase_per_m;
  DupontPlastic(double breakaway, double maximum)
      : z_ba(breakaway), z_max(maximum), mid(0.5 * (maximum + breakaway)),
        phase_per_m(kPi / (maximum - breakaway)) {}

  // a(zeta) and da/dzeta (sine and cosine of one angle).
  double Shape(double zeta, double* slope) const {
    *slope = 0.0;
    if (zeta <= z_ba) return 0.0;
    if (zeta >= z_max) return 1.0;
    const double angle = phase_per_m * (zeta - mid);
    *slope = 0.5 * phase_per_m * std::cos(angle);
    return 0.5 * std::sin(angle) + 0.5;
  }
  // The root of zeta = base + c f(zeta), c > 0: a backward-Euler step (base = zeta0, c = h) or a
  // trapezoidal one (base = zeta0 + h f(zeta0)/2, c = h/2). The residual increases in zeta; the
  // root lies between base and base + c rate_bound for any rate_bound >= f(base) (f decreases),
  // and a root beyond z_max (only for c of the order of z_max) is cut to z_max, where the exact
  // solution stops: zeta never passes z_max. Safeguarded Newton from `guess` (clamped into the
  // bracket); a Newton step below 1e-7 z_max is accepted without another evaluation, its error
  // being of the order of step^2 / z_max (quadratic convergence).
  double Solve(double base, double c, double rate_bound, double guess) const {
    if (base >= z_max) return z_max;
    double lo = base;
    double hi = std::min(z_max, base + c * rate_bound);
    double zeta = std::clamp(guess, lo, hi);
    for (int iter = 0; iter < 50; ++iter) {
      double a_slope;
      const double a = Shape(zeta, &a_slope);
      const double r = zeta - base - c * (1.0 - a * zeta / z_max);
      if (r == 0) return zeta;
      if (r < 0) {
        if (zeta >= z_max) return z_max;
        lo = zeta;
      } else {
        hi = zeta;
      }
      const double step = r / (1.0 + c * (a_slope * zeta + a) / z_max);
      const double next = zeta - step;
      if (!(next > lo && next < hi)) {
        zeta = 0.5 * (lo + hi);  // bisect
      } else if (std::fabs(step) <= 1e-7 * z_max) {
        return next;
      } else {
        zeta = next;
      }
      if (hi - lo <= 1e-15 * z_max) break;
    }
    return zeta;
  }
};

// Dupont's a(z, v) along the direction of motion: zeta = sgn(v) z (0 below z_ba, which
// includes unloading, zeta < 0).
double DupontShape(double zeta, double z_ba, double z_max) {
  double slope;
  return DupontPlastic(z_ba, z_max).Shape(zeta, &slope);
}

// Trapezoidal substeps per transition width z_max - z_ba: resolves the sine transition (second
// order). Paper rig, dt 1e-5 s: the mean force is within 0.04 % of its value with 40 substeps
// (3 substeps; 1 substep: 0.3 %).
constexpr double kDupontSubstepsPerTransition = 3.0;

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
  // Plastic segment: trapezoidal substeps, enough to resolve the sine transition.
  const DupontPlastic plastic(z_ba, z_max);
  const double travel = speed * time_left;
  const int substeps = std::clamp(
      static_cast<int>(std::ceil(kDupontSubstepsPerTransition * travel / (z_max - z_ba))), 1, 64);
  const double h = travel / substeps;
  double a_slope;
  const double a = plastic.Shape(zeta, &a_slope);
  double rate = 1.0 - a * zeta / z_max;
  const double rate_slope = -(a_slope * zeta + a) / z_max;  // df/dzeta, <= 0
  // Trapezoidal while the substep is short against z_max (always, unless the 64-substep cap
  // binds: travel > 64 z_max); beyond that backward Euler, which damps the stiff mode for any h
  // (the planar law needs it; the 1D law follows so that both agree along one axis).
  const bool trapezoidal = h <= z_max;
  const double c = trapezoidal ? 0.5 * h : h;
  for (int i = 0; i < substeps; ++i) {
    const double base = trapezoidal ? zeta + c * rate : zeta;
    // Linearly implicit guess (error O(h^3)); the slope of the first substep serves them all.
    const double guess = zeta + h * rate / (1.0 - c * rate_slope);
    zeta = plastic.Solve(base, c, rate, guess);
    rate = zeta < z_max ? (zeta - base) / c : 0.0;  // f(zeta) from the step equation
  }
  return s * zeta;
}

// The law's own deflection rate (no play).
double LawDeflectionRate(const LawParameters& p, const LawInput& in, double z) {
  const double v = in.velocity;
  if (v == 0) return 0.0;
  const double s = Sign(v);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = StribeckLevel(p, in) / p.contact_stiffness;
      if (z_c <= 0) return 0.0;
      const double w = 1.0 - s * z / z_c;
      // alpha = 1 (the usual value) without pow: the same result, cheaper
      const double base = p.alpha == 1.0 ? std::fabs(w) : std::pow(std::fabs(w), p.alpha);
      return v * Sign(w) * base;
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
    case Law::kGms:  // (its own state: AdvanceGms)
      return 0.0;
  }
  return 0.0;
}

// The law's own step (no play); v != 0, dt > 0.
double LawAdvance(const LawParameters& p, const LawInput& in, double z, double dt) {
  const double v = in.velocity;
  const double s = Sign(v);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = StribeckLevel(p, in) / p.contact_stiffness;
      if (z_c <= 0) return 0.0;  // no normal load: no friction, no deflection
      if (p.alpha == 1.0) {
        // |w| decays as exp(-|v| t / z_c): z relaxes exponentially to s z_c (as LuGre).
        const double z_ss = s * z_c;
        return z_ss + (z - z_ss) * std::exp(-std::fabs(v) * dt / z_c);
      }
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
    case Law::kGms:  // (its own state: AdvanceGms)
      return 0.0;
  }
  return z;
}

// Time (s) for the law, with the input held, to bring a deflection z_e that lies against the
// motion back to 0 (unloading: z_e v < 0). Exact: the laws' steps are closed forms there.
double UnloadingTime(const LawParameters& p, const LawInput& in, double z_e) {
  const double speed = std::fabs(in.velocity);
  const double level = StribeckLevel(p, in) / p.contact_stiffness;  // z_c, z_g or z_max
  if (level <= 0 || speed == 0) return 0.0;  // no level: the bristles hold nothing
  const double depth = std::fabs(z_e);
  switch (p.law) {
    case Law::kDupont:
      return depth / speed;  // below the breakaway deflection the law is elastic, dz/dt = v
    case Law::kLuGre:
      return level * std::log1p(depth / level) / speed;
    case Law::kDahl: {
      // |w| falls from 1 + depth/z_c to 1 with d|w|/dt = -(|v|/z_c) |w|^alpha
      const double log_w0 = std::log1p(depth / level);
      if (std::fabs(p.alpha - 1.0) < 1e-12) return level * log_w0 / speed;
      return level * std::expm1((1.0 - p.alpha) * log_w0) / ((1.0 - p.alpha) * speed);
    }
    case Law::kCoulomb:
    case Law::kGms:
      return 0.0;
  }
  return 0.0;
}

// The time integral (m s) of the bristles' deflection z_e over a closed segment of `tau` (s)
// from z_a to z_b at the input's constant velocity: exact for LuGre and Dahl with alpha 1
// (an exponential relaxation); otherwise Simpson's rule on the law's exact step, with panels
// of at most a quarter of the level's deflection of travel (one panel missed the mean by 10 %
// of the level at a travel of 10 deflections).
double DeflectionIntegral(const LawParameters& p, const LawInput& in, double z_a, double z_b,
                          double tau) {
  if (tau <= 0) return 0.0;
  const double level = StribeckLevel(p, in) / p.contact_stiffness;
  if (level <= 0) return 0.0;
  if (p.law == Law::kLuGre || (p.law == Law::kDahl && std::fabs(p.alpha - 1.0) < 1e-12)) {
    const double z_ss = Sign(in.velocity) * level;
    const double time_constant = level / std::fabs(in.velocity);
    return z_ss * tau - (z_a - z_ss) * time_constant * std::expm1(-tau / time_constant);
  }
  const int panels = std::clamp(
      static_cast<int>(std::ceil(4.0 * std::fabs(in.velocity) * tau / level)), 1, 256);
  const double h = tau / panels;
  double sum = 0.0, z = z_a;
  for (int i = 0; i < panels; ++i) {
    const double middle = LawAdvance(p, in, z, 0.5 * h);
    const double end = i + 1 < panels ? LawAdvance(p, in, z, h) : z_b;
    sum += h * (z + 4.0 * middle + end) / 6.0;
    z = end;
  }
  return sum;
}

// What a step with the play spends with the contact closed: the time (s) and the time
// integral of the bristles' deflection over it (m s), for the element's force.
struct ClosedPart {
  double time = 0.0;
  double deflection_integral = 0.0;
  double deflection_change = 0.0;  // of z_e, over the closed segments
  bool opened = false;             // the step has an open segment
  void Add(const LawParameters& p, const LawInput& in, double z_a, double z_b, double tau) {
    if (!(tau > 0)) return;
    time += tau;
    deflection_integral += DeflectionIntegral(p, in, z_a, z_b, tau);
    deflection_change += z_b - z_a;
  }
};

// A step with the play (ElasticDeflection): at most three exact segments -- the bristles
// unloading to the face, the free travel across the play, loading on the other face. With
// `closed`, adds what the step spends closed.
double AdvanceWithPlay(const LawParameters& p, const LawInput& in, double z, double dt,
                       ClosedPart* closed = nullptr) {
  const double v = in.velocity;
  const double s = Sign(v);
  const double half = 0.5 * p.contact_play;
  double left = dt;
  for (int segment = 0; segment < 3; ++segment) {
    if (PlayOpen(p, z, v)) {
      if (closed) closed->opened = true;
      const double to_face = (s * half - z) / v;
      if (to_face >= left) return z + v * left;
      z = s * half;
      left -= to_face;
      continue;
    }
    const double side = Sign(z);  // |z| >= half > 0: in contact with this face
    const double z_e = z - side * half;
    if (side == s) {  // loading
      const double z_end = LawAdvance(p, in, z_e, left);
      if (closed) closed->Add(p, in, z_e, z_end, left);
      return side * half + z_end;
    }
    const double unloading = UnloadingTime(p, in, z_e);
    if (unloading >= left) {
      const double advanced = LawAdvance(p, in, z_e, left);
      const double z_end = side * advanced > 0 ? advanced : 0.0;
      if (closed) closed->Add(p, in, z_e, z_end, left);
      return side * half + z_end;
    }
    if (closed) closed->Add(p, in, z_e, 0.0, unloading);
    z = side * half;  // the bristles have let go: the play opens
    left -= unloading;
  }
  return z;
}

}  // namespace

double DeflectionRate(const LawParameters& p, const LawInput& in, double z) {
  if (p.contact_play > 0) {
    if (PlayOpen(p, z, in.velocity)) return in.velocity;
    return LawDeflectionRate(p, in, ElasticDeflection(p, z));
  }
  return LawDeflectionRate(p, in, z);
}

double AdvanceDeflection(const LawParameters& p, const LawInput& in, double z, double dt) {
  if (!HasDeflection(p.law)) return 0.0;
  if (in.velocity == 0 || dt <= 0) return z;
  if (p.contact_play > 0 && TakesContactPlay(p.law)) return AdvanceWithPlay(p, in, z, dt);
  return LawAdvance(p, in, z, dt);
}

double StateForce(const LawParameters& p, const LawInput& in, double z) {
  if (PlayOpen(p, z, in.velocity)) return p.force_offset;
  const double undamped = UndampedStateForce(p, in.velocity, z);
  return p.bristle_damping != 0 ? undamped + p.bristle_damping * DeflectionRate(p, in, z)
                                : undamped;
}

namespace {

// sigma1 slope(z) + sigma2 for motion in `direction` at `speed`: the laws are homogeneous in v
// for a direction, dz/dt = slope v. 0 or less when z lies beyond its steady value.
double DampingCoefficient(const LawParameters& p, const LawInput& in, double z, double direction,
                          double speed) {
  LawInput probe = in;
  probe.velocity = direction * speed;
  return p.bristle_damping * DeflectionRate(p, probe, z) / probe.velocity + p.viscous;
}

// The force of a step whose contact is closed for the fraction `closed` of it, with the
// bristles' mean elastic force `elastic` and the damping `damping` (N s/m) at the step's end
// velocity: F = offset + closed (elastic + damping v_next), v_next = velocity_free -
// dt_inverse_mass F. (At the end velocity, with which MuJoCo moves the positions over the
// step: the damping impulse of a step that closes or opens is sigma1 times z_e's change while
// closed, so none is left at the face; at the trapezoidal mean each closing and opening left
// (sigma1 + sigma2) dt v, always toward the face.)
double PartlyClosedForce(const LawParameters& p, double closed, double elastic, double damping,
                         double velocity_free, double dt_inverse_mass) {
  return (p.force_offset + closed * (elastic + damping * velocity_free)) /
         (1.0 + closed * damping * dt_inverse_mass);
}

// With a play: whether the contact closes or opens within the step, judged along the step's
// path at its mean velocity, and then (in `force`) the mean force along that path -- the
// bristles' mean force and damping per unit of velocity over the closed part, the damping's
// impulse sigma1 times z_e's change over the closed segments (0 at each closing and opening).
// A step that reverses the motion, or one too long for the bristles to follow (the start's
// elastic force alone would turn the velocity), is not: a path walked the other way would load
// the far face and push the body along its motion.
bool ClosesOrOpens(const LawParameters& p, const LawInput& in, double z, double mean_velocity,
                   double velocity_free, double dt_inverse_mass, double dt, double* force) {
  if (!(mean_velocity * in.velocity > 0 && dt > 0)) return false;
  LawInput probe = in;
  probe.velocity = mean_velocity;
  const double z_e = ElasticDeflection(p, z);
  // (a step loading its face, or unloading but not to 0, stays closed: no path to walk)
  if (!PlayOpen(p, z, mean_velocity) &&
      (Sign(z) == Sign(mean_velocity) || UnloadingTime(p, probe, z_e) >= dt)) {
    return false;
  }
  ClosedPart closed;
  AdvanceWithPlay(p, probe, z, dt, &closed);
  if (!(closed.time > 0)) {
    *force = p.force_offset;
    return true;
  }
  const double rate = closed.deflection_change / (mean_velocity * closed.time);
  *force = PartlyClosedForce(p, closed.time / dt,
                             p.contact_stiffness * closed.deflection_integral / closed.time,
                             p.bristle_damping * std::max(rate, 0.0) + p.viscous, velocity_free,
                             dt_inverse_mass);
  return true;
}

}  // namespace

double ImplicitStateForce(const LawParameters& p, const LawInput& in, double z,
                          double velocity_free, double dt_inverse_mass, double dt) {
  const double elastic = p.contact_stiffness * ElasticDeflection(p, z) + p.force_offset;
  const double v_trial = velocity_free - dt_inverse_mass * elastic;  // damping off
  double force;
  if (p.contact_play > 0 && ClosesOrOpens(p, in, z, 0.5 * (in.velocity + v_trial),
                                          velocity_free, dt_inverse_mass, dt, &force)) {
    return force;
  }
  // (with a play: closed throughout, or no mean motion)
  const double speed = std::max(std::fabs(in.velocity), std::fabs(v_trial));
  const double direction = v_trial != 0 ? Sign(v_trial) : Sign(in.velocity);
  if (PlayOpen(p, z, direction)) return p.force_offset;  // (no play: never)
  if (speed == 0) return elastic;
  const double damping = DampingCoefficient(p, in, z, direction, speed);
  if (damping <= 0) return StateForce(p, in, z);
  // F = elastic + damping v_mid with v_next = velocity_free - dt_inverse_mass F and v_mid the
  // trapezoidal mean (v + v_next)/2 -- with a play, v_next (PartlyClosedForce says why).
  const double end_weight = p.contact_play > 0 ? 1.0 : 0.5;
  return (elastic + damping * ((1.0 - end_weight) * in.velocity + end_weight * velocity_free)) /
         (1.0 + end_weight * damping * dt_inverse_mass);
}

double StickSlipForce(const LawParameters& p, const LawInput& in, double stick_force) {
  const double needed = stick_force - p.force_offset;
  const double direction = Sign(needed);
  LawInput at_rest = in;
  at_rest.velocity = 0.0;
  const double static_level = CoulombLevel(p, at_rest, direction) * VelocityShape(p, 0.0);
  if (std::fabs(needed) <= static_level) return stick_force;
  // Kinetic level in the direction of sliding, with the Stribeck curve at the current speed.
  const double kinetic = CoulombLevel(p, in, direction) * VelocityShape(p, in.velocity);
  return direction * kinetic + p.viscous * in.velocity + p.force_offset;
}

double KinematicCoulombForce(const LawParameters& p, const LawInput& in) {
  return Sign(in.velocity) * StribeckLevel(p, in) + p.viscous * in.velocity + p.force_offset;
}

// ---- Vector (isotropic) laws ---------------------------------------------------------------------
// One implementation for every dimension: the planar element uses N = 2, the contact element
// N = 4 (the tangential velocity in world coordinates and the spin times the torsion radius).

namespace {

template <int N>
double Norm(const double v[N]) {
  double sum = 0.0;
  for (int i = 0; i < N; ++i) sum += v[i] * v[i];
  return std::sqrt(sum);
}

template <int N>
double Dot(const double a[N], const double b[N]) {
  double sum = 0.0;
  for (int i = 0; i < N; ++i) sum += a[i] * b[i];
  return sum;
}

template <>
double Norm<2>(const double v[2]) { return std::hypot(v[0], v[1]); }

// Unit direction of v and its speed; returns false (and leaves dir untouched) when v = 0.
template <int N>
bool Direction(const double v[N], double dir[N], double* speed) {
  *speed = Norm<N>(v);
  if (!(*speed > 0)) return false;
  for (int i = 0; i < N; ++i) dir[i] = v[i] / *speed;
  return true;
}

LawInput AtSpeed(const LawInput& in, double speed) {
  LawInput at = in;
  at.velocity = speed;
  return at;
}

// Dupont plastic onset: a > 0 needs z.v > 0 and |z| > z_ba. During elastic motion z = z0 + v t
// the perpendicular part q stays fixed and the projection p grows at |v|; the onset projection
// is sqrt(z_ba^2 - q^2) (or 0+ when q >= z_ba).
template <int N>
void AdvanceVectorDupont(const LawParameters& p, const LawInput& at, const double dir[N],
                         double speed, double z[N], double dt) {
  const double z_max = StribeckLevel(p, at) / p.contact_stiffness;
  const double z_ba = p.breakaway_ratio * CoulombLevel(p, at, 1.0) / p.contact_stiffness;
  if (z_max <= 0) {
    for (int i = 0; i < N; ++i) z[i] = 0.0;
    return;
  }
  double time_left = dt;
  const double proj = Dot<N>(z, dir);
  double perp[N];
  for (int i = 0; i < N; ++i) perp[i] = z[i] - proj * dir[i];
  const double q = Norm<N>(perp);
  const double onset = q < z_ba ? std::sqrt(z_ba * z_ba - q * q) : 0.0;
  if (proj < onset || (onset == 0.0 && proj <= 0.0)) {
    const double t_elastic = (onset - proj) / speed;
    if (t_elastic >= time_left) {
      for (int i = 0; i < N; ++i) z[i] += dir[i] * speed * time_left;
      return;
    }
    for (int i = 0; i < N; ++i) z[i] = perp[i] + onset * dir[i];
    time_left -= t_elastic;
  }
  const double r = Norm<N>(z);
  if (r >= z_max) {
    // a = 1: linear, exact exponential relaxation towards z_max dir.
    const double decay = std::exp(-speed * time_left / z_max);
    for (int i = 0; i < N; ++i) z[i] = z_max * dir[i] + (z[i] - z_max * dir[i]) * decay;
    return;
  }
  // Trapezoidal, as the 1D law: z1 = z0 + h (F(z0) + F(z1)) / 2 with F(z) = dir - a(|z|) z / z_max
  // gives z1 (1 + h a(|z1|) / (2 z_max)) = y = z0 + h dir - h a(|z0|) z0 / (2 z_max): z1 keeps
  // the direction of y, and |z1| solves the 1D step equation with base |y| - h/2, c = h/2.
  const DupontPlastic plastic(z_ba, z_max);
  const double travel = speed * time_left;
  const int substeps = std::clamp(
      static_cast<int>(std::ceil(kDupontSubstepsPerTransition * travel / (z_max - z_ba))), 1, 64);
  const double h = travel / substeps;
  // As the 1D law: trapezoidal while h <= z_max, else backward Euler (y = z0 + h dir, base
  // |y| - h, c = h). A trapezoid with h > 2 z_max would flip the deflection across the motion.
  const bool trapezoidal = h <= z_max;
  const double c = trapezoidal ? 0.5 * h : h;
  for (int k = 0; k < substeps; ++k) {
    double slope;
    const double shrink = trapezoidal ? c * plastic.Shape(Norm<N>(z), &slope) / z_max : 0.0;
    double y[N];
    for (int i = 0; i < N; ++i) y[i] = z[i] * (1.0 - shrink) + h * dir[i];
    const double y_norm = Norm<N>(y);
    if (!(y_norm > 0)) {
      for (int i = 0; i < N; ++i) z[i] = 0.0;
      continue;
    }
    // f <= 1 bounds the rate; the guess is the explicit end point of the bracket.
    const double radius = plastic.Solve(y_norm - c, c, 1.0, y_norm);
    for (int i = 0; i < N; ++i) z[i] = y[i] * (radius / y_norm);
  }
}

}  // namespace

template <int N>
void VectorDeflectionRate(const LawParameters& p, const LawInput& in, const double v[N],
                          const double z[N], double rate[N]) {
  for (int i = 0; i < N; ++i) rate[i] = 0.0;
  double dir[N], speed;
  if (!Direction<N>(v, dir, &speed)) return;
  const LawInput at = AtSpeed(in, speed);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = StribeckLevel(p, at) / p.contact_stiffness;
      if (z_c <= 0) return;
      double e[N];
      for (int i = 0; i < N; ++i) e[i] = dir[i] - z[i] / z_c;
      const double e_norm = Norm<N>(e);
      if (!(e_norm > 0)) return;
      const double gain = speed * std::pow(e_norm, p.alpha - 1.0);
      for (int i = 0; i < N; ++i) rate[i] = gain * e[i];
      return;
    }
    case Law::kLuGre: {
      const double z_g = StribeckLevel(p, at) / p.contact_stiffness;
      if (z_g <= 0) return;
      for (int i = 0; i < N; ++i) rate[i] = v[i] - speed * z[i] / z_g;
      return;
    }
    case Law::kDupont: {
      const double z_max = StribeckLevel(p, at) / p.contact_stiffness;
      if (z_max <= 0) return;
      const double z_ba = p.breakaway_ratio * CoulombLevel(p, at, 1.0) / p.contact_stiffness;
      const bool loading = Dot<N>(z, v) > 0;
      const double a = loading ? DupontShape(Norm<N>(z), z_ba, z_max) : 0.0;
      for (int i = 0; i < N; ++i) rate[i] = v[i] - a * speed * z[i] / z_max;
      return;
    }
    case Law::kCoulomb:
    case Law::kGms:  // (its own state: AdvanceGms)
      return;
  }
}

template <int N>
void AdvanceVectorDeflection(const LawParameters& p, const LawInput& in, const double v[N],
                             double z[N], double dt) {
  if (!HasDeflection(p.law)) {
    for (int i = 0; i < N; ++i) z[i] = 0.0;
    return;
  }
  double dir[N], speed;
  if (dt <= 0 || !Direction<N>(v, dir, &speed)) return;
  const LawInput at = AtSpeed(in, speed);
  switch (p.law) {
    case Law::kDahl: {
      const double z_c = StribeckLevel(p, at) / p.contact_stiffness;
      if (z_c <= 0) {
        for (int i = 0; i < N; ++i) z[i] = 0.0;
        return;
      }
      // e = dir - z/z_c keeps its direction; |e| follows the 1D base decay.
      double e[N];
      for (int i = 0; i < N; ++i) e[i] = dir[i] - z[i] / z_c;
      const double e_norm = Norm<N>(e);
      const double scale =
          e_norm > 0 ? DecayDahlBase(e_norm, p.alpha, speed * dt / z_c) / e_norm : 0.0;
      for (int i = 0; i < N; ++i) z[i] = z_c * (dir[i] - e[i] * scale);
      return;
    }
    case Law::kLuGre: {
      const double z_g = StribeckLevel(p, at) / p.contact_stiffness;
      if (z_g <= 0) {
        for (int i = 0; i < N; ++i) z[i] = 0.0;
        return;
      }
      const double decay = std::exp(-speed * dt / z_g);
      for (int i = 0; i < N; ++i) z[i] = dir[i] * z_g + (z[i] - dir[i] * z_g) * decay;
      return;
    }
    case Law::kDupont:
      AdvanceVectorDupont<N>(p, at, dir, speed, z, dt);
      return;
    case Law::kCoulomb:
    case Law::kGms:  // (its own state: AdvanceGms)
      return;
  }
}

template <int N>
void VectorStateForce(const LawParameters& p, const LawInput& in, const double v[N],
                      const double z[N], double force[N]) {
  double rate[N];
  VectorDeflectionRate<N>(p, in, v, z, rate);
  for (int i = 0; i < N; ++i) {
    force[i] = p.contact_stiffness * z[i] + p.bristle_damping * rate[i] + p.viscous * v[i];
  }
}

template void VectorDeflectionRate<4>(const LawParameters&, const LawInput&, const double*,
                                      const double*, double*);
template void AdvanceVectorDeflection<4>(const LawParameters&, const LawInput&, const double*,
                                         double*, double);
template void VectorStateForce<4>(const LawParameters&, const LawInput&, const double*,
                                  const double*, double*);

void PlanarDeflectionRate(const LawParameters& p, const LawInput& in, const double v[2],
                          const double z[2], double rate[2]) {
  VectorDeflectionRate<2>(p, in, v, z, rate);
}

void AdvancePlanarDeflection(const LawParameters& p, const LawInput& in, const double v[2],
                             double z[2], double dt) {
  AdvanceVectorDeflection<2>(p, in, v, z, dt);
}

void PlanarStateForce(const LawParameters& p, const LawInput& in, const double v[2],
                      const double z[2], double force[2]) {
  VectorStateForce<2>(p, in, v, z, force);
}

void PlanarImplicitStateForce(const LawParameters& p, const LawInput& in, const double v[2],
                              const double z[2], const double v_free[2], const double B[4],
                              double force[2]) {
  const double elastic[2] = {p.contact_stiffness * z[0], p.contact_stiffness * z[1]};
  const double v_trial[2] = {v_free[0] - B[0] * elastic[0] - B[1] * elastic[1],
                             v_free[1] - B[2] * elastic[0] - B[3] * elastic[1]};
  double dir[2], trial_speed, speed;
  const bool moving = Direction<2>(v_trial, dir, &trial_speed);
  speed = std::max(std::hypot(v[0], v[1]), trial_speed);
  if (!moving && !Direction<2>(v, dir, &speed)) {
    force[0] = elastic[0];
    force[1] = elastic[1];
    return;
  }
  // Damping matrix D: along the direction of motion the secant sigma1 dz/dt / speed (the laws
  // are homogeneous in v for a direction) + sigma2; across it the bristles follow the motion
  // (dz/dt = v), D = sigma1 + sigma2. Motion on one axis reduces to ImplicitStateForce.
  const double probe[2] = {speed * dir[0], speed * dir[1]};
  double rate[2];
  PlanarDeflectionRate(p, AtSpeed(in, speed), probe, z, rate);
  const double along[2] = {p.bristle_damping * rate[0] / speed + p.viscous * dir[0],
                           p.bristle_damping * rate[1] / speed + p.viscous * dir[1]};
  if (along[0] * dir[0] + along[1] * dir[1] <= 0) {
    PlanarStateForce(p, in, v, z, force);
    return;
  }
  const double across = p.bristle_damping + p.viscous;
  const double perp[2] = {-dir[1], dir[0]};
  double D[4];
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) D[2 * i + j] = along[i] * dir[j] + across * perp[i] * perp[j];
  }
  // Trapezoidal: F = elastic + D (v + v_next)/2, v_next = v_free - B F
  //   => (I + D B / 2) F = elastic + D (v + v_free) / 2.
  const double mean[2] = {v[0] + v_free[0], v[1] + v_free[1]};
  const double rhs[2] = {elastic[0] + 0.5 * (D[0] * mean[0] + D[1] * mean[1]),
                         elastic[1] + 0.5 * (D[2] * mean[0] + D[3] * mean[1])};
  const double A[4] = {1 + 0.5 * (D[0] * B[0] + D[1] * B[2]), 0.5 * (D[0] * B[1] + D[1] * B[3]),
                       0.5 * (D[2] * B[0] + D[3] * B[2]), 1 + 0.5 * (D[2] * B[1] + D[3] * B[3])};
  const double det = A[0] * A[3] - A[1] * A[2];
  force[0] = (A[3] * rhs[0] - A[1] * rhs[1]) / det;
  force[1] = (A[0] * rhs[1] - A[2] * rhs[0]) / det;
}

namespace {

template <int N>
double Determinant(const double B[N * N]);
template <>
double Determinant<2>(const double B[4]) { return B[0] * B[3] - B[1] * B[2]; }
template <>
double Determinant<3>(const double B[9]) {
  return B[0] * (B[4] * B[8] - B[5] * B[7]) - B[1] * (B[3] * B[8] - B[5] * B[6]) +
         B[2] * (B[3] * B[7] - B[4] * B[6]);
}

// x = B^+ b for a symmetric positive semi-definite B (N x N): its eigenvectors by Jacobi
// rotations, the eigenvalues below `tiny` dropped (directions without response take no force).
template <int N>
void PseudoInverseSolve(const double B[N * N], const double b[N], double tiny, double x[N]) {
  double a[N][N], q[N][N];
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < N; ++j) {
      a[i][j] = 0.5 * (B[N * i + j] + B[N * j + i]);
      q[i][j] = i == j;
    }
  }
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = 0.0, total = 0.0;
    for (int i = 0; i < N; ++i) {
      for (int j = 0; j < N; ++j) (i == j ? total : off) += a[i][j] * a[i][j];
    }
    if (off <= 1e-30 * (total + off)) break;
    for (int i = 0; i < N; ++i) {
      for (int j = i + 1; j < N; ++j) {
        if (a[i][j] == 0) continue;
        const double theta = 0.5 * std::atan2(2 * a[i][j], a[j][j] - a[i][i]);
        const double c = std::cos(theta), s = std::sin(theta);
        for (int k = 0; k < N; ++k) {  // A <- A R, then A <- R' A, Q <- Q R
          const double ki = a[k][i], kj = a[k][j];
          a[k][i] = c * ki - s * kj;
          a[k][j] = s * ki + c * kj;
        }
        for (int k = 0; k < N; ++k) {
          const double ik = a[i][k], jk = a[j][k];
          a[i][k] = c * ik - s * jk;
          a[j][k] = s * ik + c * jk;
        }
        for (int k = 0; k < N; ++k) {
          const double ki = q[k][i], kj = q[k][j];
          q[k][i] = c * ki - s * kj;
          q[k][j] = s * ki + c * kj;
        }
      }
    }
  }
  for (int i = 0; i < N; ++i) x[i] = 0.0;
  for (int k = 0; k < N; ++k) {
    if (!(a[k][k] > tiny)) continue;
    double projection = 0.0;
    for (int i = 0; i < N; ++i) projection += q[i][k] * b[i];
    for (int i = 0; i < N; ++i) x[i] += q[i][k] * projection / a[k][k];
  }
}

}  // namespace

template <int N>
void VectorStickSlipForce(const LawParameters& p, const LawInput& in, const double v[N],
                          const double v_free[N], const double B[N * N], double force[N]) {
  // Force that brings the end-of-step velocity to zero: B F = v_free.
  double stick[N];
  double trace = 0.0;
  bool diagonal = true;
  for (int i = 0; i < N; ++i) {
    trace += B[N * i + i];
    for (int j = 0; j < N; ++j) diagonal = diagonal && (i == j || B[N * i + j] == 0);
  }
  // A direction whose response is below 1e-12 of the trace has none: no force can move it.
  double scale = 1.0;  // trace^N: det > 1e-12 trace^N is invertible to working precision
  for (int i = 0; i < N; ++i) scale *= trace;
  const bool invertible = Determinant<N>(B) > 1e-12 * scale;
  if (diagonal) {  // decoupled axes (as the 1D element divides)
    for (int i = 0; i < N; ++i) {
      stick[i] = B[N * i + i] > 1e-12 * trace ? v_free[i] / B[N * i + i] : 0.0;
    }
  } else if (!invertible || !SolveLinear<N>(B, v_free, 0.0, stick)) {
    // coupled and singular (a body that moves along one combination of the axes only)
    PseudoInverseSolve<N>(B, v_free, 1e-12 * trace, stick);
  }
  const double stick_norm = Norm<N>(stick);
  LawInput at_rest = in;
  at_rest.velocity = 0.0;
  const double static_level = p.static_ratio * CoulombLevel(p, at_rest, 1.0);
  if (stick_norm <= static_level) {
    for (int i = 0; i < N; ++i) force[i] = stick[i];
    return;
  }
  const double speed = Norm<N>(v);
  double kinetic = CoulombLevel(p, in, 1.0);
  if (p.static_ratio != 1.0) {
    const double ratio = speed / p.stribeck_velocity;
    kinetic *= 1.0 + (p.static_ratio - 1.0) * std::exp(-ratio * ratio);
  }
  // Sliding: u + kinetic B u/|u| = v_free. With lambda = kinetic/|u|, u = (I + lambda B)^-1
  // v_free and lambda |u(lambda)| = kinetic, increasing in lambda from 0 to |stick| > kinetic.
  auto end_velocity = [&](double lambda, double u[N]) {
    double A[N * N];
    for (int i = 0; i < N; ++i) {
      for (int j = 0; j < N; ++j) A[N * i + j] = (i == j) + lambda * B[N * i + j];
    }
    // I + lambda B with B positive semi-definite: invertible
    if (!SolveLinear<N>(A, v_free, 0.0, u)) {
      for (int i = 0; i < N; ++i) u[i] = v_free[i];
    }
  };
  double dir[N];
  for (int i = 0; i < N; ++i) dir[i] = stick[i] / stick_norm;
  int moving_axes = 0;
  for (int i = 0; i < N; ++i) moving_axes += v_free[i] != 0;
  const bool one_axis = moving_axes <= 1 && diagonal;
  if (!one_axis && !(diagonal && !invertible) && kinetic > 0) {  // I + lambda B: invertible
    const double b_mean = std::max(trace / N, 1e-300);
    double lo = 0.0, hi = kinetic / (b_mean * std::max(stick_norm - kinetic, 1e-300 * stick_norm));
    double u[N];
    for (int k = 0; k < 200; ++k) {  // bracket the root
      end_velocity(hi, u);
      if (hi * Norm<N>(u) >= kinetic) break;
      lo = hi;
      hi *= 2;
    }
    for (int k = 0; k < 100 && hi - lo > 1e-15 * hi; ++k) {
      const double mid = 0.5 * (lo + hi);
      end_velocity(mid, u);
      if (mid * Norm<N>(u) >= kinetic) hi = mid; else lo = mid;
    }
    end_velocity(hi, u);
    const double u_norm = Norm<N>(u);
    if (u_norm > 0) {
      for (int i = 0; i < N; ++i) dir[i] = u[i] / u_norm;
    }
  }
  for (int i = 0; i < N; ++i) force[i] = kinetic * dir[i] + p.viscous * v[i];
}

template void VectorStickSlipForce<2>(const LawParameters&, const LawInput&, const double*,
                                      const double*, const double*, double*);
template void VectorStickSlipForce<3>(const LawParameters&, const LawInput&, const double*,
                                      const double*, const double*, double*);

void PlanarStickSlipForce(const LawParameters& p, const LawInput& in, const double v[2],
                          const double v_free[2], const double B[4], double force[2]) {
  VectorStickSlipForce<2>(p, in, v, v_free, B, force);
}

void PlanarKinematicCoulombForce(const LawParameters& p, const LawInput& in, const double v[2],
                                 double force[2]) {
  double dir[2] = {0.0, 0.0}, speed = 0.0;
  Direction<2>(v, dir, &speed);
  const double level = speed > 0 ? StribeckLevel(p, AtSpeed(in, speed)) : 0.0;
  force[0] = level * dir[0] + p.viscous * v[0];
  force[1] = level * dir[1] + p.viscous * v[1];
}

// ---- Lists: gms elements, level maps --------------------------------------------------------

ListCheck MakeGmsElements(const double* stiffness, const double* weight, int count,
                          double relaxation_time, GmsElements* out) {
  if (count < 1 || count > kMaxGmsElements) return {ListProblem::kCount, double(count)};
  GmsElements g;
  g.count = count;
  double total = 0.0;
  for (int i = 0; i < count; ++i) {
    const double w = weight ? weight[i] : 1.0 / count;
    if (!std::isfinite(stiffness[i]) || !std::isfinite(w)) {
      return {ListProblem::kNotFinite, std::isfinite(w) ? stiffness[i] : w};
    }
    if (!(stiffness[i] > 0)) return {ListProblem::kStiffness, stiffness[i]};
    if (!(w > 0)) return {ListProblem::kWeight, w};
    g.stiffness[i] = stiffness[i];
    g.weight[i] = w;
    total += w;
  }
  if (std::fabs(total - 1.0) > 1e-6) return {ListProblem::kWeightSum, total};
  for (int i = 0; i < count; ++i) g.weight[i] /= total;  // exactly 1 in all
  if (!(relaxation_time >= 0) || !std::isfinite(relaxation_time)) {
    return {ListProblem::kRelaxation, relaxation_time};
  }
  g.relaxation_time = relaxation_time;
  *out = g;
  return {};
}

ListCheck MakeLevelMap(const double* knots, const double* factors, int count, double period,
                       bool nonnegative_knots, LevelMap* out) {
  if (count < 0 || count > kMaxMapKnots) return {ListProblem::kCount, double(count)};
  if (!(period >= 0) || !std::isfinite(period)) return {ListProblem::kPeriod, period};
  LevelMap map = *out;
  map.count = count;
  map.period = period;
  for (int i = 0; i < count; ++i) {
    if (!std::isfinite(knots[i]) || !std::isfinite(factors[i])) {
      return {ListProblem::kNotFinite, std::isfinite(knots[i]) ? factors[i] : knots[i]};
    }
    if (!(factors[i] > -1)) return {ListProblem::kFactor, factors[i]};
    if (nonnegative_knots && knots[i] < 0) return {ListProblem::kNegativeKnot, knots[i]};
    map.knot[i] = knots[i];
    map.factor[i] = factors[i];
  }
  if (!map.SetUp()) return {ListProblem::kOrder, 0.0};
  *out = map;
  return {};
}

// ---- Level maps ------------------------------------------------------------------------------

bool LevelMap::SetUp() {
  const int n = count;
  for (int i = 0; i < kMaxMapKnots; ++i) curvature[i] = 0.0;
  if (n < 1 || n > kMaxMapKnots) return n == 0;
  for (int i = 1; i < n; ++i) {
    if (!(knot[i] > knot[i - 1])) return false;
  }
  if (period > 0 && !(knot[n - 1] < knot[0] + period)) return false;
  if (n < 3 && period <= 0) return true;  // a constant or a line: no curvature
  if (n < 2) return true;
  // Continuity of the slope at each interior knot (every knot, periodic): a linear system in
  // the curvatures, at most 16 unknowns, solved once when the config is read.
  double A[kMaxMapKnots * kMaxMapKnots] = {}, b[kMaxMapKnots] = {}, m[kMaxMapKnots] = {};
  auto x = [&](int i) { return i < n ? knot[i] : knot[i - n] + period; };
  auto y = [&](int i) { return factor[i % n]; };
  if (period > 0) {
    for (int i = 0; i < n; ++i) {
      const int prev = (i + n - 1) % n, next = (i + 1) % n;
      const double h0 = i == 0 ? knot[0] + period - knot[n - 1] : knot[i] - knot[i - 1];
      const double h1 = x(i + 1) - knot[i];
      A[n * i + prev] += h0 / 6;
      A[n * i + i] += (h0 + h1) / 3;
      A[n * i + next] += h1 / 6;
      b[i] = (y(i + 1) - factor[i]) / h1 - (factor[i] - factor[prev]) / h0;
    }
  } else {
    A[0] = 1.0;
    A[n * (n - 1) + n - 1] = 1.0;  // natural ends: zero curvature
    for (int i = 1; i + 1 < n; ++i) {
      const double h0 = knot[i] - knot[i - 1], h1 = knot[i + 1] - knot[i];
      A[n * i + i - 1] = h0 / 6;
      A[n * i + i] = (h0 + h1) / 3;
      A[n * i + i + 1] = h1 / 6;
      b[i] = (factor[i + 1] - factor[i]) / h1 - (factor[i] - factor[i - 1]) / h0;
    }
  }
  // (Gaussian elimination with partial pivoting, n <= 16)
  for (int col = 0; col < n; ++col) {
    int pivot = col;
    for (int r = col + 1; r < n; ++r) {
      if (std::fabs(A[n * r + col]) > std::fabs(A[n * pivot + col])) pivot = r;
    }
    if (!(std::fabs(A[n * pivot + col]) > 0)) return false;
    if (pivot != col) {
      for (int j = 0; j < n; ++j) std::swap(A[n * pivot + j], A[n * col + j]);
      std::swap(b[pivot], b[col]);
    }
    for (int r = col + 1; r < n; ++r) {
      const double f = A[n * r + col] / A[n * col + col];
      for (int j = col; j < n; ++j) A[n * r + j] -= f * A[n * col + j];
      b[r] -= f * b[col];
    }
  }
  for (int i = n - 1; i >= 0; --i) {
    double sum = b[i];
    for (int j = i + 1; j < n; ++j) sum -= A[n * i + j] * m[j];
    m[i] = sum / A[n * i + i];
  }
  for (int i = 0; i < n; ++i) curvature[i] = m[i];
  return true;
}

double LevelMap::Value(double at) const {
  const int n = count;
  if (n == 0) return 0.0;
  if (n == 1) return factor[0];
  double xq = at;
  int i;  // interval [x_i, x_i+1]; periodic: i = n - 1 wraps to knot 0 + period
  if (period > 0) {
    xq = knot[0] + std::fmod(at - knot[0], period);
    if (xq < knot[0]) xq += period;
    i = static_cast<int>(std::upper_bound(knot, knot + n, xq) - knot) - 1;
  } else {
    if (xq <= knot[0] || xq >= knot[n - 1]) {
      const bool low = xq <= knot[0];
      const int end = low ? 0 : n - 1;
      if (constant_ends) return factor[end];
      // the natural spline's end slope (its end curvature is 0), continued linearly
      const int a = low ? 0 : n - 2;  // the end interval [knot a, knot a + 1]
      const double h = knot[a + 1] - knot[a];
      const double chord = (factor[a + 1] - factor[a]) / h;
      const double slope = low ? chord - h * curvature[1] / 6 : chord + h * curvature[n - 2] / 6;
      return factor[end] + slope * (xq - knot[end]);
    }
    i = static_cast<int>(std::upper_bound(knot, knot + n, xq) - knot) - 1;
  }
  const int j = (i + 1) % n;
  const double x1 = i + 1 < n ? knot[i + 1] : knot[0] + period;
  const double h = x1 - knot[i];
  const double a = (x1 - xq) / h, b = (xq - knot[i]) / h;
  return a * factor[i] + b * factor[j] +
         ((a * a * a - a) * curvature[i] + (b * b * b - b) * curvature[j]) * h * h / 6;
}

// ---- Generalized Maxwell-slip ----------------------------------------------------------------

namespace {

// Time t in [0, dt] at which |z + v t| reaches `limit` (|z| < limit, v != 0): the positive root
// of |v|^2 t^2 + 2 (z.v) t + |z|^2 - limit^2 = 0, written without cancellation.
template <int D>
double CrossingTime(const double* z, const double v[D], double limit) {
  const double a = Dot<D>(v, v);
  const double b = Dot<D>(z, v);
  const double c = Dot<D>(z, z) - limit * limit;
  const double root = std::sqrt(std::max(b * b - a * c, 0.0));
  return b >= 0 ? -c / (b + root) : (root - b) / a;
}

}  // namespace

template <int D>
void AdvanceGms(const LawParameters& p, const LawInput& in, const double v[D], double* z,
                double* slipping, double dt) {
  if (dt <= 0) return;
  double speed = 0.0;
  for (int j = 0; j < D; ++j) speed += v[j] * v[j];
  speed = std::sqrt(speed);
  // The level on either side: in 1D the direction asymmetry gives each side its own, and an
  // element is limited on the side its deflection lies (so a reversal unloads it elastically
  // across to the other side's level); in the plane the level is isotropic.
  double level_positive, level_negative;
  if (D == 1) {
    LawInput at = in;
    at.velocity = v[0];
    const double shape = VelocityShape(p, v[0]);
    level_positive = CoulombLevel(p, at, 1.0) * shape;
    level_negative = CoulombLevel(p, at, -1.0) * shape;
  } else {
    level_positive = level_negative = StribeckLevel(p, AtSpeed(in, speed));
  }
  for (int i = 0; i < p.gms.count; ++i) {
    double* zi = z + D * i;
    const double share = p.gms.weight[i] / p.gms.stiffness[i];
    // the slip deflection on the side of `side` (1D: its sign; the plane: any)
    auto limit_on = [&](double side) {
      return std::max(share * (side < 0 ? level_negative : level_positive), 0.0);
    };
    if (slipping[i] != 0 && !(Dot<D>(v, zi) > 0)) slipping[i] = 0;  // reversed or stopped
    double remaining = dt;
    double limit = limit_on(v[0]);  // a slipping element's side: that of the motion
    if (slipping[i] == 0) {
      double trial[D];
      for (int j = 0; j < D; ++j) trial[j] = zi[j] + v[j] * dt;
      const double trial_norm = std::sqrt(Dot<D>(trial, trial));
      const double trial_limit = limit_on(trial[0]);
      if (trial_norm <= trial_limit) {  // sticks the whole step
        for (int j = 0; j < D; ++j) zi[j] = trial[j];
        continue;
      }
      if (!(Dot<D>(v, trial) > 0)) {
        // Unloading, yet beyond a level that fell (Stribeck, load): back to the level.
        for (int j = 0; j < D; ++j) zi[j] = trial_limit * trial[j] / trial_norm;
        continue;
      }
      // Loading through the level (on the side of the motion): stick until the crossing,
      // slip for the rest of the step.
      const double t_cross =
          Dot<D>(zi, zi) < limit * limit ? std::min(CrossingTime<D>(zi, v, limit), dt) : 0.0;
      for (int j = 0; j < D; ++j) zi[j] += v[j] * t_cross;
      remaining = dt - t_cross;
      slipping[i] = 1;
    }
    // Slipping: the magnitude relaxes to the level, along the elastic trial direction.
    double trial[D];
    for (int j = 0; j < D; ++j) trial[j] = zi[j] + v[j] * remaining;
    const double trial_norm = std::sqrt(Dot<D>(trial, trial));
    if (!(trial_norm > 0)) continue;
    const double magnitude = std::sqrt(Dot<D>(zi, zi));
    const double relaxed =
        p.gms.relaxation_time > 0
            ? limit + (magnitude - limit) * std::exp(-remaining / p.gms.relaxation_time)
            : limit;
    for (int j = 0; j < D; ++j) zi[j] = relaxed * trial[j] / trial_norm;
  }
}

template <int D>
void GmsElementForce(const LawParameters& p, const double* z, double force[D]) {
  for (int j = 0; j < D; ++j) force[j] = 0.0;
  for (int i = 0; i < p.gms.count; ++i) {
    for (int j = 0; j < D; ++j) force[j] += p.gms.stiffness[i] * z[D * i + j];
  }
}

template <int D>
void GmsEquivalentDeflection(const LawParameters& p, const double* z, double deflection[D]) {
  double stiffness = 0.0;
  for (int i = 0; i < p.gms.count; ++i) stiffness += p.gms.stiffness[i];
  GmsElementForce<D>(p, z, deflection);
  for (int j = 0; j < D; ++j) deflection[j] /= stiffness;
}

template <int D>
void GmsImplicitForce(const LawParameters& p, const double* z, const double v[D],
                      const double v_free[D], const double B[D * D], double force[D]) {
  double rhs[D];
  GmsElementForce<D>(p, z, rhs);
  if (D == 1) rhs[0] += p.force_offset;
  if (p.viscous == 0) {
    for (int j = 0; j < D; ++j) force[j] = rhs[j];
    return;
  }
  // F = E + sigma2 (v + v_free - B F) / 2  <=>  (I + sigma2 B / 2) F = E + sigma2 (v + v_free)/2
  double A[D * D];
  for (int r = 0; r < D; ++r) {
    rhs[r] += 0.5 * p.viscous * (v[r] + v_free[r]);
    for (int c = 0; c < D; ++c) A[D * r + c] = (r == c ? 1.0 : 0.0) + 0.5 * p.viscous * B[D * r + c];
  }
  if (!SolveLinear<D>(A, rhs, 1e-300, force)) {
    for (int j = 0; j < D; ++j) force[j] = rhs[j];  // (B is PSD: I + sB/2 is never singular)
  }
}

template void AdvanceGms<1>(const LawParameters&, const LawInput&, const double*, double*,
                            double*, double);
template void AdvanceGms<2>(const LawParameters&, const LawInput&, const double*, double*,
                            double*, double);
template void GmsElementForce<1>(const LawParameters&, const double*, double*);
template void GmsElementForce<2>(const LawParameters&, const double*, double*);
template void GmsEquivalentDeflection<1>(const LawParameters&, const double*, double*);
template void GmsEquivalentDeflection<2>(const LawParameters&, const double*, double*);
template void GmsImplicitForce<1>(const LawParameters&, const double*, const double*,
                                  const double*, const double*, double*);
template void GmsImplicitForce<2>(const LawParameters&, const double*, const double*,
                                  const double*, const double*, double*);

// ---- The deflection step taken implicitly (steps that do not resolve the contact) ---------------

namespace {

// Newton's method for the end-of-step velocity w: R(w) = w + B F(w) - v_free = 0, with the
// Jacobian I + B dF/dw by forward differences (step h_j = 1e-7 max(|w|, kink), kink the speed
// at which one step's travel is the steady deflection) and a backtracking line search on |R|.
// With the level frozen over the step F is monotone in w (more velocity, more deflection) and B
// positive semi-definite, so the root is unique; from the better of the two starting guesses (`guesses`) it converges in a few
// iterations. Returns the force at the root in `force` and the root in `w`.
template <int N, typename Force>
void SolveImplicitEndVelocity(const double B[N * N], const double v_free[N], double kink,
                              const double* const guesses[2], Force&& force_of, double w[N],
                              double force[N]) {
  auto residual = [&](const double x[N], double f[N], double r[N]) {
    force_of(x, f);
    double size = 0.0;
    for (int i = 0; i < N; ++i) {
      double bf = 0.0;
      for (int j = 0; j < N; ++j) bf += B[N * i + j] * f[j];
      r[i] = x[i] + bf - v_free[i];
      size += r[i] * r[i];
    }
    return std::sqrt(size);
  };
  double f[N] = {}, r[N] = {}, size = 0.0;
  for (int g = 0; g < 2; ++g) {
    double fg[N], rg[N];
    const double s = residual(guesses[g], fg, rg);
    if (g == 0 || s < size) {
      size = s;
      for (int i = 0; i < N; ++i) {
        w[i] = guesses[g][i];
        f[i] = fg[i];
        r[i] = rg[i];
      }
    }
  }
  // the size of the terms of R: below 1e-13 of it R is rounding
  double scale = kink + Norm<N>(v_free);
  bool central = false;  // central differences: at w = 0 (where F has a kink) and on a retry
  for (int iter = 0; iter < 60; ++iter) {
    scale = std::max(scale, Norm<N>(w));
    if (!(size > 1e-13 * scale)) break;
    const double h = 1e-7 * std::max(Norm<N>(w), kink);
    if (Norm<N>(w) < 10 * h) central = true;
    double J[N * N];  // I + B dF/dw
    double dF[N * N];  // column j: dF/dw_j
    for (int j = 0; j < N; ++j) {
      double x[N], fx[N], fy[N];
      for (int i = 0; i < N; ++i) x[i] = w[i];
      x[j] += h;
      force_of(x, fx);
      if (central) {
        x[j] -= 2 * h;
        force_of(x, fy);
        for (int i = 0; i < N; ++i) dF[N * i + j] = (fx[i] - fy[i]) / (2 * h);
      } else {
        for (int i = 0; i < N; ++i) dF[N * i + j] = (fx[i] - f[i]) / h;
      }
    }
    for (int i = 0; i < N; ++i) {
      for (int j = 0; j < N; ++j) {
        double sum = i == j ? 1.0 : 0.0;
        for (int k = 0; k < N; ++k) sum += B[N * i + k] * dF[N * k + j];
        J[N * i + j] = sum;
      }
    }
    double minus_r[N], step[N];
    for (int i = 0; i < N; ++i) minus_r[i] = -r[i];
    if (!SolveLinear<N>(J, minus_r, 1e-300, step)) {
      for (int i = 0; i < N; ++i) step[i] = minus_r[i];  // (I + B dF: not singular in practice)
    }
    // Backtracking: accept the first fraction of the step that lowers |R|.
    double alpha = 1.0;
    bool moved = false;
    for (int k = 0; k < 40; ++k, alpha *= 0.5) {
      double x[N], fx[N], rx[N];
      for (int i = 0; i < N; ++i) x[i] = w[i] + alpha * step[i];
      const double s = residual(x, fx, rx);
      if (s < (1.0 - 1e-4 * alpha) * size) {
        for (int i = 0; i < N; ++i) {
          w[i] = x[i];
          f[i] = fx[i];
          r[i] = rx[i];
        }
        size = s;
        moved = true;
        break;
      }
    }
    if (!moved) {
      if (central) break;  // at the root to working precision
      central = true;      // a kink between w and the root: retry with central differences
      continue;
    }
    central = false;
    // a full step below 1e-10 of the velocity scale: the next would be below rounding
    if (alpha == 1.0 && Norm<N>(step) <= 1e-10 * (Norm<N>(w) + kink)) break;
  }
  for (int i = 0; i < N; ++i) force[i] = f[i];
}

}  // namespace

LawParameters LevelAtSpeed(const LawParameters& p, double speed) {
  const double shape = VelocityShape(p, speed);
  LawParameters q = p;
  if (shape == 1.0) return q;
  q.static_ratio = 1.0;
  q.velocity_map.count = 0;
  q.friction_coefficient *= shape;
  q.breakaway_ratio = p.breakaway_ratio / shape;
  return q;
}

namespace {

// The elastic guess: the deflection follows the motion over the step, z + dt w (exact while it
// sticks in Dupont's elastic range, close for Dahl and LuGre): (I + (k dt + s1 + s2) B) w =
// v_free - k B z.
template <int N>
void ElasticGuess(double stiffness, double damping, const double z[N], const double v_free[N],
                  const double B[N * N], double dt, double w[N]) {
  double A[N * N], rhs[N];
  for (int i = 0; i < N; ++i) {
    double bz = 0.0;
    for (int j = 0; j < N; ++j) {
      A[N * i + j] = (i == j) + (stiffness * dt + damping) * B[N * i + j];
      bz += B[N * i + j] * z[j];
    }
    rhs[i] = v_free[i] - stiffness * bz;
  }
  if (!SolveLinear<N>(A, rhs, 1e-300, w)) {
    for (int i = 0; i < N; ++i) w[i] = v_free[i];
  }
}

// The rigid guess: rigid Coulomb's end-of-step velocity (the limit of an infinite stiffness),
// v_free - B F_coulomb.
template <int N>
void RigidGuess(const LawParameters& p, const LawInput& in, const double v_free[N],
                const double B[N * N], double w[N]) {
  LawParameters rigid = p;
  rigid.law = Law::kCoulomb;
  rigid.viscous = 0.0;
  double f[N];
  VectorStickSlipForce<N>(rigid, in, v_free, v_free, B, f);
  for (int i = 0; i < N; ++i) {
    double bf = 0.0;
    for (int j = 0; j < N; ++j) bf += B[N * i + j] * f[j];
    w[i] = v_free[i] - bf;
  }
}

}  // namespace

template <int N>
double LargestEigenvalue(const double A[N * N]) {
  static_assert(N >= 1 && N <= 3, "LargestEigenvalue: N = 1, 2 or 3");
  if constexpr (N == 1) {
    return A[0];
  } else if constexpr (N == 2) {
    const double mean = 0.5 * (A[0] + A[3]);
    const double half = 0.5 * (A[0] - A[3]);
    const double off = 0.5 * (A[1] + A[2]);
    return mean + std::hypot(half, off);
  } else {
    // the trigonometric solution for a symmetric matrix (Smith 1961)
    const double a01 = 0.5 * (A[1] + A[3]), a02 = 0.5 * (A[2] + A[6]);
    const double a12 = 0.5 * (A[5] + A[7]);
    const double off = a01 * a01 + a02 * a02 + a12 * a12;
    const double q = (A[0] + A[4] + A[8]) / 3.0;
    const double d0 = A[0] - q, d1 = A[4] - q, d2 = A[8] - q;
    const double p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off;
    if (!(p2 > 0)) return q;
    const double p = std::sqrt(p2 / 6.0);
    // det((A - q I) / p) / 2
    const double b00 = d0 / p, b11 = d1 / p, b22 = d2 / p;
    const double b01 = a01 / p, b02 = a02 / p, b12 = a12 / p;
    const double det = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) +
                       b02 * (b01 * b12 - b11 * b02);
    const double r = std::clamp(0.5 * det, -1.0, 1.0);
    return q + 2.0 * p * std::cos(std::acos(r) / 3.0);
  }
}

template <int N>
void VectorImplicitDeflectionForce(const LawParameters& p, const LawInput& in, const double z[N],
                                   const double v_free[N], const double B[N * N], double dt,
                                   double force[N], double end_velocity[N], double next[N]) {
  const double k = p.contact_stiffness;
  // The level at the step's start speed, as rigid Coulomb's kinetic level: a level falling
  // with the speed (Stribeck) taken at the end speed would give the step several solutions.
  const LawParameters q = LevelAtSpeed(p, in.velocity);
  const double level = CoulombLevel(q, in, 1.0);
  // A deflection beyond what that level holds (the load or the level fell) is taken at the
  // level: it would slip back within a travel of order level / k, a small part of the step.
  double start[N];
  const double size = Norm<N>(z), limit = level / k;
  for (int i = 0; i < N; ++i) start[i] = size > limit ? z[i] * (limit / size) : z[i];
  auto force_of = [&](const double w[N], double f[N]) {
    double after[N];
    for (int i = 0; i < N; ++i) after[i] = start[i];
    AdvanceVectorDeflection<N>(q, in, w, after, dt);
    for (int i = 0; i < N; ++i) {
      f[i] = k * after[i] + q.bristle_damping * (after[i] - start[i]) / dt + q.viscous * w[i];
    }
  };
  // (no level: no deflection, F = sigma2 w; a velocity scale for the differences all the same)
  const double kink = std::max(level / k / dt, 1e-12 * Norm<N>(v_free) + 1e-300);
  double elastic[N], rigid[N];
  ElasticGuess<N>(k, q.bristle_damping + q.viscous, start, v_free, B, dt, elastic);
  RigidGuess<N>(q, in, v_free, B, rigid);
  const double* const guesses[2] = {elastic, rigid};
  SolveImplicitEndVelocity<N>(B, v_free, kink, guesses, force_of, end_velocity, force);
  for (int i = 0; i < N; ++i) next[i] = start[i];
  AdvanceVectorDeflection<N>(q, in, end_velocity, next, dt);
}

template <int D>
void GmsImplicitDeflectionForce(const LawParameters& p, const LawInput& in, const double* z,
                                const double* slipping, const double v_free[D],
                                const double B[D * D], double dt, double force[D],
                                double end_velocity[D], double* next, double* next_slipping) {
  const int count = p.gms.count;
  double stiffness = 0.0;
  for (int i = 0; i < count; ++i) stiffness += p.gms.stiffness[i];
  const LawParameters q = LevelAtSpeed(p, in.velocity);  // (as VectorImplicitDeflectionForce)
  auto force_of = [&](const double w[D], double f[D]) {
    double after[D * kMaxGmsElements], flags[kMaxGmsElements];
    for (int i = 0; i < D * count; ++i) after[i] = z[i];
    for (int i = 0; i < count; ++i) flags[i] = slipping[i];
    LawInput at = in;
    if (D == 1) at.velocity = w[0];
    AdvanceGms<D>(q, at, w, after, flags, dt);
    GmsElementForce<D>(q, after, f);
    for (int j = 0; j < D; ++j) f[j] += q.viscous * w[j] + (D == 1 ? q.force_offset : 0.0);
  };
  const double level = CoulombLevel(q, in, 1.0);
  double zsum[D];
  GmsElementForce<D>(p, z, zsum);
  const double kink = std::max(std::max(level, Norm<D>(zsum)) / (stiffness * dt),
                               1e-12 * Norm<D>(v_free) + 1e-300);
  double elastic[D], rigid[D];
  for (int j = 0; j < D; ++j) zsum[j] /= stiffness;  // the one deflection with that force
  ElasticGuess<D>(stiffness, q.viscous, zsum, v_free, B, dt, elastic);
  RigidGuess<D>(q, in, v_free, B, rigid);
  const double* const guesses[2] = {elastic, rigid};
  SolveImplicitEndVelocity<D>(B, v_free, kink, guesses, force_of, end_velocity, force);
  for (int i = 0; i < D * count; ++i) next[i] = z[i];
  for (int i = 0; i < count; ++i) next_slipping[i] = slipping[i];
  LawInput at = in;
  if (D == 1) at.velocity = end_velocity[0];
  AdvanceGms<D>(q, at, end_velocity, next, next_slipping, dt);
}

template double LargestEigenvalue<1>(const double*);
template double LargestEigenvalue<2>(const double*);
template double LargestEigenvalue<3>(const double*);
template void VectorImplicitDeflectionForce<2>(const LawParameters&, const LawInput&,
                                               const double*, const double*, const double*,
                                               double, double*, double*, double*);
template void VectorImplicitDeflectionForce<3>(const LawParameters&, const LawInput&,
                                               const double*, const double*, const double*,
                                               double, double*, double*, double*);
template void GmsImplicitDeflectionForce<2>(const LawParameters&, const LawInput&, const double*,
                                            const double*, const double*, const double*, double,
                                            double*, double*, double*, double*);

bool ParseLaw(const char* name, Law* law) {
  if (!name) return false;
  static const struct { const char* name; Law law; } kNames[] = {
      {"coulomb", Law::kCoulomb}, {"dahl", Law::kDahl}, {"dupont", Law::kDupont},
      {"lugre", Law::kLuGre}, {"gms", Law::kGms}};
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
    case Law::kGms: return "gms";
  }
  return "unknown";
}

}  // namespace vibrofriction
