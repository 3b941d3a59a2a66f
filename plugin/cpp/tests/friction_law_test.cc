// The friction laws (friction_law.h) against their closed forms and limits: Dahl's deflection at
// constant velocity (alpha = 1: z_c (1 - exp(-v t / z_c))), never past the steady deflection for
// any alpha; LuGre's steady force, the Stribeck curve g(v) + sigma2 v; the Stribeck level's ends;
// Coulomb's stick/slip decision; the vector laws equal the 1D ones on one axis and turn with
// the velocity (isotropy). Exit status 0: every check held.
// sources: laws/friction_law.cc
#include <cmath>
#include <cstdio>

#include "laws/friction_law.h"

using namespace vibrofriction;

namespace {

int failures = 0;

void ExpectNear(double got, double want, double tolerance, const char* what) {
  if (!(std::fabs(got - want) <= tolerance)) {
    ++failures;
    std::printf("FAILED %s: %.15g, want %.15g (tolerance %.3g)\n", what, got, want, tolerance);
  }
}

LawParameters Parameters(vibrofriction::Law law) {
  LawParameters p;
  p.law = law;
  p.friction_coefficient = 0.2;
  p.contact_stiffness = 2e6;
  p.alpha = 1.0;
  return p;
}

LawInput Input(double velocity, double normal_force = 50.0) {
  LawInput in;
  in.velocity = velocity;
  in.normal_force = normal_force;
  return in;
}

}  // namespace

int main() {
  // Dahl, alpha = 1, constant velocity from rest: z(t) = z_c (1 - exp(-v t / z_c)).
  {
    const LawParameters p = Parameters(Law::kDahl);
    const double v = 3e-3, z_c = p.friction_coefficient * 50.0 / p.contact_stiffness;
    double z = 0.0;
    const double dt = 1e-4;
    for (int k = 1; k <= 200; ++k) {
      z = AdvanceDeflection(p, Input(v), z, dt);
      const double exact = z_c * (1 - std::exp(-v * k * dt / z_c));
      ExpectNear(z, exact, 1e-12 * z_c, "Dahl alpha 1: z(t) at constant velocity");
    }
    // one long step lands on the same curve (the advance is exact, not stepped)
    ExpectNear(AdvanceDeflection(p, Input(v), 0.0, 200 * dt), z_c * (1 - std::exp(-v * 0.02 / z_c)),
               1e-12 * z_c, "Dahl alpha 1: one step of 200 dt");
    ExpectNear(StateForce(p, Input(v), z), p.contact_stiffness * z, 1e-9, "Dahl: F = k_t z");
  }
  // Dahl, any alpha: with u = z / z_c, du/dx = (1 - u)^alpha for motion x forward, so
  // (1 - u)^(1 - alpha) = (1 - u0)^(1 - alpha) + (alpha - 1) x / z_c (alpha != 1; for alpha < 1
  // u reaches 1 at a finite x and stays). Steps of any size land on it and never pass z_c.
  for (double alpha : {0.5, 1.5, 2.5}) {
    LawParameters p = Parameters(Law::kDahl);
    p.alpha = alpha;
    const double v = 2e-3, z_c = p.friction_coefficient * 50.0 / p.contact_stiffness;
    const double u0 = -0.9;
    double z = u0 * z_c, previous = z, x = 0.0;
    for (double dt : {1e-6, 1e-5, 1e-4, 1e-3, 1e-2}) {
      z = AdvanceDeflection(p, Input(v), z, dt);
      x += v * dt;
      const double power = std::pow(1 - u0, 1 - alpha) + (alpha - 1) * x / z_c;
      const double exact = power <= 0 ? z_c : z_c * (1 - std::pow(power, 1 / (1 - alpha)));
      ExpectNear(z, exact, 1e-9 * z_c, "Dahl: z(x) for alpha != 1");
      if (!(z >= previous && z <= z_c * (1 + 1e-12))) {
        ++failures;
        std::printf("FAILED Dahl alpha %g: z %.15g after %.15g (z_c %.15g)\n", alpha, z,
                    previous, z_c);
      }
      previous = z;
    }
  }
  // LuGre at constant velocity settles on the Stribeck curve: F = g(v) + sigma2 v.
  {
    LawParameters p = Parameters(Law::kLuGre);
    p.static_ratio = 1.4;
    p.stribeck_velocity = 2e-3;
    p.bristle_damping = 300.0;
    p.viscous = 40.0;
    for (double v : {-5e-3, -1e-3, 5e-4, 2e-3, 8e-3}) {
      const double z = AdvanceDeflection(p, Input(v), 0.0, 10.0);
      const double g = StribeckLevel(p, Input(v));
      ExpectNear(StateForce(p, Input(v), z), std::copysign(g, v) + p.viscous * v,
                 1e-9 * g, "LuGre steady force g(v) sgn v + sigma2 v");
    }
    ExpectNear(StribeckLevel(p, Input(0.0)), 1.4 * 0.2 * 50.0, 1e-12, "g(0) = F_s");
    ExpectNear(StribeckLevel(p, Input(1.0)), 0.2 * 50.0, 1e-12, "g(v >> v_s) = F_c");
    ExpectNear(StribeckLevel(p, Input(-2e-3)), 10.0 * (1 + 0.4 * std::exp(-1.0)), 1e-12,
               "g(v_s) = F_c (1 + (F_s/F_c - 1) / e)");
  }
  // Coulomb: sticks within the static level, else slides at the kinetic level, sign of the pull.
  {
    LawParameters p = Parameters(Law::kCoulomb);
    p.static_ratio = 1.2;
    ExpectNear(StickSlipForce(p, Input(0.0), 11.0), 11.0, 0.0, "Coulomb sticks below F_s = 12");
    // sliding at the Stribeck level of the current speed: g(0) = F_s from rest, F_c when fast
    ExpectNear(StickSlipForce(p, Input(0.0), -13.0), -12.0, 1e-12, "Coulomb slides at g(0)");
    ExpectNear(StickSlipForce(p, Input(-1.0), -13.0), -10.0, 1e-12, "Coulomb slides at F_c");
  }
  // Vector laws: on one axis they are the 1D laws; rotated inputs give rotated forces.
  for (vibrofriction::Law law : {Law::kDahl, Law::kLuGre, Law::kDupont}) {
    LawParameters p = Parameters(law);
    p.alpha = 1.7;
    p.bristle_damping = 100.0;
    const double v1 = 1.5e-3, z1 = 2e-6;
    const double f1 = StateForce(p, Input(v1), z1);
    const double v[2] = {v1, 0.0}, z[2] = {z1, 0.0};
    double f[2];
    PlanarStateForce(p, Input(std::fabs(v1)), v, z, f);
    ExpectNear(f[0], f1, 1e-9 * std::fabs(f1), "vector force on one axis = 1D force");
    ExpectNear(f[1], 0.0, 1e-12, "vector force: nothing across");
    double z_next[2] = {z[0], z[1]};
    AdvancePlanarDeflection(p, Input(std::fabs(v1)), v, z_next, 1e-3);
    ExpectNear(z_next[0], AdvanceDeflection(p, Input(v1), z1, 1e-3), 1e-12 * 1e-5,
               "vector advance on one axis = 1D advance");
    const double c = std::cos(0.7), s = std::sin(0.7);
    const double vr[2] = {c * v[0], s * v[0]}, zr[2] = {c * z[0], s * z[0]};
    double fr[2];
    PlanarStateForce(p, Input(std::fabs(v1)), vr, zr, fr);
    ExpectNear(fr[0], c * f[0], 1e-9 * std::fabs(f1), "isotropy: rotated force, x");
    ExpectNear(fr[1], s * f[0], 1e-9 * std::fabs(f1), "isotropy: rotated force, y");
  }
  // A play: a step in which the contact closes, opens or does both carries the step's mean
  // force. With an infinite mass (the velocity held, dt_inverse_mass 0) that mean is known:
  // the force along the law's exact path, averaged over many short steps. Checked for every
  // law with the bristle damping and viscous term (the force jumps at a closing) from inside
  // the play, from a loaded face (opening), across the whole play within one step, and
  // loading far beyond the level's deflection (LuGre exact; Dahl alpha 0.6 and Dupont by
  // Simpson's rule on quarter-deflection panels: 3e-5 of the level at most, measured).
  for (const Law law : {Law::kDahl, Law::kLuGre, Law::kDupont}) {
    LawParameters p = Parameters(law);
    p.alpha = law == Law::kDahl ? 0.6 : 1.0;
    p.bristle_damping = 300.0;
    p.viscous = 20.0;
    p.force_offset = 0.4;
    p.contact_play = 4e-6;
    const double level = p.friction_coefficient * 50.0;  // 10 N, z_c 5 um
    struct Case {
      double z, v, dt;
      const char* what;
    } cases[] = {
        {1.0e-6, 1e-3, 2e-3, "closing from inside the play"},
        {-1.9e-6, -2e-3, 1e-3, "closing right after the start"},
        {2e-6 + 3e-6, -1e-3, 4e-3, "unloading until the play opens"},
        {2e-6 + 3e-6, -5e-3, 2e-3, "unloading, crossing the play and loading the other face"},
        {-1.9e-6, 5e-3, 1e-2, "closing, then loading over 9 level deflections"},
    };
    for (const Case& c : cases) {
      const LawInput in = Input(c.v);
      const double step_force = ImplicitStateForce(p, in, c.z, c.v, 0.0, c.dt);
      const int fine = 200000;
      double z = c.z, impulse = 0.0;
      for (int i = 0; i < fine; ++i) {  // the force at each short step's middle
        const double h = c.dt / fine;
        const double middle = AdvanceDeflection(p, in, z, 0.5 * h);
        impulse += StateForce(p, in, middle) * h;
        z = AdvanceDeflection(p, in, z, h);
      }
      ExpectNear(step_force, impulse / c.dt, 1e-4 * level, c.what);
    }
    // A step closed throughout is the law's force at its start (as without a play), also
    // with the bristles beyond their steady deflection, where the damping pulls back.
    p.static_ratio = 2.0;
    p.stribeck_velocity = 1e-3;
    for (const double beyond : {0.5, 1.0, 1.8}) {
      const LawInput in = Input(4e-3);
      const double z = 2e-6 + beyond * StribeckLevel(p, in) / p.contact_stiffness;
      ExpectNear(ImplicitStateForce(p, in, z, 4e-3, 0.0, 1e-6), StateForce(p, in, z),
                 1e-9 * level, "closed throughout: the force at the start");
    }
    // A step too long for the bristles to follow (the start's elastic force alone would turn
    // the velocity): taken as it stands, the friction against the loaded face's direction --
    // not a path walked the other way, which loaded the far face and pushed the body along.
    p.static_ratio = 1.0;
    p.bristle_damping = 0.0;
    p.viscous = 0.0;
    const double z_loaded = 2e-6 + 10.0 / p.contact_stiffness;
    const double f = ImplicitStateForce(p, Input(5e-4), z_loaded, -0.0145, 2e-3, 1e-3);
    ExpectNear(f, p.contact_stiffness * (z_loaded - 2e-6) + p.force_offset, 1e-9 * level,
               "an under-resolved step: the loaded face's force");
  }
  std::printf("%s: %d failures\n", __FILE__, failures);
  return failures == 0 ? 0 : 1;
}
