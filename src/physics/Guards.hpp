#pragma once
// Numerical guards: the run stops, with the step, time, particle id, rank and cause, rather
// than running on with NaN, runaway overlaps, exploding energy or lost particles.
// Checks are local and cheap (one pass over owned particles per step); the verdict is
// combined across ranks in the step loop's existing reduction, so every rank stops together.
#include <string>

#include "core/Module.hpp"

namespace cassini {

class Guards : public Module {
 public:
  Guards(double max_overlap, double energy_growth, double max_step)
      : max_overlap_(max_overlap), energy_growth_(energy_growth), max_step_(max_step) {}
  std::string name() const override { return "guards"; }
  unsigned stages() const override { return kInitialIntegrate | kEndOfStep; }
  void setup(Simulation& sim) override;
  // Runs after the integrator's drift: a particle that moved too far in one step (relative to
  // the imposed flow) may have passed through another one unseen: tunnelling.
  void initial_integrate(Simulation& sim) override;
  void end_of_step(Simulation& sim) override;

 private:
  static constexpr long kEnergyPeriod = 100;  // steps between energy checks (at least)
  std::string diagnose(const Simulation& sim) const;  // why the fast scan failed
  double max_overlap_, energy_growth_;
  struct Energy {
    double kinetic, potential, input;  // global: KE, sum of the modules' potentials, their work + the shear's
  };
  Energy energy(const Simulation& sim) const;  // collective
  Energy start_{};
  double max_step_;      // fraction of the smallest radius
  double step_limit2_ = 0;  // (max_step_ * smallest radius)^2
  double last_drift2_ = 0;  // the integrator's max_drift2 of the previous step
  long next_energy_check_ = 0;  // the energy guard's next step (or the first synchronised one after it)
};

}  // namespace cassini
