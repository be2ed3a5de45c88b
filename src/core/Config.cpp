#include "core/Config.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cassini {

bool Config::friction() const {
  return std::any_of(species.begin(), species.end(), [](const Species& s) { return s.mu_s > 0 || s.wall_mu_s > 0; }) ||
         std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.mu_s > 0; });
}

double Config::max_radius() const {
  double r = 0;
  for (const auto& s : species) r = std::max(r, s.radius_max);
  return r;
}

double Config::min_radius() const {
  double r = species.empty() ? 0.0 : species[0].radius_min;
  for (const auto& s : species) r = std::min(r, s.radius_min);
  return r;
}

bool Config::velocity_dependent_restitution() const {
  return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.v_c > 0; });
}

bool Config::hertz() const {
  return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.e_star > 0; });
}

bool Config::rolling() const {
  return std::any_of(pairs.begin(), pairs.end(), [](const PairParameters& q) { return q.mu_r > 0 || q.mu_o > 0; });
}

const std::any& Config::find_settings(const std::type_index& type) const {
  const auto it = settings.find(type);
  if (it == settings.end())  // a module asked for another's settings without naming it in ModuleKind::needs
    throw std::logic_error(std::string("no settings of type ") + type.name() + " in the configuration of " + source);
  return it->second;
}

bool Config::has_module(const std::string& name) const {
  return std::find(modules.begin(), modules.end(), name) != modules.end();
}

}  // namespace cassini
