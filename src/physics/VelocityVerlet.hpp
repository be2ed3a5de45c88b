#pragma once
// Velocity Verlet (kick-drift-kick) for translation and, when the scene rotates, for spin.
// Forces are evaluated after the drift with x(t+dt) and the half-step velocity v(t+dt/2), so
// velocity-dependent forces (dashpots) see v(t+dt/2). In planar scenes only x and y move.
#include <memory>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/Simulation.hpp"

namespace cassini {

class VelocityVerlet : public Module {
 public:
  // time.integrator = "verlet" (the default), in the frame's rotation (Config::frame_rotation).
  static ModuleKind kind() {
    auto read = [](CaseFile& f, Config&) {
      for (const char* k : {"time.long_step", "time.max_tidal_phase"})
        if (f.has(k)) f.fail(k, "no value unless time.integrator = \"multirate\"");
    };
    auto make = [](Simulation& sim) {
      auto v = std::make_unique<VelocityVerlet>(sim.cfg.planar);
      v->set_frame_rotation(sim.cfg.frame_rotation);
      return v;
    };
    return {"verlet", {}, read, make};
  }
  explicit VelocityVerlet(bool planar) : planar_(planar) {}
  std::string name() const override {
    return std::string("velocity-verlet") + (planar_ ? " (planar x-y)" : "") + (omega_ != 0 ? " in rotating frame" : "");
  }
  // Integrate in a frame rotating at omega about z: the Coriolis acceleration 2 omega (vy, -vx)
  // is applied as an exact rotation of the velocity over each half step (see HillFrame.hpp).
  void set_frame_rotation(double omega) { omega_ = omega; }
  unsigned stages() const override { return kInitialIntegrate | kFinalIntegrate; }
  void initial_integrate(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;
  // In a rotating frame the Coriolis force 2 m omega (vy, -vx, 0) is a body force too.
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;

 private:
  bool planar_;
  double omega_ = 0;
  double position_sum_ = 0;  // the sum of the positions' components after this step's drift (Simulation::state_sum)
};

}  // namespace cassini
