#include "physics/VelocityVerlet.hpp"

#include "core/Simulation.hpp"

namespace cassini {

void VelocityVerlet::initial_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double dt = sim.dt, h = 0.5 * sim.dt;
  if (planar_) {
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
