#pragma once
// Particle-particle contacts: the linear spring-dashpot law over the neighbour list.
// Owns the tangential history (with friction: a spring per owned pair on the entry that
// evaluates it, per side for ghost pairs) and carries it across rebuilds and migrations by
// (owner id, partner id).
#include <vector>

#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/NeighborList.hpp"
#include "core/ParticleStore.hpp"
#include "parallel/HaloExchange.hpp"
#include "physics/contact/ContactSprings.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"

namespace cassini {

class ContactForces : public Module {
 public:
  static ModuleKind kind();
  ContactForces(const Config& cfg, double dt) : law_(cfg, dt) {}
  std::string name() const override {
    return "contact (" + law_.label() + (limit_.on() ? " + damping limit" : "") + ")";
  }
  // The exact scheme moves pairs at its onset and exit steps, at the end of the step.
  unsigned stages() const override {
    return kForce | kRebuild | (law_.exact() || limit_.owner() ? kFinalIntegrate : 0u);
  }
  void final_integrate(Simulation& sim) override;

  void force(Simulation& sim) override;
  // Work done on this rank's particles through contacts with images across a Lees-Edwards
  // boundary (see force()); with HaloExchange::shear_energy, the shear's whole work.
  double energy_input() const override { return boundary_work_; }
  void pre_rebuild(Simulation& sim) override;
  // Contact history, one row per owned contact that has some, in the columns this module
  // declares when it is made (kind()): "xi", the tangential spring (friction); "impact_speed",
  // the normal speed of the contact's impact (Bridges restitution); "roll", the rolling and
  // twisting torque spring (rolling resistance).
  void contact_history(const Simulation& sim, PairHistory& out) const override;
  // Every contact once (springs unchanged).
  void pair_forces(const Simulation& sim, std::vector<PairForce>& out) const override;
  // Recomputes contact counts and overlaps without touching forces or springs (after a restart).
  void refresh_diagnostics(const Simulation& sim);
  void post_rebuild(Simulation& sim) override;

  // Diagnostics of the last force evaluation (this rank).
  long contacts() const { return contacts_; }               // pairs in contact, each counted once per owned side
  double max_overlap_fraction() const override { return max_overlap_; }  // max delta / min(a_i, a_j)
  std::int64_t worst_id() const override { return worst_id_; }
  double elastic_energy(const Simulation& sim) const override;  // sum 1/2 k delta^2 over this rank's owned sides / 2
  bool pair_loop() const override { return true; }
  // After a restart the state is restored without a force evaluation: the diagnostics are
  // recomputed from it.
  void setup(Simulation& sim) override;
  double overlap_sum() const { return overlap_sum_; }        // sum of delta / min(a_i, a_j) over contacts
  // Columns of observables.csv: contacts (pairs touching), collisions (new contacts since the
  // last row), mean and max overlap over the smaller radius.
  void observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) override;
  // New contacts (collisions) since the last call, each pair counted once across all ranks.
  long take_collisions() { const long c = collisions_; collisions_ = 0; return c; }
  // Since the last call, over the collisions counted above, from each impact's normal speed u
  // (this rank's share): the energy a free binary collision dissipates, sum (1 - e^2) m u^2 / 2
  // (exact for frictionless binary collisions under the exact scheme), and the hard-sphere
  // collisional virial sum J r^T with J = (1 + e) m u n, r = (a_i + a_j) n (the collisional
  // stress is its rate over the volume). Frictionless contacts only: friction dissipates more.
  struct Impacts {
    double loss;
    Eigen::Matrix3d virial;
  };
  Impacts take_impacts() {
    const Impacts out{impact_loss_, impact_virial_};
    impact_loss_ = 0;
    impact_virial_.setZero();
    return out;
  }

 private:
  // Per list entry: on the entry that evaluates an owned pair (partner above), the partner's
  // entry for the same pair; on the partner's (receiving) entry, this step's result slot, or
  // kNoMirror for none (written whenever the entry has work: both entries of a pair always
  // do, the same test from either side); kNoMirror for a ghost partner.
  static constexpr std::uint32_t kNoMirror = 0xffffffffu;
  // A pair's result from its evaluating side; the receiving side reads f negated.
  struct Result {
    Vec3 f;
    Vec3 nxft;     // with friction: n x f_t, the torque's lever product (the same from both sides)
    double shift;  // the exact scheme's overlap shift (0 but at onset and exit steps)
    std::uint32_t flags;
  };
  static constexpr std::uint32_t kHasForce = 1, kContact = 2;  // kContact: torque and load too
  template <bool Plain, class Parts>
  void evaluate(Simulation& sim, const Parts& parts);
  void build_mirrors(const ParticleStore& p, const NeighborList& nl);
  bool keeps_history() const { return law_.friction() || law_.velocity_dependent(); }
  // Offsets of this module's columns in a PairHistory row (-1: the scene keeps none).
  int xi_column_ = -1, impact_column_ = -1, roll_column_ = -1;
  // The law of list entry k's contact (its own under the Bridges law).
  PairLaw entry_law(int a, int b, std::uint32_t k) const;

  LinearSpringDashpot law_;
  DampingLimit limit_;  // on when a crowded particle could need it (LinearSpringDashpot::damping_limit)
  std::vector<std::uint32_t> mirror_;
  std::vector<std::uint32_t> active_;      // force(): the entries with work this step
  std::vector<std::uint32_t> evaluating_;  // force(): those of them that evaluate their pair
  std::vector<Result> results_;            // force(): one per evaluating entry, then extra
  std::vector<Vec3> result_roll_;          // rolling resistance: the rolling torque, per result
  // Tangential (and rolling) springs, only where there is contact. A pair of owned particles
  // keeps its springs on its evaluating entry; its receiving entry's are their exact negatives
  // (spring_of), so the pair loop never touches the partner's entry for them. Pairs in split_
  // keep a spring on each entry, each side evolving its own.
  ContactSprings springs_;
  std::vector<double> impact_;  // Bridges law: impact normal speed per entry in contact (0: none)
  // The evaluating entries (ascending, then kSplitEnd) of owned pairs whose two sides' history
  // came from independent evaluations (across a rank or periodic boundary before a migration)
  // and is not an exact negation: springs or impact speeds that may differ in the last bits.
  // Their partner side is evaluated on its own history, as the partner would, until the next
  // rebuild. Found by post_rebuild, the only place history arrives from elsewhere.
  static constexpr std::uint32_t kSplitEnd = 0xffffffffu;
  std::vector<std::uint32_t> split_{kSplitEnd};
  struct Springs {
    Vec3 xi = Vec3::Zero(), roll = Vec3::Zero();
  };
  // The springs of list entry k (zero without contact), whichever side of its pair it is on.
  Springs spring_of(const ParticleStore& p, const NeighborList& nl, std::uint32_t k) const;
  bool has_springs(const NeighborList& nl) const { return law_.friction() && springs_.entries() == nl.size(); }
  std::vector<std::uint8_t> touching_;  // per entry: in contact at the last evaluation
  // Sheared runs, per ghost: +1 (-1) for an image across the upper (lower) y face, 0 otherwise;
  // set at each rebuild (boundary work, force()).
  std::vector<std::int8_t> image_side_;
  PendingShifts shifts_;  // exact scheme: moves of this step
  std::vector<std::uint32_t> table_;     // post_rebuild: the history stash hashed by (owner, partner)
  std::vector<std::uint32_t> touching_now_;  // post_rebuild: the entries whose pair touches
  // The entries in contact at the last evaluation, ascending (springs are zero elsewhere).
  void in_contact(std::vector<std::uint32_t>& out) const;
  double overlap_sum_ = 0;
  long collisions_ = 0;
  double impact_loss_ = 0;
  double boundary_work_ = 0;
  Eigen::Matrix3d impact_virial_ = Eigen::Matrix3d::Zero();
  long contacts_ = 0;
  double max_overlap_ = 0;
  std::int64_t worst_id_ = -1;
};

}  // namespace cassini
