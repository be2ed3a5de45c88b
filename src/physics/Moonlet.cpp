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
    const double delta = radius_ + a - d;
    Vec3 xi = Vec3::Zero(), torque;  // the moonlet is frictionless in the ring scene; no history kept
    p.f[i] += law_.wall_force(p, i, r / d, delta, fric ? &xi : nullptr, torque);
    if (fric) p.torque[i] += torque;
    worst = std::max(worst, delta / a);
    ++contacts;
  }
  max_overlap_ = worst;
  contacts_ = contacts;
}

void Moonlet::wall_forces(const Simulation& sim, std::vector<WallForce>& out) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    Vec3 r = p.x[i];
    if (dims_ == 2) r[2] = 0;
    const double d = r.norm();
    if (d >= radius_ + p.radius[i] || d == 0) continue;
    Vec3 xi = Vec3::Zero(), torque;
    const Vec3 f = law_.wall_force(p, i, r / d, radius_ + p.radius[i] - d, law_.friction() ? &xi : nullptr, torque);
    out.push_back({p.id[i], radius_ * r / d, p.x[i] - radius_ * r / d, f});
  }
}

void Moonlet::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * gravity(p.x[i]);
}

}  // namespace cassini
