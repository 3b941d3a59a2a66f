// The deflection step taken implicitly (friction_law.h, VectorImplicitDeflectionForce and
// GmsImplicitDeflectionForce), for steps that do not resolve the contact: the returned end
// velocity w solves w + B F(w) = v_free with F(w) the law's force at the deflection the exact
// update gives with w (checked by recomputing it), over random deflections, velocities and
// responses from resolved (k dt lambda 0.01) to far beyond (1e6), for every state law, in 2
// and 3 components; below the level the body stops with the stick force, above it slides at
// the level; LargestEigenvalue against closed forms. Exit status 0: every check held.
// sources: laws/friction_law.cc
#include <cmath>
#include <cstdio>
#include <random>

#include "laws/friction_law.h"

using namespace vibrofriction;

namespace {

int failures = 0;

void Expect(bool ok, const char* what, double got, double want) {
  if (!ok) {
    ++failures;
    if (failures < 40) std::printf("FAILED %s: %.15g, want %.15g\n", what, got, want);
  }
}

LawParameters Parameters(Law law, double alpha = 1.0) {
  LawParameters p;
  p.law = law;
  p.friction_coefficient = 0.2;
  p.contact_stiffness = 8e7;
  p.alpha = alpha;
  return p;
}

LawInput Input(double normal_force) {
  LawInput in;
  in.normal_force = normal_force;
  return in;
}

// A random symmetric positive definite response B (N x N) with eigenvalues around `size`,
// spread over a factor `spread`.
template <int N>
void RandomResponse(std::mt19937_64& rng, double size, double spread, double B[N * N]) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> log_spread(0.0, std::log(spread));
  double Q[N * N];
  for (int i = 0; i < N * N; ++i) Q[i] = unit(rng);
  // Gram-Schmidt
  for (int c = 0; c < N; ++c) {
    for (int p = 0; p < c; ++p) {
      double dot = 0.0;
      for (int r = 0; r < N; ++r) dot += Q[N * r + c] * Q[N * r + p];
      for (int r = 0; r < N; ++r) Q[N * r + c] -= dot * Q[N * r + p];
    }
    double norm = 0.0;
    for (int r = 0; r < N; ++r) norm += Q[N * r + c] * Q[N * r + c];
    norm = std::sqrt(norm);
    for (int r = 0; r < N; ++r) Q[N * r + c] /= norm;
  }
  double eig[N];
  for (int i = 0; i < N; ++i) eig[i] = size * std::exp(log_spread(rng));
  for (int r = 0; r < N; ++r) {
    for (int c = 0; c < N; ++c) {
      double sum = 0.0;
      for (int k = 0; k < N; ++k) sum += Q[N * r + k] * eig[k] * Q[N * c + k];
      B[N * r + c] = sum;
    }
  }
}

template <int N>
double Norm(const double* v) {
  double s = 0.0;
  for (int i = 0; i < N; ++i) s += v[i] * v[i];
  return std::sqrt(s);
}

template <int N>
void CheckLaw(const LawParameters& p, std::mt19937_64& rng, const char* name) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> log_unit(0.0, 1.0);
  const double dt = 1e-3, load = 9.81;
  const double level = p.friction_coefficient * load;  // static_ratio 1
  const double z_c = level / p.contact_stiffness;
  double worst = 0.0;
  for (int trial = 0; trial < 3000; ++trial) {
    // k dt lambda from 1e-2 to 1e6
    const double resolution = std::pow(10.0, -2.0 + 8.0 * log_unit(rng));
    double B[N * N];
    RandomResponse<N>(rng, resolution / (p.contact_stiffness * dt), 10.0, B);
    double z[N], v_free[N];
    const double z_size = z_c * log_unit(rng);
    for (int i = 0; i < N; ++i) z[i] = z_size * unit(rng) / std::sqrt(double(N));
    // free velocities from far below the kink to far above it
    const double v_size = std::pow(10.0, -8.0 + 9.0 * log_unit(rng));
    for (int i = 0; i < N; ++i) v_free[i] = v_size * unit(rng);
    double force[N], w[N], after[N];
    const LawInput in = Input(load);
    VectorImplicitDeflectionForce<N>(p, in, z, v_free, B, dt, force, w, after);
    // recompute F(w) and the residual, the level frozen at the start speed (0: the static one)
    LawParameters q = p;
    q.friction_coefficient *= p.static_ratio;
    q.breakaway_ratio /= p.static_ratio;
    q.static_ratio = 1.0;
    double next[N];
    for (int i = 0; i < N; ++i) next[i] = z[i];
    AdvanceVectorDeflection<N>(q, in, w, next, dt);
    for (int i = 0; i < N; ++i) Expect(after[i] == next[i], "next: the deflection at w", after[i], next[i]);
    double f[N], r[N];
    for (int i = 0; i < N; ++i) {
      f[i] = q.contact_stiffness * next[i] + q.bristle_damping * (next[i] - z[i]) / dt +
             q.viscous * w[i];
    }
    for (int i = 0; i < N; ++i) {
      double bf = 0.0;
      for (int j = 0; j < N; ++j) bf += B[N * i + j] * f[j];
      r[i] = w[i] + bf - v_free[i];
    }
    const double scale = Norm<N>(v_free) + z_c / dt;
    const double error = Norm<N>(r) / scale;
    if (error > worst) worst = error;
    Expect(error < 1e-8, name, error, 0.0);
    if (!(error < 1e-8)) {
      std::printf("  resolution %g z %g %g v_free %g %g w %g %g B %g %g %g %g\n", resolution,
                  z[0], z[1], v_free[0], v_free[1], w[0], w[1], B[0], B[1], B[N], B[N + 1]);
    }
    for (int i = 0; i < N; ++i) Expect(std::fabs(f[i] - force[i]) <= 1e-9 * (level + Norm<N>(f)),
                                      "returned force is F(w)", force[i], f[i]);
    // never beyond what the law's deflection can carry (the static level)
    if (p.bristle_damping == 0 && p.viscous == 0) {
      Expect(Norm<N>(force) <= p.static_ratio * level * (1 + 1e-9), "force within the level",
             Norm<N>(force), p.static_ratio * level);
    }
  }
  std::printf("%s N=%d: worst relative residual %.3g\n", name, N, worst);
}

// Far beyond resolution (k dt lambda = 1e3) a body pushed below the level stops within the
// step, above it slides with the force at the level, as rigid Coulomb.
template <int N>
void CheckRigidLimit(const LawParameters& p, const char* name) {
  const double dt = 1e-3, load = 9.81, mass = 1.0;
  const double level = p.friction_coefficient * load;
  double B[N * N] = {};
  for (int i = 0; i < N; ++i) B[N * i + i] = dt / mass;
  const LawInput in = Input(load);
  for (double fraction : {0.5, 1.5}) {
    // at rest, deflected to hold half the level, pushed at `fraction` of it
    double z[N] = {}, v_free[N] = {};
    z[0] = 0.5 * level / p.contact_stiffness;
    v_free[0] = fraction * level * dt / mass;
    double force[N], w[N], after[N];
    VectorImplicitDeflectionForce<N>(p, in, z, v_free, B, dt, force, w, after);
    if (fraction < 1) {
      Expect(std::fabs(force[0] - fraction * level) < 1e-3 * level, name, force[0],
             fraction * level);
      Expect(std::fabs(w[0]) < 1e-3 * v_free[0], "held: stops", w[0], 0.0);
    } else {
      Expect(std::fabs(force[0] - level) < 1e-6 * level, name, force[0], level);
      Expect(std::fabs(w[0] - (fraction - 1) * level * dt / mass) < 1e-6 * v_free[0],
             "slides at (F - level)/m", w[0], (fraction - 1) * level * dt / mass);
    }
    for (int i = 1; i < N; ++i) Expect(std::fabs(force[i]) < 1e-9 * level, "no cross force",
                                       force[i], 0.0);
  }
}

}  // namespace


int main() {
  std::mt19937_64 rng(7);
  const struct {
    Law law;
    double alpha, sigma1, viscous, static_ratio;
    const char* name;
  } cases[] = {
      {Law::kDahl, 1.0, 0, 0, 1, "dahl"},
      {Law::kDahl, 0.5, 0, 0, 1, "dahl alpha 0.5"},
      {Law::kDahl, 2.0, 0, 0, 1, "dahl alpha 2"},
      {Law::kLuGre, 1.0, 0, 0, 1, "lugre"},
      {Law::kLuGre, 1.0, 3e3, 20, 1.0, "lugre damped"},
      {Law::kLuGre, 1.0, 0, 0, 1.5, "lugre Stribeck"},
      {Law::kDahl, 1.0, 3e3, 20, 1.5, "dahl damped, Stribeck"},
      {Law::kDupont, 1.0, 0, 0, 1, "dupont"},
      {Law::kDupont, 1.0, 0, 5, 1.3, "dupont viscous, Stribeck"},
  };
  for (const auto& c : cases) {
    LawParameters p = Parameters(c.law, c.alpha);
    p.bristle_damping = c.sigma1;
    p.viscous = c.viscous;
    p.static_ratio = c.static_ratio;
    CheckLaw<2>(p, rng, c.name);
    CheckLaw<3>(p, rng, c.name);
    if (c.viscous == 0 && c.static_ratio == 1 && c.alpha <= 1) {  // (alpha 2 saturates slowly)
      CheckRigidLimit<2>(p, c.name);
      CheckRigidLimit<3>(p, c.name);
    }
  }
  // No level (mu 0, or no load): no deflection, the force sigma2 w, finite
  for (double viscous : {0.0, 5.0}) {
    LawParameters p = Parameters(Law::kLuGre);
    p.friction_coefficient = 0.0;
    p.viscous = viscous;
    const double B[4] = {1e-3, 0.0, 0.0, 1e-3}, z[2] = {0.0, 0.0};
    for (double v : {0.0, 0.3}) {
      const double v_free[2] = {v, 0.0};
      double force[2], w[2], after[2];
      VectorImplicitDeflectionForce<2>(p, Input(9.81), z, v_free, B, 1e-3, force, w, after);
      const double expect_w = v / (1 + viscous * 1e-3);
      Expect(std::fabs(w[0] - expect_w) <= 1e-12 * (v + 1e-300) + 1e-300, "no level: w", w[0],
             expect_w);
      Expect(std::fabs(force[0] - viscous * expect_w) <= 1e-9 * (viscous * v) + 1e-300,
             "no level: F = sigma2 w", force[0], viscous * expect_w);
      Expect(std::isfinite(force[1]) && std::isfinite(w[1]), "no level: finite", force[1], 0.0);
    }
  }
  // gms in the plane: the residual with the elements advanced from their state
  {
    LawParameters p = Parameters(Law::kGms);
    const double stiffness[3] = {4e7, 2e7, 1e7};
    MakeGmsElements(stiffness, nullptr, 3, 0.0, &p.gms);
    const double dt = 1e-3, load = 9.81, level = 0.2 * load;
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_real_distribution<double> log_unit(0.0, 1.0);
    double worst = 0.0;
    for (int trial = 0; trial < 3000; ++trial) {
      const double resolution = std::pow(10.0, -2.0 + 8.0 * log_unit(rng));
      double B[4];
      RandomResponse<2>(rng, resolution / (7e7 * dt), 10.0, B);
      double z[6], slipping[3] = {0, 0, 0}, v_free[2];
      for (int i = 0; i < 3; ++i) {
        const double limit = level / 3 / stiffness[i];
        z[2 * i] = limit * 0.5 * unit(rng);
        z[2 * i + 1] = limit * 0.5 * unit(rng);
      }
      const double v_size = std::pow(10.0, -8.0 + 9.0 * log_unit(rng));
      for (double& v : v_free) v = v_size * unit(rng);
      double force[2], w[2], after[6], after_flags[3];
      GmsImplicitDeflectionForce<2>(p, Input(load), z, slipping, v_free, B, dt, force, w, after,
                                    after_flags);
      double next[6], flags[3] = {0, 0, 0}, f[2];
      for (int i = 0; i < 6; ++i) next[i] = z[i];
      AdvanceGms<2>(p, Input(load), w, next, flags, dt);
      GmsElementForce<2>(p, next, f);
      double r[2];
      for (int i = 0; i < 2; ++i) r[i] = w[i] + B[2 * i] * f[0] + B[2 * i + 1] * f[1] - v_free[i];
      const double error = Norm<2>(r) / (Norm<2>(v_free) + level / 7e7 / dt);
      if (error > worst) worst = error;
      Expect(error < 1e-8, "gms residual", error, 0.0);
    }
    std::printf("gms N=2: worst relative residual %.3g\n", worst);
  }
  // LargestEigenvalue
  {
    const double A2[4] = {3.0, 1.0, 1.0, 3.0};
    Expect(std::fabs(LargestEigenvalue<2>(A2) - 4.0) < 1e-14, "eigenvalue 2x2", LargestEigenvalue<2>(A2), 4.0);
    const double A3[9] = {2.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 1.0};
    Expect(std::fabs(LargestEigenvalue<3>(A3) - 5.0) < 1e-13, "eigenvalue 3x3 diagonal", LargestEigenvalue<3>(A3), 5.0);
    // [[2,1,0],[1,2,1],[0,1,2]]: 2 + sqrt 2
    const double A4[9] = {2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0};
    Expect(std::fabs(LargestEigenvalue<3>(A4) - (2.0 + std::sqrt(2.0))) < 1e-13, "eigenvalue 3x3",
           LargestEigenvalue<3>(A4), 2.0 + std::sqrt(2.0));
    const double A5[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    Expect(std::fabs(LargestEigenvalue<3>(A5) - 1.0) < 1e-15, "eigenvalue identity", LargestEigenvalue<3>(A5), 1.0);
  }
  if (failures) std::printf("%d checks failed\n", failures);
  return failures ? 1 : 0;
}
