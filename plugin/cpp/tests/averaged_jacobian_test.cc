// The averaged force's exact Jacobian (AveragedVectorForceJacobian) against central differences
// of AveragedVectorForce, on a random table with the across part zero along the axis (as a
// symmetric law's): off the axis to the differences' own error; along it, in the pure along and
// pure across directions (between them the along part has a kink, which the Jacobian takes flat).
// Exit status 0: every check held.
// sources: plugins/averaged_friction.cc plugins/planar_friction.cc laws/friction_law.cc common/plugin_util.cc common/element_config.cc c_api/c_api.cc
#include <cmath>
#include <cstdio>
#include <random>

#include "plugins/averaged_friction.h"

using namespace vibrofriction;

namespace {

int failures = 0;

void Expect(bool ok, const char* what, double got, double want) {
  if (!ok) {
    ++failures;
    std::printf("FAILED %s: %.9g, want %.9g\n", what, got, want);
  }
}

}  // namespace

int main() {
  AveragedTable table;
  for (int i = 0; i < 9; ++i) table.xi.push_back(0.25 * i);
  for (int j = 0; j < 7; ++j) table.angle.push_back(kPi / 6 * j);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (size_t k = 0; k < table.xi.size() * table.angle.size(); ++k) {
    table.along.push_back(uniform(rng));
    table.across.push_back(k % 7 == 0 || k % 7 == 6 ? 0.0 : uniform(rng));
  }
  LawParameters law;
  law.friction_coefficient = 0.3;
  law.viscous = 0.7;
  const double axis[3] = {0.6, 0.8, 0.0}, normal = 10.0, amplitude = 0.02, h = 1e-9;
  auto force = [&](const double u[3], double f[3]) {
    AveragedVectorForce<3>(table, law, axis, u, normal, amplitude, f);
  };
  // directional derivative by central differences
  auto difference = [&](const double u[3], const double d[3], double out[3]) {
    double up[3], um[3], fp[3], fm[3];
    for (int i = 0; i < 3; ++i) {
      up[i] = u[i] + h * d[i];
      um[i] = u[i] - h * d[i];
    }
    force(up, fp);
    force(um, fm);
    for (int i = 0; i < 3; ++i) out[i] = (fp[i] - fm[i]) / (2 * h);
  };
  for (int trial = 0; trial < 400; ++trial) {
    const bool on_axis = trial % 4 == 0;
    double u[3];
    if (on_axis) {
      const double s = 0.005 + 0.03 * std::fabs(uniform(rng));  // away from rest
      for (int i = 0; i < 3; ++i) u[i] = (trial % 8 == 0 ? s : -s) * axis[i];
    } else {
      for (double& x : u) x = 0.04 * uniform(rng);
    }
    double f[3], J[9], f0[3];
    if (!AveragedVectorForceJacobian<3>(table, law, axis, u, normal, amplitude, f, J)) {
      Expect(false, "a Jacobian away from rest", 0, 1);
      continue;
    }
    force(u, f0);
    for (int i = 0; i < 3; ++i) Expect(std::fabs(f[i] - f0[i]) <= 1e-12, "the force", f[i], f0[i]);
    // along the axis: the pure directions (along, across in the plane, spin); off it: x, y, z
    const double along_axis[3][3] = {{0.6, 0.8, 0.0}, {-0.8, 0.6, 0.0}, {0.0, 0.0, 1.0}};
    const double unit[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int k = 0; k < 3; ++k) {
      const double* d = on_axis ? along_axis[k] : unit[k];
      double fd[3];
      difference(u, d, fd);
      for (int i = 0; i < 3; ++i) {
        double analytic = 0.0;
        for (int j = 0; j < 3; ++j) analytic += J[3 * i + j] * d[j];
        Expect(std::fabs(analytic - fd[i]) <= 1e-5 * (1.0 + std::fabs(fd[i])),
               on_axis ? "dF/du along the axis" : "dF/du off the axis", analytic, fd[i]);
      }
    }
  }
  // at rest the direction is undefined: the caller differentiates numerically
  const double rest[3] = {0, 0, 0};
  double f[3], J[9];
  Expect(!AveragedVectorForceJacobian<3>(table, law, axis, rest, normal, amplitude, f, J),
         "no Jacobian at rest", 1, 0);
  std::printf("%s: %d failures\n", __FILE__, failures);
  return failures == 0 ? 0 : 1;
}
