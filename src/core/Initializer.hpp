#pragma once
// Initial particles: random non-overlapping, simple-cubic lattice, or read from a text file.
// Every rank generates the same full set from the case's seed and keeps the particles in its
// own slab, so the initial state does not depend on the rank count.
#include <cstdint>

#include "core/Config.hpp"
#include "core/ParticleStore.hpp"
#include "parallel/Decomposition.hpp"

namespace cassini {

// Deterministic, portable random numbers (the std distributions are not portable).
class Random {
 public:
  explicit Random(std::uint64_t seed) : s_(seed ? seed : 0x9E3779B97F4A7C15ull) {}
  std::uint64_t next() {  // splitmix64
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double gaussian();

 private:
  std::uint64_t s_;
};

void place_particles(const Config& cfg, const Decomposition& dom, ParticleStore& p);

}  // namespace cassini
