#include "core/Modules.hpp"

#include "core/Simulation.hpp"
#include "physics/ChannelWalls.hpp"
#include "physics/ClogMonitor.hpp"
#include "physics/ContactForces.hpp"
#include "physics/Inlet.hpp"
#include "physics/Lubrication.hpp"
#include "physics/StokesDrag.hpp"
#include "physics/Gravity.hpp"
#include "physics/Guards.hpp"
#include "physics/HillFrame.hpp"
#include "physics/Moonlet.hpp"
#include "physics/MultiRateHill.hpp"
#include "physics/PlaneWalls.hpp"
#include "physics/SelfGravity.hpp"
#include "physics/VelocityVerlet.hpp"

namespace cassini {

// The particles' wall-spring columns: domain planes first, then channel features, then the moonlet.
int moonlet_wall_slot(const Config& cfg) {
  int slot = static_cast<int>(domain_walls(cfg).size());
  if (cfg.has_module("channel")) slot += ChannelGeometry(cfg.channel).features();
  return slot;
}

std::vector<std::unique_ptr<Module>> make_modules(const Config& cfg, Simulation& sim) {
  std::vector<std::unique_ptr<Module>> m;
  if (cfg.integrator == "multirate") {
    m.push_back(std::make_unique<MultiRateHill>(cfg, sim.dt));
  } else {
    auto integrator = std::make_unique<VelocityVerlet>(cfg.planar);
    if (cfg.has_module("hill")) integrator->set_frame_rotation(cfg.omega0());
    m.push_back(std::move(integrator));
  }
  // Force order is fixed (contacts, walls, body forces): part of what makes runs reproducible.
  if (cfg.has_module("contact")) m.push_back(std::make_unique<ContactForces>(cfg, sim.dt));
  if (cfg.has_module("lubrication")) m.push_back(std::make_unique<Lubrication>(cfg, sim.dt));
  if (cfg.has_module("walls")) m.push_back(std::make_unique<PlaneWalls>(cfg, sim.dt));
  if (cfg.has_module("channel")) {
    auto walls = std::make_unique<ChannelWalls>(cfg, sim.dt, static_cast<int>(domain_walls(cfg).size()));
    const ChannelGeometry& geo = walls->geometry();
    m.push_back(std::move(walls));
    if (cfg.has_module("drag")) m.push_back(std::make_unique<StokesDrag>(cfg, geo));
    if (cfg.has_module("inlet")) m.push_back(std::make_unique<Inlet>(cfg, geo));
    if (cfg.has_module("clog")) m.push_back(std::make_unique<ClogMonitor>(cfg));
  }
  if (cfg.has_module("moonlet")) m.push_back(std::make_unique<Moonlet>(cfg, sim.dt, moonlet_wall_slot(cfg)));
  if (cfg.has_module("hill")) m.push_back(std::make_unique<HillFrame>(cfg));
  if (cfg.has_module("gravity")) m.push_back(std::make_unique<Gravity>(cfg.gravity));
  if (cfg.has_module("self-gravity")) m.push_back(std::make_unique<SelfGravity>(cfg, sim.domain));
  // Last: the guards see every module's potential energy and energy input.
  m.push_back(std::make_unique<Guards>(cfg.max_overlap_fraction, cfg.energy_growth, cfg.max_step));
  return m;
}

}  // namespace cassini
