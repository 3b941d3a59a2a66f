// Registers the vibrofriction engine plugins when the library is loaded
// (vibrofriction.load() calls mj_loadPluginLibrary on it).
#include <mujoco/mjplugin.h>

#include "plugins/averaged_friction.h"  // vibrofriction.planar, vibrofriction.averaged
#include "plugins/contact_friction.h"
#include "plugins/friction_element.h"
#include "plugins/lagged_tendon.h"
#include "plugins/sampled_pd.h"
#include "plugins/state_sensor.h"
#include "plugins/support_motion.h"

mjPLUGIN_LIB_INIT(vibrofriction) {
  vibrofriction::FrictionElement::RegisterPlugin();
  vibrofriction::SupportMotion::RegisterPlugin();
  vibrofriction::RegisterPlanarPlugins();
  vibrofriction::RegisterContactPlugins();
  vibrofriction::RegisterStateSensors();
  vibrofriction::LaggedTendon::RegisterPlugin();
  vibrofriction::SampledPd::RegisterPlugin();
}
