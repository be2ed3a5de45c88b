#include "physics/HillFrame.hpp"

#include <cmath>

#include "core/Simulation.hpp"

namespace cassini {

HillFrame::HillFrame(const Config& cfg)
    : exact_(cfg.hill_form == "exact"),
      omega_(cfg.omega0()),
      gm_(kGravitationalConstant * cfg.saturn_mass),
      r0_(cfg.orbit_radius) {}

Vec3 HillFrame::acceleration(const Vec3& x) const {
  if (!exact_) return Vec3(0, 3 * omega_ * omega_ * x[1], 0);
  const Vec3 s(x[0], x[1] + r0_, 0);  // from Saturn
  const double r = s.norm();
  return (omega_ * omega_ - gm_ / (r * r * r)) * s;
}

void HillFrame::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * acceleration(p.x[i]);
}

void HillFrame::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (!exact_) {
    const double k = 3 * omega_ * omega_;
    const Vec3* X = p.x.data();  // raw views: the stores to f could alias the vectors' pointers
    const double* M = p.mass.data();
    Vec3* F = p.f.data();
    for (std::size_t i = 0; i < p.nlocal; ++i) F[i][1] += M[i] * k * X[i][1];
    return;
  }
  for (std::size_t i = 0; i < p.nlocal; ++i) p.f[i] += p.mass[i] * acceleration(p.x[i]);
}

}  // namespace cassini
