// The friction laws of vibrofriction: the one implementation used by the MuJoCo plugin,
// by identification (through the C API in c_api.cc) and by the plots.
//
// Sign convention: v is the relative sliding velocity v_r = xdot - udot of the body over its
// support; the friction force F is the force the support exerts *against* that motion, so F > 0
// when v > 0 in steady sliding. The deflection z (m) is the bristle / asperity deflection.
//
// Laws (see plugin/cpp/README.md for the equations and sources):
//   coulomb  F = g(v) sgn(v) + s2 v, stick handled by the caller (StickSlipForce)
//   dahl     dz/dt = v |w|^alpha sgn(w), w = 1 - k_t z sgn(v) / g(v)    (Dahl 1968)
//   dupont   dz/dt = v (1 - a(z, v) z / z_ss(v))                         (Dupont et al. 2002)
//   lugre    dz/dt = v - |v| z s0 / g(v)                                 (Canudas de Wit 1995)
//   gms      N elasto-slide elements in parallel, F = sum k_i z_i        (Al-Bender et al. 2005)
// with g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2), F_c = mu F_N (times the effect factors):
// the same velocity-dependent level bounds Dahl's, LuGre's and Dupont's deflection.
#ifndef VIBROFRICTION_FRICTION_LAW_H_
#define VIBROFRICTION_FRICTION_LAW_H_

#include <algorithm>
#include <cmath>
#include <utility>

#include "vocabulary.h"  // generated from vibrofriction/vocabulary.py: defaults, list sizes

namespace vibrofriction {

inline constexpr double kPi = 3.14159265358979323846;

enum class Law : int { kCoulomb = 0, kDahl = 1, kDupont = 2, kLuGre = 3, kGms = 4 };

// The generalized Maxwell-slip law's elements (law gms): element i is a spring k_i in series
// with a slide whose level is weight_i g(v). Its deflection z_i (m) follows the motion while it
// sticks (dz_i/dt = v); it slips once its force reaches its level in the direction of motion,
// and then its force relaxes towards weight_i g(v) sgn(v) with the time constant
// relaxation_time (0: at once, an ideal Jenkins element), until the motion reverses.
struct GmsElements {
  int count = 0;
  double stiffness[kMaxGmsElements] = {};  // k_i (N/m)
  double weight[kMaxGmsElements] = {};     // share of the level g(v), summing to 1 (-)
  // tau (s) of a slipping element's force
  double relaxation_time = defaults::kGmsRelaxationTime;
};

// A friction level that varies smoothly along a coordinate (the relative position: a
// position_map; the sliding speed |v|: a velocity_map; the time t: a time_map, the level's
// drift from heating, run-in or wear): the level is multiplied by
// max(0, 1 + s(x)), s the cubic spline through (knot_i, factor_i) -- natural (zero curvature at
// the ends), or periodic when period > 0. Beyond the knots s stays at its end value
// (constant_ends, a position or a time) or goes on along its end slope (a speed: the map
// generalises a viscous term). count 0: off.
struct LevelMap {
  int count = 0;
  double knot[kMaxMapKnots] = {};       // increasing; periodic: within one period
  double factor[kMaxMapKnots] = {};     // relative change of the level at the knot (-)
  double curvature[kMaxMapKnots] = {};  // the spline's second derivatives (SetUp)
  double period = defaults::kPositionMapPeriod;  // > 0: periodic (m)
  bool constant_ends = true;

  // Computes the curvatures; false when the knots do not increase (or, periodic, do not fit
  // within one period).
  bool SetUp();
  double Value(double x) const;  // s(x)
  double Factor(double x) const { return count ? std::max(0.0, 1.0 + Value(x)) : 1.0; }
  static LevelMap WithLinearEnds() {
    LevelMap map;
    map.constant_ends = false;
    return map;
  }
};

// What is wrong with a gms element list or a level map, if anything: one check serves the MJCF
// config reader (which names the attribute and the value) and the C API (which returns -1).
enum class ListProblem {
  kNone,
  kCount,         // gms: not 1..kMaxGmsElements elements; map: more than kMaxMapKnots knots
  kNotFinite,     // a value is not a finite number
  kStiffness,     // a gms stiffness <= 0
  kWeight,        // a gms weight <= 0
  kWeightSum,     // the gms weights do not sum to 1 (value: their sum)
  kRelaxation,    // the gms relaxation time < 0
  kFactor,        // a map factor <= -1
  kNegativeKnot,  // a speed or time map's knot < 0
  kPeriod,        // a map's period < 0
  kOrder,         // the map's knots do not increase (or, periodic, leave one period)
};
struct ListCheck {
  ListProblem problem = ListProblem::kNone;
  double value = 0.0;  // the offending value
  bool ok() const { return problem == ListProblem::kNone; }
};

// The gms elements of `count` stiffnesses (N/m), weights (shares of the level, summing to 1
// within 1e-6, then normalised; null: equal shares) and a relaxation time (s).
ListCheck MakeGmsElements(const double* stiffness, const double* weight, int count,
                          double relaxation_time, GmsElements* out);
// A level map of `count` (knot, factor) pairs (count 0: off); `out` keeps its constant_ends.
ListCheck MakeLevelMap(const double* knots, const double* factors, int count, double period,
                       bool nonnegative_knots, LevelMap* out);

// Parameters of one friction element; names follow the Python FrictionParameters, defaults are
// the table's (vocabulary.py through the generated vocabulary.h).
struct LawParameters {
  Law law = Law::kDahl;
  double friction_coefficient = defaults::kMu;  // mu (-)
  double normal_force = 0.0;                 // F_N (N), constant part
  double contact_stiffness = defaults::kStiffness;  // k_t = sigma0 (N/m)
  double alpha = defaults::kAlpha;  // Dahl shape exponent (-)
  double breakaway_ratio = defaults::kBreakaway;  // Dupont z_ba / z_ss at the Coulomb level (-)
  double bristle_damping = defaults::kSigma1;  // sigma1 (N s/m)
  double viscous = defaults::kViscous;  // sigma2 (N s/m)
  double static_ratio = defaults::kStaticRatio;  // F_s / F_c (-)
  double stribeck_velocity = defaults::kStribeckVelocity;  // v_s (m/s)
  // effects, 0 = off
  double asymmetry = defaults::kAsymmetry;  // level x(1+a) for v>0, x(1-a) for v<0
  double ripple = defaults::kRipple;  // level x(1 + r sin(2 pi x/lambda + phi))
  double ripple_wavelength = defaults::kRippleWavelength;  // lambda (m)
  double ripple_phase = defaults::kRipplePhase;  // phi (rad)
  double normal_modulation = defaults::kNormalModulation;  // F_N x(1 + m sin(2 pi f_m t + phi_m))
  double normal_modulation_frequency = defaults::kModulationFrequency;  // f_m (Hz)
  double normal_modulation_phase = defaults::kModulationPhase;  // phi_m (rad)
  double force_offset = defaults::kForceOffset;  // constant added to F (N)
  double contact_play = defaults::kContactPlay;  // width b of a play before the bristles (m)
  GmsElements gms;                           // law gms only
  LevelMap position_map;                     // level x factor along the relative position
  LevelMap velocity_map = LevelMap::WithLinearEnds();  // level x factor over the speed |v|
  LevelMap time_map;                         // level x factor over the time t
};

// What the law sees at one instant besides its state.
struct LawInput {
  double velocity = 0.0;      // v_r (m/s)
  double position = 0.0;      // relative position of the body on its support (m)
  double time = 0.0;          // (s), for the normal-load modulation and the time map
  double normal_force = 0.0;  // F_N (N) before modulation (config + sensor input)
};

// Normal load (N) after the normal-load modulation, unclamped: negative when a sensor or a
// gain pulls it below 0 (lift-off). The state sensors report it, so lift-off is visible.
inline double ModulatedNormalLoad(const LawParameters& p, const LawInput& in) {
  double normal = in.normal_force;
  if (p.normal_modulation != 0) {
    normal *= 1.0 + p.normal_modulation *
                        std::sin(2 * kPi * p.normal_modulation_frequency * in.time +
                                 p.normal_modulation_phase);
  }
  return normal;
}

// Normal force (N, >= 0) the law uses: a lifted-off contact (load < 0) is open, no friction.
inline double ModulatedNormalForce(const LawParameters& p, const LawInput& in) {
  return std::max(ModulatedNormalLoad(p, in), 0.0);
}

// Coulomb level F_c (N) for the direction of motion `direction` (+1 / -1 / 0) with all effects.
// Inline (as the two below): the plugin calls them every step and the effects are usually off.
inline double CoulombLevel(const LawParameters& p, const LawInput& in, double direction) {
  double level = p.friction_coefficient * ModulatedNormalForce(p, in);
  if (p.asymmetry != 0) {
    if (direction > 0) level *= 1.0 + p.asymmetry;
    if (direction < 0) level *= 1.0 - p.asymmetry;
  }
  if (p.ripple != 0) {
    level *= 1.0 + p.ripple * std::sin(2 * kPi * in.position / p.ripple_wavelength + p.ripple_phase);
  }
  if (p.position_map.count) level *= p.position_map.Factor(in.position);
  if (p.time_map.count) level *= p.time_map.Factor(in.time);
  return level;
}

// The level's dependence on the sliding velocity v, g(v) / F_c: the Stribeck curve
// 1 + (F_s/F_c - 1) exp(-(v/v_s)^2) times the velocity map's factor at |v|.
inline double VelocityShape(const LawParameters& p, double velocity) {
  double shape = 1.0;
  if (p.static_ratio != 1.0) {
    const double ratio = velocity / p.stribeck_velocity;
    shape = 1.0 + (p.static_ratio - 1.0) * std::exp(-ratio * ratio);
  }
  if (p.velocity_map.count) shape *= p.velocity_map.Factor(std::fabs(velocity));
  return shape;
}

// The parameters with the level's speed dependence (Stribeck curve, velocity map) frozen at
// `speed`: the level g(speed) as the Coulomb level, Dupont's breakaway deflection kept. The
// implicit steps take it so: a level that falls with the speed, taken at the end speed, would
// give the step several solutions.
LawParameters LevelAtSpeed(const LawParameters& p, double speed);

// Stribeck curve g (N) at the input's velocity: F_c + (F_s - F_c) exp(-(v/v_s)^2) (x the
// velocity map).
inline double StribeckLevel(const LawParameters& p, const LawInput& in) {
  const double coulomb = CoulombLevel(p, in, (in.velocity > 0) - (in.velocity < 0));
  if (p.static_ratio == 1.0 && !p.velocity_map.count) return coulomb;
  return coulomb * VelocityShape(p, in.velocity);
}

// The laws with bristles, which alone take a play (contact_play): dahl, dupont, lugre.
inline bool TakesContactPlay(Law law) {
  return law == Law::kDahl || law == Law::kDupont || law == Law::kLuGre;
}

// A play in the contact (contact_play = b > 0; dahl, dupont, lugre): the state z is the whole
// deflection, play included, and the bristles deflect by the part beyond b/2 on either side,
// z_e = dz(z, b/2). Inside the play the contact is open: z follows the motion (dz/dt = v) and
// the contact carries no friction force (bristles, their damping and the viscous term; the
// force offset, a sensor's, stays). At a face the law takes over with z_e from 0, and while
// unloading it gives z_e back to 0 before the play opens again: after a reversal the force
// drops elastically, stays near 0 across the play, then loads again on the other face.
inline double ElasticDeflection(const LawParameters& p, double z) {
  if (p.contact_play <= 0) return z;
  const double half = 0.5 * p.contact_play;
  return z > half ? z - half : (z < -half ? z + half : 0.0);
}

// True when the play is open at deflection z with the motion v: inside it, or at a face and
// moving away from it.
inline bool PlayOpen(const LawParameters& p, double z, double velocity) {
  if (p.contact_play <= 0) return false;
  const double half = 0.5 * p.contact_play;
  return std::fabs(z) < half || (std::fabs(z) == half && velocity * z < 0);
}

// k_t z_e + sigma2 v + offset (N): the state force without bristle damping, which needs no level.
inline double UndampedStateForce(const LawParameters& p, double velocity, double z) {
  if (p.contact_play > 0) {
    if (PlayOpen(p, z, velocity)) return p.force_offset;
    z = ElasticDeflection(p, z);
  }
  return p.contact_stiffness * z + p.viscous * velocity + p.force_offset;
}

// Deflection rate dz/dt (m/s) at state z.
double DeflectionRate(const LawParameters& p, const LawInput& in, double z);

// Deflection after a step dt (s) with the input held constant. Exact for Dahl (any alpha) and
// LuGre; for Dupont an exact elastic segment then trapezoidal substeps of the plastic part.
// Unconditionally stable: the result never overshoots the steady deflection. With a play the
// step is split exactly where the bristles let go (z_e reaches 0: a closed form per law) and
// where the motion reaches the other face.
double AdvanceDeflection(const LawParameters& p, const LawInput& in, double z, double dt);

// Friction force F (N) of a state law at deflection z (not for Coulomb).
double StateForce(const LawParameters& p, const LawInput& in, double z);


// State force of a simulation step with the damping terms (sigma1 dz/dt + sigma2 v) at the
// trapezoidal mean of the step's start and end velocities, where the end velocity responds to
// the force, v_next = velocity_free - dt_inverse_mass F (dt_inverse_mass = dt J M^-1 J'). For a
// direction of motion dz/dt is linear in v, so this is one linear equation. Stable for any
// sigma1, sigma2 and dt (an explicit damping force needs (sigma1 + sigma2) dt < 2 m) and second
// order in dt (without a play). With a prescribed velocity (C API, identification) StateForce
// is used instead.
// With a play (contact_play) a step in which the contact closes or opens carries the mean
// force along its path at the step's mean velocity (the time closed, the bristles' mean
// deflection, the damping impulse sigma1 times z_e's change while closed); a step closed
// throughout, the bristles' force at its start with the damping at the end velocity (first
// order); a step that would reverse the motion, the force as it stands. (With
// damping the force jumps by (sigma1 + sigma2) v at a closing; deciding open or closed for
// the whole step left an error that a vibration crossing the play at the same phase every
// period did not average out.) `dt` is the step (s).
double ImplicitStateForce(const LawParameters& p, const LawInput& in, double z,
                          double velocity_free, double dt_inverse_mass, double dt);

// Rigid Coulomb with a time-stepping stick/slip decision. `stick_force` is the force that
// brings v_r to zero at the end of the step; the element sticks when it is within the static
// level, else it slides at the kinetic level in the direction of `stick_force`.
double StickSlipForce(const LawParameters& p, const LawInput& in, double stick_force);

// Coulomb force when the velocity is prescribed (kinematic driving, identification): no stick
// solve is possible, so F = g(v) sgn(v) + s2 v + offset (0 + offset at v = 0).
double KinematicCoulombForce(const LawParameters& p, const LawInput& in);

// ---- Planar (isotropic) laws: vector velocity v = (v_x, v_y), vector deflection z ----------------
// The 1D laws written for vectors so that they coincide with the functions above when v and z
// lie on one axis (plugins/planar_friction.h has the equations). The levels use the speed
// |v| (set LawInput::velocity = |v|); asymmetry, position ripple and force offset have no
// isotropic meaning and are ignored (the planar plugin rejects them). Normal-load modulation
// applies as in 1D.
//   dahl    dz/dt = |v| |e|^(alpha-1) e,  e = v/|v| - z/z_c    (|e| decays as the 1D Dahl base)
//   lugre   dz/dt = v - |v| z / z_g(|v|)
//   dupont  dz/dt = v - a(|z|) |v| z / z_max(|v|), a = 0 unless z.v > 0 (loading)
// Deflection rate dz/dt (m/s) at state z.
void PlanarDeflectionRate(const LawParameters& p, const LawInput& in, const double v[2],
                          const double z[2], double rate[2]);

// Advances z over dt with v and the input held constant: exact for Dahl (any alpha) and LuGre,
// exact elastic segment + trapezoidal plastic substeps for Dupont. Never leaves the disc of
// radius z_max (z_c) when started inside it.
void AdvancePlanarDeflection(const LawParameters& p, const LawInput& in, const double v[2],
                             double z[2], double dt);

// Friction force vector F = k_t z + sigma1 dz/dt + sigma2 v (N), against the motion.
void PlanarStateForce(const LawParameters& p, const LawInput& in, const double v[2],
                      const double z[2], double force[2]);

// The planar ImplicitStateForce: damping terms at the trapezoidal mean of the step's start and
// end velocities, v_next = v_free - B F (B = dt J M^-1 J', 2x2 row-major).
void PlanarImplicitStateForce(const LawParameters& p, const LawInput& in, const double v[2],
                              const double z[2], const double v_free[2], const double B[4],
                              double force[2]);

// Rigid Coulomb in the plane with a time-stepping stick/slip decision. The velocity at the end
// of the step responds to the friction force F as v_next = v_free - B F (B = dt J M^-1 J', 2x2,
// row-major, symmetric positive semi-definite). Sticks (F = B^-1 v_free) when that force is within
// the static level; else slides at the kinetic level (Stribeck curve at the current speed |v|)
// opposing the *end-of-step* velocity (maximal dissipation), plus sigma2 v. Reduces to
// StickSlipForce when everything lies on one axis.
void PlanarStickSlipForce(const LawParameters& p, const LawInput& in, const double v[2],
                          const double v_free[2], const double B[4], double force[2]);

// Kinematic Coulomb in the plane: F = g(|v|) v/|v| + sigma2 v (0 at v = 0).
void PlanarKinematicCoulombForce(const LawParameters& p, const LawInput& in, const double v[2],
                                 double force[2]);

// The same state laws for an N-vector (N = 2: the functions above; N = 4: the contact element's
// tangential velocity in world coordinates and its spin times the torsion radius). Explicitly
// instantiated for N = 4; N = 2 is reached through the Planar* functions above.
template <int N>
void VectorDeflectionRate(const LawParameters& p, const LawInput& in, const double v[N],
                          const double z[N], double rate[N]);
template <int N>
void AdvanceVectorDeflection(const LawParameters& p, const LawInput& in, const double v[N],
                             double z[N], double dt);
template <int N>
void VectorStateForce(const LawParameters& p, const LawInput& in, const double v[N],
                      const double z[N], double force[N]);

// Solves A x = b (N x N, row-major) by Gaussian elimination with partial pivoting; false when a
// pivot is below `tiny` (singular to working precision at the scale of A).
template <int N>
bool SolveLinear(const double A[N * N], const double b[N], double tiny, double x[N]) {
  double a[N][N + 1];
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < N; ++j) a[i][j] = A[N * i + j];
    a[i][N] = b[i];
  }
  for (int col = 0; col < N; ++col) {
    int pivot = col;
    for (int r = col + 1; r < N; ++r) {
      if (std::fabs(a[r][col]) > std::fabs(a[pivot][col])) pivot = r;
    }
    if (!(std::fabs(a[pivot][col]) > tiny)) return false;
    if (pivot != col) {
      for (int j = 0; j <= N; ++j) std::swap(a[pivot][j], a[col][j]);
    }
    for (int r = col + 1; r < N; ++r) {
      const double factor = a[r][col] / a[col][col];
      for (int j = col; j <= N; ++j) a[r][j] -= factor * a[col][j];
    }
  }
  for (int i = N - 1; i >= 0; --i) {
    double sum = a[i][N];
    for (int j = i + 1; j < N; ++j) sum -= a[i][j] * x[j];
    x[i] = sum / a[i][i];
  }
  return true;
}

// The rigid Coulomb stick/slip solve above for an N-vector (N = 2: PlanarStickSlipForce; N = 3:
// the contact element's two tangential directions and its spin times the torsion radius),
// B row-major N x N. Explicitly instantiated for N = 2 and 3 (N = 2 also through
// PlanarStickSlipForce).
template <int N>
void VectorStickSlipForce(const LawParameters& p, const LawInput& in, const double v[N],
                          const double v_free[N], const double B[N * N], double force[N]);

// ---- Generalized Maxwell-slip (law gms) -----------------------------------------------------
// State: the elements' deflections z (count values in 1D; count vectors of D components in the
// plane, z[D i + j]) and their slip flags slipping[i] (0 stuck, 1 slipping). The level is
// g = StribeckLevel at the input's speed; element i slips at |k_i z_i| = weight_i g.

// Advances every element over dt with the velocity v (D components) and the input held
// constant. A stuck element follows the motion, z_i += v t, up to the time its force reaches
// its level while loading (an exact crossing of the circle |k_i z_i| = weight_i g in the
// plane); from then on it slips: |z_i| relaxes to its level as exp(-t / tau) along the elastic
// trial direction z_i + v t (tau = 0: the return mapping of an ideal Jenkins element, exact in
// 1D). A slipping element sticks again once v . z_i <= 0 (the motion reverses or stops). An
// element held beyond a level that fell while unloading is brought back to it at once.
// D = 1 and D = 2 are instantiated; D = 2 reduces to D = 1 when v and z lie on one axis.
template <int D>
void AdvanceGms(const LawParameters& p, const LawInput& in, const double v[D], double* z,
                double* slipping, double dt);

// sum_i k_i z_i (D components, N): the elements' force, without the viscous term and offset.
template <int D>
void GmsElementForce(const LawParameters& p, const double* z, double force[D]);

// The one deflection with the elements' elastic force over their total stiffness,
// sum k_i z_i / sum k_i (D components, m): what the state sensors report as z.
template <int D>
void GmsEquivalentDeflection(const LawParameters& p, const double* z, double deflection[D]);

// The viscous term at the trapezoidal mean of the step's start and end velocities with the end
// velocity responding to the force, v_next = v_free - B F (B = dt J M^-1 J', D x D): the
// gms counterpart of ImplicitStateForce / PlanarImplicitStateForce. Returns F (D components)
// = elements + sigma2 (v + v_next)/2 + offset (offset in 1D only).
template <int D>
void GmsImplicitForce(const LawParameters& p, const double* z, const double v[D],
                      const double v_free[D], const double B[D * D], double force[D]);

// ---- Steps that do not resolve the contact (robot timesteps) --------------------------------
// The state laws' force k_t z_n of the step's start, with z advanced over the step at the new
// velocity, is a symplectic-Euler pair: for a body of response B = dt J M^-1 J' it is stable
// only while omega dt < 2, omega^2 dt^2 = k_t dt lambda_max(B) (measured on a free 1 kg box:
// the spin mode, lambda = rho^2/I = 3/m with MuJoCo's corner contacts, breaks at omega dt
// 1.14-1.17 against 2/sqrt 3 = 1.155 predicted). Beyond it the contact chatters and the mean
// friction falls below the level: a part pushed at half its sliding friction slid on at
// 1.45 mm/s (1 ms) and 2.90 mm/s (2 ms). The elements therefore take the step implicitly once
// k_t dt lambda_max(B) >= kUnresolvedDeflection (omega dt >= 1, half the limit), or the explicit
// damping sigma dt lambda_max(B) / dt reaches it (the contact element).
inline constexpr double kUnresolvedDeflection = 1.0;

// The largest eigenvalue of a symmetric N x N matrix (N = 1, 2, 3; row-major).
template <int N>
double LargestEigenvalue(const double A[N * N]);

// The state laws' force of a step taken implicitly: backward Euler in the body's motion with
// the law's exact constant-velocity update of the deflection. The end-of-step velocity w solves
// w + B F(w) = v_free (B = dt J M^-1 J', N x N, positive semi-definite), with
//   F(w) = k_t z(w) + sigma1 (z(w) - z)/dt + sigma2 w,  z(w) = AdvanceVectorDeflection(z, w, dt),
// (Newton, from the better of the elastic guess and rigid Coulomb's end velocity). The level is
// taken at the step's start speed in.velocity (as rigid Coulomb's kinetic level: a level that
// falls with the speed, taken at w, would give the step several solutions), and a deflection
// beyond it at the level. Stable for any dt: below the level the body stops (F = B^+ v_free,
// the stick force), above it slides at the level; as k_t dt lambda(B) grows it tends to rigid
// Coulomb with the law's Stribeck curve. Returns w and z(w) in `next`: the elements take it as
// the deflection after the step (the state the force was computed with), whatever the body's
// true end velocity (their B is an estimate): integrating the true velocity into z instead
// made the stick loop unstable when B overestimates the response (a box on MuJoCo's contacts:
// B is the free body's, 2.5 times the true dt/m), a limit cycle that ratcheted a held part
// forward by a few um/s. N = 2 and 3.
template <int N>
void VectorImplicitDeflectionForce(const LawParameters& p, const LawInput& in, const double z[N],
                                   const double v_free[N], const double B[N * N], double dt,
                                   double force[N], double end_velocity[N], double next[N]);

// The same for law gms in the plane (D = 2): F(w) = sum k_i z_i(w) + sigma2 w with the elements
// advanced by AdvanceGms from (z, slipping) (neither is changed; the elements and flags after
// the step at w in `next`, `next_slipping`).
template <int D>
void GmsImplicitDeflectionForce(const LawParameters& p, const LawInput& in, const double* z,
                                const double* slipping, const double v_free[D],
                                const double B[D * D], double dt, double force[D],
                                double end_velocity[D], double* next, double* next_slipping);

// True for the laws that keep a deflection state.
inline bool HasDeflection(Law law) { return law != Law::kCoulomb; }

// Parses "coulomb" | "dahl" | "dupont" | "lugre" | "gms"; returns false on anything else.
bool ParseLaw(const char* name, Law* law);
const char* LawName(Law law);

}  // namespace vibrofriction

#endif  // VIBROFRICTION_FRICTION_LAW_H_
