#include "common/plugin_util.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "common/element_config.h"

namespace vibrofriction {
namespace {

// MuJoCo's compiler keeps 500 characters of an error: the message and the element's names fit.
constexpr int kMessageSize = 480;
thread_local char config_error[kMessageSize] = "";
thread_local char report[kMessageSize] = "";

// Physical ranges (SI) of the numeric attributes: the table's limits (vocabulary.py's, through
// the generated vocabulary.h): far past any rig or machine, small enough that a step stays
// finite. A key without limits there takes AttributeRange's default.
const KeyRange* FindRange(const char* attr) {
  for (const KeyRange& named : kKeyRanges) {
    if (std::strcmp(named.key, attr) == 0) return &named;
  }
  return nullptr;
}

AttributeRange RangeOf(const KeyRange* named) {
  return named ? AttributeRange{named->smallest_nonzero, named->largest} : AttributeRange{};
}

}  // namespace

bool ConfigError(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::vsnprintf(config_error, sizeof(config_error), format, args);
  va_end(args);
  return false;
}

void ReportConfigError(const mjModel* m, int instance, bool fatal) {
  // Plain buffers only: mju_error leaves this frame by longjmp inside MuJoCo's compiler.
  const mjpPlugin* plugin = mjp_getPluginAtSlot(m->plugin[instance]);
  const char* name = plugin && plugin->name ? plugin->name : "vibrofriction";
  const std::size_t length = std::strlen(name);
  const char* message = config_error;
  if (std::strncmp(message, name, length) == 0 && std::strncmp(message + length, ": ", 2) == 0) {
    message += length + 2;  // the element is named below, with its plugin
  }
  // Where: the instance's name and the actuators and sensors it backs.
  char where[160] = "";
  int used = 0;
  auto add = [&](const char* kind, const char* element, int id) {
    if (used >= static_cast<int>(sizeof(where)) - 1) return;
    const char* separator = used ? ", " : "";
    used += element && element[0]
                ? std::snprintf(where + used, sizeof(where) - used, "%s%s '%.40s'", separator,
                                kind, element)
                : std::snprintf(where + used, sizeof(where) - used, "%s%s %d", separator, kind,
                                id);
  };
  const char* instance_name = mj_id2name(m, mjOBJ_PLUGIN, instance);
  if (instance_name && instance_name[0]) add("instance", instance_name, instance);
  for (int i = 0; i < m->nactuator; ++i) {
    if (m->actuator_plugin[i] == instance) add("actuator", mj_id2name(m, mjOBJ_ACTUATOR, i), i);
  }
  for (int i = 0; i < m->nsensor; ++i) {
    if (m->sensor_plugin[i] == instance) add("sensor", mj_id2name(m, mjOBJ_SENSOR, i), i);
  }
  if (!used) add("plugin instance", nullptr, instance);
  std::snprintf(report, sizeof(report), "%s (%s): %s", name, where, message);
  if (fatal) {
    mju_error("%s", report);
  } else {
    mju_warning("%s", report);
  }
}

bool CheckIntegrator(const mjModel* m, const char* plugin) {
  if (m->opt.integrator != mjINT_RK4) return true;
  return ConfigError("%s: option integrator=\"RK4\" is not supported: the plugin assumes one "
                     "semi-implicit Euler step per force (RK4 evaluates it at four intermediate "
                     "states); write <option integrator=\"Euler\"/> (or \"implicitfast\")",
                     plugin);
}

bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double default_value, double* out) {
  const char* text = mj_getPluginConfig(m, instance, attr);
  if (text == nullptr || text[0] == '\0') {  // absent, or value="": MuJoCo stores both as ""
    *out = default_value;
    return true;
  }
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text, &end);
  while (end && (*end == ' ' || *end == '\t')) ++end;
  // strtod also reads hexadecimal ("0x10") and "inf"/"nan": only plain decimal numbers pass
  const bool hexadecimal = std::strpbrk(text, "xXpP") != nullptr;
  if (end == text || (end && *end != '\0') || hexadecimal ||
      (errno == ERANGE && std::fabs(value) > 1) || !std::isfinite(value)) {
    return ConfigError("%s: attribute '%s'=\"%.40s\" is not a finite number in decimal "
                       "notation; write a plain number, e.g. %s=\"%g\"", plugin, attr, text,
                       attr, default_value);
  }
  if (errno == ERANGE) {  // underflow: the text is not zero but reads as 0 or a denormal
    return ConfigError("%s: attribute '%s'=\"%.40s\" is too small to represent (below "
                       "2.2e-308); write 0 or a number of normal size", plugin, attr, text);
  }
  const KeyRange* named = FindRange(attr);
  const AttributeRange range = RangeOf(named);
  const double magnitude = std::fabs(value);
  if (magnitude > range.largest || (magnitude > 0 && magnitude < range.smallest)) {
    if (!named) {
      return ConfigError("%s: attribute '%s'=\"%.40s\" is beyond +-%g, past any physical "
                         "value (SI units); check the unit", plugin, attr, text,
                         kLargestAttribute);
    }
    char smallest[64] = "";
    if (range.smallest > 0) {
      std::snprintf(smallest, sizeof(smallest), " and be 0 or at least %g in magnitude",
                    range.smallest);
    }
    return ConfigError("%s: attribute '%s'=\"%.40s\" is out of its physical range: it must lie "
                       "within +-%g%s (SI units); check the unit", plugin, attr, text,
                       range.largest, smallest);
  }
  *out = value;
  return true;
}

bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double* out) {
  for (const KeyDefault& entry : kKeyDefaults) {
    if (std::strcmp(entry.key, attr) == 0) {
      return ReadNumber(m, instance, plugin, attr, entry.value, out);
    }
  }
  return ConfigError("%s: attribute '%s' has no default number in the vocabulary (a bug: "
                     "report it)", plugin, attr);
}

bool ReadNumbers(const mjModel* m, int instance, const char* plugin,
                 std::initializer_list<NumberKey> numbers) {
  for (const NumberKey& number : numbers) {
    if (!ReadNumber(m, instance, plugin, number.attr, number.target)) return false;
  }
  return true;
}

bool ReadBool(const mjModel* m, int instance, const char* plugin, const char* attr,
              bool default_value, bool* out) {
  const char* text = mj_getPluginConfig(m, instance, attr);
  if (text == nullptr || text[0] == '\0') {
    *out = default_value;
    return true;
  }
  if (std::strcmp(text, "true") == 0 || std::strcmp(text, "false") == 0) {
    *out = text[0] == 't';
    return true;
  }
  return ConfigError("%s: attribute '%s'=\"%.40s\" must be \"true\" or \"false\"", plugin,
                     attr, text);
}

std::uint64_t NumberListChecksum(std::initializer_list<const std::vector<double>*> lists) {
  std::uint64_t hash = 14695981039346656037ull;
  auto add = [&hash](std::uint64_t word) {
    for (int k = 0; k < 8; ++k) {
      hash ^= (word >> (8 * k)) & 0xffu;
      hash *= 1099511628211ull;
    }
  };
  for (const std::vector<double>* list : lists) {
    add(list->size());
    for (const double value : *list) {
      std::uint64_t bits;
      std::memcpy(&bits, &value, sizeof bits);
      add(bits);
    }
  }
  return hash;
}

ConfigFingerprint FingerprintOf(const mjModel* m, int instance, bool checksum_verified) {
  const auto [block, size] = ConfigBlock(m, instance);
  ConfigFingerprint fingerprint;
  fingerprint.bytes.assign(block, block + size);
  std::vector<std::pair<std::size_t, std::size_t>> skipped;
  const char* checksum = mj_getPluginConfig(m, instance, keys::kTableChecksum);
  if (checksum_verified && checksum && checksum[0]) {
    for (const char* key : keys::kTableLists) {
      const char* value = mj_getPluginConfig(m, instance, key);
      if (!value) continue;
      if (value < block || value >= block + size) {  // not in place: all
        skipped.clear();
        break;
      }
      const std::size_t from = static_cast<std::size_t>(value - block);
      skipped.emplace_back(from, from + std::strlen(value));  // its terminator stays compared
    }
    std::sort(skipped.begin(), skipped.end());
  }
  std::size_t from = 0;
  for (const auto& [skip_from, skip_to] : skipped) {
    if (skip_from > from) fingerprint.compared.emplace_back(from, skip_from);
    from = skip_to;
  }
  if (fingerprint.bytes.size() > from) {
    fingerprint.compared.emplace_back(from, fingerprint.bytes.size());
  }
  return fingerprint;
}

int FindActuator(const mjModel* m, int instance, const char* plugin) {
  int found = -1;
  for (int i = 0; i < m->nactuator; ++i) {
    if (m->actuator_plugin[i] != instance) continue;
    if (found != -1) {
      ConfigError("%s: one plugin instance backs several actuators; give each actuator its "
                  "own <plugin> element", plugin);
      return -1;
    }
    found = i;
  }
  if (found == -1) {
    ConfigError("%s: no actuator uses this plugin instance; reference it from an "
                "<actuator><plugin .../> element", plugin);
  }
  return found;
}

void TransmissionTrees(const mjModel* m, int actuator, std::vector<int>* trees) {
  const int id = m->actuator_trnid[2 * actuator];
  auto add_joint = [&](int joint) {
    if (joint >= 0 && m->jnt_dofadr[joint] >= 0) {
      trees->push_back(m->dof_treeid[m->jnt_dofadr[joint]]);
    }
  };
  switch (m->actuator_trntype[actuator]) {
    case mjTRN_JOINT:
    case mjTRN_JOINTINPARENT:
      add_joint(id);
      break;
    case mjTRN_TENDON:
      for (int w = m->tendon_adr[id]; w < m->tendon_adr[id] + m->tendon_num[id]; ++w) {
        if (m->wrap_type[w] == mjWRAP_JOINT) add_joint(m->wrap_objid[w]);
      }
      break;
    default:
      trees->push_back(-1);
  }
}

double TransmissionVelocity(const mjModel* m, const mjData* d, int out) {
  const int adr = d->moment_rowadr[out];
  double velocity = 0.0;
  for (int k = 0; k < d->moment_rownnz[out]; ++k) {
    velocity += d->actuator_moment[adr + k] * d->qvel[d->moment_colind[adr + k]];
  }
  return velocity;
}

namespace {

// Bitwise equality of a few numbers, inline (memcmp calls cost more than these short rows).
template <class T>
bool SameBits(const T* a, const T* b, std::size_t n) {
  static_assert(sizeof(T) == 8 || sizeof(T) == 4);
  using Word = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
  for (std::size_t i = 0; i < n; ++i) {
    Word x, y;
    std::memcpy(&x, a + i, sizeof(T));
    std::memcpy(&y, b + i, sizeof(T));
    if (x != y) return false;
  }
  return true;
}

}  // namespace

StepResponse ComputeStepResponse(const mjModel* m, mjData* d, int out,
                                 StepResponseWorkspace* w) {
  const int nv = m->nv;
  const std::size_t nC = static_cast<std::size_t>(m->nC);
  w->force.resize(nv);
  mjtNum* force = w->force.data();

  // Generalized force known so far: passive - bias + applied + other actuators' outputs.
  for (int i = 0; i < nv; ++i) {
    force[i] = d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_applied[i];
  }
  for (int j = 0; j < m->nout; ++j) {
    if (j == out || d->actuator_force[j] == 0) continue;
    const int adr = d->moment_rowadr[j];
    for (int k = 0; k < d->moment_rownnz[j]; ++k) {
      force[d->moment_colind[adr + k]] += d->actuator_moment[adr + k] * d->actuator_force[j];
    }
  }
  const int adr = d->moment_rowadr[out];
  const int nnz = d->moment_rownnz[out];
  const mjtNum* moment = d->actuator_moment + adr;
  const int* colind = d->moment_colind + adr;

  // M^-1 J' (one solve; M is symmetric, so J M^-1 force = (M^-1 J') . force), reused while the
  // factorization of M and the row J are unchanged.
  const bool reuse = w->model == m && w->solution.size() == static_cast<std::size_t>(nv) &&
                     w->factor.size() == nC + nv &&
                     w->moment.size() == static_cast<std::size_t>(nnz) &&
                     SameBits(w->factor.data(), d->qLD, nC) &&
                     SameBits(w->factor.data() + nC, d->qLDiagInv, nv) &&
                     SameBits(w->moment.data(), moment, nnz) &&
                     SameBits(w->colind.data(), colind, nnz);
  if (!reuse) {
    w->model = m;
    w->factor.assign(d->qLD, d->qLD + nC);
    w->factor.insert(w->factor.end(), d->qLDiagInv, d->qLDiagInv + nv);
    w->moment.assign(moment, moment + nnz);
    w->colind.assign(colind, colind + nnz);
    w->row.assign(nv, 0.0);
    for (int k = 0; k < nnz; ++k) w->row[colind[k]] = moment[k];
    w->solution.resize(nv);
    mj_solveM(m, d, w->solution.data(), w->row.data(), 1);
  }
  const mjtNum* response_row = w->solution.data();
  StepResponse response;
  double acceleration_free = 0.0;
  for (int i = 0; i < nv; ++i) acceleration_free += response_row[i] * force[i];
  for (int k = 0; k < nnz; ++k) response.inverse_mass += moment[k] * response_row[colind[k]];
  response.velocity_free = d->actuator_velocity[out] + m->opt.timestep * acceleration_free;
  return response;
}

bool ReadNumberList(const mjModel* m, int instance, const char* plugin, const char* attr,
                    std::vector<double>* out) {
  out->clear();
  const char* text = mj_getPluginConfig(m, instance, attr);
  if (text == nullptr || text[0] == '\0') return true;
  const char* cursor = text;
  while (true) {
    while (*cursor == ' ' || *cursor == '\t' || *cursor == '\n' || *cursor == '\r') ++cursor;
    if (*cursor == '\0') break;
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(cursor, &end);
    // as ReadNumber: plain decimals only (strtod also reads "0x10", "1p3", "inf")
    bool decimal = end != cursor;
    for (const char* c = cursor; decimal && c < end; ++c) {
      decimal = *c != 'x' && *c != 'X' && *c != 'p' && *c != 'P';
    }
    if (!decimal || errno == ERANGE || !std::isfinite(value) ||
        !(*end == '\0' || *end == ' ' || *end == '\t' || *end == '\n' || *end == '\r')) {
      return ConfigError("%s: attribute '%s' has a non-number at position %d; write finite "
                         "decimal numbers separated by spaces", plugin, attr,
                         static_cast<int>(cursor - text));
    }
    const KeyRange* named = FindRange(attr);
    const AttributeRange range = RangeOf(named);
    if (std::fabs(value) > range.largest || (value != 0 && std::fabs(value) < range.smallest)) {
      char smallest[64] = "";
      if (range.smallest > 0) {
        std::snprintf(smallest, sizeof(smallest), " and be 0 or at least %g in magnitude",
                      range.smallest);
      }
      return ConfigError("%s: attribute '%s'=\"%.40s\" holds %g, out of its physical range: "
                         "each value must lie within +-%g%s (SI units); check the unit", plugin,
                         attr, text, value, range.largest, smallest);
    }
    out->push_back(value);
    cursor = end;
  }
  return true;
}

}  // namespace vibrofriction
