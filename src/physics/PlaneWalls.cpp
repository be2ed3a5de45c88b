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

PlaneWalls::PlaneWalls(const Config& cfg, double dt) : law_(cfg, dt), planes_(domain_walls(cfg)) {}

void PlaneWalls::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const bool fric = law_.friction();
  const int nw = static_cast<int>(planes_.size());
  double worst = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double a = p.radius[i];
    for (int w = 0; w < nw; ++w) {
      const Plane& pl = planes_[w];
      const double s = (p.x[i] - pl.point).dot(pl.normal);
      Vec3* xi = fric ? &p.wall_xi[i * p.walls + w] : nullptr;  // planes take the first slots
      if (s >= a) {
        if (xi) xi->setZero();
        continue;
      }
      const double delta = a - s;
      Vec3 vrel = p.v[i];
      if (fric) vrel -= a * p.omega[i].cross(pl.normal);
      Vec3 ft;
      const int sp = p.species[i];
      p.f[i] += law_.force(law_.law(sp, sp), p.mass[i], delta, pl.normal, vrel, xi, ft);
      if (fric) p.torque[i] += (-a * pl.normal).cross(ft);
      worst = std::max(worst, delta / a);
    }
  }
  max_overlap_ = worst;
}

}  // namespace cassini
