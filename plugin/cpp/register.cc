// Registers the vibrofriction engine plugins when the library is loaded
// (vibrofriction.load() calls mj_loadPluginLibrary on it).
#include <mujoco/mjplugin.h>

#include "averaged_friction.h"  // vibrofriction.planar, vibrofriction.averaged
#include "contact_friction.h"
#include "friction_element.h"
#include "lagged_tendon.h"
#include "sampled_pd.h"
#include "state_sensor.h"
#include "support_motion.h"

mjPLUGIN_LIB_INIT(vibrofriction) {
  vibrofriction::FrictionElement::RegisterPlugin();
  vibrofriction::SupportMotion::RegisterPlugin();
  vibrofriction::RegisterPlanarPlugins();
  vibrofriction::RegisterContactPlugins();
  vibrofriction::RegisterStateSensors();
  vibrofriction::LaggedTendon::RegisterPlugin();
  vibrofriction::SampledPd::RegisterPlugin();
}
