#pragma once
// Lubrication between two beads in a viscous fluid (spec section 3; thesis 8.6, Metzger et
// al.): the Reynolds force of the film squeezed between approaching surfaces,
//   F_i = -6 pi eta a*^2 / h  ((v_i - v_j) . n) n,    a* = a_i a_j / (a_i + a_j),
// which for equal beads is the spec's 3 pi eta d^2 / (8 h). n points from j to i, h is the
// surface gap. It acts for gaps up to 2 a* (d/2 for equal beads); below 2 eps_r (surface
// roughness, lubrication.roughness) h is held at 2 eps_r, also while the beads touch, so the
// force stays finite and the contact law takes over the rest.
//
// Time integration: the film is a pair damper of rate beta = 6 pi eta a*^2 / (h m*), which
// at h = 2 eps_r can exceed 1/dt by orders of magnitude (for 67 um beads in water-glycerol
// and eps_r = 1 % of d, beta dt ~ 1). Like the drag, the damping uses the exact relaxation
// of the pair's normal velocity over one step, m* (1 - exp(-beta dt)) / dt instead of
// m* beta: the same force when beta dt << 1, and it never reverses the approach velocity of
// an isolated pair however small eps_r is.
//
// Many films at once (a dense pile, a held clog): the relaxations, exact for an isolated pair,
// add up on a bead with many films, and summed as they are they overshoot once the films are
// stiff (beta dt >~ 1): the pile's kinetic energy then grows geometrically (eps_r = 0.1 % of d
// in issue 19). Each film's relaxation c = 1 - exp(-beta dt) is therefore scaled by
//   s_ij = min(1, 2 / (D_i + D_j)),   D_i = sum over i's films of c m* (1/m_i + 1/sqrt(m_i m_j)),
// the bead's film load. With it the step's velocity update v -> v - A v has, in the
// mass-weighted norm, every eigenvalue of A in [0, 2] (Gershgorin: each row sum of the scaled
// relaxations is at most 2), so the films never add kinetic energy, however many and however
// stiff. An isolated pair (D_i + D_j = 2c <= 2) and any dilute film network keep s = 1: the
// force is unchanged where the plain sum was already stable. D comes from the previous step
// (a particle column the ghosts carry), so both sides of a pair scale alike.
//
// Evaluated from each side with the same operations, so the pair forces cancel bitwise.
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/ParticleStore.hpp"
#include "core/Vec3.hpp"

namespace cassini {

struct LubricationSettings {  // [lubrication]
  double roughness = 0;  // eps_r (m): h is held at 2 eps_r below it; default 1 % of the smallest diameter
  double viscosity = 0;  // Pa s; default flow.viscosity, else 1.8e-3
};

class Lubrication : public Module {
 public:
  static ModuleKind kind();
  Lubrication(const LubricationSettings& s, double dt);
  std::string name() const override { return "lubrication (eps_r = " + std::to_string(roughness_) + " m)"; }
  unsigned stages() const override { return kForce; }
  void force(Simulation& sim) override;
  void pair_forces(const Simulation& sim, std::vector<PairForce>& out) const override;
  // The force on i for one pair, from (x_i - x_j), (v_i - v_j), radii and masses; `scale`:
  // the many-film scaling s_ij (1 for an isolated pair).
  Vec3 pair_force(const Vec3& d, const Vec3& dv, double ai, double aj, double mi, double mj, double scale = 1.0) const;
  // The film's relaxation over one step, 1 - exp(-beta dt) (0 beyond the film's reach).
  double relaxation(double r, double ai, double aj, double mi, double mj) const;
  long active_pairs() const { return active_; }
  // lubricated_pairs: pairs within the film's reach at the last force evaluation.
  void observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) override;

 private:
  double roughness_, viscosity_, dt_;
  long active_ = 0;
  std::size_t load_ = 0;      // the particle column of D_i (ParticleStore::declare)
  std::vector<double> next_;  // this step's D_i of the owned particles, stored at the end
  std::vector<Vec3> film_;    // this step's film force on each owned particle
  double scale(const ParticleStore& p, std::size_t i, std::size_t j) const;
  // The force on i of a film with relaxation c at centre distance r = |d|.
  Vec3 film_force(const Vec3& d, double r, double c, const Vec3& dv, double mi, double mj, double scale) const;
};

}  // namespace cassini
