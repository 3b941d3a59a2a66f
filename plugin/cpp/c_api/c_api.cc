#include "c_api/c_api.h"

#include <cmath>

#include <mujoco/mujoco.h>

#include "laws/friction_law.h"

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
  p.contact_play = c.contact_play;
  return p;
}

// The C lists, checked as the config reader checks them (MakeGmsElements, MakeLevelMap).
bool SetLawLists(const vf_law_lists* lists, LawParameters* p) {
  if (!lists) return true;
  const int count = lists->gms_count;
  if (count < 0) return false;
  if (count > 0) {
    if (!lists->gms_stiffness || !lists->gms_weight) return false;
    if (!MakeGmsElements(lists->gms_stiffness, lists->gms_weight, count,
                         lists->gms_relaxation_time, &p->gms).ok()) {
      return false;
    }
  }
  const struct {
    const double* knots;
    const double* factors;
    int count;
    double period;
    bool nonnegative_knots;
    LevelMap* map;
  } maps[] = {
      {lists->position_map_knots, lists->position_map_factors, lists->position_map_count,
       lists->position_map_period, false, &p->position_map},
      {lists->velocity_map_knots, lists->velocity_map_factors, lists->velocity_map_count, 0.0,
       true, &p->velocity_map},
      {lists->time_map_knots, lists->time_map_factors, lists->time_map_count, 0.0, true,
       &p->time_map},
  };
  for (const auto& map : maps) {
    if (map.count > 0 && (!map.knots || !map.factors)) return false;
    if (!MakeLevelMap(map.knots, map.factors, map.count, map.period, map.nonnegative_knots,
                      map.map).ok()) {
      return false;
    }
  }
  return true;
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

// A play needs the bristles of dahl, dupont or lugre (the config reader's rule).
bool PlayValid(const vf_law_parameters& c) {
  if (!(c.contact_play >= 0)) return false;
  return c.contact_play == 0 ||
         vibrofriction::TakesContactPlay(static_cast<vibrofriction::Law>(c.law));
}

}  // namespace

extern "C" {

int vf_api_version(void) { return 4; }

int vf_mujoco_header_version(void) { return mjVERSION_HEADER; }

int vf_run_law(const vf_law_parameters* params, int n, const double* time,
               const double* velocity, const double* position, const double* normal_force,
               double z0, double* force_out, double* deflection_out) {
  if (!params || n < 0 || !time || !velocity || !force_out || !deflection_out) return -1;
  if (params->law < 0 || params->law > 3) return -1;  // (gms: vf_run_law_with_lists)
  if (!PlayValid(*params)) return -1;
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
  if (!PlayValid(*params)) return -1;
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
