#pragma once
// Velocity Verlet (kick-drift-kick) for translation and, when the scene rotates, for spin.
// Forces are evaluated after the drift with x(t+dt) and the half-step velocity v(t+dt/2), so
// velocity-dependent forces (dashpots) see v(t+dt/2). In planar scenes only x and y move.
#include "core/Module.hpp"

namespace cassini {

class VelocityVerlet : public Module {
 public:
  explicit VelocityVerlet(bool planar) : planar_(planar) {}
  std::string name() const override { return planar_ ? "velocity-verlet (planar x-y)" : "velocity-verlet"; }
  unsigned stages() const override { return kInitialIntegrate | kFinalIntegrate; }
  void initial_integrate(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;

 private:
  bool planar_;
};

}  // namespace cassini
