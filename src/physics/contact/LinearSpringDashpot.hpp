#pragma once
// Linear spring-dashpot contact law of spec section 1, parametrised by contact time t_c and
// restitution e through the reduced mass m_ij:
//   eta = -ln(e)/t_c, omega = pi/t_c, k = m_ij (omega^2 + eta^2), gamma = 2 m_ij eta,
// so that a free binary collision lasts exactly t_c and returns exactly e. The normal force
// is f_n = k delta - gamma v_n; it may pull slightly at the end of a contact (that is what
// the exact relations assume). clip_normal = true clips it at zero, which makes the
// effective restitution larger than e (noticeably for small e).
//
// Two ways to integrate it (contact.scheme):
//  - "verlet": the force above, evaluated at x(t+dt) and the half-step velocity, as LAMMPS,
//    LIGGGHTS and MercuryDPM do. The dashpot's half-step lag and a contact that starts or ends
//    between steps make the restitution wrong by up to ~3 |ln e| / N_c, at first order in dt.
//  - "exact" (default): the step reproduces the exact solution of the binary collision at
//    every step, for any onset phase and any N_c. Velocity Verlet is leapfrog in the half-step
//    velocities, x_{n+1} = x_n + dt v_{n+1/2}, v_{n+1/2} = v_{n-1/2} + dt a_n; if the overlaps
//    delta_{n-1}, delta_n are exact samples of a contact, a_n = (delta_{n+1} - 2 delta_n +
//    delta_{n-1}) / dt^2 with the exact delta_{n+1} keeps them exact. Inside a contact this is
//    the spring-dashpot itself with discrete constants (the damped oscillator's samples obey
//    delta_{n+1} = 2 rho cos(omega dt) delta_n - rho^2 delta_{n-1}, rho = exp(-eta dt)):
//        k_eff = m ((1 - rho)^2 + 4 rho sin^2(omega dt / 2)) / dt^2,  gamma_eff = m (1 - rho^2) / dt
//    (-> k, gamma as dt -> 0; e = 1: Verlet with the stiffness whose discrete period is t_c).
//    The two steps where the contact starts or ends inside a step get a closed-form correction:
//    the step in which an overlap first appears (delta_n > 0 >= delta_{n-1}, the last step was
//    free flight, so the contact began delta_n / v a step ago) moves the pair to the exact
//    overlap and sets its normal velocity to the exact chord of the next step; the step in which
//    it is first gone (delta_n <= 0 < delta_{n-1}: two samples of the oscillator locate the
//    exit and its velocity) moves it to the exact free-flight position and gives it the exit
//    velocity. The moves are position shifts split by mass (momentum and centre of mass kept),
//    applied at the end of the step, so nothing is carried from step to step: the scheme is
//    memoryless, restart-exact and rank-independent like the force. Everything reads the state
//    of the step (delta_n, and delta_{n-1} ~ delta_n + v_n dt from the half-step normal velocity).
//    Why this route and not a per-pair propagator over the whole step: additive pair propagators
//    are not symplectic in dense packings (an elastic chain gains energy), while here every
//    in-contact step is velocity Verlet, so packings are as stable as under Verlet.
//
// Tangential (only when friction is on): spring xi with history, f_t = -k_t xi - gamma_t v_t,
// capped by Coulomb (|f_t| <= mu_s f_n static; on sliding |f_t| = mu_d f_n of the same step,
// and xi reset so that spring and dashpot together give the Coulomb force, as LAMMPS does: the
// force is continuous when the contact sticks again, and sliding converges as dt -> 0).
// Under "exact" a sticking contact is the normal one's twin: its contact points move as a
// damped oscillator of mass m / 3.5 (set_tangential), integrated with that oscillator's
// discrete constants, so its samples are exact at any N_c (with the default ratios the
// normal oscillator itself: the static k_t / k_n is 2/7 as in the law); at the onset step the
// spring takes the exact displacement since the contact began and the force the exact chord
// of the next step. A sliding step's force follows its step's normal force, which the exact
// scheme makes the exact mean over the step; the slip reset takes the continuous contact's
// state at the step's instant. What is not exact: a change between sticking and sliding inside
// a step (every impact has one: the Coulomb limit falls to zero before the spheres part).
// Measured against the continuous contact (tests ObliqueImpacts...): beta within 0.45 / N_c
// (0.089 at N_c = 5 in the worst onset phase of a stick/slip impact, 0.01-0.02 typically).
//
// Every operation is sign-symmetric, so that evaluating the pair from j's side (negated n,
// vrel and spring) gives exactly the negated result, bitwise, provided no product is fused
// into an add (ContactForces.cpp is compiled with -ffp-contract=off). ContactForces relies on
// this to evaluate a pair of owned particles once, and a pair across a rank boundary from
// both sides, with the same trajectory on any number of ranks.
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>

#include "core/Config.hpp"
#include "physics/contact/ContactSettings.hpp"
#include "core/ParticleStore.hpp"
#include "core/Vec3.hpp"
#include "physics/contact/Adhesion.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "physics/contact/HertzMindlin.hpp"

namespace cassini {

// Largest stable time step of this project's integrator on one contact: velocity Verlet with
// the dashpot on the half-step velocity. That lag lowers the bound below the undamped
// 2/sqrt(omega^2 + eta^2) (0.64 t_c): to 0.62 t_c at e = 0.9, 0.50 t_c at e = 0.5 and 0.29 t_c
// at e = 0.1. Found from the spectral radius of the one-step map of (x, v, a).
inline double verlet_stability_limit(double t_c, double e) {
  // The map scales with t_c: work in units of t_c so the matrix is well conditioned.
  const double eta = -std::log(e), w = std::numbers::pi;
  const double K = w * w + eta * eta, G = 2 * eta;
  auto radius = [&](double dt) {
    const double h = 0.5 * dt;
    Eigen::Matrix3d M;
    for (int j = 0; j < 3; ++j) {
      Eigen::Vector3d s = Eigen::Vector3d::Zero();
      s[j] = 1;
      const double vh = s[1] + h * s[2], x1 = s[0] + dt * vh, a1 = -K * x1 - G * vh, v1 = vh + h * a1;
      M.col(j) << x1, v1, a1;
    }
    return M.eigenvalues().cwiseAbs().maxCoeff();
  };
  double lo = 0, hi = 2 / std::sqrt(K);  // unstable beyond the undamped bound
  for (double dt = 0.01 * hi; dt < hi; dt += 0.01 * hi)  // first unstable step on a coarse scan
    if (radius(dt) > 1 + 1e-12) { hi = dt; break; } else lo = dt;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (radius(mid) > 1 + 1e-12 ? hi : lo) = mid;
  }
  return lo * t_c;
}

// What rolling resistance needs of a contact beyond the force's arguments (LinearSpringDashpot::
// rolling): the relative spin omega_i - omega_j, the reduced moment of inertia about the contact
// point, and the torque spring (history, like the tangential spring); out: the torque on i.
struct Rolling {
  Vec3 spin;
  double inertia;
  Vec3 spring;
  Vec3 torque = Vec3::Zero();
};

// A damped oscillator x'' = -w0^2 x - 2 eta x' (w2 = w0^2 - eta^2; < 0 overdamped) sampled
// exactly by Verlet with the half-step dashpot: the spring and dashpot per unit mass (or
// inertia) that make x_{n+1} = 2 rho c x_n - rho^2 x_{n-1}, rho = exp(-eta dt), c = cos(sqrt(w2)
// dt), the step's recurrence (see the top of this file).
struct DiscreteOscillator {
  double k, gamma;  // per unit mass
};
inline DiscreteOscillator discrete_oscillator(double w2, double eta, double dt) {
  const double rho = std::exp(-eta * dt), one_minus_rho = -std::expm1(-eta * dt);
  // 1 - c without cancellation: 2 sin^2(w dt / 2), or -2 sinh^2 when overdamped.
  const double half = 0.5 * std::sqrt(std::abs(w2)) * dt;
  const double one_minus_c = w2 >= 0 ? 2 * std::sin(half) * std::sin(half) : -2 * std::sinh(half) * std::sinh(half);
  return {(one_minus_rho * one_minus_rho + 2 * rho * one_minus_c) / (dt * dt), -std::expm1(-2 * eta * dt) / dt};
}
// The same oscillator's displacement a time s after it left x = 0 at unit speed.
inline double oscillator_displacement(double w2, double eta, double s) {
  const double decay = std::exp(-eta * s);
  if (w2 > 0) { const double w = std::sqrt(w2); return decay * std::sin(w * s) / w; }
  if (w2 < 0) { const double w = std::sqrt(-w2); return decay * std::sinh(w * s) / w; }
  return decay * s;
}

struct PairLaw {
  double k_per_mass;      // omega^2 + eta^2
  double gamma_per_mass;  // 2 eta
  double kt_ratio, gammat_ratio, mu_s, mu_d;
  // "exact" scheme: the discrete constants and the oscillator (see the top of this file)
  double k_eff, gamma_eff, eta, omega, cos_w, sin_w, exp_eta;  // cos/sin(omega dt), exp(eta dt)
  double e;  // the pair's restitution
  double t_c;
  double v_c;  // > 0: e is set per impact by the Bridges law (LinearSpringDashpot::at_impact)
  double e_star, g_star, c_hertz;  // e_star > 0: Hertz-Mindlin (HertzMindlin.hpp), c from e
  double mu_r, mu_o, eta_r;        // rolling and twisting resistance (LinearSpringDashpot::rolling)
  double adhesion;                 // DMT pull-off force per reduced radius (Adhesion.hpp); 0: none
  // "exact" scheme, tangential: the sticking contact's oscillator (per tangential mass m / 3.5:
  // damping rate eta_t, squared frequency w2_t, <= 0 when overdamped) and its discrete spring
  // and dashpot per reduced mass (LinearSpringDashpot::set_tangential).
  double kt_eff, gt_eff, eta_t, w2_t;
  // The tangential displacement a sticking contact has made s after it began, per unit
  // tangential speed at its start: exp(-eta_t s) sin(w_t s) / w_t (sinh when overdamped).
  double stuck_displacement(double s) const { return oscillator_displacement(w2_t, eta_t, s); }
};

// The normal part of one evaluation: force along n (repulsive > 0), the overlap the pair is to
// be moved by at the end of the step (split by mass), and the time of this step the spheres
// were in contact (the tangential spring's increment; dt inside a contact, 0 when parted).
struct NormalStep {
  double fn = 0, shift = 0, contact_time = 0;
  double fn_now = 0;  // exact scheme's onset step: the normal force at the step's instant (fn is its mean)
};

// Moves the exact scheme asks for at onset and exit steps, applied to owned particles at the end
// of the step (final_integrate), after every force of the step has been evaluated.
class PendingShifts {
 public:
  void clear() { moves_.clear(); }
  void add(std::size_t i, const Vec3& d) { moves_.push_back({i, d}); }
  void apply(ParticleStore& p) {
    for (const auto& [i, d] : moves_) p.x[i] += d;
    moves_.clear();
  }

 private:
  std::vector<std::pair<std::size_t, Vec3>> moves_;
};

// Which parts of the law a scene uses: the normal model (linear under the exact scheme, linear
// under Verlet, Hertz), friction, rolling resistance, Bridges restitution, adhesion. The law below is
// written once against a Parts type: with LawParts<...> every choice is a compile-time constant
// and the branches of the parts a scene lacks vanish (the pair loop is compiled once per valid
// combination, LinearSpringDashpot::with_parts); RuntimeParts carries the same choices as
// values, for callers off the hot path (walls, reports). The two give identical results.
template <bool Exact, bool Hertz, bool Friction, bool Rolling, bool Bridges, bool Adhesive>
struct LawParts {
  static constexpr bool exact = Exact && !Hertz;  // Hertz pairs use velocity Verlet under either scheme
  static constexpr bool hertz = Hertz, friction = Friction, rolling = Rolling, bridges = Bridges, adhesion = Adhesive;
  static constexpr bool reduced_radius = Hertz || Rolling || Adhesive;  // callers pass reff
  // The combinations ReadConfig admits: rolling needs friction, Bridges is a linear law's.
  static constexpr bool valid = (!Rolling || Friction) && !(Hertz && (Bridges || Exact));
  bool clip;
};
struct RuntimeParts {
  bool exact, hertz, friction, rolling, bridges, adhesion, clip;
};

// a where mask is all ones, b where it is zero: a lane-wise bit select in vector registers.
// (Per component through general registers, the picked Vec3 was put together again through
// memory, and the next load of it waited on two stores it could not forward from.)
[[gnu::always_inline]] inline Vec3 select_lanes(std::int64_t mask, const Vec3& a, const Vec3& b) {
  using Lanes = double __attribute__((vector_size(32)));
  using Bits = std::int64_t __attribute__((vector_size(32)));
  const Lanes va = {a[0], a[1], a[2], 0.0}, vb = {b[0], b[1], b[2], 0.0};
  const Bits m = {mask, mask, mask, mask};
  const Lanes r = reinterpret_cast<Lanes>((reinterpret_cast<Bits>(va) & m) | (reinterpret_cast<Bits>(vb) & ~m));
  return Vec3(r[0], r[1], r[2]);
}

class LinearSpringDashpot {
 public:
  // The per-pair constants are computed out of line (LinearSpringDashpot.cpp, without fused
  // multiply-adds): one copy in every build, so results do not depend on which translation
  // unit's inline copy the linker keeps.
  LinearSpringDashpot(const Config& cfg, double dt);

  // The damping rate eta (and what follows from it at fixed t_c) of a law; half =
  // sin(omega dt / 2). Cancellation-free: 1 + rho^2 - 2 rho cos = (1 - rho)^2 + 4 rho half^2.
  void set_damping(PairLaw& L, double eta, double half) const;
  // The tangential oscillator of a law whose normal constants are set (see the top of this file).
  void set_tangential(PairLaw& L) const;

  PairLaw at_impact(int a, int b, double u) const;
  // The parameters the law's parts declare in their own files (read for every [[species]] and
  // [[pair]] table by the case reader, mixed by their own rules): one entry per part that has any.
  static std::vector<ContactParameter> parameters() { return {Adhesion::parameter()}; }
  // The restitution the law gives an impact at normal speed u.
  double restitution(int a, int b, double u) const {
    const PairLaw& L = table_[a * n_ + b];
    return L.v_c > 0 && u > L.v_c ? std::pow(u / L.v_c, -kBridgesExponent) : L.e;
  }
  // Some pair's restitution is set per impact: contacts then carry their impact speed.
  bool velocity_dependent() const { return velocity_dependent_; }
  // Some pair follows Hertz-Mindlin: callers pass the reduced radius (reff).
  bool hertz() const { return hertz_; }
  // Some pair resists rolling or twisting: callers pass a Rolling (below) to force().
  bool rolling() const { return rolling_; }

  const PairLaw& law(int a, int b) const { return table_[a * n_ + b]; }
  bool friction() const { return friction_; }
  bool exact() const { return exact_; }
  const RuntimeParts& parts() const { return parts_; }
  // The law and its parts, for run.log: "LSD + friction + Bridges e(u)", ...
  std::string label() const {
    return std::string(hertz_ ? "Hertz-Mindlin" : "LSD") + (friction_ ? " + friction" : "") +
           (rolling_ ? " + rolling resistance" : "") + (velocity_dependent_ ? " + Bridges e(u)" : "") +
           (adhesion_ ? " + DMT adhesion" : "");
  }
  // Calls f(LawParts<...>{}) with this scene's parts as compile-time constants: the one place
  // that lists the combinations a loop is compiled for.
  template <class F>
  void with_parts(F&& f) const {
    const bool flags[6] = {parts_.exact, parts_.hertz, parts_.friction, parts_.rolling, parts_.bridges, parts_.adhesion};
    pick<0>(f, flags);
  }
  double dt() const { return dt_; }

  // A contact's stiffness and damping per step and per reduced mass, K = k dt^2 / m*, G = gamma
  // dt / m*, as the step sees them (the exact scheme's discrete constants, or Verlet's), the
  // larger of the normal and the tangential ones (the tangential per its own effective mass
  // m* / 3.5 of solid spheres, translation and rotation together): DampingLimit's loads.
  struct Stability {
    double K, G;
  };
  Stability stability(const PairLaw& L) const {
    const double dt2 = dt_ * dt_;
    Stability s = exact_ ? Stability{L.k_eff * dt2, L.gamma_eff * dt_} : Stability{L.k_per_mass * dt2, L.gamma_per_mass * dt_};
    if (friction_ && (L.mu_s > 0 || L.mu_d > 0)) {
      s.K = std::max(s.K, 3.5 * (exact_ ? L.kt_eff : L.kt_ratio * L.k_per_mass) * dt2);
      s.G = std::max(s.G, 3.5 * (exact_ ? L.gt_eff : L.gammat_ratio * L.gamma_per_mass) * dt_);
    }
    return s;
  }
  // The load a contact's rolling and twisting springs (rolling()) put on a bead's spin, per step
  // and per the bead's own inertia: k dt^2 / I, c dt / I summed over both parts. They turn the
  // pair's reduced inertia about the contact point (`inertia`: the rolling oscillator's, 1.4 m a^2
  // per sphere), but a crowded bead's spin feels all its contacts' torques through its own
  // 2/5 m a^2 (`inv_inertia`: 1/I_i + 1/sqrt(I_i I_j), a wall 1/I_i, the weight of DampingLimit's
  // Gershgorin row folded in). Left out, a pile's spins went unstable at mu_r 0.3 and N_c 5
  // (HardCases.PileWithRollingResistanceComesToRestAtFiveStepsPerContact). kn: d f_n / d delta.
  Stability spin_stability(const PairLaw& L, double kn, double reff, double inertia, double inv_inertia) const {
    const TorqueSpring roll = torque_spring(L, kn, L.mu_r, reff, inertia, exact_),
                       twist = torque_spring(L, kn, L.mu_o, reff, inertia * (2.0 / 7.0), exact_);
    return {(roll.k + twist.k) * dt_ * dt_ * inv_inertia, (roll.c + twist.c) * dt_ * inv_inertia};
  }
  // The law with its dashpots (normal, tangential, rolling and twisting) scaled by s; springs
  // and the exact scheme's onset and exit forms unchanged (the torque springs' discrete
  // stiffness follows their oscillator's decay rate, so it moves with s by O((w0 dt)^2)).
  static PairLaw damped(const PairLaw& L, double s) {
    PairLaw d = L;
    d.gamma_eff *= s;
    d.gamma_per_mass *= s;
    d.gt_eff *= s;
    d.eta_r *= s;
    return d;
  }
  // Some particle could crowd enough contacts (12, a dense packing's most) to need DampingLimit:
  // the scene declares its loads. Off for Hertz laws (their stiffness grows with the overlap).
  bool damping_limit() const { return damping_limit_; }

  // The normal law for overlap delta (may be <= 0: a pair that parted this step) and normal
  // velocity vn = vrel . n (< 0 approaching) of the last half step; m: reduced mass; reff:
  // reduced radius (Hertz pairs only).
  NormalStep normal(const PairLaw& L, double m, double delta, double vn, double reff = 0) const {
    return normal(parts(), L, m, delta, vn, reff);
  }
  template <class Parts>
  [[gnu::always_inline]] NormalStep normal(const Parts& parts, const PairLaw& L, double m, double delta, double vn,
                                           double reff) const {
    NormalStep r;
    const double fa = parts.adhesion ? L.adhesion * reff : 0.0;  // DMT attraction (Adhesion.hpp)
    if (parts.hertz) {  // Hertz: velocity Verlet under either scheme
      if (delta <= 0) return r;
      const double K = (4.0 / 3.0) * L.e_star * std::sqrt(reff * delta);  // f = K delta
      r.fn = K * delta - L.c_hertz * std::sqrt(K * m) * vn;
      if (parts.clip && r.fn < 0) r.fn = 0;
      if (parts.adhesion) r.fn -= fa;
      r.contact_time = dt_;
      return r;
    }
    if (!parts.exact) {
      if (delta <= 0) return r;
      r.fn = m * (L.k_per_mass * delta - L.gamma_per_mass * vn);
      if (parts.clip && r.fn < 0) r.fn = 0;
      if (parts.adhesion) r.fn -= fa;
      r.contact_time = dt_;
      return r;
    }
    const double dt = dt_, before = delta + vn * dt;  // the overlap a step ago
    // Adhesion: the rest overlap of the oscillator the steps sample, f_a / k_eff (Adhesion.hpp).
    const double rest = parts.adhesion ? fa / (m * L.k_eff) : 0.0;
    if (delta > 0 && before > 0) {  // inside a contact: the damped oscillator's recurrence
      r.fn = m * (L.k_eff * delta - L.gamma_eff * vn);
      if (parts.adhesion) r.fn -= fa;
      r.contact_time = dt;
      return r;
    }
    if (delta <= 0 && before <= 0) return r;  // free flight
    double target, chord;  // the exact overlap now, and the exact chord of the next step
    if (delta > 0 && parts.adhesion) {  // began during the last step, delta / u ago: about the rest overlap
      const double u = -vn, since = delta / u;
      const Adhesion::State now = Adhesion::since_onset(u, rest, L.eta, L.omega, since);
      target = now.overlap;
      chord = (Adhesion::since_onset(u, rest, L.eta, L.omega, since + dt).overlap - target) / dt;
      r.contact_time = since;
      if (parts.friction) r.fn_now = m * (L.k_per_mass * (target - rest) + L.gamma_per_mass * now.rate);
    } else if (delta > 0) {  // began during the last step, delta / u ago (u = -vn > 0, free flight before)
      const double u = -vn, since = delta / u;
      // Overlap of a contact that began s ago at speed u: u exp(-eta s) sin(omega s) / omega.
      auto overlap = [&](double s) { return u * std::exp(-L.eta * s) * std::sin(L.omega * s) / L.omega; };
      target = overlap(since);
      chord = (overlap(since + dt) - target) / dt;
      r.contact_time = since;
      // k delta + gamma d(delta)/dt at this instant (a Coulomb limit for a spring that slides).
      if (parts.friction) {
        const double wave = std::exp(-L.eta * since), rate = u * wave * std::cos(L.omega * since) - L.eta * target;
        r.fn_now = m * (L.k_per_mass * target + L.gamma_per_mass * rate);
      }
    } else if (parts.adhesion) {  // ended during the last step: the oscillator about the rest overlap
      const Adhesion::Exit x = Adhesion::exit(before, delta, rest, L.eta, L.omega, L.cos_w, L.sin_w, L.exp_eta, dt);
      target = x.rate * (dt - x.time);
      chord = x.rate;
    } else {  // ended during the last step: delta_{n-1} = before and delta_n = delta lie on
      // delta(s) = exp(-eta s) (before cos(omega s) + q sin(omega s)), s from the last step,
      // which reaches zero at omega s = pi - atan2(before, q) with speed -|.| omega exp(-eta s).
      const double q = (delta * L.exp_eta - before * L.cos_w) / L.sin_w;
      const double exit = (std::numbers::pi - std::atan2(before, q)) / L.omega;
      const double speed = -std::hypot(before, q) * L.omega * std::exp(-L.eta * exit);
      target = speed * (dt - exit);
      chord = speed;
    }
    // a_n (per reduced mass, along n) turns the last chord (-vn) into `chord`.
    r.fn = m * (-vn - chord) / dt;
    r.shift = target - delta;
    return r;
  }

  // Force on body i. n: unit normal pointing from the partner to i; delta: overlap;
  // vrel: velocity of i's contact point relative to the partner's; m: reduced mass.
  // Returns the total force; ft receives the tangential part (for the torque).
  // advance = false evaluates the force of the spring as it stands, without this step's
  // increment v_t dt: for reports (snapshots, stress) after the step already advanced it.
  // reff: the reduced radius (Hertz pairs; rolling resistance).
  // roll (with friction, for pairs that resist rolling): in the relative spin and the torque
  // spring, out the rolling and twisting torque on i (see rolling()).
  Vec3 force(const PairLaw& L, double m, double delta, const Vec3& n, const Vec3& vrel, Vec3* xi, Vec3& ft,
             bool advance = true, double* shift = nullptr, double reff = 0, Rolling* roll = nullptr) const {
    return force(parts(), L, m, delta, n, vrel, xi, ft, advance, shift, reff, roll);
  }
  template <class Parts>
  [[gnu::always_inline]] Vec3 force(const Parts& parts, const PairLaw& L, double m, double delta, const Vec3& n,
                                     const Vec3& vrel, Vec3* xi, Vec3& ft, bool advance, double* shift, double reff,
                                     Rolling* roll) const {
    const double vn = vrel.dot(n);
    const NormalStep ns = normal(parts, L, m, delta, vn, reff);
    if (shift) *shift = ns.shift;
    const double fn = ns.fn;
    Vec3 f = fn * n;
    if (!parts.friction || !xi || delta <= 0) {  // no friction, or the spheres parted: no tangential force
      ft.setZero();
      return f;
    }
    const Vec3 vt = vrel - vn * n;
    // Keep the spring in the current tangent plane, preserving its length. Squared norms
    // and one sqrt per call: this is the innermost loop of every frictional scene.
    Vec3 s = *xi;
    const double len2 = s.squaredNorm();
    if (len2 > 0) {
      s -= n.dot(s) * n;
      const double slen2 = s.squaredNorm();
      if (slen2 > 0) s *= std::sqrt(len2 / slen2);
    }
    // The spring and dashpot the step applies: under "exact" the sticking contact's discrete
    // constants (the tangential oscillator sampled exactly, as the normal one), else the law's.
    double kt = L.kt_ratio * m * L.k_per_mass, gt = L.gammat_ratio * m * L.gamma_per_mass;
    const double kt_law = kt, gt_law = gt;
    if (parts.hertz) {  // Mindlin: k_t = 8 G* sqrt(R* delta), g_t = 2 sqrt(5/6) beta sqrt(k_t m), beta = c / sqrt(5)
      kt = 8 * L.g_star * std::sqrt(reff * delta);
      gt = 2 / std::sqrt(6.0) * L.c_hertz * std::sqrt(kt * m);
      // Mindlin in displacement form does work from nothing when the contact is pressed harder
      // at a fixed displacement (k_t grows, so would the force). As Thornton's incremental form
      // (LIGGGHTS, LAMMPS's mindlin_rescale), a growing k_t keeps the force: the spring shrinks
      // by k_t(before) / k_t(now); on unloading the force falls with k_t.
      const double before = delta + vn * dt_;
      if (advance && before > 0 && before < delta) s *= std::sqrt(before / delta);
    } else if (parts.exact) {
      kt = m * L.kt_eff;
      gt = m * L.gt_eff;
    }
    const bool onset = parts.exact && advance && ns.contact_time < dt_;
    if (onset) {
      // The contact began ns.contact_time ago at tangential speed vt (free flight before). If it
      // sticks, the spring has stretched to its exact displacement since then, and this step's
      // force turns the last chord (vt) into the exact chord of the next step: m_t (chord - vt)
      // / dt, m_t = m / 3.5 the tangential mass of two solid spheres (or a sphere and a wall).
      const double since = ns.contact_time;
      const double x0 = L.stuck_displacement(since), x1 = L.stuck_displacement(since + dt_);
      s = x0 * vt;
      ft = (m / 3.5 * ((x1 - x0) / dt_ - 1.0) / dt_) * vt;
    } else {
      if (advance) s += vt * ns.contact_time;
      ft = -kt * s - gt * vt;
    }
    // The load pressing the surfaces together: with adhesion f_n + 2 f_a (Adhesion.hpp).
    const double load = parts.adhesion ? fn + 2 * L.adhesion * reff : fn;
    const double cap = L.mu_s * std::max(load, 0.0);
    const double ft2 = ft.squaredNorm();
    // Sliding (ft2 > 0 then, since cap >= 0) or sticking, both computed and one picked by a
    // mask: in a gas about a third of the contacts slide at random, and a branch here
    // mispredicted behind the long chain of square roots and divisions that decides it, which
    // cost more than the sliding arithmetic.
    const Vec3 dir = ft / std::sqrt(ft2);
    const double slide = L.mu_d * std::max(load, 0.0);
    const Vec3 ft_slide = slide * dir;
    // A sliding spring is reset so that spring and dashpot together give the Coulomb force (as
    // LAMMPS does): the force then changes continuously when the contact sticks again. Under
    // "exact" the spring is the continuous contact's at this instant: the Coulomb force of the
    // normal force now (its step mean fn, or at onset its value at the step's instant) and the
    // tangential velocity now (half-way through this step's kick, m_t = m / 3.5).
    Vec3 s_slide;
    if (parts.exact) {
      const double load_now = parts.adhesion ? ns.fn_now + 2 * L.adhesion * reff : ns.fn_now;
      const double now = onset ? L.mu_d * std::max(load_now, 0.0) : slide;
      const Vec3 v_now = vt + (1.75 * dt_ / m) * ft_slide;
      s_slide = -(now * dir + gt_law * v_now) / kt_law;
    } else {
      s_slide = -(ft_slide + gt * vt) / kt;
    }
    const std::int64_t sliding = -static_cast<std::int64_t>(ft2 > cap * cap);
    ft = select_lanes(sliding, ft_slide, ft);
    s = select_lanes(sliding, s_slide, s);
    *xi = s;
    if (parts.rolling && roll) {
      const double kn = parts.hertz ? 2 * L.e_star * std::sqrt(reff * delta) : m * L.k_per_mass;  // d f_n / d delta
      roll->torque = rolling(L, kn, std::max(load, 0.0), reff, n, advance ? ns.contact_time : 0.0, *roll,
                             parts.exact && !parts.hertz);
    }
    return f + ft;
  }

  // Elastic energy stored in one contact at overlap delta > 0: the normal spring (linear:
  // 1/2 k delta^2; Hertz: 8/15 E* sqrt(R*) delta^5/2), the tangential spring xi (1/2 k_t |xi|^2,
  // k_t linear or Mindlin's at this overlap) and the rolling and twisting torque springs
  // (|M|^2 / 2k for each part, k as in rolling()). m: reduced mass; reff: reduced radius; n the
  // contact normal; xi, roll: null where the contact keeps none.
  double spring_energy(const PairLaw& L, double m, double delta, double reff, const Vec3& n, const Vec3* xi,
                       const Vec3* roll) const {
    if (!(delta > 0)) return 0.0;
    const bool hertz = L.e_star > 0;
    double e = hertz ? (8.0 / 15.0) * L.e_star * std::sqrt(reff * delta) * delta * delta
                     : 0.5 * m * L.k_per_mass * delta * delta;
    e -= L.adhesion * reff * delta;  // the attraction's potential (Adhesion.hpp)
    if (xi) {
      // The stiffness the force applies (under "exact", the sticking contact's discrete one).
      const double kt = hertz ? 8 * L.g_star * std::sqrt(reff * delta) : exact_ ? m * L.kt_eff : L.kt_ratio * m * L.k_per_mass;
      e += 0.5 * kt * xi->squaredNorm();
    }
    if (roll && (L.mu_r > 0 || L.mu_o > 0)) {
      const double kn = hertz ? 2 * L.e_star * std::sqrt(reff * delta) : m * L.k_per_mass;
      const Vec3 twist = roll->dot(n) * n, bend = *roll - twist;
      auto part = [&](const Vec3& M, double mu) { return mu > 0 ? M.squaredNorm() / (2 * 2.25 * kn * mu * mu * reff * reff) : 0.0; };
      e += part(bend, L.mu_r) + part(twist, L.mu_o);
    }
    return e;
  }
  // The same for particle i of p against a wall (its species' wall law; impact: the contact's
  // Bridges impact speed, or null).
  double wall_spring_energy(const ParticleStore& p, std::size_t i, const Vec3& n, double delta, const Vec3* xi,
                            const double* impact, const Vec3* roll, double wall_radius = 0) const {
    const double a = p.radius[i];
    const int sp = p.species[i];
    const PairLaw* L = &wall_table_[sp];
    PairLaw own;
    if (L->v_c > 0) {
      own = at_impact(sp, sp, impact ? *impact : 0.0);
      own.mu_s = L->mu_s;
      own.mu_d = L->mu_d;
      L = &own;
    }
    const double reff = wall_radius > 0 ? a * wall_radius / (a + wall_radius) : a;
    return spring_energy(*L, p.mass[i], delta, reff, n, xi, roll);
  }

  // One part of rolling resistance (rolling()) as the step applies it: its torque spring k and
  // dashpot c (under "exact" the discrete constants of the oscillator I theta'' = -k_law theta -
  // 2 eta_r sqrt(I k_law) theta', whose squared frequency w2 and decay rate it also gives); 0
  // where mu is 0.
  struct TorqueSpring {
    double k = 0, c = 0, w2 = 0, decay = 0;
  };
  TorqueSpring torque_spring(const PairLaw& L, double kn, double mu, double reff, double inertia, bool exact) const {
    if (!(mu > 0)) return {};
    const double k = 2.25 * kn * mu * mu * reff * reff;
    if (!exact) return {k, 2 * L.eta_r * std::sqrt(inertia * k), 0, 0};
    const TorqueOscillator& o = torque_oscillator(k / inertia, L.eta_r);
    return {inertia * o.d.k, inertia * o.d.gamma, o.w2, o.decay};
  }

  // Rolling and twisting resistance, the elastic-plastic spring-dashpot (Ai, Chen, Rotter & Ooi
  // 2011, their model C; twisting alike): a torque spring M on the relative spin
  // w = omega_i - omega_j, in its rolling part (across n) and its twisting part (along n). Each
  // part grows by -k w dt with k = 2.25 k_n mu^2 R*^2, k_n the normal stiffness, and is capped at
  // mu R* f_n (mu_r rolling, mu_o twisting): at the cap the contact turns plastically and the
  // dashpot is off; below it a dashpot -2 eta_r sqrt(I k) w acts. I is the reduced moment of
  // inertia the part turns: about the contact point for rolling (r.inertia, I + m a^2 = 1.4 m a^2
  // per solid sphere), about the line of centres for twisting (2/5 m a^2: 2/7 of it). A sphere
  // rolling on a plane then decelerates at 5/7 mu_r g (test: SphereRollsToRestUnderRolling-
  // Resistance). Torque on i; j gets its negative.
  // exact (the exact scheme, linear law): each part's elastic regime is the damped oscillator
  // I theta'' = -k theta - 2 eta_r sqrt(I k) theta', stepped with its discrete constants (exact
  // samples, as the normal and tangential contacts), and its onset step puts the spring at the
  // oscillator's exact twist since the contact began (TwistingSpringIsSampledExactly).
  Vec3 rolling(const PairLaw& L, double kn, double fn, double reff, const Vec3& n, double contact_time,
               Rolling& r, bool exact = false) const {
    const Vec3 w_twist = r.spin.dot(n) * n, w_roll = r.spin - w_twist;
    Vec3 m_twist = r.spring.dot(n) * n, m_roll = r.spring - m_twist;
    auto part = [&](Vec3& spring, const Vec3& w, double mu, double inertia) -> Vec3 {
      if (!(mu > 0)) {
        spring.setZero();
        return Vec3::Zero();
      }
      const TorqueSpring t = torque_spring(L, kn, mu, reff, inertia, exact);
      const double cap = mu * reff * fn;
      Vec3 torque;
      if (exact && contact_time > 0 && contact_time < dt_) {  // onset: the exact twist since the contact began
        const double x0 = oscillator_displacement(t.w2, t.decay, contact_time),
                     x1 = oscillator_displacement(t.w2, t.decay, contact_time + dt_);
        spring = (-t.k * x0) * w;
        torque = (inertia * ((x1 - x0) / dt_ - 1.0) / dt_) * w;
      } else {
        spring -= (t.k * contact_time) * w;
        torque = spring - t.c * w;
      }
      const double s2 = spring.squaredNorm();
      if (s2 > cap * cap) {  // plastic: the spring stays at the limit torque, no dashpot
        spring *= cap / std::sqrt(s2);
        return spring;
      }
      return torque;
    };
    const Vec3 torque = part(m_roll, w_roll, L.mu_r, r.inertia) + part(m_twist, w_twist, L.mu_o, r.inertia * (2.0 / 7.0));
    r.spring = m_roll + m_twist;
    return torque;
  }

  // Force on particle i of p from an immovable wall (infinite mass: m_ij = m_i, the particle's
  // own species). n: unit normal from the wall to the centre; delta: overlap; xi: the (particle,
  // wall) spring or nullptr without friction. torque receives the wall's torque on i.
  // shift (if given) receives the distance to move the particle along n at the end of the step.
  // impact: the (particle, wall) impact speed under the Bridges law (WallHistory, WallContact.hpp):
  // set by the first evaluation of a contact, cleared by its exit step; the caller clears it
  // when a particle is away from the wall without an exit step.
  // roll: the (particle, wall) rolling-resistance torque spring (WallHistory), or
  // nullptr; its torque joins `torque`. wall_radius: the surface's radius of curvature for Hertz
  // and rolling resistance (a sphere such as the moonlet: R* = a R / (a + R)); 0: flat (R* = a).
  // damping: DampingLimit's scale for this particle; load (if given): the contact's Stability.
  Vec3 wall_force(const ParticleStore& p, std::size_t i, const Vec3& n, double delta, Vec3* xi, Vec3& torque,
                  bool advance = true, double* shift = nullptr, double* impact = nullptr, Vec3* roll = nullptr,
                  double wall_radius = 0, double damping = 1.0, Stability* load = nullptr) const {
    const double a = p.radius[i];
    Vec3 vrel = p.v[i], ft;
    const int sp = p.species[i];
    const PairLaw* L = &wall_table_[sp];
    PairLaw own;
    if (L->v_c > 0) {
      double u = impact ? *impact : 0.0;
      if (u == 0 && delta > 0) u = std::max(-vrel.dot(n), 0.0);  // this contact's impact
      own = at_impact(sp, sp, u);
      own.mu_s = L->mu_s;
      own.mu_d = L->mu_d;
      L = &own;
      if (impact && advance) *impact = delta > 0 ? u : 0.0;
    }
    const double reff = wall_radius > 0 ? a * wall_radius / (a + wall_radius) : a;
    const bool rolls = roll && xi && delta > 0 && (L->mu_r > 0 || L->mu_o > 0);
    const double inertia = 1.4 * p.mass[i] * a * a;  // the wall does not spin; I + m a^2
    if (load) {
      *load = stability(*L);
      if (rolls) {
        const Stability spin = spin_stability(*L, p.mass[i] * L->k_per_mass, reff, inertia, p.inv_inertia[i]);
        load->K += spin.K;
        load->G += spin.G;
      }
    }
    PairLaw limited;
    if (damping < 1) {
      limited = damped(*L, damping);
      L = &limited;
    }
    if (xi) vrel -= a * p.omega[i].cross(n);
    double overlap_shift = 0;
    Rolling rl;
    if (rolls) rl = {p.omega[i], inertia, *roll};
    const Vec3 f = force(parts_, *L, p.mass[i], delta, n, vrel, xi, ft, advance, &overlap_shift, reff, rolls ? &rl : nullptr);
    if (shift) *shift = -overlap_shift;  // more overlap: towards the wall
    if (xi) torque = (-a * n).cross(ft) + rl.torque;  // frictionless walls exert no torque: skip the work
    else torque.setZero();
    if (roll) *roll = rolls ? rl.spring : Vec3::Zero();
    return f;
  }

 private:
  // An exact torque spring's discrete oscillator per unit inertia: a function of w0^2 = k / I and
  // eta_r only. A scene of one bead size has four (pair and wall, rolling and twisting), asked for
  // several times per contact and step (the force and DampingLimit's load): remembered, each
  // costs a comparison instead of five transcendental calls (a quarter of a rolling clog run's
  // time; its snapshots came out bitwise as before). Polydisperse pairs miss and compute.
  struct TorqueOscillator {
    double w0sq = -1, eta = -1;  // the key
    DiscreteOscillator d{};
    double w2 = 0, decay = 0;
  };
  const TorqueOscillator& torque_oscillator(double w0sq, double eta) const {
    for (const TorqueOscillator& o : oscillators_)
      if (o.w0sq == w0sq && o.eta == eta) return o;
    return remember_oscillator(w0sq, eta);
  }
  // Out of line (without fused multiply-adds), like the per-pair constants: the pair loop and
  // the walls' modules share one memo, and must find in it what either would have computed.
  const TorqueOscillator& remember_oscillator(double w0sq, double eta) const;
  mutable std::array<TorqueOscillator, 8> oscillators_{};
  mutable std::size_t next_oscillator_ = 0;

  template <int N, class F, bool... Chosen>
  void pick(F& f, const bool* flags) const {
    if constexpr (N == 6) {
      using P = LawParts<Chosen...>;
      if constexpr (P::valid) f(P{parts_.clip});
      else throw std::logic_error("contact law: an invalid combination of parts");
    } else if (flags[N]) {
      pick<N + 1, F, Chosen..., true>(f, flags);
    } else {
      pick<N + 1, F, Chosen..., false>(f, flags);
    }
  }

  int n_;
  double dt_;
  bool clip_ = false, friction_ = false, exact_ = true;
  bool velocity_dependent_ = false, hertz_ = false, rolling_ = false, damping_limit_ = false, adhesion_ = false;
  RuntimeParts parts_{};  // the flags above, as the law's run-time parts
  std::vector<PairLaw> table_;
  std::vector<PairLaw> wall_table_;  // per species: its own law, with its wall friction
  std::vector<double> half_ = std::vector<double>(n_ * n_);  // sin(omega dt / 2) per pair
};

}  // namespace cassini
