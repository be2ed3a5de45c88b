#pragma once
// Which part of the box this rank owns: one slab along `axis`, bounded by cuts[rank] and
// cuts[rank+1]. The cuts are plain data so a load balancer can move them at run time.
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
  int axis = 0;
  int dims = 3;  // 2 in planar scenes: z is neither imaged nor cut
  Vec3 lo, hi, length;
  std::array<Boundary, 3> boundary{};
  std::vector<double> cuts;  // nranks + 1 entries, cuts.front() = lo[axis], cuts.back() = hi[axis]
  ShearBoundary shear;

  Decomposition(const Config& cfg, MPI_Comm comm);

  double slab_lo() const { return cuts[rank]; }
  double slab_hi() const { return cuts[rank + 1]; }
  int owner(double coord) const;  // rank whose slab holds this coordinate along axis (clamped)
  // Moves the cuts so that every slab holds about the same cost: `coord` and `cost` are this
  // rank's particles' positions along the axis and their costs. Collective. Returns the
  // imbalance (max over mean of the per-rank cost) before the move.
  double balance(const std::vector<double>& coord, const std::vector<double>& cost);
  bool periodic(int d) const { return boundary[d] == Boundary::Periodic; }
};

}  // namespace cassini
