#include "plugin_util.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

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
  if (end == text || (end && *end != '\0') || errno == ERANGE || !std::isfinite(value)) {
    mju_warning("%s: attribute '%s'=\"%s\" is not a finite number; write a plain number, "
                "e.g. %s=\"%g\"", plugin, attr, text, attr, default_value);
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

StepResponse ComputeStepResponse(const mjModel* m, mjData* d, int out,
                                 std::vector<mjtNum>* scratch) {
  const int nv = m->nv;
  if (scratch->size() < static_cast<std::size_t>(3 * nv)) scratch->resize(3 * nv);
  mjtNum* force = scratch->data();
  mjtNum* row = force + nv;
  mjtNum* response_row = force + 2 * nv;

  // Generalized force known so far: passive - bias + applied + other actuators' outputs.
  for (int i = 0; i < nv; ++i) {
    force[i] = d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_applied[i];
    row[i] = 0;
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
  for (int k = 0; k < nnz; ++k) row[d->moment_colind[adr + k]] = d->actuator_moment[adr + k];

  // One solve, M^-1 J': M is symmetric, so J M^-1 force = (M^-1 J') . force.
  mj_solveM(m, d, response_row, row, 1);
  StepResponse response;
  double acceleration_free = 0.0;
  for (int i = 0; i < nv; ++i) acceleration_free += response_row[i] * force[i];
  for (int k = 0; k < nnz; ++k) {
    response.inverse_mass += d->actuator_moment[adr + k] * response_row[d->moment_colind[adr + k]];
  }
  response.velocity_free = d->actuator_velocity[out] + m->opt.timestep * acceleration_free;
  return response;
}

}  // namespace vibrofriction
