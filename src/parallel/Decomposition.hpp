#pragma once
// Which part of the box this rank owns. Three ways (domain.decomposition):
//  - "slabs" (default): one slab along `axis`, bounded by two cuts along it.
//  - "grid": a block of a px x py (x pz) grid of regions, like LAMMPS's processor grid: the
//    faces of a region shrink as the rank count grows, where a slab's do not (a slab's halo is
//    a per-step floor at many ranks: docs/scaling.md). The shape is the one with the least
//    region surface for the box, or domain.grid.
//    Slabs are the grid with P regions along one axis. The cuts are plain data per axis, so a
//    load balancer can move them at run time.
//  - "metis": the box is cut into cells at least one interaction range wide and every cell
//    is given to a rank by a METIS partition of the cell graph, weighted by cost when
//    balancing. Any shape of region, e.g. a crowded upstream channel split along y too.
// Everything else asks only owner(x), ranks_near(x, reach) and local_box(), so the halo
// exchange and the neighbour build are the same code for all three.
// Also the box geometry every rank agrees on: bounds, boundary types, and the Lees-Edwards
// shear state (x shifted by a growing offset across the y boundaries) when a scene has one.
#include <array>
#include <cmath>
#include <vector>

#include <mpi.h>

#include "core/Config.hpp"
#include "core/Vec3.hpp"

namespace cassini {

// Lees-Edwards boundaries: shear along x with gradient along y. An image across the top
// (y + Ly) sits at x + offset and moves faster by rate * Ly.
struct ShearBoundary {
  bool enabled = false;
  double rate = 0;            // gamma_dot
  double offset = 0;          // unwrapped offset gamma_dot Ly t: never wrapped in the state
  double wrapped(double Lx) const { return offset - Lx * std::floor(offset / Lx); }  // in [0, Lx)
};

struct Decomposition {
  MPI_Comm comm = MPI_COMM_WORLD;
  int rank = 0, nranks = 1;
  int axis = 0;  // slabs: the axis cut
  int dims = 3;  // 2 in planar scenes: z is neither imaged nor cut
  Vec3 lo, hi, length;
  std::array<Boundary, 3> boundary{};
  // Regions per axis (slabs: nranks along `axis`, 1 along the others), this rank's place in
  // the grid (rank = (k * grid[1] + j) * grid[0] + i), and the cuts along each axis:
  // grid[d] + 1 entries, from lo[d] to hi[d].
  std::array<int, 3> grid{1, 1, 1}, place{0, 0, 0};
  std::array<std::vector<double>, 3> cuts;
  ShearBoundary shear;
  // Modified Lees-Edwards boundaries (Config::modified_lees_edwards): across x, LE1 (copy 0)
  // is open and sees LE2 (copy 1) beyond it, and LE2 feeds what crosses into LE1.
  bool fed_x = false;
  // Cell ownership ("metis"): empty in slab mode.
  std::array<int, 3> ncell{1, 1, 1};
  Vec3 cell_size;
  std::vector<int> cell_owner;  // by cell (k * ncell[1] + j) * ncell[0] + i

  Decomposition(const Config& cfg, MPI_Comm comm);

  bool cells() const { return !cell_owner.empty(); }
  // Switches to cell ownership with cells at least `range` wide, partitioned with unit weights.
  void use_cells(double range);
  std::size_t cell_of(const Vec3& x) const;  // cell holding the point (clamped into the box)
  int owner(const Vec3& x) const;  // rank owning the point (clamped into the box)
  // Every rank whose region lies within `reach` of x (x may be a periodic image outside the
  // box), ascending, this rank included.
  void ranks_near(const Vec3& x, double reach, std::vector<int>& out) const;
  // x lies farther than `reach` from every face of the box and from the cuts of this rank's
  // slab: no other rank and no periodic image can be within reach of it (false under cell
  // ownership, where the question is not asked this way).
  bool deep_inside(const Vec3& x, double reach) const {
    if (cells()) return false;
    for (int d = 0; d < dims; ++d) {
      if (x[d] < lo[d] + reach || x[d] >= hi[d] - reach) return false;
      if (grid[d] > 1 && (x[d] - reach < cuts[d][place[d]] || x[d] + reach >= cuts[d][place[d] + 1])) return false;
    }
    return true;
  }
  // Bounding box of this rank's region (the whole box when it owns nothing).
  void local_box(Vec3& box_lo, Vec3& box_hi) const;
  // Moves the region borders so that every rank holds about the same cost: `x` and `cost`
  // are this rank's particles' positions and costs. Collective. Returns the imbalance (max
  // over mean of the per-rank cost) before the move.
  double balance(const std::vector<Vec3>& x, const std::vector<double>& cost);
  // Max over mean of the per-rank cost, without moving anything. Collective.
  double imbalance(double my_cost) const;
  bool periodic(int d) const { return boundary[d] == Boundary::Periodic; }

 private:
  // The region index along axis d holding coordinate v (clamped into the box).
  int region_along(int d, double v) const;
};

}  // namespace cassini
