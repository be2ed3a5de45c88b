#include "physics/Moonlet.hpp"

#include <cmath>

#include "core/Simulation.hpp"

namespace cassini {

Moonlet::Moonlet(const Config& cfg, double dt)
    : law_(cfg, dt), gm_(kGravitationalConstant * cfg.moonlet_mass), radius_(cfg.moonlet_radius),
      dims_(cfg.planar ? 2 : 3) {}

Vec3 Moonlet::gravity(const Vec3& x) const {
  Vec3 r = x;
  if (dims_ == 2) r[2] = 0;
  const double d = r.norm();
  if (d >= radius_) return (-gm_ / (d * d * d)) * r;
  return (-gm_ / (radius_ * radius_ * radius_)) * r;  // uniform interior: finite at the centre
}

void Moonlet::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const bool fric = law_.friction();
  double worst = 0;
  long contacts = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    p.f[i] += p.mass[i] * gravity(p.x[i]);
    Vec3 r = p.x[i];
    if (dims_ == 2) r[2] = 0;
    const double d = r.norm(), a = p.radius[i];
    if (d >= radius_ + a || d == 0) continue;
    const Vec3 n = r / d;
    const double delta = radius_ + a - d;
    Vec3 vrel = p.v[i];
    if (fric) vrel -= a * p.omega[i].cross(n);
    Vec3 ft;
    Vec3 xi = Vec3::Zero();  // the moonlet is frictionless in the ring scene; no history kept
    const int sp = p.species[i];
    p.f[i] += law_.force(law_.law(sp, sp), p.mass[i], delta, n, vrel, fric ? &xi : nullptr, ft);
    if (fric) p.torque[i] += (-a * n).cross(ft);
    worst = std::max(worst, delta / a);
    ++contacts;
  }
  max_overlap_ = worst;
  contacts_ = contacts;
}

}  // namespace cassini
