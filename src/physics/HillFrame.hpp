#pragma once
// Forces of the rotating (Hill) frame centred on a moonlet on a circular orbit of radius r0
// around Saturn (spec section 2): x azimuthal, y radial outwards, Saturn at (0, -r0).
//
//   linear (default):  F = m (0, 3 Omega0^2 y)                     tidal (Hill) term
//   exact:             F = -G M_S m (x, y + r0)/|.|^3 + m Omega0^2 (x, y + r0)
//
// The exact form subtracts two ~2.8 m/s^2 terms to leave ~1e-4 m/s^2 and so loses about five
// significant digits; it is there to measure what the linearisation costs.
//
// Coriolis, 2 m Omega0 (vy, -vx), is not added as a force: it rotates the velocity at rate
// 2 Omega0 and does no work, so the integrator applies it as an exact rotation of v over
// each half step (VelocityVerlet::set_frame_rotation). The step is then the symmetric
// splitting kick(dt/2) rotate(dt/2) drift(dt) rotate(dt/2) kick(dt/2): time-reversible, and
// a free epicycle neither gains nor loses energy secularly.
#include "core/Config.hpp"
#include "core/Module.hpp"

namespace cassini {

class HillFrame : public Module {
 public:
  explicit HillFrame(const Config& cfg);
  std::string name() const override { return "hill (" + std::string(exact_ ? "exact" : "linear") + ")"; }
  unsigned stages() const override { return kForce; }
  void force(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;

  double omega() const { return omega_; }
  // Acceleration (per unit mass) of the frame's position-dependent forces at x.
  Vec3 acceleration(const Vec3& x) const;

 private:
  bool exact_;
  double omega_, gm_, r0_;
};

}  // namespace cassini
