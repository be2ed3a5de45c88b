#include "physics/PlaneWalls.hpp"

#include "core/Simulation.hpp"

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
  const bool fric = law_.friction(), exact = law_.exact();
  const double dt = law_.dt();
  const int nw = static_cast<int>(planes_.size());
  double worst = 0;
  shifts_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double a = p.radius[i];
    Vec3 move = Vec3::Zero();
    for (int w = 0; w < nw; ++w) {
      const Plane& pl = planes_[w];
      const double s = (p.x[i] - pl.point).dot(pl.normal);
      Vec3* xi = fric ? &p.wall_xi[i * p.walls + first_slot_ + w] : nullptr;
      double* impact = p.impacts ? &p.wall_impact[i * p.walls + first_slot_ + w] : nullptr;  // Bridges restitution
      Vec3* roll = p.rolling ? &p.wall_roll[i * p.walls + first_slot_ + w] : nullptr;         // rolling resistance
      if (s >= a) {
        if (xi) xi->setZero();
        if (roll) roll->setZero();
        // The exact scheme's exit step: touching a step ago (a - s + v_n dt > 0), parted now.
        // (A particle moves less than its radius per step: the tunnelling guard.)
        if (!exact || s >= 2 * a || a - s + p.v[i].dot(pl.normal) * dt <= 0) {
          if (impact) *impact = 0;
          continue;
        }
      }
      const double delta = a - s;
      Vec3 torque;
      double shift = 0;
      p.f[i] += law_.wall_force(p, i, pl.normal, delta, delta > 0 ? xi : nullptr, torque, true, &shift, impact,
                                delta > 0 ? roll : nullptr);
      move += shift * pl.normal;
      if (fric && delta > 0) p.torque[i] += torque;
      if (delta / a > worst) { worst = delta / a; worst_id_ = p.id[i]; }
    }
    if (!move.isZero(0)) shifts_.add(i, move);
  }
  max_overlap_ = worst;
}

void PlaneWalls::wall_forces(const Simulation& sim, std::vector<WallForce>& out) const {
  const ParticleStore& p = sim.particles;
  const int nw = static_cast<int>(planes_.size());
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (int w = 0; w < nw; ++w) {
      const Plane& pl = planes_[w];
      const double s = (p.x[i] - pl.point).dot(pl.normal);
      if (s >= p.radius[i]) continue;
      Vec3 spring = law_.friction() ? p.wall_xi[i * p.walls + first_slot_ + w] : Vec3::Zero(), torque;
      double impact = p.impacts ? p.wall_impact[i * p.walls + first_slot_ + w] : 0.0;
      Vec3 roll = p.rolling ? p.wall_roll[i * p.walls + first_slot_ + w] : Vec3::Zero();
      const Vec3 f = law_.wall_force(p, i, pl.normal, p.radius[i] - s, law_.friction() ? &spring : nullptr, torque,
                                     false, nullptr, &impact, &roll);  // the step already advanced the springs
      out.push_back({p.id[i], p.x[i] - s * pl.normal, s * pl.normal, f});
    }
}

void PlaneWalls::final_integrate(Simulation& sim) { shifts_.apply(sim.particles); }

}  // namespace cassini
