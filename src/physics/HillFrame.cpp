#include "physics/HillFrame.hpp"

#include <cmath>

#include "core/Simulation.hpp"

namespace cassini {

HillFrame::HillFrame(const Config& cfg)
    : exact_(cfg.hill_form == "exact"),
      planar_(cfg.planar),
      omega_(cfg.omega0()),
      gm_(kGravitationalConstant * cfg.saturn_mass),
      r0_(cfg.orbit_radius) {
  const double wz = cfg.vertical_frequency * omega_;
  extra_z2_ = exact_ ? wz * wz - omega_ * omega_ : wz * wz;
}

Vec3 HillFrame::acceleration(const Vec3& x) const {
  const double z = planar_ ? 0.0 : x[2];
  if (!exact_) return Vec3(0, 3 * omega_ * omega_ * x[1], -extra_z2_ * z);
  const Vec3 s(x[0], x[1] + r0_, z);  // from Saturn
  const double r = s.norm();
  const double g = gm_ / (r * r * r);
  return Vec3((omega_ * omega_ - g) * s[0], (omega_ * omega_ - g) * s[1], -(g + extra_z2_) * z);
}

double HillFrame::potential_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double x = p.x[i][0], y = p.x[i][1], z = planar_ ? 0.0 : p.x[i][2];
    if (!exact_) {
      u += p.mass[i] * (-1.5 * omega_ * omega_ * y * y + 0.5 * extra_z2_ * z * z);
    } else {
      const double s2 = x * x + (y + r0_) * (y + r0_);
      u += p.mass[i] * (-gm_ / std::sqrt(s2 + z * z) - 0.5 * omega_ * omega_ * s2 + 0.5 * extra_z2_ * z * z);
    }
  }
  return u;
}

void HillFrame::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * acceleration(p.x[i]);
}

void HillFrame::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (!exact_) {
    const double k = 3 * omega_ * omega_, kz = extra_z2_;
    const Vec3* X = p.x.data();  // raw views: the stores to f could alias the vectors' pointers
    const double* M = p.mass.data();
    Vec3* F = p.f.data();
    const Simulation::TargetList T = sim.target_list();
    if (planar_) {
      if (!T.list)  // the plain loop for all: it vectorises
        for (std::size_t i = 0; i < T.count; ++i) F[i][1] += M[i] * k * X[i][1];
      else
        for (std::size_t t = 0; t < T.count; ++t) F[T[t]][1] += M[T[t]] * k * X[T[t]][1];
    } else {
      for (std::size_t t = 0; t < T.count; ++t) {
        const std::size_t i = T[t];
        F[i][1] += M[i] * k * X[i][1];
        F[i][2] -= M[i] * kz * X[i][2];
      }
    }
    return;
  }
  const Simulation::TargetList T = sim.target_list();
  for (std::size_t t = 0; t < T.count; ++t) p.f[T[t]] += p.mass[T[t]] * acceleration(p.x[T[t]]);
}

}  // namespace cassini
