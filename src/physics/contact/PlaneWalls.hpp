#pragma once
// Flat walls: the domain faces declared "wall" in domain.boundary. A particle touching a wall
// feels the same LSD law as a particle-particle contact with the wall as an infinite mass
// (m_ij = m_i), using the particle's own species parameters. Each (particle, wall) keeps its
// own springs, in this module's per-particle columns plane_wall_* (WallHistory).
#include <cstdint>
#include <vector>

#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"
#include "physics/contact/WallContact.hpp"

namespace cassini {

struct Plane {
  Vec3 point;
  Vec3 normal;  // unit, pointing into the domain
};

class PlaneWalls : public Module {
 public:
  static ModuleKind kind();  // the domain faces declared "wall" (added to `modules` by itself)
  PlaneWalls(const Config& cfg, double dt);
  std::string name() const override { return "walls (" + std::to_string(planes_.size()) + " planes)"; }
  unsigned stages() const override {
    return kForce | kRebuild | (law_.exact() || limit_.owner() ? kFinalIntegrate : 0u);
  }
  void force(Simulation& sim) override;
  void post_rebuild(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;
  void wall_forces(const Simulation& sim, std::vector<WallForce>& out) const override;
  double elastic_energy(const Simulation& sim) const override;
  const std::vector<Plane>& planes() const { return planes_; }
  double max_overlap_fraction() const override { return max_overlap_; }
  std::int64_t worst_id() const override { return worst_id_; }
  std::string overlap_label() const override { return "wall overlap"; }

 private:
  LinearSpringDashpot law_;
  DampingLimit limit_;
  PendingShifts shifts_;
  std::vector<Plane> planes_;
  WallHistory history_;  // one point per plane
  // Per particle, the planes within its radius + skin at the last rebuild (one bit each): the
  // only ones it can touch, or have touched a step ago, before the next rebuild.
  std::vector<std::uint8_t> candidates_;
  double max_overlap_ = 0;
  std::int64_t worst_id_ = -1;
};

// Wall planes implied by a case's domain boundaries.
std::vector<Plane> domain_walls(const Config& cfg);

}  // namespace cassini
