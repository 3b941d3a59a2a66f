#include "plugins/state_sensor.h"

#include <cstring>
#include <memory>
#include <string>
#include <utility>

#include <mujoco/mujoco.h>

#include "common/plugin_util.h"
#include "vocabulary.h"  // generated from vibrofriction/vocabulary.py
#include "plugins/averaged_friction.h"
#include "plugins/friction_element.h"
#include "plugins/planar_friction.h"

namespace vibrofriction {
namespace {

using namespace keys;  // NOLINT: the MJCF keys (vocabulary.h)

using Writer = void (*)(const mjModel* m, mjData* d, int instance, mjtNum* out);

template <class Element>
void Write(const mjModel* m, mjData* d, int instance, mjtNum* out) {
  InstanceOf<Element>(d, instance)->WriteSensor(m, d, instance, out);
}

// The elements a sensor plugin can read, and their writers.
struct FrictionSensorSpec {
  static constexpr char kName[] = "vibrofriction.friction_sensor";
  static constexpr char kElements[] = "vibrofriction.friction";
  static constexpr const auto& kAttributes = attributes::kFrictionSensor;
  static constexpr int kDim = FrictionElement::kSensorDim;
  static Writer Resolve(const char* element) {
    return std::strcmp(element, FrictionElement::kName) == 0 ? &Write<FrictionElement> : nullptr;
  }
};

struct PlanarSensorSpec {
  static constexpr char kName[] = "vibrofriction.planar_sensor";
  static constexpr char kElements[] = "vibrofriction.planar or vibrofriction.averaged";
  static constexpr const auto& kAttributes = attributes::kPlanarSensor;
  static constexpr int kDim = PlanarFriction::kSensorDim;
  static_assert(AveragedFriction::kSensorDim == PlanarFriction::kSensorDim, "same layout");
  static Writer Resolve(const char* element) {
    if (std::strcmp(element, PlanarFriction::kName) == 0) return &Write<PlanarFriction>;
    if (std::strcmp(element, AveragedFriction::kName) == 0) return &Write<AveragedFriction>;
    return nullptr;
  }
};

struct SensorConfig {
  int element = -1;          // plugin instance of the friction element
  Writer write = nullptr;

  // Every check holds while compiling (actuator names, actuator_plugin): scope does not matter.
  template <class Spec>
  static bool FromModel(const mjModel* m, int instance, SensorConfig* config,
                        ReadScope /*scope*/) {
    const char* name = mj_getPluginConfig(m, instance, kActuator);
    if (name == nullptr || name[0] == '\0') {
      ConfigError("%s: attribute 'actuator' is missing; name the actuator of a %s element, "
                  "e.g. <config key=\"actuator\" value=\"friction\"/>", Spec::kName,
                  Spec::kElements);
      return false;
    }
    const int actuator = mj_name2id(m, mjOBJ_ACTUATOR, name);
    if (actuator < 0) {
      ConfigError("%s: attribute 'actuator'=\"%s\" names no actuator; use the name of the "
                  "friction element's actuator", Spec::kName, name);
      return false;
    }
    const int element = m->actuator_plugin[actuator];
    const mjpPlugin* plugin = element >= 0 ? mjp_getPluginAtSlot(m->plugin[element]) : nullptr;
    const Writer write = plugin ? Spec::Resolve(plugin->name) : nullptr;
    if (write == nullptr) {
      ConfigError("%s: attribute 'actuator'=\"%s\" is not backed by %s; name an actuator "
                  "<plugin> of that element", Spec::kName, name, Spec::kElements);
      return false;
    }
    config->element = element;
    config->write = write;
    return true;
  }
};

template <class Spec>
class StateSensor {
 public:
  explicit StateSensor(CachedConfig<SensorConfig> config) : config_(std::move(config)) {}
  static int StateSize(const mjModel* m, int instance) { return 0; }

  void Compute(const mjModel* m, mjData* d, int instance) {
    for (int s : sensors_.Of(m, instance)) {
      mjtNum* out = d->sensordata + m->sensor_adr[s];
      if (config_.Refresh(m, instance)) {
        config_->write(m, d, config_->element, out);
      } else {
        mju_zero(out, Spec::kDim);
      }
    }
  }

  static void RegisterPlugin() {
    // after actuation (acceleration stage): this step's friction force
    RegisterElementPlugin<StateSensor, &SensorConfig::FromModel<Spec>, Spec::kDim, mjSTAGE_ACC>(
        Spec::kName, Spec::kAttributes, mjPLUGIN_SENSOR);
  }

 private:
  CachedConfig<SensorConfig> config_;
  InstanceSensors sensors_;
};

}  // namespace

void RegisterStateSensors() {
  StateSensor<FrictionSensorSpec>::RegisterPlugin();
  StateSensor<PlanarSensorSpec>::RegisterPlugin();
}

}  // namespace vibrofriction
