#pragma once
// A moonlet fixed at the origin: point-mass gravity on every particle and an immovable
// sphere they collide with (linear spring-dashpot with the wall reduced mass m_ij = m_i and
// the particle's own species t_c and e).
//
// Inside the moonlet's radius the gravity is that of a uniform sphere, -G M r / R^3, so a
// particle pushed into it (or aimed at its centre) feels a finite force: no r -> 0 blow-up.
#include <algorithm>
#include <cmath>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/ParticleStore.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"
#include "physics/contact/WallContact.hpp"

namespace cassini {

struct MoonletSettings {  // [moonlet]
  double mass = 0, radius = 0;  // kg, m
};

class Moonlet : public Module {
 public:
  static ModuleKind kind();
  Moonlet(const Config& cfg, double dt);
  std::string name() const override { return "moonlet"; }
  unsigned stages() const override { return kForce | (law_.exact() || limit_.owner() ? kFinalIntegrate : 0u); }
  void final_integrate(Simulation& sim) override;
  void force(Simulation& sim) override;
  void wall_forces(const Simulation& sim, std::vector<WallForce>& out) const override;
  double elastic_energy(const Simulation& sim) const override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  double potential_energy(const Simulation& sim) const override;  // -G M m / r (uniform sphere inside)

  Vec3 gravity(const Vec3& x) const;  // acceleration at x
  // Whether particle i sees the moonlet: under modified Lees-Edwards boundaries only LE1
  // (copy 0) holds it; LE2 is the unperturbed ring that feeds LE1.
  static bool feels(const ParticleStore& p, std::size_t i) { return !p.copies || p.le_copy[i] == 0; }
  Vec3 acceleration(const ParticleStore& p, std::size_t i) const {
    return feels(p, i) ? gravity(p.x[i]) : Vec3::Zero();
  }
  double max_overlap_fraction() const override { return max_overlap_; }
  std::int64_t worst_id() const override { return worst_id_; }
  std::string overlap_label() const override { return "moonlet overlap"; }
  long contacts() const { return contacts_; }
  // A column of observables.csv: moonlet_contacts, the particles touching it.
  void observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) override;

 private:
  // Acceleration / r at squared distance d2: -G M / max(d, R)^3 (inside, the uniform sphere).
  // Branch-free and on plain values (no members: stores to the forces could alias them), so
  // the per-particle gravity loop vectorises.
  static double gravity_scale(double d2, double gm, double R) {
    const double d = std::max(std::sqrt(d2), R);
    return -gm / (d * d * d);
  }
  // Calls visit(i, n, delta) for every owned particle touching the surface now (reports).
  template <class Visit>
  void for_each_touching(const ParticleStore& p, Visit&& visit) const;
  LinearSpringDashpot law_;
  DampingLimit limit_;
  PendingShifts shifts_;
  double gm_, radius_;
  int dims_;
  WallHistory history_;  // each particle's springs with the surface (one point)
  double max_overlap_ = 0;
  std::int64_t worst_id_ = -1;
  long contacts_ = 0;
};

}  // namespace cassini
