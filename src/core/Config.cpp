#include "core/Config.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cassini {

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
