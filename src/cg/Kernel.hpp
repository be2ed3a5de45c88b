#pragma once
// Coarse-graining kernels psi(r) of width w in d = 1, 2 or 3 dimensions (thesis 3.3-3.5),
// each normalised so that its integral over its support is exactly 1:
//   gauss      exp(-r^2 / 2w^2), cut off at c = 3w (the normalisation includes the cut)
//   lucy       (1 + 3r/c)(1 - r/c)^3, c = 2w (4th-order Lucy polynomial)
//   heaviside  1 inside c = w
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace cassini::cg {

class Kernel {
 public:
  Kernel(const std::string& kind, double width, int dims) : dims_(dims), w_(width) {
    const double pi = std::numbers::pi;
    if (kind == "gauss") {
      type_ = 0;
      c_ = 3 * w_;
      const double s = c_ / (std::sqrt(2.0) * w_), tail = std::exp(-0.5 * c_ * c_ / (w_ * w_));
      if (dims == 1) norm_ = 1 / (std::sqrt(2 * pi) * w_ * std::erf(s));
      if (dims == 2) norm_ = 1 / (2 * pi * w_ * w_ * (1 - tail));
      if (dims == 3) norm_ = 1 / (std::pow(2 * pi * w_ * w_, 1.5) * (std::erf(s) - std::sqrt(2 / pi) * (c_ / w_) * tail));
    } else if (kind == "lucy") {
      type_ = 1;
      c_ = 2 * w_;
      const double k[4] = {0, 5.0 / 4.0, 5.0 / pi, 105.0 / (16.0 * pi)};
      norm_ = k[dims] / std::pow(c_, dims);
    } else if (kind == "heaviside") {
      type_ = 2;
      c_ = w_;
      const double v[4] = {0, 2 * c_, pi * c_ * c_, 4.0 / 3.0 * pi * c_ * c_ * c_};
      norm_ = 1 / v[dims];
    } else {
      throw std::invalid_argument("--kernel: expected gauss, lucy or heaviside, got '" + kind + "'");
    }
  }
  double cutoff() const { return c_; }
  double operator()(double r2) const {
    if (r2 >= c_ * c_) return 0;
    switch (type_) {
      case 0: return norm_ * std::exp(-0.5 * r2 / (w_ * w_));
      case 1: {
        const double q = std::sqrt(r2) / c_;
        return norm_ * (1 + 3 * q) * (1 - q) * (1 - q) * (1 - q);
      }
      default: return norm_;
    }
  }

 private:
  int dims_, type_ = 0;
  double w_, c_ = 0, norm_ = 1;
};

}  // namespace cassini::cg
