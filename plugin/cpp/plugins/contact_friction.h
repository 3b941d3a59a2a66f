// Passive-force plugin "vibrofriction.contact": dynamic friction between a body and its support
// acting over MuJoCo's own contacts, for free bodies in unmodified scenes (a part on a vibrating
// plate, a conveyor, a gripper finger). Attached to the sliding body:
//   <body name="part"> <freejoint/> <plugin instance="part_friction"/> ... </body>
// with config `support` = the support body's name and the law keys of vibrofriction.planar.
//
// Each step, from the contacts between the two bodies' geoms (MuJoCo solves their normal force;
// their condim must be 1 so that MuJoCo adds no friction of its own); with config
// `support_geom` (names of the support's geoms that form the conveying surface) only the
// contacts with those, the others (walls, end stops) left to MuJoCo as ordinary contacts:
//   F_N  the summed normal force, p the force-weighted contact point, n the normal (support to
//        body), rho the torsion radius (config `torsion_radius`, or sum F_i |p_i - p| / F_N: the
//        moment arm of Coulomb point loads at the contacts);
//   u    the generalized sliding velocity (v_t, rho w_n): the body's velocity relative to the
//        support at p, tangential part (3 world components), and the relative spin about n.
// The deflection state zeta = (z_t, rho theta) follows the planar law in these four components
// (dahl, lugre, dupont; friction_law.h, VectorDeflectionRate<4>); law coulomb is rigid, with the
// stick/slip solve of the planar element over (v_t . t1, v_t . t2, rho w_n) (VectorStickSlipForce<3>,
// the response B = dt J M^-1 J' of those to the force, the other forces' acceleration taken from
// the last step). Either way the tangential force
// F_t and the moment M = rho F_s n satisfy |(F_t, M/rho)| <= g(|u|): the ellipsoidal limit
// surface of a patch (Howe & Cutkosky); a uniform-pressure disc of radius R has rho = 2R/3.
// The body receives -F_t at p and -M, the support +F_t and +M (qfrc_passive).
//
// Step order: passive forces run before the constraint solve, so compute uses the contacts of
// the previous step (kept in plugin_state by advance, which sums this step's contact forces and
// updates zeta in closed form with the new velocity). A state law's step that does not resolve
// the contact (k_t dt lambda_max(B) or (sigma1 + sigma2) lambda_max(B) >= 1, friction_law.h) is
// taken implicitly instead: the force of the deflection at the end of the step, with the
// end-of-step velocity solved as coulomb's (B and the other forces' acceleration of the last
// step), and advance keeps that deflection. Without contact F_N = 0: no force, and
// zeta resets (a part lifted off and set down starts undeflected).
#ifndef VIBROFRICTION_CONTACT_FRICTION_H_
#define VIBROFRICTION_CONTACT_FRICTION_H_

#include <vector>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"
#include "laws/friction_law.h"
#include "plugins/averaged_friction.h"

namespace vibrofriction {

struct ContactConfig {
  LawParameters law;           // averaged: rigid Coulomb, the law without vibration
  int body = -1;               // the sliding body (its <plugin instance=.../>)
  int support = -1;            // config `support`
  // The dofs that move the body or the support (their kinematic chains), each with +1 for the
  // body's, -1 for the support's; a dof in both moves them together and is left out. The
  // relative Jacobians are nonzero only there: computed and applied on them alone, they cost the
  // same in a model of any size (the response B of coulomb and the averaged laws still solves
  // with M over the whole model).
  std::vector<int> chain_dofs;
  std::vector<double> chain_signs;
  double torsion_radius = 0;   // m; 0: from the contact points
  // config `support_geom`: per geom of the model, 1 for the support's geoms that form the
  // conveying surface; empty (the key not given): every geom of the support
  std::vector<unsigned char> surface;
  bool OnSurface(int geom) const { return surface.empty() || surface[geom]; }
  // vibrofriction.contact_averaged: the averaged law's table, for this vibration
  bool averaged = false;
  AveragedTable table;
  double velocity_amplitude = 0;            // v_a (m/s) the table was made for; 0: none
  double axis_local[3] = {1.0, 0.0, 0.0};   // vibration direction in the support's frame
  // vibrofriction.contact_feeder: the feeder map along the axis' in-plane part (the conveying
  // direction): the part's mean velocity relative to the support (m/s, increasing; a repeated
  // value bounds a static band) and the mean friction on it over F_N there (non-increasing),
  // from vibrofriction.robots.feeder_map
  bool feeder = false;
  std::vector<double> map_velocity, map_force;
  // config `helix_pitch` (m, the rise per turn counter-clockwise about the support's z axis;
  // 0: off): a bowl feeder's spiral track, conveying along the helix's tangent at the contact
  // point (HelixTangent) instead of along `axis`
  double helix_pitch = 0.0;

  static bool FromModel(const mjModel* m, int instance, ContactConfig* config,
                        ReadScope scope = ReadScope::kAll);
  static bool FromModelAveraged(const mjModel* m, int instance, ContactConfig* config,
                                ReadScope scope = ReadScope::kAll);
  static bool FromModelFeeder(const mjModel* m, int instance, ContactConfig* config,
                              ReadScope scope = ReadScope::kAll);

 private:
  // support, support_geom, torsion_radius, the body, and the geoms' condim (shared by the three
  // plugins).
  bool ReadPair(const mjModel* m, int instance, const char* plugin, ReadScope scope);
  // `axis` (default "1 0 0"), normalized into axis_local.
  bool ReadAxis(const mjModel* m, int instance, const char* plugin);
};

// plugin_state layout of one instance.
struct ContactState {
  static constexpr int kDeflection = 0;  // z_t, 3 world components (m)
  static constexpr int kTwist = 3;       // theta, the spin deflection (rad)
  static constexpr int kNormalForce = 4; // F_N (N)
  static constexpr int kPoint = 5;       // p, 3 (m)
  static constexpr int kNormal = 8;      // n, 3
  static constexpr int kRadius = 11;     // rho (m)
  // the last step's acceleration of u from every force but the element's, 4 (as u): v_free of
  // the implicit steps (coulomb, the averaged laws, the state laws at unresolved steps)
  static constexpr int kOtherAcceleration = 12;
  static constexpr int kSize = 16;
};

class ContactFriction {
 public:
  static constexpr char kName[] = "vibrofriction.contact";
  // vibrofriction.contact_sensor: the force on the body (3, world), its moment about n (the
  // spin friction), z_t (3), theta, F_N, the sliding speed |u|: this step's values (the force
  // is computed with the passive forces, before the velocity-stage sensors).
  static constexpr int kSensorDim = 10;

  explicit ContactFriction(CachedConfig<ContactConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel*, int) { return ContactState::kSize; }

  void Compute(const mjModel* m, mjData* d, int instance);
  void Advance(const mjModel* m, mjData* d, int instance);
  void WriteSensor(const mjModel* m, const mjData* d, int instance, mjtNum* out) const;

 private:
  // The generalized velocity u (4) at point p about normal n, with rho, for the current qvel;
  // keeps the relative Jacobians' columns on the chain dofs (translation, rotation: 6 each) in
  // columns_.
  void SlidingVelocity(const mjModel* m, const mjData* d, const mjtNum* state, double u[4]);
  // The response of (v_t . t1, v_t . t2, rho w_n) to the force over this step: B = dt J M^-1 J'
  // (3 x 3), with the tangent directions t1, t2 it chose.
  void TangentResponse(const mjModel* m, mjData* d, const mjtNum* state, mjtNum t1[3],
                       mjtNum t2[3], double B[9]);
  // law coulomb (velocity_amplitude = 0), the averaged table or the feeder map: the force (4,
  // as u) from the end-of-step velocity, solved with B and the other forces' acceleration of
  // the last step (one step late, like the contact's normal force).
  void ImplicitForce(const mjModel* m, mjData* d, const mjtNum* state, const LawInput& in,
                     double velocity_amplitude, const double u[4], double f[4]);
  // dahl, dupont, lugre: the force of the deflection zeta (4, as u). Explicit (k_t zeta of the
  // step's start, VectorStateForce) while the step resolves the contact, k_t dt lambda_max(B)
  // and (sigma1 + sigma2) lambda_max(B) below kUnresolvedDeflection; else implicit
  // (VectorImplicitDeflectionForce, with the other forces' acceleration of the last step as
  // ImplicitForce).
  void DeflectionForce(const mjModel* m, mjData* d, const mjtNum* state, const LawInput& in,
                       const double u[4], const double zeta[4], double f[4]);

  CachedConfig<ContactConfig> config_;
  std::vector<mjtNum> columns_;  // per chain dof: d(v at p)/dq (3), d(omega)/dq (3), signed
  std::vector<mjtNum> rows_;     // J (3 x nv) and M^-1 J' (3 x nv)
  // Advance: this step's contacts between the two bodies (index in d->contact, normal force,
  // sign of the frame's normal), each read once with mj_contactForce
  struct Touch {
    int contact;
    double normal_force;
    double sign;
  };
  std::vector<Touch> touches_;
  // Over one step, for the acceleration estimate of the implicit steps: u at compute, and the
  // change of u that the applied force causes (B f, as u).
  double u_start_[4] = {0, 0, 0, 0};
  double response_[4] = {0, 0, 0, 0};
  bool response_known_ = false;  // this step's Compute applied a force with a known B f
  // A state law's step taken implicitly: the deflection after it (z_t world, 3; theta), which
  // advance takes instead of integrating the body's end velocity.
  bool implicit_step_ = false;
  double implicit_next_[4] = {0, 0, 0, 0};
  // What the last Compute applied to the body (zero without contact), for the sensor.
  double force_[3] = {0, 0, 0};
  double moment_ = 0;
  double speed_ = 0;
};

// The upward unit tangent at `point` (world) of the helix about support's z axis through its
// origin with rise `pitch` per counter-clockwise turn (pitch < 0: the spiral climbs clockwise):
// sign(pitch) (2 pi r e_phi + pitch e_z), normalized, in world coordinates; zero on the axis.
void HelixTangent(const mjData* d, int support, const mjtNum point[3], double pitch,
                  mjtNum tangent[3]);

// The feeder map's force in (along, across, spin) components, f as the element's force (the
// body receives -f; B f is the change of velocity it takes off), from the velocity without it
// v_free and the response B (both in those components), for normal force `load`:
//   along   f_a = -load phi(v_a'), phi the map interpolated at the end-of-step velocity
//           v_a' = v_free_a - B_aa f_a (solved exactly: phi is piecewise linear, non-increasing);
//   across, spin: rigid Coulomb stick/slip within what the cone leaves,
//           sqrt(mu^2 - phi^2) load (the conveying takes the rest).
// `spin` false: a point contact, no spin component.
void FeederMapForce(const ContactConfig& config, const LawInput& in, const double B[9],
                    const double v[3], const double v_free[3], bool spin, double f[3]);

// Registers vibrofriction.contact, vibrofriction.contact_averaged (the same element with the
// vibration-averaged table, for robot timesteps), vibrofriction.contact_feeder (the same element
// with a feeder's conveying map, for parts on a vibratory feeder at robot timesteps) and
// vibrofriction.contact_sensor (config `body`: the body any of them is attached to).
void RegisterContactPlugins();

}  // namespace vibrofriction

#endif  // VIBROFRICTION_CONTACT_FRICTION_H_
