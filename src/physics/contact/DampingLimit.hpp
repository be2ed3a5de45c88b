#pragma once
// Many damped contacts on one particle (a held clog, a settled pile, a bead wedged between a
// channel's floor and ceiling). Each contact alone is stable at any N_c: the exact scheme's
// constants give a binary contact K = k_eff dt^2 < 4 and G = gamma_eff dt < 1 (per reduced
// mass). But velocity Verlet with the dashpot on the half-step velocity is stable only while
// every mode of the whole contact network has K + 2 G < 4, and a particle's contacts add up:
// with e = 0.1 at N_c = 5 three or four contacts already exceed it. The clogging scene then
// blows up in a floor-bead-bead-ceiling wedge (docs/clogging.md), and LAMMPS or LIGGGHTS users
// have to shrink the time step for the densest moment of a run.
//
// The limit scales each contact's damping (its normal, tangential, rolling and twisting
// dashpots, not the springs) by s_ij = min(s_i, s_j), where particle i's
//   s_i = min(1, (B - K_i) / (2 G_i)),  K_i = sum w_c K_c,  G_i = sum w_c G_c,
// over i's contacts c, with K_c and G_c the contact's stiffness and damping per step
// (LinearSpringDashpot::stability) and w_c = m* (1/m_i + 1/sqrt(m_i m_j)) (1 for a wall; 1 for
// equal beads), plus, for contacts that resist rolling, their torque springs on i's spin
// (LinearSpringDashpot::spin_stability: per i's own moment of inertia, which is what a crowded
// bead's spin feels, not the rolling oscillator's 3.5x larger one). Then every row sum of the
// step's matrix is at most B < 4 (Gershgorin, in the mass-weighted norm, as Lubrication's
// many-film scaling): no mode can grow, however many
// contacts. Where the plain sum was already below B (every binary collision, any dilute
// gas) s = 1 and the force is bit for bit the unlimited one, so e and t_c of a binary collision
// stay exact. Only the dashpots of crowded particles lose part of their damping, and only the
// part no explicit step could have delivered.
//
// K_i and G_i come from the previous step (the loads a particle column carries to the ghosts),
// so both sides of a pair see the same s_ij. Every module that makes contacts (particle pairs,
// plane walls, the channel, the moonlet) adds its contacts' loads and scales its dashpots; the
// first of them in the registry's order owns the column and moves this step's loads into it at
// the end of the step.
//
// Force reports (snapshots' contact forces, cassini-cg's stress) show the unlimited dashpot: a
// packing at rest has no dashpot force, so its stress is the same either way.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/ParticleStore.hpp"

namespace cassini {

class DampingLimit {
 public:
  static constexpr double kBound = 3.6;  // B: a 10 % margin below the stability edge 4

  DampingLimit() = default;
  // Declares the particle columns, or finds them when an earlier module declared them; the
  // declaring module owns them (calls finish_step).
  static DampingLimit attach(ParticleStore& p) {
    DampingLimit d;
    d.on_ = true;
    const std::size_t found = p.find_column("damping_load");
    d.owner_ = found == ParticleStore::kNoColumn;
    d.load_ = d.owner_ ? p.declare("damping_load", 2, ParticleStore::Ghosts::carry) : found;  // last step's K_i, G_i; ghosts read them
    d.next_ = d.owner_ ? p.declare("damping_load_next", 2, ParticleStore::Ghosts::zero) : p.find_column("damping_load_next");
    return d;
  }
  bool on() const { return on_; }
  bool owner() const { return owner_; }

  // s_i from the loads of the last step (1 for a particle that had no contact).
  double scale(const ParticleStore& p, std::size_t i) const {
    const double* l = p.column(load_, i);
    if (l[0] + 2 * l[1] <= kBound) return 1.0;
    return std::clamp((kBound - l[0]) / (2 * l[1]), 0.0, 1.0);
  }
  // This step's contact of owned particle i: stiffness and damping per step, and its weight.
  void add(ParticleStore& p, std::size_t i, double K, double G, double weight) const {
    double* n = p.column(next_, i);
    n[0] += weight * K;
    n[1] += weight * G;
  }
  // The weight of a contact with a particle of mass mj (w_c above); mj = 0: a wall.
  static double weight(double mi, double mj) {
    if (mj == 0) return 1.0;
    const double m = mi * mj / (mi + mj);
    return m * (1 / mi + 1 / std::sqrt(mi * mj));
  }
  // The owner, at the end of the step: this step's loads become the next step's.
  // Moves this step's loads into last step's, on the owner's final_integrate. Only particles
  // that can hold a load are visited when the step had `targets` (a multi-rate contact step:
  // only they got forces, so only they have new loads) and no slot has moved since the last
  // call: those, and the ones loaded last step (now unloaded). Otherwise every owned particle.
  // Under the multi-rate integrator the full pass over 30,000 particles was half of a ring's
  // step time, where a few dozen are on contact steps.
  void finish_step(ParticleStore& p, const std::uint32_t* targets, std::size_t count, long rebuilds) {
    if (!owner_) return;
    const bool sparse = targets && rebuilds == rebuilds_ && p.nlocal == nlocal_;
    rebuilds_ = rebuilds;
    nlocal_ = p.nlocal;
    if (sparse)
      for (const std::uint32_t i : loaded_) {
        double* l = p.column(load_, i);
        l[0] = l[1] = 0;
      }
    const std::size_t n = sparse ? count : p.nlocal;
    loaded_.resize(n + 1);  // written one past the last kept entry (no branch: most carry no load)
    std::size_t kept = 0;
    for (std::size_t t = 0; t < n; ++t) {
      const std::size_t i = sparse ? targets[t] : t;
      double* l = p.column(load_, i);
      double* nx = p.column(next_, i);
      l[0] = nx[0];
      l[1] = nx[1];
      nx[0] = nx[1] = 0;
      loaded_[kept] = static_cast<std::uint32_t>(i);
      kept += (l[0] != 0) | (l[1] != 0);
    }
    loaded_.resize(kept);
  }

 private:
  bool on_ = false, owner_ = false;
  std::size_t load_ = 0, next_ = 0;
  std::vector<std::uint32_t> loaded_;  // owned particles with a load after the last finish_step
  long rebuilds_ = -1;                 // the neighbour rebuilds and owned count it was made with
  std::size_t nlocal_ = 0;
};

}  // namespace cassini
