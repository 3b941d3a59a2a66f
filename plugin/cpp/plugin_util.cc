#include "plugin_util.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace vibrofriction {

bool ReadNumber(const mjModel* m, int instance, const char* plugin, const char* attr,
                double default_value, double* out) {
  const char* text = mj_getPluginConfig(m, instance, attr);
  if (text == nullptr || text[0] == '\0') {
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
    mju_warning("%s: attribute '%s'=\"%s\" is not a finite number in decimal notation; write "
                "a plain number, e.g. %s=\"%g\"", plugin, attr, text, attr, default_value);
    return false;
  }
  if (errno == ERANGE) {  // underflow: the text is not zero but reads as 0 or a denormal
    mju_warning("%s: attribute '%s'=\"%s\" is too small to represent (below 2.2e-308); write 0 "
                "or a number of normal size", plugin, attr, text);
    return false;
  }
  if (std::fabs(value) > kLargestAttribute) {
    mju_warning("%s: attribute '%s'=\"%s\" is beyond +-%g, past any physical value (SI units); "
                "check the unit", plugin, attr, text, kLargestAttribute);
    return false;
  }
  *out = value;
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
  mju_warning("%s: attribute '%s'=\"%s\" must be \"true\" or \"false\"", plugin, attr, text);
  return false;
}

std::string ConfigFingerprint(const mjModel* m, int instance) {
  const int begin = m->plugin_attradr[instance];
  const int end = instance + 1 < m->nplugin ? m->plugin_attradr[instance + 1] : m->npluginattr;
  return std::string(m->plugin_attr + begin, m->plugin_attr + end);
}

int FindActuator(const mjModel* m, int instance, const char* plugin) {
  int found = -1;
  for (int i = 0; i < m->nu; ++i) {
    if (m->actuator_plugin[i] != instance) continue;
    if (found != -1) {
      mju_warning("%s: one plugin instance backs several actuators; give each actuator its "
                  "own <plugin> element", plugin);
      return -1;
    }
    found = i;
  }
  if (found == -1) {
    mju_warning("%s: no actuator uses this plugin instance; reference it from an "
                "<actuator><plugin .../> element", plugin);
  }
  return found;
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

}  // namespace vibrofriction
