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

namespace {

// A map from the C lists, checked as the config reader checks it (element_config.cc).
bool SetMap(int count, const double* knots, const double* factors, double period,
            bool nonnegative_knots, LevelMap* map) {
  if (count < 0 || count > kMaxMapKnots || (count > 0 && (!knots || !factors))) return false;
  if (!(period >= 0)) return false;
  map->count = count;
  map->period = period;
  for (int i = 0; i < count; ++i) {
    if (!(factors[i] > -1) || !std::isfinite(knots[i]) || !std::isfinite(factors[i])) {
      return false;
    }
    if (nonnegative_knots && knots[i] < 0) return false;
    map->knot[i] = knots[i];
    map->factor[i] = factors[i];
  }
  return map->SetUp();
}

}  // namespace

bool SetLawLists(const vf_law_lists* lists, LawParameters* p) {
  if (!lists) return true;
  const int count = lists->gms_count;
  if (count < 0 || count > kMaxGmsElements) return false;
  if (count > 0) {
    if (!lists->gms_stiffness || !lists->gms_weight || !(lists->gms_relaxation_time >= 0)) {
      return false;
    }
    double total = 0.0;
    for (int i = 0; i < count; ++i) {
      if (!(lists->gms_stiffness[i] > 0) || !(lists->gms_weight[i] > 0)) return false;
      p->gms.stiffness[i] = lists->gms_stiffness[i];
      p->gms.weight[i] = lists->gms_weight[i];
      total += lists->gms_weight[i];
    }
    if (!(std::fabs(total - 1.0) <= 1e-6)) return false;
    for (int i = 0; i < count; ++i) p->gms.weight[i] /= total;  // as the config reader: 1 in all
    p->gms.count = count;
    p->gms.relaxation_time = lists->gms_relaxation_time;
  }
  return SetMap(lists->position_map_count, lists->position_map_knots,
                lists->position_map_factors, lists->position_map_period, false,
                &p->position_map) &&
         SetMap(lists->velocity_map_count, lists->velocity_map_knots,
                lists->velocity_map_factors, 0.0, true, &p->velocity_map);
}

}  // namespace vibrofriction

namespace {

using vibrofriction::LawInput;
using vibrofriction::LawParameters;

LawInput InputAt(const LawParameters& p, int i, const double* time, const double* velocity,
                 const double* position, const double* normal_force) {
  LawInput in;
  in.velocity = velocity[i];
  in.time = time[i];
  in.position = position ? position[i] : 0.0;
  in.normal_force = normal_force ? normal_force[i] : p.normal_force;
  return in;
}

// The one-state laws (and Coulomb) along the samples: the plugin's step order.
void RunOneState(const LawParameters& p, int n, const double* time, const double* velocity,
                 const double* position, const double* normal_force, double z0,
                 double* force_out, double* deflection_out) {
  double z = vibrofriction::HasDeflection(p.law) ? z0 : 0.0;
  for (int i = 0; i < n; ++i) {
    const LawInput in = InputAt(p, i, time, velocity, position, normal_force);
    deflection_out[i] = z;
    force_out[i] = vibrofriction::HasDeflection(p.law)
                       ? vibrofriction::StateForce(p, in, z)
                       : vibrofriction::KinematicCoulombForce(p, in);
    if (i + 1 < n) {
      const LawInput next = InputAt(p, i + 1, time, velocity, position, normal_force);
      z = vibrofriction::AdvanceDeflection(p, next, z, time[i + 1] - time[i]);
    }
  }
}

// Law gms along the samples: deflection_out holds every element's, sample-major.
void RunGms(const LawParameters& p, int n, const double* time, const double* velocity,
            const double* position, const double* normal_force, const double* z0,
            double* force_out, double* deflection_out) {
  const int count = p.gms.count;
  double z[vibrofriction::kMaxGmsElements] = {}, slipping[vibrofriction::kMaxGmsElements] = {};
  for (int i = 0; i < count; ++i) z[i] = z0 ? z0[i] : 0.0;
  for (int i = 0; i < n; ++i) {
    for (int e = 0; e < count; ++e) deflection_out[i * count + e] = z[e];
    double elements = 0.0;
    vibrofriction::GmsElementForce<1>(p, z, &elements);
    force_out[i] = elements + p.viscous * velocity[i] + p.force_offset;
    if (i + 1 < n) {
      const LawInput next = InputAt(p, i + 1, time, velocity, position, normal_force);
      vibrofriction::AdvanceGms<1>(p, next, &next.velocity, z, slipping, time[i + 1] - time[i]);
    }
  }
}

}  // namespace

extern "C" {

int vf_api_version(void) { return 2; }

int vf_mujoco_header_version(void) { return mjVERSION_HEADER; }

int vf_run_law(const vf_law_parameters* params, int n, const double* time,
               const double* velocity, const double* position, const double* normal_force,
               double z0, double* force_out, double* deflection_out) {
  if (!params || n < 0 || !time || !velocity || !force_out || !deflection_out) return -1;
  if (params->law < 0 || params->law > 3) return -1;  // (gms: vf_run_law_with_lists)
  RunOneState(vibrofriction::LawFromStruct(*params), n, time, velocity, position, normal_force,
              z0, force_out, deflection_out);
  return 0;
}

int vf_run_law_with_lists(const vf_law_parameters* params, const vf_law_lists* lists, int n,
                          const double* time, const double* velocity, const double* position,
                          const double* normal_force, const double* z0, double* force_out,
                          double* deflection_out) {
  if (!params || n < 0 || !time || !velocity || !force_out || !deflection_out) return -1;
  if (params->law < 0 || params->law > 4) return -1;
  LawParameters p = vibrofriction::LawFromStruct(*params);
  if (!vibrofriction::SetLawLists(lists, &p)) return -1;
  if ((p.law == vibrofriction::Law::kGms) != (p.gms.count > 0)) return -1;
  if (p.law == vibrofriction::Law::kGms) {
    RunGms(p, n, time, velocity, position, normal_force, z0, force_out, deflection_out);
  } else {
    RunOneState(p, n, time, velocity, position, normal_force, z0 ? z0[0] : 0.0, force_out,
                deflection_out);
  }
  return 0;
}

}  // extern "C"
