#include "physics/ring/Moonlet.hpp"

#include <cmath>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/contact/WallContact.hpp"

namespace cassini {

ModuleKind Moonlet::kind() {
  auto read = [](CaseFile& f, Config& c) {
    const MoonletSettings m{f.positive("moonlet.mass"), f.positive("moonlet.radius")};
    c.set(m);
    c.obstacle_radius = m.radius;
  };
  auto make = [](Simulation& sim) {
    auto moonlet = std::make_unique<Moonlet>(sim.cfg, sim.dt);
    moonlet->history_ = WallHistory(sim.particles, "moonlet", 1, moonlet->law_);
    if (moonlet->law_.damping_limit()) moonlet->limit_ = DampingLimit::attach(sim.particles);
    return moonlet;
  };
  return {"moonlet", {}, read, make};
}

Moonlet::Moonlet(const Config& cfg, double dt)
    : law_(cfg, dt), gm_(kGravitationalConstant * cfg.get<MoonletSettings>().mass), radius_(cfg.get<MoonletSettings>().radius),
      dims_(cfg.planar ? 2 : 3) {}

// Scalar components on purpose (no `r[2] = 0` on an Eigen vector): patching one lane goes
// through the stack and stalls store-to-load forwarding in this once-per-particle loop.
Vec3 Moonlet::gravity(const Vec3& x) const {
  const double z = dims_ == 2 ? 0.0 : x[2];
  const double s = gravity_scale(x[0] * x[0] + x[1] * x[1] + z * z, gm_, radius_);
  return Vec3(s * x[0], s * x[1], s * z);
}

void Moonlet::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const bool planar = dims_ == 2;
  // Raw views and two passes: gravity for everyone (a branch-free loop the compiler
  // vectorises), then the rare contacts with the moonlet's surface.
  const Vec3* X = p.x.data();
  Vec3* F = p.f.data();
  const double* M = p.mass.data();
  const double* A = p.radius.data();
  const double gm = gm_, R = radius_;
  const Simulation::TargetList T = sim.target_list();
  auto pull = [&](std::size_t i) {
    const double x = X[i][0], y = X[i][1], z = planar ? 0.0 : X[i][2];
    const double s = M[i] * gravity_scale(x * x + y * y + z * z, gm, R);
    F[i][0] += s * x;
    F[i][1] += s * y;
    F[i][2] += s * z;
  };
  if (p.copies)  // modified Lees-Edwards boundaries: only LE1 holds the moonlet
    for (std::size_t t = 0; t < T.count; ++t) {
      if (p.le_copy[T[t]] == 0) pull(T[t]);
    }
  else if (!T.list)  // the plain loop for all: it vectorises
    for (std::size_t i = 0; i < T.count; ++i) pull(i);
  else
    for (std::size_t t = 0; t < T.count; ++t) pull(T[t]);
  DeepestOverlap deepest;
  long contacts = 0;
  const bool exact = law_.exact();
  shifts_.clear();
  for (std::size_t t = 0; t < T.count; ++t) {
    const std::size_t i = T[t];
    if (!feels(p, i)) continue;
    const double x = X[i][0], y = X[i][1], z = planar ? 0.0 : X[i][2];
    const double d2 = x * x + y * y + z * z, reach = R + A[i];
    // Each particle keeps its springs with the moonlet (history_), reset when it lets go, as
    // with any wall.
    // Most particles are far: no square root for them. Only this shell can hold the exact
    // scheme's exit step (a particle moves less than its radius per step: the tunnelling guard).
    const double far = exact ? reach + A[i] : reach;
    if (d2 >= far * far || d2 == 0) {
      history_.forget(p, i, 0);
      continue;
    }
    const double d = std::sqrt(d2), delta = reach - d;
    const Vec3 normal = Vec3(x, y, z) / d;
    Vec3 move = Vec3::Zero();
    const bool touching = wall_contact(law_, p, i, normal, delta, history_, 0, move, radius_, limit_, !sim.stepping.initial_forces);
    if (!move.isZero(0)) shifts_.add(i, move);
    if (!touching) continue;
    deepest.see(delta, A[i], p.id[i]);
    ++contacts;
  }
  max_overlap_ = deepest.fraction;
  worst_id_ = deepest.id;
  contacts_ = contacts;
}

template <class Visit>
void Moonlet::for_each_touching(const ParticleStore& p, Visit&& visit) const {
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (!feels(p, i)) continue;
    Vec3 r = p.x[i];
    if (dims_ == 2) r[2] = 0;
    const double d = r.norm();
    if (d >= radius_ + p.radius[i] || d == 0) continue;
    visit(i, Vec3(r / d), radius_ + p.radius[i] - d);
  }
}

void Moonlet::wall_forces(const Simulation& sim, std::vector<WallForce>& out) const {
  const ParticleStore& p = sim.particles;
  for_each_touching(p, [&](std::size_t i, const Vec3& n, double delta) {
    const Vec3 f = wall_contact_force(law_, p, i, n, delta, history_, 0, radius_);
    out.push_back({p.id[i], radius_ * n, p.x[i] - radius_ * n, f});
  });
}

double Moonlet::elastic_energy(const Simulation& sim) const {
  double e = 0;
  for_each_touching(sim.particles, [&](std::size_t i, const Vec3& n, double delta) {
    e += wall_contact_energy(law_, sim.particles, i, n, delta, history_, 0, radius_);
  });
  return e;
}

double Moonlet::potential_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (!feels(p, i)) continue;
    const double z = dims_ == 2 ? 0.0 : p.x[i][2];
    const double r = std::sqrt(p.x[i][0] * p.x[i][0] + p.x[i][1] * p.x[i][1] + z * z);
    u -= p.mass[i] * gm_ * (r >= radius_ ? 1 / r : (3 * radius_ * radius_ - r * r) / (2 * radius_ * radius_ * radius_));
  }
  return u;
}

void Moonlet::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (feels(p, i)) F[i] += p.mass[i] * gravity(p.x[i]);
}

void Moonlet::final_integrate(Simulation& sim) {
  shifts_.apply(sim.particles);
  const Simulation::TargetList t = sim.target_list();
  limit_.finish_step(sim.particles, t.list, t.count, sim.rebuilds);
}

void Moonlet::observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) {
  const double mine = double(contacts_);
  double all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  out.push_back({"moonlet_contacts", all});
}

}  // namespace cassini
