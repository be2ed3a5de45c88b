#pragma once
// Adhesion of touching surfaces in the form of Derjaguin, Muller & Toporov (DMT, 1975): while
// two surfaces overlap they attract, besides the contact's spring and dashpot, with the constant
//     f_a = 2 pi w R*,   w = 2 gamma the work of adhesion of two surfaces of energy gamma,
// R* the reduced radius (a particle's own radius against a flat wall). f_a is DMT's pull-off
// force: a pair at rest parts when pulled with more than f_a. An approaching pair is captured
// when the dashpot takes enough of its energy that it cannot climb out of the attraction, below
// a capture speed that follows from the damped oscillator below (tests: test_contact_law.cpp,
// Adhesion*).
//
// Keys: species[i].surface_energy = gamma (J/m^2; default 0, no adhesion) and, for an unlike pair,
// pair[k].surface_energy. Unlike surfaces mix as w = 2 sqrt(gamma_a gamma_b) (Berthelot's rule, as
// Fowkes' for dispersion forces); a wall has its particle's surface energy.
//
// Friction and rolling resistance take the load pressing the surfaces together as f_n + 2 f_a
// (f_n the net normal force; Thornton & Yin 1991, as LAMMPS's dmt model): an adhesive contact
// resists sliding even with no net load.
//
// The attraction is f_a exactly under every scheme, so a pair parts under a static pull of
// exactly f_a. With the linear law under the exact scheme (LinearSpringDashpot.hpp) the steps
// inside a contact sample a damped oscillator whose static stiffness is the discrete k_eff, so
// the contact is the oscillator m delta'' = -k (delta - delta_a) - gamma delta' about the rest
// overlap delta_a = f_a / k_eff; its onset and exit steps follow that same oscillator (onset:
// the closed form below; exit: the instant it reaches delta = 0, by bisection within the step),
// so its samples are exact. Against the continuous contact (delta_a = f_a / k) the attraction
// in a collision is then f_a k / k_eff, 1 + |ln e| / N_c to first order: the capture speed is
// that close to the continuous one (test AdhesionCapturesBelowTheCaptureSpeed).
#include <cmath>
#include <numbers>

#include "core/Config.hpp"

namespace cassini {

struct Adhesion {
  static ContactParameter parameter() {
    return {"surface_energy", "a surface energy >= 0 (J/m^2; 0: no adhesion)", 0.0, 0.0,
            [](double a, double b) { return std::sqrt(a * b); }};
  }
  // The pull-off force per reduced radius of a pair whose (mixed) surface energy is gamma: 2 pi w.
  static double force_per_radius(double gamma) { return 4 * std::numbers::pi * gamma; }

  // The overlap and its rate a time s after a contact began (delta = 0) at approach speed u,
  // for the oscillator of decay rate eta and frequency omega about the rest overlap `rest`.
  struct State {
    double overlap, rate;
  };
  static State since_onset(double u, double rest, double eta, double omega, double s) {
    const double A = -rest, B = (u - eta * rest) / omega;  // delta - rest = e^(-eta s) (A cos + B sin)
    const double decay = std::exp(-eta * s), c = std::cos(omega * s), sn = std::sin(omega * s);
    return {rest + decay * (A * c + B * sn), decay * ((omega * B - eta * A) * c - (eta * B + omega * A) * sn)};
  }

  // A contact whose overlaps a step apart were before > 0 and now <= 0 (samples of the
  // oscillator about `rest`) ended in between: the time after `before` at which the overlap
  // reached zero, and its rate then. cos_w, sin_w: cos and sin(omega dt); exp_eta: exp(eta dt).
  struct Exit {
    double time, rate;
  };
  static Exit exit(double before, double now, double rest, double eta, double omega, double cos_w, double sin_w,
                   double exp_eta, double dt) {
    const double y0 = before - rest, q = ((now - rest) * exp_eta - y0 * cos_w) / sin_w;
    auto overlap = [&](double s) { return rest + std::exp(-eta * s) * (y0 * std::cos(omega * s) + q * std::sin(omega * s)); };
    double lo = 0, hi = dt;  // overlap(lo) > 0 >= overlap(hi): bisection to the last bit of dt
    for (int it = 0; it < 56; ++it) {
      const double mid = 0.5 * (lo + hi);
      (overlap(mid) > 0 ? lo : hi) = mid;
    }
    const double decay = std::exp(-eta * hi), c = std::cos(omega * hi), sn = std::sin(omega * hi);
    return {hi, decay * ((omega * q - eta * y0) * c - (eta * q + omega * y0) * sn)};
  }
};

}  // namespace cassini
