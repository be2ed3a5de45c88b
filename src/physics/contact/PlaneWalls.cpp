#include "physics/contact/PlaneWalls.hpp"

#include "core/Simulation.hpp"
#include "physics/contact/WallContact.hpp"

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
    auto walls = std::make_unique<PlaneWalls>(sim.cfg, sim.dt);
    walls->history_ = WallHistory(sim.particles, "plane_wall", static_cast<int>(walls->planes_.size()), walls->law_);
    if (walls->law_.damping_limit()) walls->limit_ = DampingLimit::attach(sim.particles);
    return walls;
  };
  return {"walls", {}, nullptr, make};
}

PlaneWalls::PlaneWalls(const Config& cfg, double dt) : law_(cfg, dt), planes_(domain_walls(cfg)) {}

void PlaneWalls::post_rebuild(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const int nw = static_cast<int>(planes_.size());
  candidates_.assign(p.nlocal, 0);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (int w = 0; w < nw; ++w) {
      // Between rebuilds a particle moves less than skin / 2: a plane further than this is out of
      // reach, and its springs are zero already (cleared here all the same, as a guarantee).
      if ((p.x[i] - planes_[w].point).dot(planes_[w].normal) < p.radius[i] + sim.skin) {
        candidates_[i] |= std::uint8_t(1u << w);
        continue;
      }
      history_.forget(p, i, w);
    }
}

void PlaneWalls::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (candidates_.size() != p.nlocal) post_rebuild(sim);
  const int nw = static_cast<int>(planes_.size());
  DeepestOverlap deepest;
  shifts_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (!candidates_[i]) continue;  // most particles: far from every wall
    const double a = p.radius[i];
    Vec3 move = Vec3::Zero();
    for (int w = 0; w < nw; ++w) {
      if (!(candidates_[i] >> w & 1)) continue;
      const Plane& pl = planes_[w];
      const double delta = a - (p.x[i] - pl.point).dot(pl.normal);
      if (wall_contact(law_, p, i, pl.normal, delta, history_, w, move, 0, limit_, !sim.stepping.initial_forces))
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
      const Vec3 f = wall_contact_force(law_, p, i, pl.normal, p.radius[i] - s, history_, w);
      out.push_back({p.id[i], p.x[i] - s * pl.normal, s * pl.normal, f});
    }
}

double PlaneWalls::elastic_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  double e = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::size_t w = 0; w < planes_.size(); ++w) {
      const double delta = p.radius[i] - (p.x[i] - planes_[w].point).dot(planes_[w].normal);
      if (delta > 0) e += wall_contact_energy(law_, p, i, planes_[w].normal, delta, history_, int(w));
    }
  return e;
}

void PlaneWalls::final_integrate(Simulation& sim) {
  shifts_.apply(sim.particles);
  const Simulation::TargetList t = sim.target_list();
  limit_.finish_step(sim.particles, t.list, t.count, sim.rebuilds);
}

}  // namespace cassini
