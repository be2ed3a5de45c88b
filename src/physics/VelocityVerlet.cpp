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

void VelocityVerlet::initial_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double dt = sim.dt, h = 0.5 * sim.dt;
  if (omega_ != 0) {  // kick, rotate, drift
    for (std::size_t i = 0; i < p.nlocal; ++i) p.v[i] += (h * p.inv_mass[i]) * p.f[i];
    if (planar_)
      for (std::size_t i = 0; i < p.nlocal; ++i) p.v[i][2] = 0;
    rotate_velocities(sim);
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      p.x[i][0] += dt * p.v[i][0];
      p.x[i][1] += dt * p.v[i][1];
      if (!planar_) p.x[i][2] += dt * p.v[i][2];
    }
  } else if (planar_) {
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      const double s = h * p.inv_mass[i];
      p.v[i][0] += s * p.f[i][0];
      p.v[i][1] += s * p.f[i][1];
      p.x[i][0] += dt * p.v[i][0];
      p.x[i][1] += dt * p.v[i][1];
    }
  } else {
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      p.v[i] += (h * p.inv_mass[i]) * p.f[i];
      p.x[i] += dt * p.v[i];
    }
  }
  if (p.rotation)
    for (std::size_t i = 0; i < p.nlocal; ++i) p.omega[i] += (h * p.inv_inertia[i]) * p.torque[i];
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
