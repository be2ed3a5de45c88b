#include "physics/channel/Lubrication.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"

namespace cassini {

ModuleKind Lubrication::kind() {
  auto read = [](CaseFile& f, Config& c) {
    double dmin = 1e300;
    for (const auto& s : c.species) dmin = std::min(dmin, 2 * s.radius_min);
    LubricationSettings s;
    s.roughness = f.positive("lubrication.roughness", 0.01 * dmin);
    s.viscosity = f.positive("lubrication.viscosity", f.number("flow.viscosity", 1.8e-3));
    c.set(s);
    c.pair_reach = c.max_radius();  // h <= d/2 for the largest pair
  };
  auto make = [](Simulation& sim) {
    auto lub = std::make_unique<Lubrication>(sim.cfg.get<LubricationSettings>(), sim.dt);
    lub->load_ = sim.particles.declare("lubrication_load", 1, ParticleStore::Ghosts::carry);  // D_i; ghosts need it too
    return lub;
  };
  return {"lubrication", {}, read, make};
}

Lubrication::Lubrication(const LubricationSettings& s, double dt)
    : roughness_(s.roughness), viscosity_(s.viscosity), dt_(dt) {}

double Lubrication::relaxation(double r, double ai, double aj, double mi, double mj) const {
  const double a_star = ai * aj / (ai + aj);
  const double gap = r - ai - aj;
  if (gap > 2 * a_star || r == 0) return 0.0;
  const double h = std::max(gap, 2 * roughness_);
  const double m_star = mi * mj / (mi + mj);
  const double beta = 6 * std::numbers::pi * viscosity_ * a_star * a_star / (h * m_star);
  return -std::expm1(-beta * dt_);
}

Vec3 Lubrication::pair_force(const Vec3& d, const Vec3& dv, double ai, double aj, double mi, double mj,
                             double scale) const {
  const double r = d.norm();
  return film_force(d, r, relaxation(r, ai, aj, mi, mj), dv, mi, mj, scale);
}

Vec3 Lubrication::film_force(const Vec3& d, double r, double c, const Vec3& dv, double mi, double mj, double scale) const {
  if (c == 0) return Vec3::Zero();
  const Vec3 n = d / r;
  const double m_star = mi * mj / (mi + mj);
  const double rate = c * scale / dt_;  // -> beta when beta dt << 1 (scale 1: bitwise c / dt)
  return (-m_star * rate * dv.dot(n)) * n;
}

double Lubrication::scale(const ParticleStore& p, std::size_t i, std::size_t j) const {
  const double load = p.column(load_, i)[0] + p.column(load_, j)[0];  // the same sum from either side
  return load > 2 ? 2 / load : 1.0;
}

void Lubrication::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  long active = 0;
  next_.assign(p.nlocal, 0.0);
  film_.assign(p.nlocal, Vec3::Zero());  // each bead's films summed in list order, then added to its force
  sim.neighbors.for_each_pair([&](std::size_t i, std::uint32_t j, std::uint32_t) {
    const Vec3 d = p.x[i] - p.x[j];
    const double mi = p.mass[i], mj = p.mass[j];
    const double r = d.norm(), c = relaxation(r, p.radius[i], p.radius[j], mi, mj);
    if (c == 0) return;
    film_[i] += film_force(d, r, c, p.v[i] - p.v[j], mi, mj, scale(p, i, j));  // the film evaluated once
    next_[i] += c * (mi * mj / (mi + mj)) * (1 / mi + 1 / std::sqrt(mi * mj));
    ++active;
  });
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    p.f[i] += film_[i];
    p.column(load_, i)[0] = next_[i];  // read by the next step
  }
  active_ = active;
}

void Lubrication::pair_forces(const Simulation& sim, std::vector<PairForce>& out) const {
  const ParticleStore& p = sim.particles;
  sim.neighbors.for_each_pair_once(p, [&](std::size_t i, std::uint32_t j, std::uint32_t) {
    const Vec3 d = p.x[i] - p.x[j];
    const Vec3 f = pair_force(d, p.v[i] - p.v[j], p.radius[i], p.radius[j], p.mass[i], p.mass[j], scale(p, i, j));
    if (!f.isZero(0)) out.push_back({p.id[i], p.id[j], p.x[i], d, f});
  });
}

void Lubrication::observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) {
  long total = 0;
  MPI_Allreduce(&active_, &total, 1, MPI_LONG, MPI_SUM, sim.domain.comm);
  out.emplace_back("lubricated_pairs", double(total));
}

}  // namespace cassini
