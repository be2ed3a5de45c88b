#include "physics/ring/MultiRateHill.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/ring/HillFrame.hpp"
#include "physics/ring/Moonlet.hpp"
#include "physics/ring/SelfGravity.hpp"

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

ModuleKind MultiRateHill::kind() {
  auto read = [](CaseFile& f, Config& c) {
    if (!c.has_module("hill") || c.get<HillSettings>().form != "linear")
      f.fail("time.integrator", "\"verlet\": \"multirate\" needs module \"hill\" with hill.form = \"linear\" (its free particles follow the exact linear epicycle)");
    for (const auto& m : c.modules)
      if (m != "contact" && m != "hill" && m != "moonlet" && m != "self-gravity")
        f.fail("time.integrator", "\"verlet\" with module \"" + m + "\" (\"multirate\" supports contact, hill, moonlet and self-gravity)");
    if (c.has_module("self-gravity") && c.get<SelfGravity::Settings>().every != 1)
      f.fail("self_gravity.every", "1 (or no key) with time.integrator = \"multirate\": the mesh is solved once a long step (time.long_step)");
    const double t0 = 2 * 3.141592653589793 / c.get<HillSettings>().omega0();
    Settings s;
    s.long_step = f.positive("time.long_step", std::max(c.dt, std::round(t0 / 1000 / c.dt) * c.dt));
    if (s.long_step < c.dt) f.fail("time.long_step", "at least time.dt = " + std::to_string(c.dt));
    s.max_tidal_phase = f.positive("time.max_tidal_phase", 0.1);
    c.set(s);
    // Free particles follow Hill's equations, whose shear is 3/2 Omega0; their drift bounds are
    // taken against the imposed flow, so the two must be the same (without a sheared boundary a
    // particle riding the Keplerian shear would drift with no bound at all).
    if (!c.sheared())
      f.fail("domain.boundary", "a \"lees_edwards\" y boundary with time.integrator = \"multirate\" (the free particles' "
                                "drift is bounded against the Keplerian shear it imposes)");
    const double kepler = 1.5 * c.get<HillSettings>().omega0();
    if (std::abs(c.shear_rate - kepler) > 1e-12 * kepler) {
      std::ostringstream os;
      os.precision(17);
      os << kepler << " 1/s (1.5 Omega0, or no key) with time.integrator = \"multirate\": its free particles follow "
            "Hill's equations, whose shear that is";
      f.fail("domain.shear_rate", os.str());
    }
  };
  auto make = [](Simulation& sim) {
    auto m = std::make_unique<MultiRateHill>(sim.cfg, sim.dt);
    m->mode_column_ = sim.particles.declare("multirate_mode", 1, ParticleStore::Ghosts::carry);  // ghosts' modes decide who is awake
    m->work_column_ = sim.particles.declare("multirate_work", 1, ParticleStore::Ghosts::none);
    return m;
  };
  return {"multirate", {"hill"}, read, make};
}

MultiRateHill::MultiRateHill(const Config& cfg, double dt)
    : dt_(dt), omega_(cfg.get<HillSettings>().omega0()),
      omega_z_(cfg.get<HillSettings>().vertical_frequency * omega_),
      max_tidal_phase_(cfg.get<Settings>().max_tidal_phase),
      substeps_(std::max(1L, std::lround(cfg.get<Settings>().long_step / dt))),
      planar_(cfg.planar) {
  long_step_ = double(substeps_) * dt;
  skin_ = cfg.skin;
  if (cfg.has_module("moonlet")) {
    gm_ = kGravitationalConstant * cfg.get<MoonletSettings>().mass;
    moonlet_radius_ = cfg.get<MoonletSettings>().radius;
  }
  rot_c_ = std::cos(omega_ * dt);
  rot_s_ = std::sin(omega_ * dt);
}

std::string MultiRateHill::name() const {
  std::ostringstream os;
  os << "multi-rate Hill (long step " << long_step_ << " s = " << substeps_ << " steps; free particles on the exact epicycle)";
  return os.str();
}

void MultiRateHill::setup(Simulation& sim) {
  moonlet_ = sim.find<Moonlet>();
  gravity_ = sim.find<SelfGravity>();
  sim.stepping.lazy_column = static_cast<int>(mode_column_);  // kFree = 0: partners the force loops skip between long steps
}

Vec3 MultiRateHill::moonlet_acceleration(const ParticleStore& p, std::size_t i) const {
  return moonlet_ ? moonlet_->acceleration(p, i) : Vec3::Zero();
}

Vec3 MultiRateHill::slow_acceleration(const ParticleStore& p, std::size_t i, bool free) const {
  if (!gravity_) return free ? moonlet_acceleration(p, i) : Vec3(Vec3::Zero());
  if (!free) return gravity_->mesh_acceleration(i);
  return moonlet_acceleration(p, i) + gravity_->mesh_acceleration(i) + gravity_->short_acceleration(i);
}

MultiRateHill::Present MultiRateHill::present(const Simulation& sim) const {
  const double tau = sim.time - t_ref_;
  return {sim.particles, sim.halo, *this, Epicycle(omega_, omega_z_, tau, planar_), sim.domain.length[1],
          sim.domain.shear.enabled ? sim.domain.shear.rate : 0.0, in_long_step_ && tau > 0};
}

Vec3 MultiRateHill::Present::operator()(std::size_t j) const {
  if (!lagging || integrator.mode_of(p, j) != kFree) return p.x[j];
  Vec3 x = p.x[j], v = p.v[j];
  const int k = halo.sheared_image(p, j);
  if (k == 0) {
    map.advance(x, v);
    return x;
  }
  // The image's offset along x is the halo's (it moves with the shear as the owner's image);
  // its epicycle is the owner's: taken in the owner's y and v_x, moved back after.
  x[1] -= k * Ly;
  v[0] -= k * rate * Ly;
  map.advance(x, v);
  x[1] += k * Ly;
  return x;
}

bool MultiRateHill::needs_contact_steps(const Simulation& sim, std::size_t i) const {
  const ParticleStore& p = sim.particles;
  const double D = delta_, W = omega_;
  const Vec3& x = p.x[i];
  const Vec3& v = p.v[i];
  if (moonlet_ && Moonlet::feels(p, i)) {
    const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + (planar_ ? 0.0 : x[2] * x[2]));
    const double speed = v.norm();
    const double accel = gm_ / (moonlet_radius_ * moonlet_radius_) + 3 * W * W * std::abs(x[1]) + 2 * W * speed;
    if (r - moonlet_radius_ - p.radius[i] < (speed + accel * D) * D) return true;
    if (std::sqrt(gm_ / (r * r * r)) * D > max_tidal_phase_) return true;
  }
  const Decomposition& dom = sim.domain;
  if (dom.fed_x && p.le_copy[i] == 1) {
    // Modified Lees-Edwards boundaries: an LE2 particle near an x face is also an LE1 ghost
    // across it, felt by LE1 particles it does not list (a one-way interaction). Its own
    // partners cannot decide for it, so it takes contact steps while it can be there; its
    // ghost then moves every step, and the LE1 particles near it are watched as usual.
    const double speed = v.norm();
    const double reach = sim.range + speed * D + (3 * W * W * std::abs(x[1]) + 2 * W * speed) * D * D;
    if (x[0] - dom.lo[0] < reach || dom.hi[0] - x[0] < reach) return true;
  }
  const NeighborList& nl = sim.neighbors;
  if (nl.start[i] == nl.start[i + 1]) return false;  // most ring particles: no partner
  const double ai_norm = moonlet_acceleration(p, i).norm(), Wz2 = omega_z_ * omega_z_;
  for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
    const std::uint32_t j = nl.partner[k];
    const Vec3 d = x - p.x[j], u = v - p.v[j];
    const double R = p.radius[i] + p.radius[j], u2 = u.squaredNorm(), speed = std::sqrt(u2);
    const double tau = u2 > 0 ? std::clamp(-d.dot(u) / u2, 0.0, D) : 0.0;
    const double closest = (d + tau * u).norm();
    const double bend = 3 * W * W * std::abs(d[1]) + Wz2 * std::abs(d[2]) + 2 * W * speed + ai_norm +
                        moonlet_acceleration(p, j).norm() + gravity_bound_;
    if (closest - R < bend * D * D + 4 * speed * dt_) return true;
  }
  return false;
}

void MultiRateHill::begin_long_step(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const long s = sim.step_count;
  long last = s;
  while (last % substeps_ != 0 && !sim.is_output_step(last)) ++last;
  last_step_ = last;
  t0_ = sim.time - dt_;  // the step about to be taken starts here; every particle is synchronised
  t_ref_ = t0_;
  delta_ = double(last - s + 1) * dt_;
  if (gravity_) gravity_bound_ = 2 * gravity_->synchronise(sim);  // collective: every rank begins a long step here
  // Ghosts as their owners are now (the last step's kicks and moves came after its update), so
  // that each side of a pair sees the same numbers whatever the rank count.
  sim.halo.update_ghosts(p);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    set_mode(p, i, needs_contact_steps(sim, i) ? kContact : kFree);
    *p.column(work_column_, i) += 1;
  }
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (mode_of(p, i) == kFree || gravity_) p.v[i] += (0.5 * delta_) * slow_acceleration(p, i, mode_of(p, i) == kFree);
  in_long_step_ = true;
  make_lists(p);
  watch_dirty_ = true;  // after this step's ghost update has carried the new modes
  // Drift bound from here (the stream at t0 is one step short of this step's).
  const double stream0 = sim.stepping.stream - (sim.domain.shear.enabled ? sim.domain.shear.rate * dt_ : 0.0);
  // Fast free particles (epicycle speed above skin / (4 Delta)) are bounded on their own, so
  // that the shared bound of the rest allows about a long step between rebuilds.
  const double fast = skin_ / (4 * delta_);
  free_drift_ = free_dy_ = free_speed_ = free_vz_ = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (mode_of(p, i) != kFree) continue;
    const double wi = 2 * (p.v[i][0] - 1.5 * omega_ * p.x[i][1]);
    if (std::sqrt(wi * wi + p.v[i][1] * p.v[i][1]) > fast) continue;
    const Vec3& x = p.x[i];
    const Vec3& xb = p.x_build[i];
    const Vec3& v = p.v[i];
    const Vec3 d(x[0] - xb[0] - stream0 * xb[1], x[1] - xb[1], x[2] - xb[2]);
    const double w = 2 * (v[0] - 1.5 * omega_ * x[1]);
    free_drift_ = std::max(free_drift_, d.norm());
    free_dy_ = std::max(free_dy_, std::abs(d[1]));
    free_speed_ = std::max(free_speed_, std::sqrt(w * w + v[1] * v[1]));
    if (!planar_) free_vz_ = std::max(free_vz_, std::hypot(v[2], omega_z_ * x[2]));
  }
  // The bound combines the maxima: taken over every rank's particles, so that it (and with it
  // the steps at which the list is rebuilt and the free particles materialised) is the same on
  // any rank count. A rank's own maxima gave a smaller bound on more ranks.
  double m[4] = {free_drift_, free_dy_, free_speed_, free_vz_};
  MPI_Allreduce(MPI_IN_PLACE, m, 4, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  free_drift_ = m[0];
  free_dy_ = m[1];
  free_speed_ = m[2];
  free_vz_ = m[3];
  fast_bounds(sim, stream0, false);
}

void MultiRateHill::fast_bounds(const Simulation& sim, double stream, bool rebuilt) {
  // Displacement D since the build, relative to the imposed flow there: dD/dtau = u + gamma
  // (y - y_b) e_x + v_z e_z, with u = v - 3/2 Omega y e_x. Along a free epicycle (2 u_x, u_y)
  // turns at Omega with invariant length M, so |u'| <= Omega M, |u_y| <= M and |v_z| <= Z =
  // |(v_z, Omega_z z)|: |D(tau)| <= |D0| + (|u0| + gamma |dy0| + Z) tau + (Omega + gamma) M tau^2 / 2.
  // Tight over a long step (Omega Delta ~ 0.006): the fast ones force rebuilds about as late
  // as when they were moved every step, and cost nothing between long steps.
  const ParticleStore& p = sim.particles;
  const double rate = sim.domain.shear.enabled ? sim.domain.shear.rate : 0.0, K = 1.5 * omega_;
  fast_a_.clear();
  fast_b_.clear();
  fast_c_.clear();
  fast_u2_ = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (mode_of(p, i) != kFree) continue;
    const Vec3& x = p.x[i];
    const Vec3& v = p.v[i];
    const double ux = v[0] - K * x[1], M2 = 4 * ux * ux + v[1] * v[1];
    if (M2 < free_speed_ * free_speed_ * (1 - 1e-12)) continue;  // within the shared bound (with room for rounding)
    const double M = std::sqrt(M2);
    const double Z = planar_ ? 0.0 : std::hypot(v[2], omega_z_ * x[2]);
    double a = 0, dy = 0;
    if (!rebuilt) {  // since the build (a rebuild's D0 is zero)
      const Vec3& xb = p.x_build[i];
      const Vec3 d(x[0] - xb[0] - stream * xb[1], x[1] - xb[1], x[2] - xb[2]);
      a = d.norm();
      dy = std::abs(d[1]);
    }
    fast_a_.push_back(a);
    fast_b_.push_back(std::hypot(ux, v[1]) + rate * dy + Z);
    fast_c_.push_back(0.5 * (omega_ + rate) * M);
    fast_u2_ = std::max(fast_u2_, 1.25 * M * M + Z * Z);
  }
}

void MultiRateHill::make_lists(const ParticleStore& p) {
  contact_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (on_contact_steps(mode_of(p, i))) contact_.push_back(static_cast<std::uint32_t>(i));
}

void MultiRateHill::materialize(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double tau = sim.time - t_ref_;
  t_ref_ = sim.time;
  if (tau <= 0) return;
  const Epicycle E(omega_, omega_z_, tau, planar_);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (mode_of(p, i) == kFree) E.advance(p.x[i], p.v[i]);
}

void MultiRateHill::pre_rebuild(Simulation& sim) {
  if (in_long_step_) materialize(sim);  // migration and the new list need the present positions
}

void MultiRateHill::post_rebuild(Simulation& sim) {
  if (!in_long_step_) return;
  ParticleStore& p = sim.particles;
  // The new list can hold pairs the long step's classification never saw: each free particle
  // looks again, over what is left of the long step (every particle is at the present time).
  const double delta = delta_;
  // At the long step's last step what is left is zero, or a rounding below it: never negative
  // (needs_contact_steps clamps times into [0, delta_]).
  delta_ = std::max(0.0, t0_ + delta - sim.time);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (!on_contact_steps(mode_of(p, i)) && needs_contact_steps(sim, i)) {
      set_mode(p, i, kWoken);  // its state is the exact present one, as a particle woken in pre_force
      ++wakes;
      rebuild_woken_.push_back(static_cast<std::uint32_t>(i));  // its ghosts were built free
    }
  delta_ = delta;
  make_lists(p);
  watch_dirty_ = true;
  free_drift_ = free_dy_ = 0;  // built here (the epicycle speeds are invariants of the free motion)
  fast_bounds(sim, 0.0, true);  // slots moved; all at the present time
}

void MultiRateHill::find_watched(const Simulation& sim) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  watch_.clear();
  // Two free particles cannot touch within the long step (see the header): only partners on
  // contact steps need watching.
  for (std::size_t j = 0; j < p.nlocal; ++j) {
    if (on_contact_steps(mode_of(p, j))) continue;
    for (std::uint32_t k = nl.start[j]; k < nl.start[j + 1]; ++k)
      if (on_contact_steps(mode_of(p, nl.partner[k]))) {
        watch_.push_back(static_cast<std::uint32_t>(j));
        break;
      }
  }
  ghosts_awake_ = 0;
  for (std::size_t g = p.nlocal; g < p.size(); ++g) ghosts_awake_ += on_contact_steps(mode_of(p, g));
  watch_dirty_ = false;
}

void MultiRateHill::initial_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (!in_long_step_) {
    begin_long_step(sim);  // kicks the free particles and sets every mode: all ghosts change
  } else {
    // Since the last ghost update only the particles on contact steps changed (their last
    // kick, this drift): the free ones keep their state of t_ref. (A rebuild in between made
    // the ghosts anew from the present state; the particles it woke send their ghosts in
    // pre_force.)
    sim.stepping.moved_known = true;
    sim.stepping.moved.assign(contact_.begin(), contact_.end());
  }
  const double dt = dt_, h = 0.5 * dt_, stream = sim.stepping.stream, c = rot_c_, s = rot_s_;
  const bool planar = planar_;
  Vec3* X = p.x.data();
  Vec3* V = p.v.data();
  const Vec3* F = p.f.data();
  const Vec3* XB = p.x_build.data();
  const double* IM = p.inv_mass.data();
  double m0 = 0, u2 = 0;  // largest drift^2 and |v - flow|^2 of the particles moved here
  const double rate = sim.domain.shear.enabled ? sim.domain.shear.rate : 0.0;
  // The new state is formed in scalars and stored once: a vector load of components just
  // stored one by one (the velocity, or a Vec3 built on the stack) stalls, as store forwarding
  // fails; it was the loop's largest cost.
  for (const std::uint32_t i : contact_) {  // velocity Verlet's first half, as VelocityVerlet
    const double k = h * IM[i];
    const double wx = V[i][0] + k * F[i][0], wy = V[i][1] + k * F[i][1];
    const double vx = c * wx + s * wy, vy = c * wy - s * wx, vz = planar ? 0.0 : V[i][2] + k * F[i][2];
    const double x = X[i][0] + dt * vx, y = X[i][1] + dt * vy, z = X[i][2] + dt * vz;
    V[i][0] = vx;
    V[i][1] = vy;
    V[i][2] = vz;
    X[i][0] = x;
    X[i][1] = y;
    X[i][2] = z;
    const double dx = x - XB[i][0] - stream * XB[i][1], dy = y - XB[i][1], dz = z - XB[i][2];
    const double ux = vx - rate * y;
    m0 = std::max(m0, dx * dx + dy * dy + dz * dz);
    u2 = std::max(u2, ux * ux + vy * vy + vz * vz);
  }
  // The free particles have not moved in memory: the farthest their epicycles can have taken
  // them from the build position. |u_x| <= M/2, |u_y| <= M with M = |(2 u_x, u_y)| invariant,
  // and the flow at the particle differs from the flow at its build position by gamma |dy|.
  // The fast ones each by their own bound (fast_bounds).
  if (contact_.size() < p.nlocal) {
    const double tau = sim.time - t_ref_;
    double far = 0;
    for (std::size_t k = 0; k < fast_a_.size(); ++k) far = std::max(far, fast_a_[k] + (fast_b_[k] + fast_c_[k] * tau) * tau);
    m0 = std::max(m0, far * far);
    u2 = std::max(u2, fast_u2_);
    const double M = free_speed_;
    const double ux = 0.5 * M + rate * (free_dy_ + M * tau);
    const double bound = free_drift_ + std::sqrt(ux * ux + M * M + free_vz_ * free_vz_) * tau;
    m0 = std::max(m0, bound * bound);
    u2 = std::max(u2, 1.25 * M * M + free_vz_ * free_vz_);  // |u_x| <= M/2, |u_y| <= M
  }
  sim.stepping.max_drift2 = m0;
  sim.stepping.max_speed = std::sqrt(u2);
  if (p.rotation)
    for (const std::uint32_t i : contact_) p.omega[i] += (h * p.inv_inertia[i]) * p.torque[i];
  contact_particle_steps += static_cast<long long>(contact_.size());
  for (const std::uint32_t i : contact_) *p.column(work_column_, i) += 1;
  stepped_particle_steps += static_cast<long long>(contact_.size());
  free_particle_steps += static_cast<long long>(p.nlocal - contact_.size());
}

void MultiRateHill::pre_force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  const bool last = sim.step_count == last_step_;
  if (!watch_dirty_) {  // a ghost joined the contact steps: its free partners here need watching
    std::size_t awake = 0;
    for (std::size_t g = p.nlocal; g < p.size(); ++g) awake += on_contact_steps(mode_of(p, g));
    watch_dirty_ = awake != ghosts_awake_;
  }
  if (watch_dirty_) find_watched(sim);
  // Wake-ups, decided on the modes as they were at the step's start (the same on any rank count).
  woken_.clear();
  const double tau = sim.time - t_ref_;
  const Epicycle now(omega_, omega_z_, tau, planar_);
  stepped_particle_steps += static_cast<long long>(watch_.size());
  for (const std::uint32_t j : watch_) {
    *p.column(work_column_, j) += 1;
    Vec3 xj = p.x[j], vj = p.v[j];
    if (mode_of(p, j) == kFree) now.advance(xj, vj);
    for (std::uint32_t k = nl.start[j]; k < nl.start[j + 1]; ++k) {
      const std::uint32_t i = nl.partner[k];
      if (!on_contact_steps(mode_of(p, i))) continue;
      const Vec3& xi = p.x[i];
      const Vec3& vi = p.v[i];
      const double gap = (xj - xi).norm() - (p.radius[i] + p.radius[j]);
      if (gap >= 4 * (vj - vi).norm() * dt_) continue;
      woken_.push_back(j);
      wakes_touching += gap < 0;
      break;
    }
  }
  for (const std::uint32_t j : woken_) {
    if (mode_of(p, j) == kFree) now.advance(p.x[j], p.v[j]);
    set_mode(p, j, kWoken);
  }
  wakes += static_cast<long>(woken_.size());
  if (last) materialize(sim);  // every particle gets forces at the long step's end
  // Ghosts must show the woken (and, at the end, the moved) particles before the forces: at
  // the end all of them; otherwise only the woken ones, in one round of messages with the
  // neighbouring ranks (no collective: a rank with none to send says so).
  if (last) {
    sim.halo.update_ghosts(p);
  } else {
    woken_.insert(woken_.end(), rebuild_woken_.begin(), rebuild_woken_.end());
    if (sim.domain.nranks > 1 || !woken_.empty()) sim.halo.update_ghosts_of(p, woken_);
    woken_.resize(woken_.size() - rebuild_woken_.size());
  }
  rebuild_woken_.clear();
  if (!woken_.empty()) {
    make_lists(p);
    find_watched(sim);  // the woken's free partners: checked from the next step, as on another rank
  }
  sim.stepping.all_targets = last;
  if (!last) sim.stepping.targets = contact_;
}

void MultiRateHill::final_integrate(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const double h = 0.5 * dt_, c = rot_c_, s = rot_s_;
  const double since = sim.time - t0_;
  for (const std::uint32_t i : contact_) {
    Vec3& v = p.v[i];
    if (mode_of(p, i) == kWoken) {
      // Its state is the free one at this time, full step. It had delta/2 of the moonlet's
      // impulse at the long step's start; it is owed `since` of it. So with gravity's short
      // range (its mesh: Delta/2 at each end, free or not).
      Vec3 owed = moonlet_acceleration(p, i);
      if (gravity_) owed += gravity_->short_acceleration_now(i);
      v += (since - 0.5 * delta_) * owed;
      set_mode(p, i, kContact);
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
    if (on_contact_steps(mode_of(p, i))) {
      if (gravity_) p.v[i] += (0.5 * delta_) * slow_acceleration(p, i, false);
      continue;
    }
    p.v[i] += (0.5 * delta_) * slow_acceleration(p, i, true);
    if (moonlet_ && Moonlet::feels(p, i)) {
      const Vec3& x = p.x[i];
      const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + (planar_ ? 0.0 : x[2] * x[2]));
      missed += r < moonlet_radius_ + p.radius[i];
    }
  }
  in_long_step_ = false;
  publish(sim);
}

void MultiRateHill::weigh(Simulation& sim, std::vector<double>& cost) {
  ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    double& work = *p.column(work_column_, i);
    cost[i] *= 1 + work;
    work = 0;
  }
}

void MultiRateHill::publish(Simulation& sim) const {
  // One collective: every rank's counts (whole numbers, so the sums are exact in any order),
  // summed here; the contact steps' work per rank (particles stepped, drifted or watched),
  // largest over mean, is what the regions' balance must even out.
  const double local[6] = {double(contact_particle_steps), double(free_particle_steps), double(wakes),
                           double(wakes_touching), double(missed), double(stepped_particle_steps)};
  std::vector<double> all(6 * sim.domain.nranks);
  MPI_Allgather(local, 6, MPI_DOUBLE, all.data(), 6, MPI_DOUBLE, sim.domain.comm);
  double g[6] = {0, 0, 0, 0, 0, 0}, most = 0;
  for (int r = 0; r < sim.domain.nranks; ++r) {
    for (int k = 0; k < 6; ++k) g[k] += all[6 * r + k];
    most = std::max(most, all[6 * r + 5]);
  }
  std::ostringstream os;
  os.precision(6);
  os << "{\"long_step\": " << long_step_ << ", \"steps_per_long_step\": " << substeps_
     << ", \"contact_step_fraction\": " << (g[0] + g[1] > 0 ? g[0] / (g[0] + g[1]) : 0.0)
     << ", \"wakes\": " << std::llround(g[2]) << ", \"wakes_touching\": " << std::llround(g[3])
     << ", \"missed_moonlet_contacts\": " << std::llround(g[4])
     << ", \"step_work_imbalance\": " << (g[5] > 0 ? most / (g[5] / sim.domain.nranks) : 1.0) << "}";
  sim.set_result("multirate", os.str());
}

void MultiRateHill::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += (2 * omega_ * p.mass[i]) * Vec3(p.v[i][1], -p.v[i][0], 0);
}

}  // namespace cassini
