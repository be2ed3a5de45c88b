#include "physics/contact/LinearSpringDashpot.hpp"

#include <cmath>
#include <numbers>

#include "physics/contact/DampingLimit.hpp"
#include "physics/contact/HertzMindlin.hpp"

namespace cassini {

LinearSpringDashpot::LinearSpringDashpot(const Config& config, double dt)
    : n_(static_cast<int>(config.species.size())), dt_(dt) {
  const ContactSettings& cfg = config.get<ContactSettings>();
  clip_ = cfg.clip_normal;
  exact_ = cfg.exact;
  friction_ = cfg.friction();
  table_.resize(n_ * n_);
  for (int a = 0; a < n_; ++a)
    for (int b = 0; b < n_; ++b) {
      // Each pair its own t_c and e through its reduced mass (spec section 1); unlike pairs
      // mix their species' values unless a [[pair]] table sets them (ContactSettings::pair).
      const PairParameters& q = cfg.pair(a, b);
      const double omega = std::numbers::pi / q.t_c;
      PairLaw& L = table_[a * n_ + b];
      L.kt_ratio = q.kt_ratio;
      L.gammat_ratio = q.gammat_ratio;
      L.mu_s = q.mu_s;
      L.mu_d = q.mu_d;
      L.omega = omega;
      L.cos_w = std::cos(omega * dt);
      L.sin_w = std::sin(omega * dt);
      L.t_c = q.t_c;
      L.v_c = q.v_c;
      half_[a * n_ + b] = std::sin(0.5 * omega * dt);
      set_damping(L, -std::log(q.e) / q.t_c, half_[a * n_ + b]);
      L.e = q.e;
      L.e_star = q.e_star;
      L.g_star = q.g_star;
      L.c_hertz = q.e_star > 0 ? hertz_damping_constant(q.e) : 0.0;
      L.mu_r = q.mu_r;
      L.mu_o = q.mu_o;
      L.eta_r = q.eta_r;
      L.adhesion = Adhesion::force_per_radius(q.value("surface_energy"));
      adhesion_ = adhesion_ || L.adhesion > 0;
      rolling_ = rolling_ || q.mu_r > 0 || q.mu_o > 0;
      hertz_ = hertz_ || q.e_star > 0;
    }
  velocity_dependent_ = cfg.velocity_dependent_restitution();
  parts_ = {exact_ && !hertz_, hertz_, friction_, rolling_, velocity_dependent_, adhesion_, clip_};
  // Against walls: the species' own law with its wall friction.
  for (int a = 0; a < n_; ++a) {
    wall_table_.push_back(table_[a * n_ + a]);
    wall_table_.back().mu_s = cfg.species[a].wall_mu_s;
    wall_table_.back().mu_d = cfg.species[a].wall_mu_d;
  }
  if (cfg.damping_limit && !hertz_) {
    // With rolling resistance, the torque springs' load on a spin as well: it is scale-free,
    // so beads of unit mass and radius give it (equal beads: m* 1/2, R* 1/2, inertia about the
    // contact point 0.7, weight 2 / 0.4; a wall: 1, 1, 1.4, 1 / 0.4).
    auto crowds = [&](const PairLaw& L, bool wall) {
      Stability s = stability(L);
      if (rolling_) {
        const Stability spin = wall ? spin_stability(L, L.k_per_mass, 1.0, 1.4, 2.5)
                                    : spin_stability(L, 0.5 * L.k_per_mass, 0.5, 0.7, 5.0);
        s.K += spin.K;
        s.G += spin.G;
      }
      return 12 * (s.K + 2 * s.G) > DampingLimit::kBound;
    };
    for (const PairLaw& L : table_) damping_limit_ = damping_limit_ || crowds(L, false);
    for (const PairLaw& L : wall_table_) damping_limit_ = damping_limit_ || crowds(L, true);
    // A Bridges law's e falls without bound as impacts get faster: any damping can occur.
    if (velocity_dependent_) damping_limit_ = true;
  }
}

void LinearSpringDashpot::set_damping(PairLaw& L, double eta, double half) const {
  const double dt = dt_, omega = L.omega;
  const double rho = std::exp(-eta * dt), one_minus_rho = -std::expm1(-eta * dt);
  L.eta = eta;
  L.k_per_mass = omega * omega + eta * eta;
  L.gamma_per_mass = 2 * eta;
  L.k_eff = (one_minus_rho * one_minus_rho + 4 * rho * half * half) / (dt * dt);
  L.gamma_eff = -std::expm1(-2 * eta * dt) / dt;  // (1 - rho^2) / dt
  L.exp_eta = std::exp(eta * dt);
  L.e = std::exp(-eta * L.t_c);
  set_tangential(L);
}

// A sticking contact's tangential displacement xi is a damped oscillator too: solid spheres'
// contact points move relative to each other under f_t as a mass m_t = m / 3.5 would (their
// translation and their spin together: 1/m + a_i^2/I_i + a_j^2/I_j = 3.5/m; a wall likewise),
// so xi'' = -(k_t xi + gamma_t xi') / m_t. Its samples obey the same two-step recurrence as the
// normal overlap's, with the damping rate eta_t = gamma_t / 2 m_t and frequency w_t^2 = k_t / m_t
// - eta_t^2; with the default ratios (k_t / k = gamma_t / gamma = 2/7) it is the normal
// oscillator itself. The discrete constants, per reduced mass: k_t,eff = m_t (1 - 2 rho c +
// rho^2) / dt^2 and gamma_t,eff = m_t (1 - rho^2) / dt, c = cos(w_t dt) (cosh when overdamped).
// A static load then stretches the spring by f / k_t,eff: k_t,eff / k_eff = 2/7 by default.
void LinearSpringDashpot::set_tangential(PairLaw& L) const {
  const double dt = dt_;
  const double same_k = 3.5 * L.kt_ratio - 1, same_g = 3.5 * L.gammat_ratio - 1;
  if (std::abs(same_k) < 1e-12 && std::abs(same_g) < 1e-12) {
    L.kt_eff = L.k_eff / 3.5;
    L.gt_eff = L.gamma_eff / 3.5;
    L.eta_t = L.eta;
    L.w2_t = L.omega * L.omega;
    return;
  }
  L.eta_t = 1.75 * L.gammat_ratio * L.gamma_per_mass;
  L.w2_t = 3.5 * L.kt_ratio * L.k_per_mass - L.eta_t * L.eta_t;
  const DiscreteOscillator d = discrete_oscillator(L.w2_t, L.eta_t, dt);  // per tangential mass m / 3.5
  L.kt_eff = d.k / 3.5;
  L.gt_eff = d.gamma / 3.5;
}

// The law of one contact whose impact had normal speed u, for a pair whose restitution
// follows the Bridges law: e(u) = min(1, (u / v_c)^-0.234), t_c fixed (so k and gamma
// follow e, as in soft-sphere ring codes). Every quantity is a function of u alone, so the
// two sides of a pair (same u, bitwise) get the same law.

PairLaw LinearSpringDashpot::at_impact(int a, int b, double u) const {
  PairLaw L = table_[a * n_ + b];
  const double eta = u > L.v_c ? kBridgesExponent * std::log(u / L.v_c) / L.t_c : 0.0;
  set_damping(L, eta, half_[a * n_ + b]);
  return L;
}

const LinearSpringDashpot::TorqueOscillator& LinearSpringDashpot::remember_oscillator(double w0sq, double eta) const {
  TorqueOscillator& o = oscillators_[next_oscillator_];
  next_oscillator_ = (next_oscillator_ + 1) % oscillators_.size();
  const double decay = eta * std::sqrt(w0sq), w2 = w0sq - decay * decay;
  o = {w0sq, eta, discrete_oscillator(w2, decay, dt_), w2, decay};
  return o;
}

}  // namespace cassini
