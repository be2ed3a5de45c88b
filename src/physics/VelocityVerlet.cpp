#include "physics/VelocityVerlet.hpp"

#include <cmath>

#include "core/Simulation.hpp"

namespace cassini {

void VelocityVerlet::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  if (omega_ == 0) return;
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += (2 * omega_ * p.mass[i]) * Vec3(p.v[i][1], -p.v[i][0], 0);
}

// The half-step kick of the spins. On raw pointers: through the vectors the compiler reloads
// each one's data pointer for every particle (a store to omega might move them), which made
// this loop ~17 instructions a particle and a tenth of a frictional gas's integration time.
// Returns the sum of the new spins' components (Guards: a NaN or an infinity anywhere makes it
// non-finite). clear: the torques are zeroed once read (the step's first kick; see
// Simulation::forces_cleared).
static double kick_spins(ParticleStore& p, double h, bool clear) {
  Vec3* W = p.omega.data();
  Vec3* TQ = p.torque.data();
  const double* II = p.inv_inertia.data();
  double s0 = 0, s1 = 0, s2 = 0;  // one chain of adds per component: no loop-carried wait
  for (std::size_t i = 0, n = p.nlocal; i < n; ++i) {
    const double c = h * II[i];
    s0 += W[i][0] += c * TQ[i][0];
    s1 += W[i][1] += c * TQ[i][1];
    s2 += W[i][2] += c * TQ[i][2];
    if (clear) TQ[i].setZero();
  }
  return s0 + s1 + s2;
}

// Kick, Coriolis rotation and drift are fused into one pass over the particles: the ring scene
// is a dilute gas whose step is dominated by such streaming loops, so each extra pass costs
// memory traffic. Scalar components on purpose: patching one lane of an Eigen vector goes
// through the stack and stalls store-to-load forwarding.
void VelocityVerlet::initial_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double dt = sim.dt, h = 0.5 * sim.dt;
  const bool rotating = omega_ != 0, planar = planar_;
  const double c = std::cos(omega_ * dt), s = std::sin(omega_ * dt);
  Vec3* X = p.x.data();
  Vec3* V = p.v.data();
  Vec3* F = p.f.data();  // zeroed once read: the step's forces start from zero (Simulation::forces_cleared)
  const double* IM = p.inv_mass.data();
  const Vec3* XB = p.x_build.data();
  const double stream = sim.stepping.stream;
  // The largest displacement since the last rebuild (see Simulation::stream), with two
  // accumulators: halves the max-reduction dependency chain. Likewise the sum of the new
  // positions' components, for Guards' finiteness check (free in this memory-bound pass, where
  // a scan of its own read every position again).
  double m0 = 0, m1 = 0, s0 = 0, s1 = 0;
  const std::size_t n = p.nlocal;
  auto advance = [&](std::size_t i, double& sum) {
    const double k = h * IM[i];
    double vx = V[i][0] + k * F[i][0], vy = V[i][1] + k * F[i][1], vz = planar ? 0.0 : V[i][2] + k * F[i][2];
    F[i].setZero();
    if (rotating) {  // Coriolis, dv/dt = 2 omega (vy, -vx) over dt/2: a clockwise rotation by omega dt
      const double rx = c * vx + s * vy, ry = c * vy - s * vx;
      vx = rx;
      vy = ry;
    }
    V[i][0] = vx;
    V[i][1] = vy;
    V[i][2] = vz;
    const double x = X[i][0] + dt * vx, y = X[i][1] + dt * vy, z = X[i][2] + dt * vz;
    X[i][0] = x;
    X[i][1] = y;
    X[i][2] = z;
    sum += (x + y) + z;
    const double dx = x - XB[i][0] - stream * XB[i][1], dy = y - XB[i][1], dz = z - XB[i][2];
    return dx * dx + dy * dy + dz * dz;
  };
  std::size_t i = 0;
  for (; i + 1 < n; i += 2) {
    m0 = std::max(m0, advance(i, s0));
    m1 = std::max(m1, advance(i + 1, s1));
  }
  if (i < n) m0 = std::max(m0, advance(i, s0));
  sim.stepping.max_drift2 = std::max(m0, m1);
  position_sum_ = s0 + s1;
  if (p.rotation) kick_spins(p, h, true);  // their sum is taken after the step's second kick
  sim.stepping.forces_cleared = true;
}

void VelocityVerlet::final_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double h = 0.5 * sim.dt;
  const bool rotating = omega_ != 0, planar = planar_;
  const double c = std::cos(omega_ * sim.dt), s = std::sin(omega_ * sim.dt);
  Vec3* V = p.v.data();
  const Vec3* F = p.f.data();
  const double* IM = p.inv_mass.data();
  const std::size_t n = p.nlocal;
  double s0 = 0, s1 = 0, s2 = 0;  // the new velocities' sum, one chain of adds per component
  for (std::size_t i = 0; i < n; ++i) {
    double vx = V[i][0], vy = V[i][1];
    if (rotating) {
      const double rx = c * vx + s * vy, ry = c * vy - s * vx;
      vx = rx;
      vy = ry;
    }
    const double k = h * IM[i];
    s0 += V[i][0] = vx + k * F[i][0];
    s1 += V[i][1] = vy + k * F[i][1];
    if (!planar) V[i][2] += k * F[i][2];
    s2 += V[i][2];
  }
  double sum = s0 + s1 + s2;
  if (p.rotation) sum += kick_spins(p, h, false);
  sim.stepping.state_sum = position_sum_ + sum;
  sim.stepping.state_summed = true;
}

}  // namespace cassini
