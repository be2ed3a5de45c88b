#pragma once
// Builds the module list a case asks for, in the fixed order their forces are summed.
#include <memory>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"

namespace cassini {
class Simulation;
std::vector<std::unique_ptr<Module>> make_modules(const Config& cfg, Simulation& sim);
}  // namespace cassini
