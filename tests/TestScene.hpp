#pragma once
// Small helpers to build a scene from an inline case text in tests.
#include <memory>
#include <string>
#include <vector>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "core/Simulation.hpp"

namespace cassini::test {

inline Config config_from(const std::string& text, const std::vector<std::string>& overrides = {}) {
  CaseFile cf = CaseFile::parse(text, "test.toml", overrides);
  return read_config(cf);
}

inline std::unique_ptr<Simulation> make_sim(const std::string& text, const std::vector<std::string>& overrides = {},
                                            MPI_Comm comm = MPI_COMM_WORLD) {
  return std::make_unique<Simulation>(config_from(text, overrides), comm);
}

// Finds an owned particle by id on this rank (nullptr-like -1 when not here).
inline long local_index(const Simulation& sim, std::int64_t id) {
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i)
    if (sim.particles.id[i] == id) return static_cast<long>(i);
  return -1;
}

}  // namespace cassini::test
