#pragma once
// What a case file tells the contact law, read beside the law (ContactLawReader.cpp) and kept
// in the Config by type (cfg.get<ContactSettings>()): each species' law, each pair's parameters
// with the mixing of unlike species, and the [contact] table's scheme. The core holds none of
// it; it learns the one thing it needs, whether particles turn, from Config::rotation.
#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace cassini {

// A contact parameter that a part of the contact law declares in its own file (listed by
// LinearSpringDashpot::parameters()): the case reader takes it from every [[species]] table
// (`fallback` where a table does not give it), refuses values below `min`, mixes an unlike
// pair's value from its species' values with `mix`, and lets a [[pair]] table override it. The
// values reach the law by key (SpeciesLaw::declared, PairParameters::declared).
struct ContactParameter {
  std::string key;
  std::string expected;  // what a valid value is, for the error message
  double fallback = 0;
  double min = 0;
  double (*mix)(double, double) = nullptr;
};

// One species' contact law ([[species]] table; Config::species holds its geometry).
struct SpeciesLaw {
  double t_c = 0;  // contact duration
  double e = 1;    // normal restitution (restitution = "constant")
  // restitution = "bridges": each impact's e from its normal speed u, the law of frosty ice
  // (Bridges et al. 1984): e(u) = min(1, (u / v_c)^-0.234). 0: constant e.
  double v_c = 0;
  // model = "hertz" (Hertz-Mindlin, HertzMindlin.hpp): Young's modulus (Pa, > 0 marks the
  // model) and Poisson ratio; t_c is then the Hertz duration of the fastest expected impact
  // (impact_speed) between two of the smallest particles, which sets the time step.
  double youngs_modulus = 0, poisson_ratio = 0, impact_speed = 0;
  double mu_s = 0, mu_d = 0;            // Coulomb static and dynamic friction
  double wall_mu_s = 0, wall_mu_d = 0;  // against walls and the moonlet (default: mu_s, mu_d)
  // Rolling and twisting resistance (elastic-plastic spring-dashpot, LinearSpringDashpot::
  // rolling): limit torques mu_r R* f_n and mu_o R* f_n, damping ratio eta_r; needs mu_s > 0.
  double mu_r = 0, mu_o = 0, eta_r = 0.3;
  double kt_ratio = 2.0 / 7.0;      // k_t = kt_ratio k
  double gammat_ratio = 2.0 / 7.0;  // gamma_t = gammat_ratio gamma
  std::map<std::string, double> declared;  // the law's declared parameters (ContactParameter), by key
};

// Contact parameters of one unordered pair of species. Without a [[pair]] table for it, an
// unlike pair mixes its species' values: arithmetic means of t_c, e, kt_ratio and
// gammat_ratio, the smaller mu_s and mu_d (the slipperier surface decides). A like pair is
// its species' own values.
struct PairParameters {
  double t_c = 0, e = 1, mu_s = 0, mu_d = 0, kt_ratio = 2.0 / 7.0, gammat_ratio = 2.0 / 7.0;
  double v_c = 0;  // > 0: Bridges restitution (e set per impact; see SpeciesLaw::v_c)
  double mu_r = 0, mu_o = 0, eta_r = 0.3;  // rolling and twisting resistance (see SpeciesLaw::mu_r)
  double e_star = 0, g_star = 0;  // > 0: Hertz-Mindlin effective moduli (see SpeciesLaw::youngs_modulus)
  std::map<std::string, double> declared;  // the law's declared parameters (ContactParameter), by key
  double value(const std::string& key) const {
    const auto it = declared.find(key);
    if (it == declared.end()) throw std::logic_error("contact parameter '" + key + "' was not declared");
    return it->second;
  }
};

// Bridges et al. (1984): e = (u / v_c)^-kBridgesExponent for impacts faster than v_c.
inline constexpr double kBridgesExponent = 0.234;
// Bridges' v_c for frosty ice at 155 K, 0.0077 cm/s (the default of restitution = "bridges").
inline constexpr double kBridgesVc = 7.7e-5;

struct ContactSettings {
  std::vector<SpeciesLaw> species;     // as Config::species
  std::vector<PairParameters> pairs;   // [a * n + b] (symmetric)
  const PairParameters& pair(int a, int b) const { return pairs[a * species.size() + b]; }

  // [contact]
  bool clip_normal = false;
  bool exact = true;          // contact.scheme: "exact" (true) or "verlet"
  bool damping_limit = true;  // contact.damping_limit: crowded particles' dashpots limited (DampingLimit.hpp)

  // Any species with friction (particles or walls): rotation and tangential history needed.
  bool friction() const {
    return std::any_of(species.begin(), species.end(), [](const SpeciesLaw& s) { return s.mu_s > 0 || s.wall_mu_s > 0; }) ||
           std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.mu_s > 0; });
  }
  // Some pair's e is set per impact (Bridges).
  bool velocity_dependent_restitution() const {
    return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.v_c > 0; });
  }
  bool hertz() const {  // some pair follows Hertz-Mindlin
    return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.e_star > 0; });
  }
  bool rolling() const {  // some pair resists rolling or twisting
    return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.mu_r > 0 || q.mu_o > 0; });
  }
};

}  // namespace cassini
