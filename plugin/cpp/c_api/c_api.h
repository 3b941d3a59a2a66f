// C API of the friction laws for Python (ctypes): the same code the MuJoCo plugin runs, driven
// along a recorded or prescribed relative-velocity history (identification, kinematic limits,
// hysteresis plots). Keep the struct layout in sync with vibrofriction/laws/_native.py.
#ifndef VIBROFRICTION_C_API_H_
#define VIBROFRICTION_C_API_H_

// The library hides its symbols (CMakeLists.txt); the C API is what ctypes must find.
#if defined(_WIN32)
#define VF_EXPORT __declspec(dllexport)
#else
#define VF_EXPORT __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vf_law_parameters {
  int law;  // 0 coulomb, 1 dahl, 2 dupont, 3 lugre (4 gms: vf_run_law_with_lists)
  // (contact_play > 0: dahl, dupont and lugre only)
  double friction_coefficient, normal_force, contact_stiffness, alpha, breakaway_ratio,
      bristle_damping, viscous, static_ratio, stribeck_velocity, asymmetry, ripple,
      ripple_wavelength, ripple_phase, normal_modulation, normal_modulation_frequency,
      normal_modulation_phase, force_offset, contact_play;
} vf_law_parameters;

// Version of this C API (bump on any layout change) and the MuJoCo header it was built with.
VF_EXPORT int vf_api_version(void);
VF_EXPORT int vf_mujoco_header_version(void);

// Runs the law along samples i = 0..n-1. Force i uses (z_i, v_i); z_{i+1} advances z_i over
// [t_i, t_{i+1}] with the input at t_{i+1}, as the plugin does (force with the old state, update
// with the new velocity). position and normal_force may be NULL (0 and the constant normal).
// Writes force_out[n] (N) and deflection_out[n] (m). Returns 0, or -1 on bad arguments.
VF_EXPORT int vf_run_law(const vf_law_parameters* params, int n, const double* time,
               const double* velocity, const double* position, const double* normal_force,
               double z0, double* force_out, double* deflection_out);

// The list-valued parameters (NULL pointers with count 0: off): law gms's elements, and the
// level maps over the relative position, the speed and the time (friction_law.h, LevelMap).
typedef struct vf_law_lists {
  int gms_count;  // 1 to 16 for law gms (params->law 4), else 0
  const double* gms_stiffness;  // [gms_count] N/m, > 0
  const double* gms_weight;     // [gms_count] > 0, summing to 1
  double gms_relaxation_time;   // s, >= 0
  int position_map_count;       // 0 to 16
  const double* position_map_knots;    // m, increasing
  const double* position_map_factors;  // > -1
  double position_map_period;          // m, 0: not periodic
  int velocity_map_count;       // 0 to 16
  const double* velocity_map_knots;    // m/s, >= 0, increasing
  const double* velocity_map_factors;  // > -1
  int time_map_count;           // 0 to 16
  const double* time_map_knots;        // s (the samples' time), >= 0, increasing
  const double* time_map_factors;      // > -1
} vf_law_lists;

// vf_run_law with the list-valued parameters (`lists` may be NULL: none). z0 holds one
// deflection per gms element (gms) or one (the other laws); NULL: 0; gms elements start stuck.
// deflection_out holds n * max(1, gms_count) values, sample-major. Returns 0, or -1 on bad
// arguments (a bad list included).
VF_EXPORT int vf_run_law_with_lists(const vf_law_parameters* params, const vf_law_lists* lists,
                                    int n, const double* time, const double* velocity,
                                    const double* position, const double* normal_force,
                                    const double* z0, double* force_out, double* deflection_out);

// The planar law (plugins/planar_friction.cc) along a prescribed velocity history, same step
// order as vf_run_law. Coulomb is kinematic (no stick solve). Effects other than the normal-load
// modulation must be 0, and so must contact_play. normal_force may be NULL. Writes fx, fy (N)
// and zx, zy (m) [n].
// Returns 0, or -1 on bad arguments.
VF_EXPORT int vf_run_planar_law(const vf_law_parameters* params, int n, const double* time,
                                const double* vx, const double* vy, const double* normal_force,
                                double z0x, double z0y, double* fx, double* fy, double* zx,
                                double* zy);

#ifdef __cplusplus
}

namespace vibrofriction {
struct LawParameters;
// The law's parameters from the C struct: every field (one copy, c_api.cc).
LawParameters LawFromStruct(const vf_law_parameters& c);
// Sets the list-valued parameters from `lists` (NULL: none); false when a list is invalid.
bool SetLawLists(const vf_law_lists* lists, LawParameters* p);
}  // namespace vibrofriction
#endif

#endif  // VIBROFRICTION_C_API_H_
