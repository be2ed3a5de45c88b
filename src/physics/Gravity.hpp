#pragma once
// A constant body force per unit mass (gravity).
#include <memory>

#include "core/CaseFile.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/Simulation.hpp"
#include "core/Vec3.hpp"

namespace cassini {

class Gravity : public Module {
 public:
  struct Settings {  // [gravity]
    Vec3 g{0, 0, 0};  // acceleration (m/s^2)
  };
  static ModuleKind kind() {
    return {"gravity", {},
            [](CaseFile& f, Config& c) { c.set(Settings{f.vec3("gravity.g")}); },
            [](Simulation& sim) { return std::make_unique<Gravity>(sim.cfg.get<Settings>().g); }};
  }
  explicit Gravity(const Vec3& g) : g_(g) {}
  std::string name() const override { return "gravity"; }
  unsigned stages() const override { return kForce; }
  void force(Simulation& sim) override {
    ParticleStore& p = sim.particles;
    for (std::size_t i = 0; i < p.nlocal; ++i) p.f[i] += p.mass[i] * g_;
  }
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override {
    const ParticleStore& p = sim.particles;
    for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * g_;
  }
  double potential_energy(const Simulation& sim) const override {  // -m g . x
    const ParticleStore& p = sim.particles;
    double u = 0;
    for (std::size_t i = 0; i < p.nlocal; ++i) u -= p.mass[i] * g_.dot(p.x[i]);
    return u;
  }
  const Vec3& g() const { return g_; }

 private:
  Vec3 g_;
};

}  // namespace cassini
