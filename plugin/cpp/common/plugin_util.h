// Helpers shared by the vibrofriction engine plugins: strict config parsing, a per-model config
// fingerprint, and the response of one actuator transmission to a force over one step.
#ifndef VIBROFRICTION_PLUGIN_UTIL_H_
#define VIBROFRICTION_PLUGIN_UTIL_H_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

namespace vibrofriction {

// The largest magnitude a numeric attribute may have (SI units): far past any physical value,
// small enough that a step's arithmetic stays finite. Narrower ranges are checked per attribute.
inline constexpr double kLargestAttribute = 1e18;

// Physical range of a numeric attribute: 0 or a magnitude in [smallest, largest] (SI units).
// Each key has one range, whichever plugin reads it (kRanges in plugin_util.cc; those with a
// Python name equal vibrofriction.params.LIMITS, checked by tests/test_plugin_config.py).
struct AttributeRange {
  double smallest = 0.0;  // smallest non-zero magnitude (0: any)
  double largest = kLargestAttribute;
};

// Why a config is invalid. The readers record the message (ConfigError, one per failure, as
// "<plugin>: <what and the fix>") and return false; the plugin callbacks report it once,
// naming the element (ReportConfigError).
bool ConfigError(const char* format, ...) mjPRINTFLIKE(1, 2);

// Reports the recorded message as "<plugin> (instance 'name', actuator 'name'): <message>".
// fatal: mju_error (compile time, before mjData exists: MuJoCo's compiler shows exactly this
// text); otherwise mju_warning.
void ReportConfigError(const mjModel* m, int instance, bool fatal);

// What a config reader checks. kAttributes: the values alone, while MuJoCo's compiler queries
// the plugin's state size (names, joints, options and actuator_plugin are set; the actuators'
// transmissions, sensors and tendons are not yet). kAll: everything, with the complete model.
enum class ReadScope { kAttributes, kAll };

// Reads a numeric attribute; the whole string must be a finite decimal number (no hexadecimal,
// no underflow to 0) within the attribute's range (kLargestAttribute when it has none of its
// own). Returns false and records the error (naming plugin,
// attribute, value and the fix) when it is not. Missing -> default (an empty value="" is
// stored by MuJoCo exactly as a missing key: the plugin cannot tell them apart).
bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double default_value, double* out);
// The same with the table's default of `attr` (vocabulary.py, through the generated
// vocabulary.h): the one place a default is written. A key without a number as its default
// there is a programming error, reported as a config error naming it.
bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double* out);

// ReadNumber (the table's default) of each (key, target) in turn; false at the first that
// fails.
struct NumberKey {
  const char* attr;
  double* target;
};
bool ReadNumbers(const mjModel* m, int instance, const char* plugin,
                 std::initializer_list<NumberKey> numbers);

// Reads a whitespace-separated list of finite decimal numbers (each as ReadNumber's, at most
// kLargestAttribute in magnitude); a missing key gives an empty list.
bool ReadNumberList(const mjModel* m, int instance, const char* plugin, const char* attr,
                    std::vector<double>* out);

// Reads a "true"/"false" attribute (missing -> default); records an error naming it otherwise.
bool ReadBool(const mjModel* m, int instance, const char* plugin, const char* attr,
              bool default_value, bool* out);

// Refuses integrator="RK4" (records the error and returns false): the friction elements' stick
// solve and state update and the motion's landing on s(t + dt) assume one semi-implicit Euler
// step per force; RK4 calls compute at four intermediate states. Euler, implicit and
// implicitfast integrate the velocity by that step (README, "Time stepping").
bool CheckIntegrator(const mjModel* m, const char* plugin);

// FNV-1a (64 bit) over each list's length and then its numbers' bit patterns, least significant
// byte first: the `table_checksum` an averaged table states for its lists (written by
// vibrofriction/robots/averaged.py, checked when the config is read).
std::uint64_t NumberListChecksum(std::initializer_list<const std::vector<double>*> lists);

// Config bytes of an instance, and what of them the per-step check compares. Rollout and batch
// can step one mjData with several models, so plugins compare these each step, not a model
// pointer. An instance with a `table_checksum` (verified by its reader before the fingerprint
// is used) has its table lists' values left out of the comparison: the checksum's own text
// stands for them, and equal bytes elsewhere (terminators included) keep every value in its
// place, so for compiled models (whose checksum the compiler's reading verified) equal compared
// bytes <=> equal configuration, at a fraction of a 16 kB table's cost. Not seen: a table's
// bytes overwritten in place in mjModel.plugin_attr with its old checksum kept (the element
// keeps the table it read; docs/interfaces.md, table_checksum).
struct ConfigFingerprint {
  std::string bytes;  // the instance's whole config block
  std::vector<std::pair<std::size_t, std::size_t>> compared;  // [begin, end) offsets in bytes
};
// `checksum_verified`: the reader accepted the config, so a table_checksum in it is the
// checksum of its table (otherwise every byte is compared).
ConfigFingerprint FingerprintOf(const mjModel* m, int instance, bool checksum_verified);

// The instance's config block in m->plugin_attr: its values, each ended by '\0', in the
// plugin's attribute order.
inline std::pair<const char*, std::size_t> ConfigBlock(const mjModel* m, int instance) {
  const int begin = m->plugin_attradr[instance];
  const int end = instance + 1 < m->nplugin ? m->plugin_attradr[instance + 1] : m->npluginattr;
  return {m->plugin_attr + begin, static_cast<std::size_t>(end - begin)};
}

// True when the instance's config matches `fingerprint` in every compared byte (and in size);
// allocates nothing. Inline: the plugins call it every step.
inline bool ConfigUnchanged(const mjModel* m, int instance, const ConfigFingerprint& fingerprint) {
  const auto [block, size] = ConfigBlock(m, instance);
  if (size != fingerprint.bytes.size()) return false;
  for (const auto& [from, to] : fingerprint.compared) {
    if (std::memcmp(block + from, fingerprint.bytes.data() + from, to - from) != 0) return false;
  }
  return true;
}

// The parsed config of one plugin instance, re-read when stepped with a model whose config
// bytes differ (rollout and batch can step one mjData with several models; a cached config
// would silently keep the first model's values). The bytes are compared in full in the first
// callback of every step (a pointer alone can be reused by a model compiled after another was
// freed; a spot check of the edges let such a model run the other's table). Later callbacks of
// the same step (later_in_step) only check the model pointer.
template <class Config>
class CachedConfig {
 public:
  using ConfigType = Config;
  using Reader = bool (*)(const mjModel* m, int instance, Config* config, ReadScope scope);

  // The config of `instance`, or nullopt when it is invalid (the reader has recorded why).
  static std::optional<CachedConfig> Load(Reader read, const mjModel* m, int instance) {
    Config config;
    if (!read(m, instance, &config, ReadScope::kAll)) return std::nullopt;
    return CachedConfig(read, std::move(config), FingerprintOf(m, instance, true), m);
  }

  // False when the config of `m` is invalid (warned once, naming the element and attribute).
  bool Refresh(const mjModel* m, int instance, bool later_in_step = false) {
    // exact: a model freed and another compiled at its address must not pass for it
    if (m == model_ && (later_in_step || ConfigUnchanged(m, instance, fingerprint_))) {
      return valid_;
    }
    return Reload(m, instance);
  }
  const Config& operator*() const { return config_; }
  const Config* operator->() const { return &config_; }

 private:
  CachedConfig(Reader read, Config config, ConfigFingerprint fingerprint, const mjModel* model)
      : read_(read), config_(std::move(config)), fingerprint_(std::move(fingerprint)),
        model_(model) {}
  // Another model, or the same one with other config bytes: read again. (Another model with
  // equal bytes too: the config holds its ids -- bodies, geoms, sensors, dofs -- which come
  // from the model's tree, not from the bytes; a rollout may step one mjData with models whose
  // trees differ.)
  bool Reload(const mjModel* m, int instance) {
    model_ = m;
    valid_ = read_(m, instance, &config_, ReadScope::kAll);
    fingerprint_ = FingerprintOf(m, instance, valid_);
    if (!valid_) ReportConfigError(m, instance, /*fatal=*/false);
    return valid_;
  }
  Reader read_;
  Config config_;
  ConfigFingerprint fingerprint_;
  const mjModel* model_ = nullptr;  // compared, never dereferenced
  bool valid_ = true;
};

// CachedConfig<Config> for a reader bool(const mjModel*, int, Config*, ReadScope)
// (declaration only).
template <class Config>
CachedConfig<Config> ConfigOfReader(bool (*)(const mjModel*, int, Config*, ReadScope));

// Checks the attribute values of `instance` (ReadScope::kAttributes), false when invalid.
// Separate from the nstate callback so that no C++ object is alive when it raises mju_error.
template <auto Read>
bool AttributesValid(const mjModel* m, int instance) {
  typename decltype(ConfigOfReader(Read))::ConfigType config;
  return Read(m, instance, &config, ReadScope::kAttributes);
}

template <class T, class = void>
struct HasAdvance : std::false_type {};
template <class T>
struct HasAdvance<T, std::void_t<decltype(&T::Advance)>> : std::true_type {};

template <class T>
T* InstanceOf(mjData* d, int instance) {
  return reinterpret_cast<T*>(d->plugin_data[instance]);
}

// The plugin callbacks of a plugin class T, one T per instance in mjData.plugin_data:
// nstate checks the attribute values (Read with ReadScope::kAttributes) and raises one
// mju_error naming the element when one is invalid, then returns T::StateSize: MuJoCo's
// compiler calls it before it makes any mjData, so the error is its whole message and nothing
// leaks (an mju_error from init would leak the mjData being made; a failing init makes MuJoCo
// print "plugin->init failed" and the warning twice). init builds T from the config read by
// `Read` (bool Read(m, instance, Config*, ReadScope); T has a constructor from
// CachedConfig<Config>) and fails, warning once, on what only the complete model shows (a
// transmission, actdim); destroy deletes it; compute (and advance, when T has one) forward to
// T; reset zeroes the instance's plugin_state (contact force, lagged force: 0 before the first
// step, like z).
template <class T, auto Read>
void SetPluginCallbacks(mjpPlugin* plugin) {
  plugin->nstate = +[](const mjModel* m, int instance) {
    if (!AttributesValid<Read>(m, instance)) ReportConfigError(m, instance, /*fatal=*/true);
    return T::StateSize(m, instance);
  };
  plugin->init = +[](const mjModel* m, mjData* d, int instance) {
    auto config = decltype(ConfigOfReader(Read))::Load(Read, m, instance);
    if (!config) {
      ReportConfigError(m, instance, /*fatal=*/false);
      return -1;
    }
    d->plugin_data[instance] = reinterpret_cast<uintptr_t>(new T(std::move(*config)));
    return 0;
  };
  plugin->destroy = +[](mjData* d, int instance) {
    delete InstanceOf<T>(d, instance);
    d->plugin_data[instance] = 0;
  };
  plugin->reset = +[](const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
    mju_zero(plugin_state, m->plugin_statenum[instance]);
  };
  plugin->compute = +[](const mjModel* m, mjData* d, int instance, int capability_bit) {
    InstanceOf<T>(d, instance)->Compute(m, d, instance);
  };
  if constexpr (HasAdvance<T>::value) {
    plugin->advance = +[](const mjModel* m, mjData* d, int instance) {
      InstanceOf<T>(d, instance)->Advance(m, d, instance);
    };
  }
}

// Registers the plugin `name` of element class T: its config keys `attributes`, its
// capability (mjPLUGIN_ACTUATOR, _PASSIVE or _SENSOR), the callbacks of SetPluginCallbacks
// with the config reader Read; a sensor gives its number of values and the stage it needs.
template <class T, auto Read, int kSensorValues = 0, mjtStage kSensorStage = mjSTAGE_NONE,
          std::size_t N>
void RegisterElementPlugin(const char* name, const char* const (&attributes)[N],
                           int capability) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = name;
  plugin.capabilityflags |= capability;
  plugin.nattribute = static_cast<int>(N);
  plugin.attributes = attributes;
  if constexpr (kSensorValues > 0) {
    plugin.needstage = kSensorStage;
    plugin.nsensordata = +[](const mjModel*, int, int) { return kSensorValues; };
  }
  SetPluginCallbacks<T, Read>(&plugin);
  mjp_registerPlugin(&plugin);
}

// One step dt of the first-order lag tau y' + y = u, exact for u linear from previous_input to
// input over the step (first-order hold; previous_input == input: u held over the step). The
// friction element's sensor_lag (its force is held over a step) and the lagged_tendon sensor
// (a length, continuous) share it; tau -> 0 gives y = input.
inline double FirstOrderLagStep(double lagged, double previous_input, double input, double dt,
                                double tau) {
  const double one_minus_a = -std::expm1(-dt / tau);
  const double a = 1.0 - one_minus_a;
  const double ramp = a - tau / dt * one_minus_a;  // weight of the input's change over the step
  return a * lagged + (one_minus_a + ramp) * input - ramp * previous_input;
}

// The single actuator backed by `instance`, or -1 (with a warning) if none or several.
int FindActuator(const mjModel* m, int instance, const char* plugin);

// The kinematic trees (dof_treeid) an actuator's transmission moves: its joint's, or its fixed
// tendon's joints' (-1: a site or body transmission, taken as any).
void TransmissionTrees(const mjModel* m, int actuator, std::vector<int>* trees);

// Velocity of actuator output `out` for the current qvel (moment row times qvel). Used after
// integration, when mjData.actuator_velocity still holds the previous velocity.
double TransmissionVelocity(const mjModel* m, const mjData* d, int out);

// How actuator output `out` responds to a force over one semi-implicit Euler step:
// velocity_free is its velocity at the end of the step without this actuator's force, with
// every force known at this point (passive, bias, applied, actuators computed before this one);
// inverse_mass is J M^-1 J' so that v_next = velocity_free + timestep * inverse_mass * force.
struct StepResponse {
  double velocity_free = 0.0;
  double inverse_mass = 0.0;
};

// Working memory of ComputeStepResponse, one per plugin instance. It keeps M^-1 J' of the last
// call and reuses it while the factorization of M and the row J are bitwise the same (a rig of
// slide joints: every step; an arm whose inertia changes: never, at the cost of a comparison).
struct StepResponseWorkspace {
  const mjModel* model = nullptr;  // of the last solve (the sparsity of qLD is the model's)
  std::vector<mjtNum> force;     // generalized force known so far (nv)
  std::vector<mjtNum> row;       // J' (nv, dense), the right-hand side of a solve
  std::vector<mjtNum> factor;    // qLD and qLDiagInv at the last solve (nC + nv)
  std::vector<mjtNum> moment;    // the row J (sparse values and columns) at the last solve
  std::vector<int> colind;
  std::vector<mjtNum> solution;  // M^-1 J' of the last solve (nv)
};
StepResponse ComputeStepResponse(const mjModel* m, mjData* d, int out,
                                 StepResponseWorkspace* workspace);

// The sensors backed by one plugin instance, found once per model: scanning all of nsensor in
// every step of every instance made a model with N elements cost O(N^2) a step. Rescanned when
// the model pointer or its sensor count changes, or a cached id no longer names the instance.
class InstanceSensors {
 public:
  const std::vector<int>& Of(const mjModel* m, int instance) {
    bool valid = m == model_ && m->nsensor == nsensor_;
    for (int s : ids_) valid = valid && s < m->nsensor && m->sensor_plugin[s] == instance;
    if (!valid) {
      model_ = m;
      nsensor_ = m->nsensor;
      ids_.clear();
      for (int s = 0; s < m->nsensor; ++s) {
        if (m->sensor_plugin[s] == instance) ids_.push_back(s);
      }
    }
    return ids_;
  }

 private:
  const mjModel* model_ = nullptr;  // compared, never dereferenced
  int nsensor_ = -1;
  std::vector<int> ids_;
};

}  // namespace vibrofriction

#endif  // VIBROFRICTION_PLUGIN_UTIL_H_
