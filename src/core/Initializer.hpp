#pragma once
// Initial particles: random non-overlapping, simple-cubic lattice, or read from a text file.
// Every rank walks the same sequence of particles drawn from the case's seed and keeps those in
// its own slab, so the initial state does not depend on the rank count. Lattice and file starts
// hold only the rank's own particles (a lattice site's draws are reached by skipping the stream
// ahead); random sequential addition needs every earlier particle to place the next, so it holds
// all N positions (32 bytes each) while it places them, then keeps its own.
#include <cstdint>

#include "core/Config.hpp"
#include "core/ParticleStore.hpp"
#include "parallel/Decomposition.hpp"

namespace cassini {

// Deterministic, portable random numbers (the std distributions are not portable).
class Random {
 public:
  explicit Random(std::uint64_t seed) : s_(seed ? seed : 0x9E3779B97F4A7C15ull) {}
  // Stream `stream` of seed `seed` (e.g. a step's draws): both scrambled, so that no two seeds or
  // streams share a stretch of the sequence. (splitmix64 steps its state by a constant G, so
  // Random(seed * G + stream) gives seed + 1 the sequence of seed shifted by one draw.)
  static Random stream(std::uint64_t seed, std::uint64_t stream) { return Random(scramble(scramble(seed) ^ stream)); }
  static std::uint64_t scramble(std::uint64_t z) {  // splitmix64's output function: a bijection
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::uint64_t next() {  // splitmix64
    const std::uint64_t z = s_;
    s_ += 0x9E3779B97F4A7C15ull;
    return scramble(z);
  }
  double uniform() { return (next() >> 11) * 0x1.0p-53; }  // [0, 1)
  void skip(std::uint64_t draws) { s_ += draws * 0x9E3779B97F4A7C15ull; }  // as `draws` calls of next()
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double gaussian();

 private:
  std::uint64_t s_;
};

void place_particles(const Config& cfg, const Decomposition& dom, ParticleStore& p);

}  // namespace cassini
