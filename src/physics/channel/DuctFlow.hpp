#pragma once
// Pressure-driven (Poiseuille) flow in a rectangular duct, thesis (7.17):
//   v_x(y, z) = 4 h^2 G / (pi^3 eta) sum_{n odd} n^-3 [1 - cosh(n pi y/h) / cosh(n pi w/(2h))] sin(n pi z/h)
// with y from the centre line, z from the floor, G = dp/L. The pressure gradient is set from
// the series' own flow rate,
//   Q = h^3 w G / (12 eta) [1 - 192 h / (pi^5 w) sum_{n odd} tanh(n pi w/(2h)) / n^5],
// so that the mean velocity is exactly the requested one for any number of terms. The
// thesis's (7.22), dp/L = 12 eta v / (h^2 (1 - 0.63 h/w)), is this with tanh -> 1
// (192/pi^5 = 0.6302).
#include <cmath>
#include <numbers>

namespace cassini {

class DuctFlow {
 public:
  DuctFlow(double width, double height, double mean_velocity, int terms)
      : w_(width), h_(height), terms_(terms) {
    const double pi = std::numbers::pi;
    double s = 0;
    for (int k = 0; k < terms_; ++k) {
      const double n = 2 * k + 1;
      s += std::tanh(n * pi * w_ / (2 * h_)) / std::pow(n, 5);
    }
    // Q / (w h) = h^2 G/(12 eta) (1 - 192 h s/(pi^5 w)) = mean_velocity; store G/eta.
    g_over_eta_ = 12 * mean_velocity / (h_ * h_ * (1 - 192 * h_ * s / (std::pow(pi, 5) * w_)));
  }
  // y from the centre line, z from the floor.
  double velocity(double y, double z) const {
    const double pi = std::numbers::pi;
    if (std::abs(y) >= 0.5 * w_ || z <= 0 || z >= h_) return 0;
    double s = 0;
    for (int k = 0; k < terms_; ++k) {
      const double n = 2 * k + 1;
      // cosh ratio written as exponentials: no overflow for many terms.
      const double a = n * pi / h_;
      const double ratio = std::exp(a * (std::abs(y) - 0.5 * w_)) * (1 + std::exp(-2 * a * std::abs(y))) /
                           (1 + std::exp(-a * w_));
      s += (1 - ratio) * std::sin(a * z) / (n * n * n);
    }
    return 4 * h_ * h_ * g_over_eta_ / std::pow(pi, 3) * s;
  }
  double pressure_gradient_over_viscosity() const { return g_over_eta_; }

 private:
  double w_, h_;
  int terms_;
  double g_over_eta_ = 0;
};

}  // namespace cassini
