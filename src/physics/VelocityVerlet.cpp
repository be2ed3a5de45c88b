#include "physics/VelocityVerlet.hpp"

#include <cmath>

#include "core/Simulation.hpp"

namespace cassini {

void VelocityVerlet::rotate_velocities(Simulation& sim) const {
  // dv/dt = 2 omega (vy, -vx) over dt/2: a clockwise rotation by 2 omega dt/2.
  ParticleStore& p = sim.particles;
  const double c = std::cos(omega_ * sim.dt), s = std::sin(omega_ * sim.dt);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double vx = p.v[i][0], vy = p.v[i][1];
    p.v[i][0] = c * vx + s * vy;
    p.v[i][1] = c * vy - s * vx;
  }
}

void VelocityVerlet::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  if (omega_ == 0) return;
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += (2 * omega_ * p.mass[i]) * Vec3(p.v[i][1], -p.v[i][0], 0);
}

void VelocityVerlet::initial_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double dt = sim.dt, h = 0.5 * sim.dt;
  if (omega_ != 0) {  // kick, rotate (Coriolis), then drift below
    for (std::size_t i = 0; i < p.nlocal; ++i) p.v[i] += (h * p.inv_mass[i]) * p.f[i];
    rotate_velocities(sim);
  } else {
    for (std::size_t i = 0; i < p.nlocal; ++i) p.v[i] += (h * p.inv_mass[i]) * p.f[i];
  }
  // Drift, measuring the displacement since the last rebuild on the way (see Simulation::stream).
  Vec3* X = p.x.data();
  Vec3* V = p.v.data();
  const Vec3* XB = p.x_build.data();
  const double stream = sim.stream;
  double m0 = 0, m1 = 0;  // two accumulators: halves the max-reduction dependency chain
  const std::size_t n = p.nlocal;
  auto drift = [&](std::size_t i) {
    if (planar_) {
      V[i][2] = 0;
      X[i][0] += dt * V[i][0];
      X[i][1] += dt * V[i][1];
    } else {
      X[i] += dt * V[i];
    }
    Vec3 d = X[i] - XB[i];
    d[0] -= stream * XB[i][1];
    return d.squaredNorm();
  };
  std::size_t i = 0;
  for (; i + 1 < n; i += 2) {
    m0 = std::max(m0, drift(i));
    m1 = std::max(m1, drift(i + 1));
  }
  if (i < n) m0 = std::max(m0, drift(i));
  sim.max_drift2 = std::max(m0, m1);
  if (p.rotation)
    for (std::size_t k = 0; k < n; ++k) p.omega[k] += (h * p.inv_inertia[k]) * p.torque[k];
}

void VelocityVerlet::final_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double h = 0.5 * sim.dt;
  if (omega_ != 0) rotate_velocities(sim);
  if (planar_) {
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      const double s = h * p.inv_mass[i];
      p.v[i][0] += s * p.f[i][0];
      p.v[i][1] += s * p.f[i][1];
    }
  } else {
    for (std::size_t i = 0; i < p.nlocal; ++i) p.v[i] += (h * p.inv_mass[i]) * p.f[i];
  }
  if (p.rotation)
    for (std::size_t i = 0; i < p.nlocal; ++i) p.omega[i] += (h * p.inv_inertia[i]) * p.torque[i];
}

}  // namespace cassini
