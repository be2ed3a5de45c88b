#include "physics/PlaneWalls.hpp"

#include "core/Simulation.hpp"
#include "physics/WallContact.hpp"

namespace cassini {

std::vector<Plane> domain_walls(const Config& cfg) {
  std::vector<Plane> planes;
  for (int d = 0; d < 3; ++d) {
    if (cfg.boundary[d] != Boundary::Wall) continue;
    Vec3 n = Vec3::Zero();
    n[d] = 1;
    planes.push_back({cfg.lo, n});
    planes.push_back({cfg.hi, -n});
  }
  return planes;
}

ModuleKind PlaneWalls::kind() {
  auto make = [](Simulation& sim) {
    const int planes = static_cast<int>(domain_walls(sim.cfg).size());
    return std::make_unique<PlaneWalls>(sim.cfg, sim.dt, sim.claim_wall_slots(planes));
  };
  return {"walls", {}, nullptr, make};
}

PlaneWalls::PlaneWalls(const Config& cfg, double dt, int first_slot)
    : law_(cfg, dt), planes_(domain_walls(cfg)), first_slot_(first_slot) {}

void PlaneWalls::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const int nw = static_cast<int>(planes_.size());
  DeepestOverlap deepest;
  shifts_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double a = p.radius[i];
    Vec3 move = Vec3::Zero();
    for (int w = 0; w < nw; ++w) {
      const Plane& pl = planes_[w];
      const double delta = a - (p.x[i] - pl.point).dot(pl.normal);
      if (wall_contact(law_, p, i, pl.normal, delta, wall_springs(p, law_.friction(), i, first_slot_ + w), move))
        deepest.see(delta, a, p.id[i]);
    }
    if (!move.isZero(0)) shifts_.add(i, move);
  }
  max_overlap_ = deepest.fraction;
  worst_id_ = deepest.id;
}

void PlaneWalls::wall_forces(const Simulation& sim, std::vector<WallForce>& out) const {
  const ParticleStore& p = sim.particles;
  const int nw = static_cast<int>(planes_.size());
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (int w = 0; w < nw; ++w) {
      const Plane& pl = planes_[w];
      const double s = (p.x[i] - pl.point).dot(pl.normal);
      if (s >= p.radius[i]) continue;
      const Vec3 f = wall_contact_force(law_, p, i, pl.normal, p.radius[i] - s, first_slot_ + w);
      out.push_back({p.id[i], p.x[i] - s * pl.normal, s * pl.normal, f});
    }
}

void PlaneWalls::final_integrate(Simulation& sim) { shifts_.apply(sim.particles); }

}  // namespace cassini
