// The one place that names concrete modules: a new module is its own file plus one line here.
// The order of module_kinds() is the order forces are summed (contacts, walls, body forces):
// part of what makes runs reproducible.
#include "core/ModuleRegistry.hpp"

#include "core/Config.hpp"
#include "core/Simulation.hpp"
#include "physics/channel/ChannelWalls.hpp"
#include "physics/channel/ClogMonitor.hpp"
#include "physics/contact/ContactForces.hpp"
#include "physics/Gravity.hpp"
#include "physics/Guards.hpp"
#include "physics/ring/HillFrame.hpp"
#include "physics/channel/Inlet.hpp"
#include "physics/channel/Lubrication.hpp"
#include "physics/ring/Moonlet.hpp"
#include "physics/ring/MultiRateHill.hpp"
#include "physics/contact/PlaneWalls.hpp"
#include "physics/ring/SelfGravity.hpp"
#include "physics/channel/StokesDrag.hpp"
#include "physics/VelocityVerlet.hpp"

namespace cassini {

const std::vector<ModuleKind>& module_kinds() {
  static const std::vector<ModuleKind> kinds = {
      ContactForces::kind(),  // "contact"
      Lubrication::kind(),    // "lubrication"
      PlaneWalls::kind(),     // "walls"
      ChannelWalls::kind(),   // "channel"
      StokesDrag::kind(),     // "drag"
      Inlet::kind(),          // "inlet"
      ClogMonitor::kind(),    // "clog"
      Moonlet::kind(),        // "moonlet"
      HillFrame::kind(),      // "hill"
      Gravity::kind(),        // "gravity"
      SelfGravity::kind(),    // "self-gravity"
  };
  return kinds;
}

const std::vector<ModuleKind>& integrator_kinds() {
  static const std::vector<ModuleKind> kinds = {VelocityVerlet::kind(), MultiRateHill::kind()};
  return kinds;
}

std::unique_ptr<Module> make_guards(Simulation& sim) {
  return std::make_unique<Guards>(sim.cfg.max_overlap_fraction, sim.cfg.energy_growth, sim.cfg.max_step);
}

}  // namespace cassini
