#pragma once
// Forces of the rotating (Hill) frame centred on a moonlet on a circular orbit of radius r0
// around Saturn (spec section 2): x azimuthal, y radial outwards, Saturn at (0, -r0).
//
//   linear (default):  F = m (0, 3 Omega0^2 y, -Omega_z^2 z)         tidal (Hill) terms
//   exact:             F = -G M_S m (x, y + r0, z)/|.|^3 + m Omega0^2 (x, y + r0, 0)
//                          - m (Omega_z^2 - Omega0^2) z e_z
//
// The vertical tide pulls particles back to the ring plane at frequency Omega_z; Saturn's
// alone gives Omega_z = Omega0 (the exact form has it from the z in the distance), ring
// simulations raise it (hill.vertical_frequency = Omega_z / Omega0, ~2-3.6) to stand in for
// the ring's own vertical self-gravity. Velocity Verlet integrates the harmonic vertical
// motion symplectically: the amplitude stays within (Omega_z dt)^2 of its start forever and
// the frequency is (Omega_z dt)^2 / 24 fast (tests/test_hill_frame.cpp). Planar scenes skip it.
//
// The exact form subtracts two ~2.8 m/s^2 terms to leave ~1e-4 m/s^2 and so loses about five
// significant digits; it is there to measure what the linearisation costs.
//
// Coriolis, 2 m Omega0 (vy, -vx), is not added as a force: it rotates the velocity at rate
// 2 Omega0 and does no work, so the integrator applies it as an exact rotation of v over
// each half step (VelocityVerlet::set_frame_rotation). The step is then the symmetric
// splitting kick(dt/2) rotate(dt/2) drift(dt) rotate(dt/2) kick(dt/2): time-reversible, and
// a free epicycle neither gains nor loses energy secularly.
#include <cmath>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"

namespace cassini {

struct HillSettings {  // [hill]
  std::string form = "linear";     // linear | exact
  double vertical_frequency = 1.0;  // Omega_z / Omega0 of the vertical tide (> 1 mimics self-gravity)
  double saturn_mass = 5.68e26, orbit_radius = 1.17e8;  // Saturn at (0, -r0)
  double omega0() const { return std::sqrt(kGravitationalConstant * saturn_mass / std::pow(orbit_radius, 3)); }
};

class HillFrame : public Module {
 public:
  // Reading [hill] also sets the frame's rotation (the integrator's Coriolis term) and the
  // default Lees-Edwards shear, Keplerian 1.5 Omega0.
  static ModuleKind kind();
  explicit HillFrame(const Config& cfg);
  HillFrame(const HillSettings& h, bool planar);
  std::string name() const override { return "hill (" + std::string(exact_ ? "exact" : "linear") + ")"; }
  unsigned stages() const override { return kForce; }
  void force(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  // With the Coriolis force doing no work, kinetic energy plus this (the Jacobi energy) is
  // conserved by a free particle: linear m (-3/2 W^2 y^2 + 1/2 W_z^2 z^2); exact, Saturn's
  // potential and the centrifugal one.
  double potential_energy(const Simulation& sim) const override;
  // 3D: ring_thickness, the mass-weighted rms height above the mid-plane (the tide's
  // equilibrium plane).
  void observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) override;

  double omega() const { return omega_; }
  // Acceleration (per unit mass) of the frame's position-dependent forces at x.
  Vec3 acceleration(const Vec3& x) const;

 private:
  bool exact_, planar_;
  double omega_, gm_, r0_;
  double extra_z2_;  // vertical stiffness beyond Saturn's own: linear Omega_z^2, exact Omega_z^2 - Omega0^2
};

}  // namespace cassini
