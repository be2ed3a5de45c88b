#pragma once
// Particle contacts with the channel's side walls (ChannelGeometry): the same LSD law and
// Coulomb friction as particle-particle contacts, the wall taken as an infinite mass. Each
// (particle, face or edge) keeps its own springs, in this module's per-particle columns
// channel_wall_* (WallHistory).
#include <cstdint>
#include <vector>

#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "physics/channel/ChannelGeometry.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"
#include "physics/contact/WallContact.hpp"

namespace cassini {

class ChannelWalls : public Module {
 public:
  // Reads [channel], [flow], [drag], [inlet] and [clog] (ChannelConfig), which the drag, inlet
  // and clog modules share.
  static ModuleKind kind();
  ChannelWalls(const Config& cfg, double dt);
  std::string name() const override { return "channel walls (" + std::to_string(geometry_.features()) + " faces and edges)"; }
  unsigned stages() const override {
    return kForce | kRebuild | (law_.exact() || limit_.owner() ? kFinalIntegrate : 0u);
  }
  void force(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;
  void post_rebuild(Simulation& sim) override;
  void wall_forces(const Simulation& sim, std::vector<WallForce>& out) const override;
  double elastic_energy(const Simulation& sim) const override;
  double max_overlap_fraction() const override { return max_overlap_; }
  std::int64_t worst_id() const override { return worst_id_; }
  std::string overlap_label() const override { return "channel wall overlap"; }
  const ChannelGeometry& geometry() const { return geometry_; }

 private:
  // Calls visit(i, contact) for every face or edge an owned particle touches now (reports).
  template <class Visit>
  void for_each_touching(const ParticleStore& p, Visit&& visit) const;
  LinearSpringDashpot law_;
  DampingLimit limit_;
  PendingShifts shifts_;
  ChannelGeometry geometry_;
  WallHistory history_;  // one point per face or edge
  double max_overlap_ = 0;
  std::int64_t worst_id_ = -1;
  std::vector<WallContact> touching_;
  // Per particle, the features within its radius + skin at the last rebuild: the only ones it
  // can touch before the next (most beads are far from every side wall). One bit per feature.
  std::vector<std::uint64_t> candidates_;
};

}  // namespace cassini
