#include "physics/MultiRateHill.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/Simulation.hpp"
#include "physics/Moonlet.hpp"

namespace cassini {

// Linear Hill equations, x azimuthal, y radial: ax = 2 W vy, ay = -2 W vx + 3 W^2 y (HillFrame).
// With w = 2 (vx - 3/2 W y), twice the velocity relative to the Keplerian shear, (w, vy) turns
// at the orbital frequency: w' = W vy, vy' = -W w. Integrating once more gives x and y.
MultiRateHill::Epicycle::Epicycle(double w, double wz, double time, bool flat)
    : omega(w), omega_z(wz), t(time), planar(flat) {
  const double half = std::sin(0.5 * w * t);
  s1 = std::sin(w * t) / w;
  c1 = 2 * half * half / w;  // (1 - cos) without the cancellation
  cz = std::cos(wz * t);
  sz = std::sin(wz * t);
}

void MultiRateHill::Epicycle::advance(Vec3& x, Vec3& v) const {
  const double W = omega, c = 1 - W * c1, s = W * s1;
  const double y = x[1], vy = v[1], w0 = 2 * (v[0] - 1.5 * W * y);
  const double y1 = y + vy * s1 - w0 * c1;
  x[0] += 1.5 * W * t * y + w0 * (2 * s1 - 1.5 * t) + 2 * vy * c1;
  x[1] = y1;
  v[1] = vy * c - w0 * s;
  v[0] = 0.5 * (w0 * c + vy * s) + 1.5 * W * y1;
  if (!planar) {
    const double z = x[2], vz = v[2];
    x[2] = z * cz + vz * sz / omega_z;
    v[2] = vz * cz - z * omega_z * sz;
  }
}

MultiRateHill::MultiRateHill(const Config& cfg, double dt)
    : dt_(dt), omega_(cfg.omega0()), omega_z_(cfg.vertical_frequency * cfg.omega0()),
      max_tidal_phase_(cfg.max_tidal_phase), substeps_(std::max(1L, std::lround(cfg.long_step / dt))),
      planar_(cfg.planar), step_map_(omega_, omega_z_, dt, cfg.planar) {
  long_step_ = double(substeps_) * dt;
  if (cfg.has_module("moonlet")) {
    gm_ = kGravitationalConstant * cfg.moonlet_mass;
    moonlet_radius_ = cfg.moonlet_radius;
  }
  rot_c_ = std::cos(omega_ * dt);
  rot_s_ = std::sin(omega_ * dt);
}

std::string MultiRateHill::name() const {
  std::ostringstream os;
  os << "multi-rate Hill (long step " << long_step_ << " s = " << substeps_ << " steps; free particles on the exact epicycle)";
  return os.str();
}

void MultiRateHill::setup(Simulation& sim) { moonlet_ = sim.moonlet; }

Vec3 MultiRateHill::moonlet_acceleration(const Vec3& x) const {
  return moonlet_ ? moonlet_->gravity(x) : Vec3::Zero();
}

bool MultiRateHill::needs_contact_steps(const Simulation& sim, std::size_t i) const {
  const ParticleStore& p = sim.particles;
  const double D = delta_, W = omega_;
  const Vec3& x = p.x[i];
  const Vec3& v = p.v[i];
  const Vec3 ai = moonlet_acceleration(x);
  if (moonlet_) {
    const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + (planar_ ? 0.0 : x[2] * x[2]));
    const double speed = v.norm();
    const double accel = gm_ / (moonlet_radius_ * moonlet_radius_) + 3 * W * W * std::abs(x[1]) + 2 * W * speed;
    if (r - moonlet_radius_ - p.radius[i] < (speed + accel * D) * D) return true;
    if (std::sqrt(gm_ / (r * r * r)) * D > max_tidal_phase_) return true;
  }
  const NeighborList& nl = sim.neighbors;
  const double ai_norm = ai.norm(), Wz2 = omega_z_ * omega_z_;
  for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
    const std::uint32_t j = nl.partner[k];
    const Vec3 d = x - p.x[j], u = v - p.v[j];
    const double R = p.radius[i] + p.radius[j], u2 = u.squaredNorm(), speed = std::sqrt(u2);
    const double tau = u2 > 0 ? std::clamp(-d.dot(u) / u2, 0.0, D) : 0.0;
    const double closest = (d + tau * u).norm();
    const double bend = 3 * W * W * std::abs(d[1]) + Wz2 * std::abs(d[2]) + 2 * W * speed + ai_norm +
                        moonlet_acceleration(p.x[j]).norm();
    if (closest - R < bend * D * D + 4 * speed * dt_) return true;
  }
  return false;
}

void MultiRateHill::begin_long_step(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const long s = sim.step_count;
  long last = s;
  while (last % substeps_ != 0 && !sim.is_output_step(last)) ++last;
  first_step_ = s;
  last_step_ = last;
  t0_ = double(s - 1) * dt_;
  delta_ = double(last - s + 1) * dt_;
  // Ghosts as their owners are now (the last step's kicks and moves came after its update), so
  // that each side of a pair sees the same numbers whatever the rank count.
  sim.halo.update_ghosts(p);
  for (std::size_t i = 0; i < p.nlocal; ++i) p.mode[i] = needs_contact_steps(sim, i) ? kContact : kFree;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (p.mode[i] == kFree) p.v[i] += (0.5 * delta_) * moonlet_acceleration(p.x[i]);
  in_long_step_ = true;
  post_rebuild(sim);
}

void MultiRateHill::post_rebuild(Simulation& sim) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  contact_.clear();
  watch_.clear();
  if (!in_long_step_) return;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (p.mode[i] != kFree) contact_.push_back(static_cast<std::uint32_t>(i));
    else if (nl.start[i] != nl.start[i + 1]) watch_.push_back(static_cast<std::uint32_t>(i));
  }
}

void MultiRateHill::initial_integrate(Simulation& sim) {
  if (!in_long_step_) begin_long_step(sim);
  ParticleStore& p = sim.particles;
  const double dt = dt_, h = 0.5 * dt_, stream = sim.stream, c_rot = rot_c_, s_rot = rot_s_;
  const bool planar = planar_;
  Vec3* X = p.x.data();
  Vec3* V = p.v.data();
  const Vec3* F = p.f.data();
  const Vec3* XB = p.x_build.data();
  const double* IM = p.inv_mass.data();
  const std::uint8_t* MODE = p.mode.data();
  double m0 = 0;
  const std::size_t n = p.nlocal;
  // The free map written out (planar and 3D) on local values, so that the loop stays in
  // registers: it is most of a dilute ring's work.
  const Epicycle& E = step_map_;
  const double W = E.omega, s1 = E.s1, c1 = E.c1, ec = 1 - W * c1, es = W * s1, shear = 1.5 * W, T = E.t;
  const double ax = 2 * s1 - 1.5 * T, cz = E.cz, sz = E.sz, wz = E.omega_z;
  // Every particle takes the free map in one branch-free pass (it vectorises); the few on
  // contact steps are put back first and take velocity Verlet's first half instead.
  saved_.resize(contact_.size());
  for (std::size_t c = 0; c < contact_.size(); ++c) saved_[c] = {X[contact_[c]], V[contact_[c]]};
  for (std::size_t i = 0; i < n; ++i) {
    const double y = X[i][1], vy = V[i][1], w0 = 2 * (V[i][0] - shear * y);
    const double y1 = y + vy * s1 - w0 * c1;
    const double x1 = X[i][0] + (shear * T * y + w0 * ax + 2 * vy * c1);
    X[i][0] = x1;
    X[i][1] = y1;
    V[i][1] = vy * ec - w0 * es;
    V[i][0] = 0.5 * (w0 * ec + vy * es) + shear * y1;
    double z1 = X[i][2];
    if (!planar) {
      const double z = X[i][2], vz = V[i][2];
      z1 = z * cz + vz * sz / wz;
      X[i][2] = z1;
      V[i][2] = vz * cz - z * wz * sz;
    }
    const double dx = x1 - XB[i][0] - stream * XB[i][1], dy = y1 - XB[i][1], dz = z1 - XB[i][2];
    const double d2 = MODE[i] == kFree ? dx * dx + dy * dy + dz * dz : 0.0;
    m0 = std::max(m0, d2);
  }
  for (std::size_t c = 0; c < contact_.size(); ++c) {  // velocity Verlet's first half, as VelocityVerlet
    const std::size_t i = contact_[c];
    X[i] = saved_[c].x;
    V[i] = saved_[c].v;
    const double k = h * IM[i];
    const double vx = V[i][0] + k * F[i][0], vy = V[i][1] + k * F[i][1];
    V[i][0] = c_rot * vx + s_rot * vy;
    V[i][1] = c_rot * vy - s_rot * vx;
    V[i][2] = planar ? 0.0 : V[i][2] + k * F[i][2];
    X[i] += dt * V[i];
    const double dx = X[i][0] - XB[i][0] - stream * XB[i][1], dy = X[i][1] - XB[i][1], dz = X[i][2] - XB[i][2];
    m0 = std::max(m0, dx * dx + dy * dy + dz * dz);
  }
  sim.max_drift2 = m0;
  if (p.rotation)
    for (const std::uint32_t i : contact_) p.omega[i] += (h * p.inv_inertia[i]) * p.torque[i];
  contact_particle_steps += static_cast<long long>(contact_.size());
  free_particle_steps += static_cast<long long>(n - contact_.size());
}

void MultiRateHill::pre_force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  bool woke = false;
  for (const std::uint32_t j : watch_) {
    for (std::uint32_t k = nl.start[j]; k < nl.start[j + 1]; ++k) {
      const std::uint32_t i = nl.partner[k];
      const double gap = (p.x[j] - p.x[i]).norm() - (p.radius[i] + p.radius[j]);
      if (gap >= 4 * (p.v[j] - p.v[i]).norm() * dt_) continue;
      p.mode[j] = kWoken;
      ++wakes;
      wakes_touching += gap < 0;
      woke = true;
      break;
    }
  }
  if (woke) post_rebuild(sim);
  sim.all_targets = sim.step_count == last_step_;
  if (!sim.all_targets) sim.targets = contact_;
}

void MultiRateHill::final_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double h = 0.5 * dt_, c = rot_c_, s = rot_s_;
  const double since = sim.time - t0_;
  for (const std::uint32_t i : contact_) {
    Vec3& v = p.v[i];
    if (p.mode[i] == kWoken) {
      // Its state is the free one at this time, full step. It had delta/2 of the moonlet's
      // impulse at the long step's start; it is owed `since` of it.
      v += (since - 0.5 * delta_) * moonlet_acceleration(p.x[i]);
      p.mode[i] = kContact;
      continue;
    }
    const double vx = c * v[0] + s * v[1], vy = c * v[1] - s * v[0];
    const double k = h * p.inv_mass[i];
    v[0] = vx + k * p.f[i][0];
    v[1] = vy + k * p.f[i][1];
    if (!planar_) v[2] += k * p.f[i][2];
    if (p.rotation) p.omega[i] += (h * p.inv_inertia[i]) * p.torque[i];
  }
  if (sim.step_count != last_step_) return;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (p.mode[i] != kFree) continue;
    p.v[i] += (0.5 * delta_) * moonlet_acceleration(p.x[i]);
    if (moonlet_) {
      const Vec3& x = p.x[i];
      const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + (planar_ ? 0.0 : x[2] * x[2]));
      missed += r < moonlet_radius_ + p.radius[i];
    }
  }
  in_long_step_ = false;
  publish(sim);
}

void MultiRateHill::publish(Simulation& sim) const {
  double local[5] = {double(contact_particle_steps), double(free_particle_steps), double(wakes), double(wakes_touching),
                     double(missed)};
  double g[5];
  MPI_Allreduce(local, g, 5, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  std::ostringstream os;
  os.precision(6);
  os << "{\"long_step\": " << long_step_ << ", \"steps_per_long_step\": " << substeps_
     << ", \"contact_step_fraction\": " << (g[0] + g[1] > 0 ? g[0] / (g[0] + g[1]) : 0.0)
     << ", \"wakes\": " << std::llround(g[2]) << ", \"wakes_touching\": " << std::llround(g[3])
     << ", \"missed_moonlet_contacts\": " << std::llround(g[4]) << "}";
  sim.set_result("multirate", os.str());
}

void MultiRateHill::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += (2 * omega_ * p.mass[i]) * Vec3(p.v[i][1], -p.v[i][0], 0);
}

}  // namespace cassini
