#pragma once
// A constant body force per unit mass (gravity).
#include "core/Module.hpp"
#include "core/Vec3.hpp"

namespace cassini {

class Gravity : public Module {
 public:
  explicit Gravity(const Vec3& g) : g_(g) {}
  std::string name() const override { return "gravity"; }
  unsigned stages() const override { return kForce; }
  void force(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  double potential_energy(const Simulation& sim) const override;  // -m g . x
  const Vec3& g() const { return g_; }

 private:
  Vec3 g_;
};

}  // namespace cassini
