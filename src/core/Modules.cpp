#include "core/Modules.hpp"

#include "core/Simulation.hpp"
#include "physics/ContactForces.hpp"
#include "physics/Gravity.hpp"
#include "physics/Guards.hpp"
#include "physics/PlaneWalls.hpp"
#include "physics/VelocityVerlet.hpp"

namespace cassini {

void Gravity::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) p.f[i] += p.mass[i] * g_;
}

std::vector<std::unique_ptr<Module>> make_modules(const Config& cfg, Simulation& sim) {
  std::vector<std::unique_ptr<Module>> m;
  m.push_back(std::make_unique<VelocityVerlet>(cfg.planar));
  // Force order is fixed (contacts, walls, body forces): part of what makes runs reproducible.
  if (cfg.has_module("contact")) m.push_back(std::make_unique<ContactForces>(cfg, sim.dt));
  if (cfg.has_module("walls")) m.push_back(std::make_unique<PlaneWalls>(cfg, sim.dt));
  if (cfg.has_module("gravity")) m.push_back(std::make_unique<Gravity>(cfg.gravity));
  m.push_back(std::make_unique<Guards>(cfg.max_overlap_fraction, cfg.energy_growth, cfg.has_module("gravity")));
  return m;
}

}  // namespace cassini
