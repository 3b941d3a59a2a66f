#include "plugins/contact_friction.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>

#include "common/element_config.h"
#include "common/plugin_util.h"
#include "plugins/averaged_friction.h"
#include "plugins/planar_friction.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the shared MJCF keys

constexpr char kPlugin[] = "vibrofriction.contact";


constexpr char kAveragedPlugin[] = "vibrofriction.contact_averaged";
// The robot-timestep form: the table of vibrofriction.averaged over the generalized velocity.

constexpr char kFeederPlugin[] = "vibrofriction.contact_feeder";
// Parts on a vibratory feeder at robot timesteps: the feeder map of
// vibrofriction.robots.feeder_map.

// True when MuJoCo's body-pair mechanism never collides bodies b1 and b2: one weld group, or a
// parent and a child weld group (not the world) while filterparent is on. An explicit <pair>
// still collides them.
bool BodyPairFiltered(const mjModel* m, int b1, int b2) {
  const int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
  if (w1 == w2) return true;
  if (m->opt.disableflags & mjDSBL_FILTERPARENT) return false;
  const int p1 = m->body_weldid[m->body_parentid[w1]];
  const int p2 = m->body_weldid[m->body_parentid[w2]];
  return (w1 != 0 && p2 == w1) || (w2 != 0 && p1 == w2);
}

// condim of the contacts MuJoCo makes between geoms g1 and g2 (an explicit <pair>, else the
// geoms' priority, else the larger condim), or 0 when MuJoCo makes none: contype/conaffinity
// exclude the pair, or `filtered` (BodyPairFiltered) and no <pair> names it.
int PairCondim(const mjModel* m, int g1, int g2, bool filtered) {
  for (int i = 0; i < m->npair; ++i) {
    if ((m->pair_geom1[i] == g1 && m->pair_geom2[i] == g2) ||
        (m->pair_geom1[i] == g2 && m->pair_geom2[i] == g1)) {
      return m->pair_dim[i];
    }
  }
  if (filtered) return 0;
  const bool collide = (m->geom_contype[g1] & m->geom_conaffinity[g2]) ||
                       (m->geom_contype[g2] & m->geom_conaffinity[g1]);
  if (!collide) return 0;
  if (m->geom_priority[g1] != m->geom_priority[g2]) {
    return m->geom_priority[g1] > m->geom_priority[g2] ? m->geom_condim[g1] : m->geom_condim[g2];
  }
  return std::max(m->geom_condim[g1], m->geom_condim[g2]);
}

const char* BodyName(const mjModel* m, int body) {
  const char* name = mj_id2name(m, mjOBJ_BODY, body);
  return name ? name : "(unnamed)";
}

}  // namespace

// ---- ContactConfig -------------------------------------------------------------------------------

bool ContactConfig::FromModel(const mjModel* m, int instance, ContactConfig* config,
                              ReadScope scope) {
  ContactConfig c;
  if (!ReadLawParameters(m, instance, kPlugin, &c.law)) return false;
  if (!c.ReadPair(m, instance, kPlugin, scope)) return false;
  if (scope == ReadScope::kAll) {
    std::vector<int> trees;
    for (const int dof : c.chain_dofs) trees.push_back(m->dof_treeid[dof]);
    if (!CheckVibrationResolved(m, kPlugin, trees, c.law, "vibrofriction.contact_averaged (the "
                                "vibration averaged out, for robot timesteps; "
                                "vibrofriction.contact_feeder on a feeder)")) {
      return false;
    }
  }
  *config = std::move(c);
  return true;
}

bool ContactConfig::FromModelAveraged(const mjModel* m, int instance, ContactConfig* config,
                                      ReadScope scope) {
  ContactConfig c;
  c.averaged = true;
  const char* plugin = kAveragedPlugin;
  // the law without vibration (rigid Coulomb) and the table's amplitude, as vibrofriction.averaged
  if (!ReadAveragedLaw(m, instance, plugin, &c.law, &c.velocity_amplitude)) return false;
  if (!c.ReadAxis(m, instance, plugin)) return false;
  if (!ReadAveragedTable(m, instance, plugin, c.velocity_amplitude, &c.table)) return false;
  if (!c.ReadPair(m, instance, plugin, scope)) return false;
  *config = std::move(c);
  return true;
}

bool ContactConfig::FromModelFeeder(const mjModel* m, int instance, ContactConfig* config,
                                    ReadScope scope) {
  ContactConfig c;
  c.feeder = true;
  const char* plugin = kFeederPlugin;
  c.law.law = Law::kCoulomb;  // across and in spin: rigid Coulomb (no vibration there)
  const char* mu_text = mj_getPluginConfig(m, instance, kMu);
  if (!mu_text || !mu_text[0]) {
    return ConfigError("%s: attribute 'mu' is required: the part's friction coefficient on the "
                       "track, the one its map was made with (FeederMap.contact_config writes "
                       "it)", plugin);
  }
  if (!ReadNumber(m, instance, plugin, kMu, 0.0, &c.law.friction_coefficient)) return false;
  const double mu = c.law.friction_coefficient;
  if (!(mu > 0)) {
    return RejectAttribute(plugin, kMu, mu, "must be > 0: the part's friction coefficient on the "
                           "track, the one its map was made with");
  }
  if (!c.ReadAxis(m, instance, plugin)) return false;
  // helix_pitch: a bowl feeder's spiral track about the support's z axis; the conveying
  // direction is the helix's tangent at the contact point, pointing up the spiral.
  if (!ReadNumber(m, instance, plugin, kHelixPitch, &c.helix_pitch)) return false;
  const char* axis_text = mj_getPluginConfig(m, instance, kAxis);
  if (c.helix_pitch != 0 && axis_text && axis_text[0]) {
    return ConfigError("%s: attributes 'axis' and 'helix_pitch' are both given; a helical track "
                       "conveys along the helix's tangent at the part (helix_pitch, the rise per "
                       "turn about the support's z axis), a straight one along 'axis': give one",
                       plugin);
  }
  for (const char* key : {kMapVelocity, kMapForce}) {
    const char* text = mj_getPluginConfig(m, instance, key);
    if (!text || !text[0]) {
      return ConfigError("%s: attribute '%s' is required: the feeder map, written by "
                         "vibrofriction.robots.feeder_map (FeederMap.contact_config)", plugin, key);
    }
  }
  if (!ReadNumberList(m, instance, plugin, kMapVelocity, &c.map_velocity) ||
      !ReadNumberList(m, instance, plugin, kMapForce, &c.map_force)) {
    return false;
  }
  const std::size_t n = c.map_velocity.size();
  if (n < 2 || c.map_force.size() != n) {
    return ConfigError("%s: 'map_velocity' and 'map_force' need the same number of values, at "
                       "least 2 (they have %zu and %zu)", plugin, n, c.map_force.size());
  }
  for (std::size_t k = 0; k < n; ++k) {
    // Velocities increase, or repeat where the force steps down (a static band: the part
    // stuck); forces never increase. So the end-of-step velocity has one solution, and a faster
    // part is never pushed harder.
    if (k > 0 && !(c.map_velocity[k] > c.map_velocity[k - 1] ||
                   (c.map_velocity[k] == c.map_velocity[k - 1] &&
                    c.map_force[k] < c.map_force[k - 1]))) {
      return ConfigError("%s: 'map_velocity' must increase (value %zu, %g, follows %g; an equal "
                         "value needs a smaller force: a static band)", plugin, k + 1,
                         c.map_velocity[k], c.map_velocity[k - 1]);
    }
    if (k > 0 && c.map_force[k] > c.map_force[k - 1]) {
      return ConfigError("%s: 'map_force' must not increase with the velocity (value %zu, %g, "
                         "follows %g)", plugin, k + 1, c.map_force[k], c.map_force[k - 1]);
    }
    if (!(std::fabs(c.map_force[k]) <= mu * (1 + 1e-9))) {
      return ConfigError("%s: 'map_force' value %zu, %g, exceeds mu = %g: the mean friction "
                         "over F_N cannot; was the map made with another mu?", plugin, k + 1,
                         c.map_force[k], mu);
    }
  }
  if (!c.ReadPair(m, instance, plugin, scope)) return false;
  *config = std::move(c);
  return true;
}

bool ContactConfig::ReadAxis(const mjModel* m, int instance, const char* plugin) {
  std::vector<double> axis = {1.0, 0.0, 0.0};
  if (mj_getPluginConfig(m, instance, kAxis) && mj_getPluginConfig(m, instance, kAxis)[0]) {
    if (!ReadNumberList(m, instance, plugin, kAxis, &axis)) return false;
  }
  const double length = axis.size() == 3 ? std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] +
                                                      axis[2] * axis[2]) : 0.0;
  if (!(length > 0)) {
    return ConfigError("%s: attribute 'axis' needs 3 numbers, not all 0: the vibration direction "
                       "in the support body's frame (default \"1 0 0\")", plugin);
  }
  for (int i = 0; i < 3; ++i) axis_local[i] = axis[i] / length;
  return true;
}

bool ContactConfig::ReadPair(const mjModel* m, int instance, const char* plugin,
                             ReadScope scope) {
  ContactConfig& c = *this;
  if (!ReadNumber(m, instance, plugin, kTorsionRadius, &c.torsion_radius)) return false;
  if (c.torsion_radius < 0) {
    return RejectAttribute(plugin, kTorsionRadius, c.torsion_radius,
                           "must be >= 0 (m; 0: from the contact points; a uniform-pressure disc "
                           "of radius R has 2R/3)");
  }
  if (!CheckIntegrator(m, plugin)) return false;
  const char* support = mj_getPluginConfig(m, instance, kSupport);
  if (!support || !support[0]) {
    return ConfigError("%s: attribute 'support' is required: the name of the body the part rests "
                       "on (a plate, a conveyor, a gripper finger; 'world' for the ground)",
                       plugin);
  }
  if (scope == ReadScope::kAttributes) return true;
  c.support = mj_name2id(m, mjOBJ_BODY, support);
  if (c.support < 0) {
    return ConfigError("%s: support=\"%s\" names no body of the model; give the name of the "
                       "body the part rests on", plugin, support);
  }
  int count = 0;
  for (int b = 0; b < m->nbody; ++b) {
    if (m->body_plugin[b] != instance) continue;
    c.body = b;
    ++count;
  }
  if (count != 1) {
    return ConfigError("%s: the instance is attached to %d bodies; attach it to exactly one, the "
                       "sliding body: <body name=\"part\"> ... <plugin instance=\"..\"/></body>",
                       plugin, count);
  }
  if (c.body == c.support) {
    return ConfigError("%s: support=\"%s\" is the body the element is attached to; name the body "
                       "it rests on", plugin, support);
  }
  // support_geom: the geoms of the support that form the conveying surface (names separated by
  // spaces); contacts with its other geoms (walls, end stops) are left to MuJoCo.
  c.surface.clear();
  const char* surface = mj_getPluginConfig(m, instance, kSupportGeom);
  for (const char* s = surface ? surface : ""; *s;) {
    while (*s == ' ' || *s == '\t' || *s == '\n' || *s == '\r') ++s;
    if (!*s) break;
    const char* end = s;
    while (*end && *end != ' ' && *end != '\t' && *end != '\n' && *end != '\r') ++end;
    const std::string name(s, end);
    s = end;
    const int geom = mj_name2id(m, mjOBJ_GEOM, name.c_str());
    if (geom < 0 || m->geom_bodyid[geom] != c.support) {
      return ConfigError("%s: support_geom=\"%s\": '%s' names no geom of the support body '%s'; "
                         "list the names of the support's geoms that form the surface the part "
                         "rests on", plugin, surface, name.c_str(), BodyName(m, c.support));
    }
    if (c.surface.empty()) c.surface.assign(m->ngeom, 0);
    c.surface[geom] = 1;
  }
  // The chains: MuJoCo's mj_jac walks the same dofs (dof_parentid from the body's last dof).
  c.chain_dofs.clear();
  c.chain_signs.clear();
  for (int k = 0; k < 2; ++k) {
    int b = k == 0 ? c.body : c.support;
    while (b > 0 && m->body_dofnum[b] == 0) b = m->body_parentid[b];
    if (b <= 0) continue;  // the world, or welded to it
    for (int i = m->body_dofadr[b] + m->body_dofnum[b] - 1; i >= 0; i = m->dof_parentid[i]) {
      const double sign = k == 0 ? 1.0 : -1.0;
      const auto it = std::find(c.chain_dofs.begin(), c.chain_dofs.end(), i);
      if (it == c.chain_dofs.end()) {
        c.chain_dofs.push_back(i);
        c.chain_signs.push_back(sign);
      } else {
        c.chain_signs[it - c.chain_dofs.begin()] += sign;  // in both chains: 0
      }
    }
  }
  for (std::size_t j = c.chain_dofs.size(); j-- > 0;) {
    if (c.chain_signs[j] == 0.0) {
      c.chain_dofs.erase(c.chain_dofs.begin() + j);
      c.chain_signs.erase(c.chain_signs.begin() + j);
    }
  }
  int touching = 0;  // geom pairs of body and support that make contacts
  const bool filtered = BodyPairFiltered(m, c.body, c.support);
  for (int g1 = 0; g1 < m->ngeom; ++g1) {
    if (m->geom_bodyid[g1] != c.body) continue;
    for (int g2 = 0; g2 < m->ngeom; ++g2) {
      if (m->geom_bodyid[g2] != c.support || !c.OnSurface(g2)) continue;
      const int condim = PairCondim(m, g1, g2, filtered);
      if (condim == 0) continue;
      if (condim != 1) {
        const char* n1 = mj_id2name(m, mjOBJ_GEOM, g1);
        const char* n2 = mj_id2name(m, mjOBJ_GEOM, g2);
        return ConfigError(
            "%s: the contacts between geom '%s' (body '%s') and geom '%s' (body '%s') have "
            "condim %d, so MuJoCo adds its own friction beside the element; set condim=\"1\" on "
            "one of them (and priority so it wins) or declare <pair geom1=.. geom2=.. "
            "condim=\"1\"/>", plugin, n1 ? n1 : "(unnamed)", BodyName(m, c.body),
            n2 ? n2 : "(unnamed)", BodyName(m, c.support), condim);
      }
      ++touching;
    }
  }
  if (touching == 0 && filtered) {
    return ConfigError("%s: MuJoCo makes no contacts between body '%s' and its support '%s': "
                       "they are welded together (no joint between them), or parent and child "
                       "with <flag filterparent=\"enable\"/>; give the part a joint, disable "
                       "filterparent, or declare <pair geom1=.. geom2=.. condim=\"1\"/>", plugin,
                       BodyName(m, c.body), BodyName(m, c.support));
  }
  if (touching == 0) {
    return ConfigError("%s: no geom of body '%s' can touch %s of its support '%s' "
                       "(contype/conaffinity exclude every pair); the element acts over their "
                       "contacts", plugin, BodyName(m, c.body),
                       c.surface.empty() ? "a geom" : "a support_geom", BodyName(m, c.support));
  }
  return true;
}

// ---- the feeder map ------------------------------------------------------------------------------

void FeederMapForce(const ContactConfig& config, const LawInput& in, const double B[9],
                    const double v[3], const double v_free[3], bool spin, double f[3]) {
  const std::vector<double>& V = config.map_velocity;
  const std::vector<double>& Phi = config.map_force;
  const int n = static_cast<int>(V.size());
  const double load = in.normal_force;
  const double gain = std::max(B[0], 0.0) * load;  // v_a' = v_free_a + gain phi(v_a')
  // h(x) = x - v_free_a - gain phi(x) increases (phi does not): its root is the end velocity.
  auto h = [&](int k) { return V[k] - v_free[0] - gain * Phi[k]; };
  double phi;
  if (h(0) >= 0) {
    phi = Phi[0];  // below the map: its first value holds
  } else if (h(n - 1) <= 0) {
    phi = Phi[n - 1];
  } else {
    int lo = 0, hi = n - 1;  // h(lo) < 0 < h(hi)
    while (hi - lo > 1) {
      const int mid = (lo + hi) / 2;
      (h(mid) < 0 ? lo : hi) = mid;
    }
    const double h_lo = h(lo), h_hi = h(hi);  // linear in between
    const double s = -h_lo / (h_hi - h_lo);
    phi = Phi[lo] + s * (Phi[hi] - Phi[lo]);
  }
  f[0] = -load * phi;
  // Across and in spin: rigid Coulomb within the rest of the cone, from the velocity the along
  // force leaves (B's coupling).
  LawParameters rest = config.law;
  const double mu = config.law.friction_coefficient;
  rest.friction_coefficient = std::sqrt(std::max(mu * mu - phi * phi, 0.0));
  const double v2[2] = {v[1], spin ? v[2] : 0.0};
  const double free2[2] = {v_free[1] - B[3] * f[0], spin ? v_free[2] - B[6] * f[0] : 0.0};
  const double B2[4] = {B[4], spin ? B[5] : 0.0, spin ? B[7] : 0.0, spin ? B[8] : 0.0};
  double f2[2];
  VectorStickSlipForce<2>(rest, in, v2, free2, B2, f2);
  f[1] = f2[0];
  f[2] = spin ? f2[1] : 0.0;
}

void HelixTangent(const mjData* d, int support, const mjtNum point[3], double pitch,
                  mjtNum tangent[3]) {
  const mjtNum* rotation = d->xmat + 9 * support;
  mjtNum offset[3], local[3];
  mju_sub3(offset, point, d->xpos + 3 * support);
  mju_mulMatTVec3(local, rotation, offset);  // the point in the support's frame
  const double radius = std::hypot(local[0], local[1]);
  if (!(radius > 1e-9)) {  // on the axis: no direction (rigid Coulomb)
    mju_zero3(tangent);
    return;
  }
  // d/dphi of (r cos phi, r sin phi, pitch phi / 2 pi), upward: sign(pitch) (r e_phi + pitch/2pi e_z)
  const double up = pitch > 0 ? 1.0 : -1.0;
  const double run = 2 * kPi * radius;
  const double length = std::hypot(run, pitch);
  const mjtNum along[3] = {up * (-local[1] / radius) * run / length,
                           up * (local[0] / radius) * run / length, std::fabs(pitch) / length};
  mju_mulMatVec3(tangent, rotation, along);
}

// ---- ContactFriction -----------------------------------------------------------------------------

void ContactFriction::SlidingVelocity(const mjModel* m, const mjData* d, const mjtNum* state,
                                      double u[4]) {
  // mj_jac's columns, on the chain dofs only: dof i's motion (cdof: rotation, translation, at
  // the subtree centre of mass of its tree's root) seen at the point, signed body - support.
  const mjtNum* point = state + ContactState::kPoint;
  const mjtNum* normal = state + ContactState::kNormal;
  const std::vector<int>& dofs = config_->chain_dofs;
  columns_.resize(6 * dofs.size());
  mjtNum v[3] = {0, 0, 0}, w[3] = {0, 0, 0};
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    const int i = dofs[k];
    const double sign = config_->chain_signs[k];
    const mjtNum* cdof = d->cdof + 6 * i;
    mjtNum offset[3], swept[3];
    mju_sub3(offset, point, d->subtree_com + 3 * m->body_rootid[m->dof_bodyid[i]]);
    mju_cross(swept, cdof, offset);
    mjtNum* column = columns_.data() + 6 * k;  // translation (3), rotation (3)
    for (int r = 0; r < 3; ++r) {
      column[r] = sign * (cdof[3 + r] + swept[r]);
      column[3 + r] = sign * cdof[r];
      v[r] += column[r] * d->qvel[i];
      w[r] += column[3 + r] * d->qvel[i];
    }
  }
  const double along = mju_dot3(v, normal);
  for (int i = 0; i < 3; ++i) u[i] = v[i] - along * normal[i];
  u[3] = state[ContactState::kRadius] * mju_dot3(w, normal);
}

void ContactFriction::TangentResponse(const mjModel* m, mjData* d, const mjtNum* state,
                                      mjtNum t1[3], mjtNum t2[3], double B[9]) {
  const int nv = m->nv;
  const mjtNum* normal = state + ContactState::kNormal;
  const double rho = state[ContactState::kRadius];
  // Tangent directions t1, t2 (any orthonormal pair perpendicular to n).
  mju_zero3(t1);
  t1[std::fabs(normal[0]) < 0.9 ? 0 : 1] = 1.0;
  const double along = mju_dot3(t1, normal);
  for (int i = 0; i < 3; ++i) t1[i] -= along * normal[i];
  mju_normalize3(t1);
  mju_cross(t2, normal, t1);
  const mjtNum* t[2] = {t1, t2};
  // J is kept zero between calls but on the chain, so it is not cleared in full each step
  // (cleared in full when nv changes: J's and M^-1 J''s parts move)
  if (rows_.size() != 6 * static_cast<std::size_t>(nv)) {
    rows_.assign(6 * static_cast<std::size_t>(nv), 0.0);
  }
  mjtNum* J = rows_.data();
  mjtNum* X = J + 3 * nv;
  const std::vector<int>& dofs = config_->chain_dofs;
  for (std::size_t k = 0; k < dofs.size(); ++k) {  // J is zero off the chain
    const mjtNum* column = columns_.data() + 6 * k;
    const int j = dofs[k];
    for (int r = 0; r < 2; ++r) J[r * nv + j] = mju_dot3(t[r], column);
    J[2 * nv + j] = rho * mju_dot3(normal, column + 3);
  }
  mj_solveM(m, d, X, J, 3);  // M^-1 J' (the factor of M is this step's)
  const double dt = m->opt.timestep;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      double sum = 0.0;
      for (const int j : dofs) sum += J[r * nv + j] * X[c * nv + j];
      B[3 * r + c] = dt * sum;
    }
  }
  for (int r = 0; r < 3; ++r) {
    for (const int j : dofs) J[r * nv + j] = 0.0;
  }
}

void ContactFriction::ImplicitForce(const mjModel* m, mjData* d, const mjtNum* state,
                                    const LawInput& in, double velocity_amplitude,
                                    const double u[4], double f[4]) {
  mjtNum t1[3], t2[3];
  double B[9];
  TangentResponse(m, d, state, t1, t2, B);
  const mjtNum* t[2] = {t1, t2};
  const double dt = m->opt.timestep;
  const mjtNum* other = state + ContactState::kOtherAcceleration;
  double ahead[4];  // u after this step without the element's force (estimate)
  for (int i = 0; i < 4; ++i) ahead[i] = u[i] + dt * other[i];
  if (!(state[ContactState::kRadius] > 0)) ahead[3] = 0.0;  // a point: no spin coordinate
  const double v[3] = {mju_dot3(u, t1), mju_dot3(u, t2), u[3]};
  const double v_free[3] = {mju_dot3(ahead, t1), mju_dot3(ahead, t2), ahead[3]};
  double f3[3];
  double axis3[3] = {0, 0, 0};
  double in_plane = 0.0;  // the axis' length in the contact plane
  if (config_->feeder || velocity_amplitude > 0) {
    // The vibration's part in the tangent plane, in (t1, t2, spin) components: the table is
    // read at that amplitude (the part along the normal is not modelled: it would modulate
    // the load, which MuJoCo's contact carries). A feeder's map holds its throw: the axis
    // gives only the conveying direction.
    mjtNum axis[3];
    if (config_->helix_pitch != 0) {
      HelixTangent(d, config_->support, state + ContactState::kPoint, config_->helix_pitch, axis);
    } else {
      mju_mulMatVec3(axis, d->xmat + 9 * config_->support, config_->axis_local);
    }
    axis3[0] = mju_dot3(axis, t1);
    axis3[1] = mju_dot3(axis, t2);
    in_plane = std::hypot(axis3[0], axis3[1]);
    velocity_amplitude *= in_plane;
    if (in_plane > 0) {
      axis3[0] /= in_plane;
      axis3[1] /= in_plane;
    }
  }
  // Below 1e-9 of the table's amplitude the dither slides nothing: rigid Coulomb.
  const bool vibrating = velocity_amplitude > 1e-9 * config_->velocity_amplitude;
  // A feeder's map conveys along the axis' part in the contact plane; an axis (nearly) normal
  // to the contact has none: rigid Coulomb.
  const bool conveying = config_->feeder && in_plane > 1e-6;
  if (conveying) {
    // (along, across) = R (t1, t2)
    const double R[9] = {axis3[0], axis3[1], 0.0, -axis3[1], axis3[0], 0.0, 0.0, 0.0, 1.0};
    double Br[9], vr[3], vfr[3], fr[3], RB[9];
    for (int r = 0; r < 3; ++r) {
      vr[r] = R[3 * r] * v[0] + R[3 * r + 1] * v[1] + R[3 * r + 2] * v[2];
      vfr[r] = R[3 * r] * v_free[0] + R[3 * r + 1] * v_free[1] + R[3 * r + 2] * v_free[2];
      for (int c = 0; c < 3; ++c) {
        RB[3 * r + c] = R[3 * r] * B[c] + R[3 * r + 1] * B[3 + c] + R[3 * r + 2] * B[6 + c];
      }
    }
    for (int r = 0; r < 3; ++r) {  // R B R'
      for (int c = 0; c < 3; ++c) {
        Br[3 * r + c] = RB[3 * r] * R[3 * c] + RB[3 * r + 1] * R[3 * c + 1] +
                        RB[3 * r + 2] * R[3 * c + 2];
      }
    }
    FeederMapForce(*config_, in, Br, vr, vfr, state[ContactState::kRadius] > 0, fr);
    for (int i = 0; i < 3; ++i) {  // R' fr
      f3[i] = R[i] * fr[0] + R[3 + i] * fr[1] + R[6 + i] * fr[2];
    }
  } else if (vibrating) {
    double end[3] = {v[0], v[1], v[2]};
    SolveAveragedEndVelocity<3>(config_->table, config_->law, axis3, in.normal_force,
                                velocity_amplitude, B, v_free, end, f3);
  } else if (state[ContactState::kRadius] > 0) {
    VectorStickSlipForce<3>(config_->law, in, v, v_free, B, f3);
  } else {  // a point contact: no spin friction, the tangential block alone
    const double B2[4] = {B[0], B[1], B[3], B[4]};
    VectorStickSlipForce<2>(config_->law, in, v, v_free, B2, f3);
    f3[2] = 0.0;
  }
  double change[3];  // B f3: the change of (v_t . t1, v_t . t2, rho w_n) the force causes
  for (int r = 0; r < 3; ++r) {
    change[r] = B[3 * r] * f3[0] + B[3 * r + 1] * f3[1] + B[3 * r + 2] * f3[2];
  }
  for (int i = 0; i < 3; ++i) {
    f[i] = f3[0] * t[0][i] + f3[1] * t[1][i];
    response_[i] = change[0] * t[0][i] + change[1] * t[1][i];
  }
  f[3] = f3[2];
  response_[3] = change[2];
}

void ContactFriction::DeflectionForce(const mjModel* m, mjData* d, const mjtNum* state,
                                      const LawInput& in, const double u[4],
                                      const double zeta[4], double f[4]) {
  const LawParameters& p = config_->law;
  mjtNum t1[3], t2[3];
  double B[9];
  TangentResponse(m, d, state, t1, t2, B);
  const bool spin = state[ContactState::kRadius] > 0;  // else a point: no spin coordinate
  const double B2[4] = {B[0], B[1], B[3], B[4]};
  const double lambda = spin ? LargestEigenvalue<3>(B) : LargestEigenvalue<2>(B2);
  const double dt = m->opt.timestep;
  const bool resolved = p.contact_stiffness * dt * lambda < kUnresolvedDeflection &&
                        (p.bristle_damping + p.viscous) * lambda < kUnresolvedDeflection;
  const mjtNum* t[2] = {t1, t2};
  double f3[3] = {0, 0, 0};
  if (resolved) {
    // The explicit force of the step's start deflection (the symplectic-Euler pair with
    // advance): exact as dt -> 0, second to none at resolved steps.
    VectorStateForce<4>(p, in, u, zeta, f);
    for (int r = 0; r < 2; ++r) f3[r] = mju_dot3(f, t[r]);
    f3[2] = f[3];
  } else {
    const mjtNum* other = state + ContactState::kOtherAcceleration;
    double ahead[4];  // u after this step without the element's force (estimate)
    for (int i = 0; i < 4; ++i) ahead[i] = u[i] + dt * other[i];
    const double v_free[3] = {mju_dot3(ahead, t1), mju_dot3(ahead, t2), spin ? ahead[3] : 0.0};
    const double z3[3] = {mju_dot3(zeta, t1), mju_dot3(zeta, t2), spin ? zeta[3] : 0.0};
    LawInput mid = in;  // the deflection's update over the step, as advance takes it
    mid.time = in.time + 0.5 * dt;
    double end[3], next[3] = {0, 0, 0};
    if (spin) {
      VectorImplicitDeflectionForce<3>(p, mid, z3, v_free, B, dt, f3, end, next);
    } else {
      VectorImplicitDeflectionForce<2>(p, mid, z3, v_free, B2, dt, f3, end, next);
      f3[2] = 0.0;
    }
    for (int i = 0; i < 3; ++i) {
      f[i] = f3[0] * t1[i] + f3[1] * t2[i];
      implicit_next_[i] = next[0] * t1[i] + next[1] * t2[i];
    }
    f[3] = f3[2];
    implicit_next_[3] = spin ? next[2] / state[ContactState::kRadius] : 0.0;  // theta
    implicit_step_ = true;
  }
  // B f: the change of u the force causes, for the next step's estimate of the other forces
  double change[3];
  for (int r = 0; r < 3; ++r) {
    change[r] = B[3 * r] * f3[0] + B[3 * r + 1] * f3[1] + (spin ? B[3 * r + 2] * f3[2] : 0.0);
  }
  for (int i = 0; i < 3; ++i) response_[i] = change[0] * t1[i] + change[1] * t2[i];
  response_[3] = spin ? change[2] : 0.0;
}

void ContactFriction::Compute(const mjModel* m, mjData* d, int instance) {
  force_[0] = force_[1] = force_[2] = moment_ = speed_ = 0.0;
  response_known_ = false;
  implicit_step_ = false;
  if (!config_.Refresh(m, instance)) return;
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const double normal_force = state[ContactState::kNormalForce];
  if (!(normal_force > 0)) return;  // no contact in the last step: no friction
  double u[4];
  SlidingVelocity(m, d, state, u);
  const double rho = state[ContactState::kRadius];
  LawInput in;
  in.time = d->time;
  in.normal_force = normal_force;
  in.velocity = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + u[3] * u[3]);
  double f[4];
  if (HasDeflection(config_->law.law)) {
    const double zeta[4] = {state[0], state[1], state[2], rho * state[ContactState::kTwist]};
    DeflectionForce(m, d, state, in, u, zeta, f);
  } else {  // coulomb, the averaged table or the feeder map
    ImplicitForce(m, d, state, in, config_->averaged ? config_->velocity_amplitude : 0.0, u, f);
  }
  mju_copy(u_start_, u, 4);
  response_known_ = true;
  const mjtNum* normal = state + ContactState::kNormal;
  const double along = f[0] * normal[0] + f[1] * normal[1] + f[2] * normal[2];
  mjtNum force[3], torque[3];
  for (int i = 0; i < 3; ++i) {
    force[i] = -(f[i] - along * normal[i]);
    torque[i] = -rho * f[3] * normal[i];
  }
  mju_copy3(force_, force);
  moment_ = -rho * f[3];
  speed_ = in.velocity;
  // The force and moment on the body at p and their opposites on the support: through the
  // relative Jacobians' columns at p (body - support) that SlidingVelocity kept.
  const std::vector<int>& dofs = config_->chain_dofs;
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    const mjtNum* column = columns_.data() + 6 * k;
    d->qfrc_passive[dofs[k]] += mju_dot3(column, force) + mju_dot3(column + 3, torque);
  }
}

void ContactFriction::Advance(const mjModel* m, mjData* d, int instance) {
  if (!config_.Refresh(m, instance, /*later_in_step=*/true)) return;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const int body = config_->body, support = config_->support;
  // This step's contacts between the two bodies (the constraint solve has run).
  touches_.clear();
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.efc_address < 0) continue;
    const int b0 = m->geom_bodyid[c.geom[0]], b1 = m->geom_bodyid[c.geom[1]];
    const bool body_first = b0 == body && b1 == support;
    if (!body_first && !(b0 == support && b1 == body)) continue;
    if (!config_->OnSurface(c.geom[body_first ? 1 : 0])) continue;  // a wall, an end stop
    mjtNum wrench[6];
    mj_contactForce(m, d, i, wrench);
    if (!(wrench[0] > 0)) continue;
    // The frame's normal points from geom[0] to geom[1]; n points from the support to the body.
    touches_.push_back({i, wrench[0], body_first ? -1.0 : 1.0});
  }
  double total = 0.0, point[3] = {0, 0, 0}, normal[3] = {0, 0, 0};
  for (const Touch& touch : touches_) {
    const mjContact& c = d->contact[touch.contact];
    total += touch.normal_force;
    for (int k = 0; k < 3; ++k) {
      point[k] += touch.normal_force * c.pos[k];
      normal[k] += touch.sign * touch.normal_force * c.frame[k];
    }
  }
  if (!(total > 0) || !(mju_normalize3(normal) > 0)) {
    mju_zero(state, ContactState::kSize);  // separated: no load, no deflection
    return;
  }
  mju_scl3(point, point, 1.0 / total);
  double rho = config_->torsion_radius;
  if (rho == 0) {
    for (const Touch& touch : touches_) {
      mjtNum arm[3];
      mju_sub3(arm, d->contact[touch.contact].pos, point);
      rho += touch.normal_force * mju_norm3(arm);
    }
    rho /= total;
    // One contact point (a sphere, a vertex) has no arm: its rounding noise (1e-20 m) would
    // make a spin axis without response. Below a picometre is a point.
    if (rho < 1e-12) rho = 0.0;
  }
  state[ContactState::kNormalForce] = total;
  mju_copy3(state + ContactState::kPoint, point);
  mju_copy3(state + ContactState::kNormal, normal);
  state[ContactState::kRadius] = rho;
  // The deflection stays in the tangent plane as the normal turns. After an implicit step it is
  // the one the step's force was computed with (VectorImplicitDeflectionForce).
  mjtNum* z = state + ContactState::kDeflection;
  if (implicit_step_) {
    mju_copy3(z, implicit_next_);
    state[ContactState::kTwist] = implicit_next_[3];
  }
  const double along = mju_dot3(z, normal);
  for (int k = 0; k < 3; ++k) z[k] -= along * normal[k];

  const double dt = m->opt.timestep;
  double u[4];
  SlidingVelocity(m, d, state, u);
  // The acceleration of u from every other force over this step: its change plus what the
  // element's own force took off. Zero after a step without contact (nothing was applied).
  mjtNum* other = state + ContactState::kOtherAcceleration;
  for (int i = 0; i < 4; ++i) {
    other[i] = response_known_ ? (u[i] + response_[i] - u_start_[i]) / dt : 0.0;
  }
  if (!(rho > 0)) other[3] = 0.0;  // a point: no spin coordinate
  if (!HasDeflection(config_->law.law) || implicit_step_) return;
  LawInput in;
  in.time = d->time - 0.5 * dt;  // mid-step: time has already advanced
  in.normal_force = total;
  in.velocity = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + u[3] * u[3]);
  double zeta[4] = {z[0], z[1], z[2], rho * state[ContactState::kTwist]};
  AdvanceVectorDeflection<4>(config_->law, in, u, zeta, dt);
  mju_copy3(z, zeta);
  state[ContactState::kTwist] = rho > 0 ? zeta[3] / rho : 0.0;
}

void ContactFriction::WriteSensor(const mjModel* m, const mjData* d, int instance,
                                  mjtNum* out) const {
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  mju_copy3(out, force_);
  out[3] = moment_;
  mju_copy3(out + 4, state + ContactState::kDeflection);
  out[7] = state[ContactState::kTwist];
  out[8] = state[ContactState::kNormalForce];
  out[9] = speed_;
}

// ---- vibrofriction.contact_sensor ----------------------------------------------------------------

namespace {

constexpr char kSensorPlugin[] = "vibrofriction.contact_sensor";

struct ContactSensorConfig {
  int element = -1;  // plugin instance of the contact element

  static bool FromModel(const mjModel* m, int instance, ContactSensorConfig* config,
                        ReadScope /*scope*/) {
    const char* name = mj_getPluginConfig(m, instance, kBody);
    if (name == nullptr || name[0] == '\0') {
      return ConfigError("%s: attribute 'body' is missing; name the body a vibrofriction.contact "
                         "element is attached to", kSensorPlugin);
    }
    // Body names and body_plugin are set while compiling: scope does not matter.
    const int body = mj_name2id(m, mjOBJ_BODY, name);
    const int element = body >= 0 ? m->body_plugin[body] : -1;
    const mjpPlugin* plugin = element >= 0 ? mjp_getPluginAtSlot(m->plugin[element]) : nullptr;
    if (!plugin || (std::strcmp(plugin->name, ContactFriction::kName) != 0 &&
                    std::strcmp(plugin->name, kAveragedPlugin) != 0 &&
                    std::strcmp(plugin->name, kFeederPlugin) != 0)) {
      return ConfigError("%s: body=\"%s\" has no vibrofriction.contact, contact_averaged or "
                         "contact_feeder element; name the body whose <plugin instance=\"..\"/> "
                         "is one",
                         kSensorPlugin, name);
    }
    config->element = element;
    return true;
  }
};

class ContactSensor {
 public:
  explicit ContactSensor(CachedConfig<ContactSensorConfig> config) : config_(std::move(config)) {}
  static int StateSize(const mjModel*, int) { return 0; }

  void Compute(const mjModel* m, mjData* d, int instance) {
    for (int s : sensors_.Of(m, instance)) {
      mjtNum* out = d->sensordata + m->sensor_adr[s];
      if (config_.Refresh(m, instance)) {
        InstanceOf<ContactFriction>(d, config_->element)->WriteSensor(m, d, config_->element, out);
      } else {
        mju_zero(out, ContactFriction::kSensorDim);
      }
    }
  }

  static void RegisterPlugin() {
    // The element's force is computed with the passive forces: the velocity stage has it, and
    // an acceleration-stage plugin sensor would make MuJoCo run mj_rnePostConstraint each step.
    RegisterElementPlugin<ContactSensor, &ContactSensorConfig::FromModel,
                          ContactFriction::kSensorDim, mjSTAGE_VEL>(
        kSensorPlugin, attributes::kContactSensor, mjPLUGIN_SENSOR);
  }

 private:
  CachedConfig<ContactSensorConfig> config_;
  InstanceSensors sensors_;
};

}  // namespace

void RegisterContactPlugins() {
  ContactFriction::RegisterPlugin();
  // vibrofriction.contact_averaged: the same element with the averaged law
  RegisterElementPlugin<ContactFriction, &ContactConfig::FromModelAveraged>(
      kAveragedPlugin, attributes::kContactAveraged, mjPLUGIN_PASSIVE);
  // vibrofriction.contact_feeder: the same element with a feeder's map
  RegisterElementPlugin<ContactFriction, &ContactConfig::FromModelFeeder>(
      kFeederPlugin, attributes::kContactFeeder, mjPLUGIN_PASSIVE);
  ContactSensor::RegisterPlugin();
}

void ContactFriction::RegisterPlugin() {
  RegisterElementPlugin<ContactFriction, &ContactConfig::FromModel>(
      kName, attributes::kContact, mjPLUGIN_PASSIVE);
}

}  // namespace vibrofriction
