#include "physics/ContactForces.hpp"

#include <algorithm>

#include "core/Simulation.hpp"

namespace cassini {

void ContactForces::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  const bool fric = law_.friction();
  if (fric && xi_.size() != nl.size()) xi_.assign(nl.size(), Vec3::Zero());
  long contacts = 0;
  double worst = 0;
  std::int64_t worst_id = -1;
  // Raw views: the compiler cannot prove the vectors' data pointers stay put across the
  // stores below, and would reload them for every pair.
  const Vec3* X = p.x.data();
  const Vec3* V = p.v.data();
  const Vec3* W = fric ? p.omega.data() : nullptr;
  const double* A = p.radius.data();
  const double* M = p.mass.data();
  const std::int32_t* S = p.species.data();
  const std::uint32_t* start = nl.start.data();
  const std::uint32_t* partner = nl.partner.data();
  Vec3* XI = fric ? xi_.data() : nullptr;
  if (touching_.size() != nl.size()) touching_.assign(nl.size(), 0);
  std::uint8_t* T = touching_.data();
  const std::int64_t* ID = p.id.data();
  double overlap_sum = 0;
  long onsets = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Vec3 xi = X[i], vi = V[i];
    const double ai = A[i], mi = M[i];
    const int si = S[i];
    Vec3 fsum = Vec3::Zero(), tsum = Vec3::Zero();
    for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
      const std::uint32_t j = partner[k];
      const Vec3 d = xi - X[j];
      const double r2 = d.squaredNorm(), R = ai + A[j];
      if (r2 >= R * R) {
        if (T[k]) {  // contact just ended: forget the spring (writes only on transitions)
          T[k] = 0;
          if (fric) XI[k].setZero();
        }
        continue;
      }
      onsets += (!T[k] && ID[i] < ID[j]);  // the lower id counts the pair, wherever it lives
      T[k] = 1;
      const double r = std::sqrt(r2);
      const Vec3 n = d / r;
      const double delta = R - r;
      const double mj = M[j];
      const double m = mi * mj / (mi + mj);
      Vec3 vrel = vi - V[j];
      if (fric) vrel -= (ai * W[i] + A[j] * W[j]).cross(n);
      Vec3 ft;
      fsum += law_.force(law_.law(si, S[j]), m, delta, n, vrel, fric ? &XI[k] : nullptr, ft);
      if (fric) tsum += (-ai * n).cross(ft);  // lever from i's centre to the contact point
      ++contacts;
      const double frac = delta / std::min(ai, A[j]);
      overlap_sum += frac;
      if (frac > worst) { worst = frac; worst_id = p.id[i]; }
    }
    p.f[i] += fsum;
    if (fric) p.torque[i] += tsum;
  }
  contacts_ = contacts;
  overlap_sum_ = overlap_sum;
  collisions_ += onsets;
  max_overlap_ = worst;
  worst_id_ = worst_id;
}

double ContactForces::elastic_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  double e = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      const double R = p.radius[i] + p.radius[j], r = (p.x[i] - p.x[j]).norm();
      if (r >= R) continue;
      const double m = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
      const PairLaw& L = law_.law(p.species[i], p.species[j]);
      e += 0.25 * m * L.k_per_mass * (R - r) * (R - r);  // 1/2 k delta^2, half per side
      if (law_.friction()) e += 0.25 * L.kt_ratio * m * L.k_per_mass * xi_[k].squaredNorm();
    }
  return e;
}

void ContactForces::springs(const Simulation& sim, std::vector<HistoryEntry>& out) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  out.clear();
  if (!law_.friction() || nl.start.size() != p.nlocal + 1 || xi_.size() != nl.size()) return;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k)
      if (!xi_[k].isZero(0)) out.push_back({p.id[i], p.id[nl.partner[k]], xi_[k]});
}

void ContactForces::pair_forces(const Simulation& sim, std::vector<PairForce>& out) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  const bool fric = law_.friction();
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      if (p.id[i] >= p.id[j]) continue;
      const Vec3 d = p.x[i] - p.x[j];
      const double r = d.norm(), R = p.radius[i] + p.radius[j];
      if (r >= R) continue;
      const Vec3 n = d / r;
      const double m = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
      Vec3 vrel = p.v[i] - p.v[j];
      if (fric) vrel -= (p.radius[i] * p.omega[i] + p.radius[j] * p.omega[j]).cross(n);
      Vec3 spring = fric && k < xi_.size() ? xi_[k] : Vec3::Zero(), ft;
      const Vec3 f = law_.force(law_.law(p.species[i], p.species[j]), m, R - r, n, vrel, fric ? &spring : nullptr, ft);
      out.push_back({p.id[i], p.id[j], p.x[i], d, f});
    }
}

void ContactForces::refresh_diagnostics(const Simulation& sim) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  contacts_ = 0;
  max_overlap_ = overlap_sum_ = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      const double R = p.radius[i] + p.radius[j], r = (p.x[i] - p.x[j]).norm();
      if (r >= R) continue;
      ++contacts_;
      const double frac = (R - r) / std::min(p.radius[i], p.radius[j]);
      overlap_sum_ += frac;
      if (frac > max_overlap_) { max_overlap_ = frac; worst_id_ = p.id[i]; }
    }
}

void ContactForces::pre_rebuild(Simulation& sim) {
  // Without a list yet (first rebuild, or after a restart) keep what is in the stash.
  if (!law_.friction() || sim.neighbors.start.size() != sim.particles.nlocal + 1) return;
  springs(sim, sim.history);
}

void ContactForces::post_rebuild(Simulation& sim) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  // Pairs already touching across a rebuild are not new collisions.
  touching_.assign(nl.size(), 0);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      const double R = p.radius[i] + p.radius[j];
      touching_[k] = (p.x[i] - p.x[j]).squaredNorm() < R * R;
    }
  if (!law_.friction()) return;
  auto& stash = sim.history;
  xi_.assign(nl.size(), Vec3::Zero());
  auto before = [](const HistoryEntry& a, const HistoryEntry& b) {
    return a.owner < b.owner || (a.owner == b.owner && a.partner < b.partner);
  };
  std::sort(stash.begin(), stash.end(), before);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      if (!touching_[k]) continue;  // separated during the drift: the spring is gone
      const HistoryEntry key{p.id[i], p.id[nl.partner[k]], {}};
      auto it = std::lower_bound(stash.begin(), stash.end(), key, before);
      if (it != stash.end() && it->owner == key.owner && it->partner == key.partner) xi_[k] = it->xi;
    }
  stash.clear();
}

}  // namespace cassini
