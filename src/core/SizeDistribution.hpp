#pragma once
// Particle radii of a species between radius_min and radius_max (Species::sizes):
//   "uniform"    uniform in a (the default for radius_min < radius_max)
//   "power_law"  dN/da ~ a^-q (q = size_exponent; 3 is the classic ring-particle law)
//   "list"       given radii with number fractions (radii, radius_weights)
// quantile() turns a uniform random number into a radius (inverse CDF: one draw per particle,
// so a seed's sequence does not depend on the law), mean_power() gives <a^k> exactly, which
// sets the particle count for an optical depth or volume fraction.
#include <algorithm>
#include <cmath>
#include <vector>

namespace cassini {

struct SizeDistribution {
  enum Kind { Uniform, PowerLaw, List } kind = Uniform;
  double q = 3;                        // PowerLaw exponent
  std::vector<double> radii, weights;  // List: radii (ascending) and number fractions (sum 1)

  double quantile(double amin, double amax, double u) const {
    if (amin == amax) return amin;
    switch (kind) {
      case Uniform: return amin + u * (amax - amin);
      case PowerLaw: {
        const double p = 1 - q;
        if (std::abs(p) < 1e-12) return amin * std::pow(amax / amin, u);
        const double lo = std::pow(amin, p), hi = std::pow(amax, p);
        return std::clamp(std::pow(lo + u * (hi - lo), 1 / p), amin, amax);
      }
      case List: {
        double acc = 0;
        for (std::size_t k = 0; k + 1 < radii.size(); ++k)
          if (u < (acc += weights[k])) return radii[k];
        return radii.back();
      }
    }
    return amin;
  }

  // <a^k> over the distribution.
  double mean_power(double amin, double amax, int k) const {
    if (amin == amax) return std::pow(amin, k);
    switch (kind) {
      case Uniform:
        return (std::pow(amax, k + 1) - std::pow(amin, k + 1)) / ((k + 1) * (amax - amin));
      case PowerLaw: {
        auto integral = [&](double s) {  // int a^(s-1) da from amin to amax
          return std::abs(s) < 1e-12 ? std::log(amax / amin) : (std::pow(amax, s) - std::pow(amin, s)) / s;
        };
        return integral(k + 1 - q) / integral(1 - q);
      }
      case List: {
        double m = 0;
        for (std::size_t j = 0; j < radii.size(); ++j) m += weights[j] * std::pow(radii[j], k);
        return m;
      }
    }
    return 0;
  }
};

}  // namespace cassini
