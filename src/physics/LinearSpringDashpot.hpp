#pragma once
// Linear spring-dashpot contact law of spec section 1, parametrised by contact time t_c and
// restitution e through the reduced mass m_ij:
//   eta = -ln(e)/t_c, omega = pi/t_c, k = m_ij (omega^2 + eta^2), gamma = 2 m_ij eta,
// so that a free binary collision lasts exactly t_c and returns exactly e. The normal force
// is f_n = k delta - gamma v_n; by default it may pull slightly at the end of a contact (that
// is what the exact relations assume). clip_normal = true clips it at zero, which makes the
// effective restitution larger than e (noticeably for small e).
//
// Tangential (only when friction is on): spring xi with history, f_t = -k_t xi - gamma_t v_t,
// capped by Coulomb (|f_t| <= mu_s f_n static; on sliding |f_t| = mu_d f_n and xi reset so
// that k_t |xi| = mu_d f_n).
//
// Every operation is sign-symmetric, so that evaluating the pair from j's side (negated n,
// vrel and spring) gives exactly the negated result, bitwise, provided no product is fused
// into an add (ContactForces.cpp is compiled with -ffp-contract=off). ContactForces relies on
// this to evaluate a pair of owned particles once, and a pair across a rank boundary from
// both sides, with the same trajectory on any number of ranks.
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Eigenvalues>

#include "core/Config.hpp"
#include "core/ParticleStore.hpp"
#include "core/Vec3.hpp"

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

struct PairLaw {
  double k_per_mass;      // omega^2 + eta^2
  double gamma_per_mass;  // 2 eta
  double kt_ratio, gammat_ratio, mu_s, mu_d;
};

class LinearSpringDashpot {
 public:
  LinearSpringDashpot(const Config& cfg, double dt) : n_(static_cast<int>(cfg.species.size())), dt_(dt) {
    clip_ = cfg.clip_normal;
    friction_ = cfg.friction();
    table_.resize(n_ * n_);
    for (int a = 0; a < n_; ++a)
      for (int b = 0; b < n_; ++b) {
        // Each pair its own t_c and e through its reduced mass (spec section 1); unlike pairs
        // mix their species' values unless a [[pair]] table sets them (Config::pair).
        const PairParameters& q = cfg.pair(a, b);
        const double eta = -std::log(q.e) / q.t_c, omega = std::numbers::pi / q.t_c;
        table_[a * n_ + b] = {omega * omega + eta * eta, 2 * eta, q.kt_ratio, q.gammat_ratio, q.mu_s, q.mu_d};
      }
  }

  const PairLaw& law(int a, int b) const { return table_[a * n_ + b]; }
  bool friction() const { return friction_; }

  // Force on body i. n: unit normal pointing from the partner to i; delta: overlap;
  // vrel: velocity of i's contact point relative to the partner's; m: reduced mass.
  // Returns the total force; ft receives the tangential part (for the torque).
  // advance = false evaluates the force of the spring as it stands, without this step's
  // increment v_t dt: for reports (snapshots, stress) after the step already advanced it.
  [[gnu::always_inline]] Vec3 force(const PairLaw& L, double m, double delta, const Vec3& n, const Vec3& vrel, Vec3* xi,
                                     Vec3& ft, bool advance = true) const {
    const double vn = vrel.dot(n);
    double fn = m * (L.k_per_mass * delta - L.gamma_per_mass * vn);
    if (clip_ && fn < 0) fn = 0;
    Vec3 f = fn * n;
    if (!xi) {
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
    if (advance) s += vt * dt_;
    const double kt = L.kt_ratio * m * L.k_per_mass, gt = L.gammat_ratio * m * L.gamma_per_mass;
    ft = -kt * s - gt * vt;
    const double cap = L.mu_s * std::max(fn, 0.0);
    const double ft2 = ft.squaredNorm();
    if (ft2 > cap * cap) {  // sliding (ft2 > 0 here, since cap >= 0)
      const Vec3 dir = ft / std::sqrt(ft2);
      const double slide = L.mu_d * std::max(fn, 0.0);
      ft = slide * dir;
      s = -(slide / kt) * dir;
    }
    *xi = s;
    return f + ft;
  }

  // Force on particle i of p from an immovable wall (infinite mass: m_ij = m_i, the particle's
  // own species). n: unit normal from the wall to the centre; delta: overlap; xi: the (particle,
  // wall) spring or nullptr without friction. torque receives the wall's torque on i.
  Vec3 wall_force(const ParticleStore& p, std::size_t i, const Vec3& n, double delta, Vec3* xi, Vec3& torque,
                  bool advance = true) const {
    const double a = p.radius[i];
    Vec3 vrel = p.v[i], ft;
    if (xi) vrel -= a * p.omega[i].cross(n);
    const int sp = p.species[i];
    const Vec3 f = force(law(sp, sp), p.mass[i], delta, n, vrel, xi, ft, advance);
    if (xi) torque = (-a * n).cross(ft);  // frictionless walls exert no torque: skip the work
    else torque.setZero();
    return f;
  }

 private:
  int n_;
  double dt_;
  bool clip_ = false, friction_ = false;
  std::vector<PairLaw> table_;
};

}  // namespace cassini
