// Actuator (+ optional sensor) plugin "vibrofriction.averaged": the robot-timestep mode of the
// planar element. At millisecond timesteps a kHz support vibration cannot be resolved; what the
// body feels is the friction force averaged over a vibration period as a function of its mean
// sliding velocity V. This element applies that averaged law,
//   F(V) = mu F_N R f(|V|/v_a, angle of V from the vibration axis) + sigma2 V,
// with f a table of the mean force over mu F_N in the vibration frame (components along and
// across the vibration axis), precomputed from the resolved planar law for the given vibration
// (vibrofriction.robots.averaged.build_table) and stored in the config. Between table points f is
// interpolated bilinearly in (xi, angle); beyond the last xi it is held at the last row.
//
// Like vibrofriction.planar, ONE instance backs TWO actuators (x then y transmissions of the
// body relative to its support; actdim is not needed). The force is applied implicitly: each step
// solves u + B F(u) = v_free for the end-of-step velocity u (B = dt J M^-1 J', the same response
// as the Coulomb stick solve) and applies F(u). A friction law whose slope is large compared with
// m/dt (the averaged law near V = 0 at small vibration) therefore stays stable at dt = 1-2 ms.
// With no vibration (velocity_amplitude = 0, or ctrl = 0 with use_ctrl) it is rigid Coulomb with
// the planar stick solve, its level raised by static_ratio near rest on the Stribeck curve of
// stribeck_velocity (as vibrofriction.planar with law="coulomb"). With vibration both are unused:
// the table was built from the resolved law, Stribeck curve included.
//
// Normal load: as vibrofriction.planar (normal + normal_gain * sensor or contact force between
// contact_geom1 and contact_geom2 of the previous step). The table is normalized by mu F_N; it
// scales exactly with F_N for rigid contact and approximately for elastic laws (the ratio of
// vibration amplitude to pre-slip length changes with F_N).
#ifndef VIBROFRICTION_AVERAGED_FRICTION_H_
#define VIBROFRICTION_AVERAGED_FRICTION_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"

#include "laws/friction_law.h"
#include "plugins/planar_friction.h"

namespace vibrofriction {

// Mean friction over mu F_N in the vibration frame; xi = |V| / v_a, angle of V from the
// vibration axis in [0, pi]. Values row-major: index i * angle.size() + j.
struct AveragedTable {
  std::vector<double> xi, angle, along, across;
  // Components (along, across) at xi >= 0 and angle in [0, pi]; with `slopes`, also their
  // derivatives in the cell (d along/d xi, d along/d angle, d across/d xi, d across/d angle;
  // 0 in a variable clamped at the table's edge).
  void Evaluate(double xi_value, double angle_value, double* f_along, double* f_across,
                double slopes[4] = nullptr) const;
};

// Reads and checks the averaged elements' law without vibration (rigid Coulomb: mu, viscous,
// static_ratio, stribeck_velocity) and velocity_amplitude; records the error naming `plugin`.
bool ReadAveragedLaw(const mjModel* m, int instance, const char* plugin, LawParameters* law,
                     double* velocity_amplitude);

// Reads and checks table_xi, table_angle, table_along, table_across (checked when
// velocity_amplitude > 0); records the error naming `plugin` and returns false when invalid.
bool ReadAveragedTable(const mjModel* m, int instance, const char* plugin,
                       double velocity_amplitude, AveragedTable* table);

// The averaged force (N) at the mean sliding velocity u of an isotropic law in N components,
// the vibration along the unit vector `axis`: the table at xi = |u|/v_a and the angle of u from
// the axis gives the parts along the axis and along u's part across it (rotational symmetry
// about the axis), times mu F_N, plus sigma2 u. N = 2: the planar element; N = 3: the contact
// element's two tangential directions and its spin times the torsion radius.
template <int N>
void AveragedVectorForce(const AveragedTable& table, const LawParameters& law,
                         const double axis[N], const double u[N], double normal_force,
                         double velocity_amplitude, double force[N]);

// AveragedVectorForce and its Jacobian dF/du (row-major N x N), exact within the table's cell;
// along the axis its limit there (the along part's kink across the axis taken flat). False
// (nothing written) at rest to rounding, where no direction is defined: the caller
// differentiates numerically.
template <int N>
bool AveragedVectorForceJacobian(const AveragedTable& table, const LawParameters& law,
                                 const double axis[N], const double u[N], double normal_force,
                                 double velocity_amplitude, double force[N],
                                 double jacobian[N * N]);

// The end-of-step velocity u of u + B F(u) = v_free with F the averaged force (B = dt J M^-1 J',
// row-major N x N): Newton with the table's exact Jacobian (a forward difference where it has
// none) and backtracking on |R| (the law is monotone and Lipschitz, piecewise bilinear); u in:
// the start, out: the solution; `force`: F(u) at the solution (the residual's own evaluation,
// not repeated).
template <int N>
void SolveAveragedEndVelocity(const AveragedTable& table, const LawParameters& law,
                              const double axis[N], double normal_force,
                              double velocity_amplitude, const double B[N * N],
                              const double v_free[N], double u[N], double force[N]);

struct AveragedConfig {
  // mu, static_ratio, stribeck_velocity, viscous: the no-vibration law (v_a = 0, or use_ctrl
  // with ctrl <= 0). With vibration the table already holds the averaged Stribeck curve.
  LawParameters coulomb;
  NormalLoad normal;
  PlanarTransmission transmission;
  AveragedTable table;
  double velocity_amplitude = 0;  // v_a (m/s) the table was made for
  double axis_angle = 0;          // vibration axis, from the x transmission towards y (rad)
  double axis_cos = 1, axis_sin = 0;
  bool use_ctrl = false;          // ctrl of the x actuator scales v_a

  static bool FromModel(const mjModel* m, int instance, AveragedConfig* config,
                        ReadScope scope = ReadScope::kAll);
};

class AveragedFriction {
 public:
  static constexpr char kName[] = "vibrofriction.averaged";
  // F_x, F_y, 0, 0, v_x, v_y, F_N (same layout as planar; F_N unclamped: < 0 when lifted off)
  static constexpr int kSensorDim = 7;

  // From a validated config (SetPluginCallbacks builds one per plugin instance).
  explicit AveragedFriction(CachedConfig<AveragedConfig> config) : config_(std::move(config)) {}
  static void RegisterPlugin();
  static int StateSize(const mjModel* m, int instance) {
    return NormalLoad::StateSize(m, instance);
  }

  void Compute(const mjModel* m, mjData* d, int instance);
  // Writes kSensorDim values of this element's state to `out` (vibrofriction.*_sensor).
  void WriteSensor(const mjModel* m, mjData* d, int instance, mjtNum* out);
  void Advance(const mjModel* m, mjData* d, int instance);

 private:
  CachedConfig<AveragedConfig> config_;
  std::vector<mjtNum> scratch_;
};

// Registers vibrofriction.planar and vibrofriction.averaged.
void RegisterPlanarPlugins();

}  // namespace vibrofriction

#endif  // VIBROFRICTION_AVERAGED_FRICTION_H_
