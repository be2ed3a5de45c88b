#pragma once
// Reads a case file into a Config: the domain, species and contact laws, time, initial
// particles, output and guards here; each module's own tables by that module
// (ModuleKind::read). Validates everything; a bad value throws ConfigError naming the file,
// the key and what was expected.
#include "core/CaseFile.hpp"
#include "core/Config.hpp"

namespace cassini {

Config read_config(CaseFile& file);

}  // namespace cassini
