#include "c_api.h"

#include <cmath>

#include <mujoco/mujoco.h>

#include "friction_law.h"

namespace vibrofriction {

LawParameters LawFromStruct(const vf_law_parameters& c) {
  LawParameters p;
  p.law = static_cast<Law>(c.law);
  p.friction_coefficient = c.friction_coefficient;
  p.normal_force = c.normal_force;
  p.contact_stiffness = c.contact_stiffness;
  p.alpha = c.alpha;
  p.breakaway_ratio = c.breakaway_ratio;
  p.bristle_damping = c.bristle_damping;
  p.viscous = c.viscous;
  p.static_ratio = c.static_ratio;
  p.stribeck_velocity = c.stribeck_velocity;
  p.asymmetry = c.asymmetry;
  p.ripple = c.ripple;
  p.ripple_wavelength = c.ripple_wavelength;
  p.ripple_phase = c.ripple_phase;
  p.normal_modulation = c.normal_modulation;
  p.normal_modulation_frequency = c.normal_modulation_frequency;
  p.normal_modulation_phase = c.normal_modulation_phase;
  p.force_offset = c.force_offset;
  return p;
}

}  // namespace vibrofriction

namespace {

vibrofriction::LawInput InputAt(const vibrofriction::LawParameters& p, int i, const double* time,
                                const double* velocity, const double* position,
                                const double* normal_force) {
  vibrofriction::LawInput in;
  in.velocity = velocity[i];
  in.time = time[i];
  in.position = position ? position[i] : 0.0;
  in.normal_force = normal_force ? normal_force[i] : p.normal_force;
  return in;
}

}  // namespace

extern "C" {

int vf_api_version(void) { return 2; }

int vf_mujoco_header_version(void) { return mjVERSION_HEADER; }

int vf_run_law(const vf_law_parameters* params, int n, const double* time,
               const double* velocity, const double* position, const double* normal_force,
               double z0, double* force_out, double* deflection_out) {
  if (!params || n < 0 || !time || !velocity || !force_out || !deflection_out) return -1;
  if (params->law < 0 || params->law > 3) return -1;
  const vibrofriction::LawParameters p = vibrofriction::LawFromStruct(*params);
  double z = vibrofriction::HasDeflection(p.law) ? z0 : 0.0;
  for (int i = 0; i < n; ++i) {
    const vibrofriction::LawInput in = InputAt(p, i, time, velocity, position, normal_force);
    deflection_out[i] = z;
    force_out[i] = vibrofriction::HasDeflection(p.law)
                       ? vibrofriction::StateForce(p, in, z)
                       : vibrofriction::KinematicCoulombForce(p, in);
    if (i + 1 < n) {
      const vibrofriction::LawInput next = InputAt(p, i + 1, time, velocity, position, normal_force);
      z = vibrofriction::AdvanceDeflection(p, next, z, time[i + 1] - time[i]);
    }
  }
  return 0;
}

int vf_run_gms_law(const vf_law_parameters* params, int count, const double* stiffness,
                   const double* weight, double relaxation_time, int n, const double* time,
                   const double* velocity, const double* position, const double* normal_force,
                   const double* z0, double* force_out, double* deflection_out) {
  using vibrofriction::kMaxGmsElements;
  if (!params || params->law != 4 || count < 1 || count > kMaxGmsElements || !stiffness ||
      !weight || !(relaxation_time >= 0) || n < 0 || !time || !velocity || !force_out ||
      !deflection_out) {
    return -1;
  }
  vibrofriction::LawParameters p = vibrofriction::LawFromStruct(*params);
  p.gms.count = count;
  double total = 0.0;
  for (int i = 0; i < count; ++i) {
    if (!(stiffness[i] > 0) || !(weight[i] > 0)) return -1;
    p.gms.stiffness[i] = stiffness[i];
    p.gms.weight[i] = weight[i];
    total += weight[i];
  }
  if (!(std::fabs(total - 1.0) <= 1e-6)) return -1;
  p.gms.relaxation_time = relaxation_time;
  double z[kMaxGmsElements] = {}, slipping[kMaxGmsElements] = {};
  for (int i = 0; i < count; ++i) z[i] = z0 ? z0[i] : 0.0;
  for (int i = 0; i < n; ++i) {
    for (int e = 0; e < count; ++e) deflection_out[i * count + e] = z[e];
    double elements = 0.0;
    vibrofriction::GmsElementForce<1>(p, z, &elements);
    force_out[i] = elements + p.viscous * velocity[i] + p.force_offset;
    if (i + 1 < n) {
      const vibrofriction::LawInput next = InputAt(p, i + 1, time, velocity, position, normal_force);
      vibrofriction::AdvanceGms<1>(p, next, &next.velocity, z, slipping, time[i + 1] - time[i]);
    }
  }
  return 0;
}

}  // extern "C"
