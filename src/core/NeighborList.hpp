#pragma once
// Verlet neighbour list built with linked cells. Full list: every owned particle lists all
// partners (owned or ghost) within a_i + a_j + skin, sorted by partner id. Each particle then
// sums its own contact forces in id order, so its force is bitwise the same whatever the
// rank count, and no ghost forces need to be sent back (the pair force is computed on both
// sides; it is exactly antisymmetric).
#include <cstdint>
#include <vector>

#include "core/ParticleStore.hpp"
#include "parallel/Decomposition.hpp"

namespace cassini {

class NeighborList {
 public:
  std::vector<std::uint32_t> start;    // nlocal + 1 offsets into partner
  std::vector<std::uint32_t> partner;  // local or ghost index
  // Per entry: the owned particle whose list holds it. Loops over every entry then run flat,
  // without an inner loop per particle whose length (about one in a gas) no branch predictor
  // can guess.
  std::vector<std::uint32_t> row;

  void build(const ParticleStore& p, const Decomposition& dom, double range, double skin);
  // Order of owned particles by cell, to keep neighbours close in memory.
  static std::vector<std::size_t> spatial_order(const ParticleStore& p, const Decomposition& dom, double range);

  std::size_t size() const { return partner.size(); }

  // The pair iteration, written once for every loop off the force kernel's hot path (reports,
  // lubrication, diagnostics): f(i, j, k) for owned particle i, partner j (owned or ghost) and
  // list entry k, in list order.
  template <class F>
  void for_each_pair(F&& f) const {
    const std::size_t n = partner.size();
    for (std::size_t k = 0; k < n; ++k) f(std::size_t(row[k]), partner[k], static_cast<std::uint32_t>(k));
  }
  // Every pair once on any number of ranks: from the side with the lower id.
  template <class F>
  void for_each_pair_once(const ParticleStore& p, F&& f) const {
    for_each_pair([&](std::size_t i, std::uint32_t j, std::uint32_t k) {
      if (p.id[i] < p.id[j]) f(i, j, k);
    });
  }
  // A listed pair whose spheres overlap, as contact reports need it.
  struct Overlap {
    std::size_t i;
    std::uint32_t j, k;  // partner, list entry
    Vec3 d, n;           // x_i - x_j and its direction (from j to i)
    double r, delta;     // distance, overlap a_i + a_j - r > 0
  };
  // f(Overlap) for every overlapping entry (once = true: every overlapping pair once).
  template <class F>
  void for_each_overlap(const ParticleStore& p, bool once, F&& f) const {
    for_each_pair([&](std::size_t i, std::uint32_t j, std::uint32_t k) {
      if (once && p.id[i] >= p.id[j]) return;
      const Vec3 d = p.x[i] - p.x[j];
      const double R = p.radius[i] + p.radius[j], r = d.norm();
      if (r >= R) return;
      f(Overlap{i, j, k, d, d / r, r, R - r});
    });
  }
  long long candidates = 0;  // pairs distance-tested at the last build (the search's cost)

 private:
  struct Grid {
    Vec3 lo;
    Vec3 inv_size;
    int n[3];
    int cell(const Vec3& x) const;
  };
  // Cells of at least `range`, and never many more cells than particles: a few particles
  // in a huge box must not allocate a huge grid.
  static Grid make_grid(const Decomposition& dom, double range, std::size_t particles);
  // Radii spread over more than a factor 2 (a size distribution): one grid per size class
  // (radii within a factor 2), each with cells as wide as its own largest pair reach, searched
  // over the cells a particle's reach to that class covers (the "multi" binning of LAMMPS).
  // A cell grid sized for the largest pair would test ~(a_max / a)^2 times more candidates.
  void build_by_size_class(const ParticleStore& p, const Decomposition& dom, double range, double skin, double amin,
                           double amax);
  void sort_into_cells(std::size_t ncells);  // cell_start_, cell_items_ from cell_of_
  void fill_rows();                          // row from start (the size-class build)
  std::vector<std::uint32_t> cell_start_, cell_items_, cell_of_;
  std::vector<double> sx_, sy_, sz_, sa_;  // positions and radii in cell order (build)
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs_;  // the half-stencil build's pairs
  std::vector<std::uint32_t> fill_;
};

}  // namespace cassini
