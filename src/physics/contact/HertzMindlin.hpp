#pragma once
// Hertz-Mindlin contact (species model = "hertz"): the elastic sphere contact with damping set
// from the restitution, as DEM codes use it for real materials (glass, steel, ice):
//   f_n = K delta - c sqrt(K m) v_n,  K = 4/3 E* sqrt(R* delta)     (Hertz; K delta = 4/3 E* R*^1/2 delta^3/2)
//   f_t = -k_t xi - g_t v_t,          k_t = 8 G* sqrt(R* delta)    (Mindlin's no-slip stiffness)
// with 1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2, 1/G* = 2(2 - nu_1)(1 + nu_1)/E_1 + (same for 2),
// R* and m the reduced radius and mass. The damping grows as delta^1/4, which makes the
// equation of a binary collision scale-free: in units of the peak overlap and the impact speed
// it is x'' = -x^3/2 - c x^1/4 x', so the restitution depends on c alone, not on the impact
// speed (hertz_damping_constant). In the usual DEM form (Tsuji et al. 1992; LIGGGHTS, MercuryDPM)
// the damping is g_n = 2 sqrt(5/6) beta sqrt(S_n m), S_n = 2 E* sqrt(R* delta), i.e. c = sqrt(5)
// beta; tangentially g_t = 2 sqrt(5/6) beta sqrt(k_t m).
//
// Hertz pairs are integrated with velocity Verlet under either contact.scheme (the exact
// scheme's closed forms are those of the linear law).
#include <cmath>
#include <numbers>

namespace cassini {

// The damping constant c of the usual DEM form, c = sqrt(5) beta, beta = -ln e / sqrt(ln^2 e +
// pi^2). Because the damping grows as delta^1/4 the restitution of a binary collision depends
// on c alone, and this c returns e itself: integrating x'' = -x^3/2 - c x^1/4 x' gives e to
// 1e-8 for e in [0.05, 0.99] (tests/test_contact_law.cpp, HertzDampingOfTheUsualFormRestitutesE).
inline double hertz_damping_constant(double e) {
  if (e >= 1) return 0;
  const double l = std::log(e);
  return std::sqrt(5.0) * -l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
}

// Duration of an elastic Hertz collision at relative normal speed v: 2 I delta_max / v with
// delta_max = (15 m v^2 / (16 E* R*^1/2))^2/5 and I = int_0^1 (1 - x^5/2)^-1/2 dx
// = sqrt(pi) Gamma(7/5) / Gamma(9/10) (~1.4716), i.e. t = 2.943 delta_max / v.
inline double hertz_contact_time(double m, double reff, double e_star, double v) {
  const double dmax = std::pow(15 * m * v * v / (16 * e_star * std::sqrt(reff)), 0.4);
  const double I = std::sqrt(std::numbers::pi) * std::tgamma(1.4) / std::tgamma(0.9);
  return 2 * I * dmax / v;
}

// Effective moduli of a pair of materials (E, nu) and (E', nu').
inline double hertz_e_star(double E1, double nu1, double E2, double nu2) {
  return 1 / ((1 - nu1 * nu1) / E1 + (1 - nu2 * nu2) / E2);
}
inline double hertz_g_star(double E1, double nu1, double E2, double nu2) {
  return 1 / (2 * (2 - nu1) * (1 + nu1) / E1 + 2 * (2 - nu2) * (1 + nu2) / E2);
}

}  // namespace cassini
