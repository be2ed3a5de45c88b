#pragma once
// Drag of the carrier fluid on each particle (spec section 3):
//   F = f(phi) K 6 pi eta a (u(x) - v),
// u from the FlowField, phi from the VolumeFraction, refreshed every drag.refresh seconds.
// phi counts the bead's own volume (drag.self_volume = true, the default and the runs in
// docs/clogging.md) or not (false: an isolated bead then sees phi = 0 and f = 1, the dilute
// limit Beetstra's correlation is built on). K is the confinement by floor and ceiling
// (drag.confinement = "faxen": Faxen's midplane factor, see confinement(); "none": 1).
// F is the whole fluid force on the bead: no separate pressure-gradient force is added.
// Voidage f: "beetstra" (default; Beetstra et al. 2007 at Re -> 0, f -> 1 when dilute),
// "thesis" (2 k phi / (1 - phi)^2, k = 5.34, which vanishes for an isolated particle), or
// "stokes" (f = 1).
//
// Time integration. The relaxation rate beta = 6 pi eta a f / m (1/beta ~ 3e-4 s for a
// 66 um bead, 40x shorter in a packed clog) can approach 1/dt. Over one step the bead's velocity
// relaxes exactly, with the other forces on it (F_o: contacts, walls, lubrication, which the
// registry sums before the drag) held constant:
//   v(t+3dt/2) = u + F_o / (m beta) + exp(-beta dt) (v(t+dt/2) - u - F_o / (m beta)),
// which velocity Verlet's kicks reproduce with the drag force
//   F = m (1 - exp(-beta dt)) / dt (u - v(t+dt/2)) - (1 - (1 - exp(-beta dt)) / (beta dt)) F_o.
// It is the plain drag when beta dt << 1, never overshoots however stiff, and a bead held still
// by contacts feels exactly m beta u: the load on an arch is the pile's full drag. (Without the
// F_o term a held bead felt (1 - exp(-x)) / x of it, x = beta dt: 0.77 at x = 0.5, in a packed
// pile at N_c = 5.) Stress output reports the physical drag m beta (u - v).
//
// flow.coupling = "two-way": the fluid feels the beads (FlowCoupling.hpp). Then u is the
// coupled flow, beta carries the 1 / (1 - phi) of the relative velocity, and observables gain
// the flow rate, the pressure drop and the number of coupled solves.
#include <memory>
#include <vector>

#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "physics/channel/ChannelConfig.hpp"
#include "physics/channel/FlowCoupling.hpp"
#include "physics/channel/FlowField.hpp"
#include "physics/channel/VolumeFraction.hpp"

namespace cassini {

class StokesDrag : public Module {
 public:
  static ModuleKind kind();
  StokesDrag(const Config& cfg, const ChannelGeometry& geo);
  std::string name() const override { return "Stokes drag (voidage " + voidage_ + ")"; }
  unsigned stages() const override { return kForce | kRebuild; }
  void setup(Simulation& sim) override;
  void force(Simulation& sim) override;
  void post_rebuild(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;

  double voidage(double phi) const;
  double confinement(double a) const;  // drag factor of the floor and ceiling (drag.confinement)
  double energy_input() const override { return work_; }
  const FlowField& flow() const { return *flow_; }
  std::string setup_report() const override;  // how the flow field was obtained, and its checks
  const VolumeFraction& fraction() const { return phi_field_; }
  double phi_of(std::size_t i) const { return phi_[i]; }
  // The flow's direction: -1 reverses it (a back-flush after a clog, clog.backflush).
  void set_flow_sign(double s) { sign_ = s; }
  // The fluid velocity a bead at x sees.
  Vec3 fluid_velocity(const Vec3& x) const {
    return coupling_ ? coupling_->velocity(x, flow_->velocity(x)) : sign_ * flow_->velocity(x);
  }
  const FlowCoupling* coupling() const { return coupling_.get(); }
  // Two-way only: bead i's drag coefficient beta_i (kg/s), F_i = beta_i (u - v_i) (FlowCoupling.hpp).
  double drag_coefficient(std::size_t i) const { return beta_[i]; }
  void observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) override;

 private:
  void refresh(Simulation& sim, bool solve = false);  // the phi field, sample(), the coupled flow
  void sample(Simulation& sim);   // phi and the relaxation factor per particle from the held field
  const Config& cfg_;
  std::string voidage_;
  double viscosity_;
  bool self_volume_, faxen_;
  double height_;
  std::unique_ptr<FlowField> flow_;
  std::unique_ptr<FlowCoupling> coupling_;
  std::vector<double> beta_;    // per owned particle: the drag coefficient (kg/s), two-way only
  std::vector<Vec3> one_way_;   // per owned particle: the one-way field at its centre, two-way only
  VolumeFraction phi_field_;
  long refresh_every_ = 1;
  std::vector<double> phi_;     // per owned particle, in the current slot order
  std::vector<double> factor_;  // (1 - exp(-beta dt)) / dt per owned particle
  std::vector<double> rate_;    // beta (1/s) per owned particle
  std::vector<double> lag_;     // 1 - (1 - exp(-beta dt)) / (beta dt): the share of the other forces taken back
  double work_ = 0;             // done on this rank's particles so far: sum F . v dt
  double sign_ = 1;
};

}  // namespace cassini
