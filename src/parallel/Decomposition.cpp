#include "parallel/Decomposition.hpp"

#include <algorithm>

#include "parallel/MetisPartition.hpp"

namespace cassini {

namespace {

// The grid of `ranks` regions with the least region surface for the box (the halo a region
// exchanges): every factorisation px * py (* pz) tried; among equal surfaces the one that cuts
// the fewest axes (fewer region edges and neighbours: in a box of 80 x 50 x 50 sites, 16 ranks
// as 4 x 1 x 4 move 13 % fewer halo bytes in 8 messages per step than 4 x 2 x 2 in 11), then
// fewer regions along x, then along y (the first found).
std::array<int, 3> least_surface_grid(int ranks, const Vec3& length, int dims) {
  std::array<int, 3> best{ranks, 1, 1};
  double best_area = 1e300;
  int best_axes = 4;
  for (int px = 1; px <= ranks; ++px) {
    if (ranks % px) continue;
    for (int py = 1; py <= ranks / px; ++py) {
      if ((ranks / px) % py) continue;
      const int pz = ranks / px / py;
      if (dims == 2 && pz != 1) continue;
      const std::array<int, 3> p{px, py, pz};
      double area = 0;  // faces of one region normal to each cut axis
      for (int d = 0; d < dims; ++d) {
        if (p[d] == 1) continue;
        double face = 1;
        for (int e = 0; e < dims; ++e)
          if (e != d) face *= length[e] / p[e];
        area += face;
      }
      const int axes = (px > 1) + (py > 1) + (pz > 1);
      if (area < best_area * (1 - 1e-9) || (area < best_area * (1 + 1e-9) && axes < best_axes))
        best_area = area, best_axes = axes, best = p;
    }
  }
  return best;
}

}  // namespace

Decomposition::Decomposition(const Config& cfg, MPI_Comm c) : comm(c) {
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &nranks);
  axis = cfg.slab_axis;
  dims = cfg.planar ? 2 : 3;
  lo = cfg.lo;
  hi = cfg.hi;
  length = hi - lo;
  boundary = cfg.boundary;
  if (cfg.decomposition == "grid") {
    grid = cfg.grid_shape;
    if (grid[0] * grid[1] * grid[2] == 0) {
      grid = least_surface_grid(nranks, length, dims);
    } else if (grid[0] * grid[1] * grid[2] != nranks || (dims == 2 && grid[2] != 1)) {
      throw ConfigError(cfg.source + ": key 'domain.grid': " + std::to_string(grid[0]) + " x " + std::to_string(grid[1]) +
                        " x " + std::to_string(grid[2]) + " regions for " + std::to_string(nranks) +
                        " ranks; expected a shape whose product is the rank count (z: 1 in a planar scene), or no key");
    }
  } else {
    grid = {1, 1, 1};
    grid[axis] = nranks;
  }
  place = {rank % grid[0], rank / grid[0] % grid[1], rank / (grid[0] * grid[1])};
  for (int d = 0; d < 3; ++d) {
    cuts[d].resize(grid[d] + 1);
    for (int r = 0; r <= grid[d]; ++r) cuts[d][r] = lo[d] + length[d] * r / grid[d];
    cuts[d][grid[d]] = hi[d];
  }
  shear.enabled = cfg.sheared();
  shear.rate = cfg.shear_rate;
  fed_x = cfg.modified_lees_edwards;
}

void Decomposition::use_cells(double range) {
  // Cells at least one range wide, so a particle's neighbours are in the 27 cells around it;
  // coarser when the box would have more than ~20,000 (METIS time, replicated map).
  double size = range;
  for (;;) {
    double count = 1;
    for (int d = 0; d < dims; ++d) count *= std::max(1.0, std::floor(length[d] / size));
    if (count <= 20000) break;
    size *= 1.25;
  }
  for (int d = 0; d < 3; ++d) {
    ncell[d] = d < dims ? std::max(1, static_cast<int>(length[d] / size)) : 1;
    cell_size[d] = length[d] / ncell[d];
  }
  const std::array<bool, 3> wrap{periodic(0), periodic(1) || shear.enabled, periodic(2)};
  cell_owner = partition_cells(ncell, wrap, std::vector<double>(ncell[0] * ncell[1] * ncell[2], 1.0), nranks);
}

double Decomposition::imbalance(double mine) const {
  double worst = 0, total = 0;
  MPI_Allreduce(&mine, &worst, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(&mine, &total, 1, MPI_DOUBLE, MPI_SUM, comm);
  return total > 0 ? worst / (total / nranks) : 1.0;
}

double Decomposition::balance(const std::vector<Vec3>& x, const std::vector<double>& cost) {
  double mine = 0;
  for (double c : cost) mine += c;
  const double before = imbalance(mine);
  if (nranks == 1 || before == 1.0) return before;
  if (cells()) {
    // Cost per cell, summed over ranks; every rank runs the same deterministic partition.
    const std::size_t n = cell_owner.size();
    std::vector<double> w(n, 0.0), g(n);
    for (std::size_t i = 0; i < x.size(); ++i) w[cell_of(x[i])] += cost[i];
    MPI_Allreduce(w.data(), g.data(), static_cast<int>(n), MPI_DOUBLE, MPI_SUM, comm);
    const std::array<bool, 3> wrap{periodic(0), periodic(1) || shear.enabled, periodic(2)};
    cell_owner = partition_cells(ncell, wrap, g, nranks);
    return before;
  }
  // Slabs and grids: along each cut axis a cost histogram, summed over ranks; cuts at its
  // equal-cost quantiles (linear within a bin). Periodic wrap-around is not exploited: the
  // regions stay ordered. (Per axis, as LAMMPS's balance shift: a grid's blocks are balanced
  // along each axis, not each block on its own.)
  for (int d = 0; d < dims; ++d) {
    const int parts = grid[d];
    if (parts == 1) continue;
    const int bins = 64 * parts;
    const double lo0 = lo[d], L = length[d];
    std::vector<double> h(bins, 0.0), g(bins);
    for (std::size_t i = 0; i < x.size(); ++i) {
      const int b = std::clamp(static_cast<int>((x[i][d] - lo0) / L * bins), 0, bins - 1);
      h[b] += cost[i];
    }
    MPI_Allreduce(h.data(), g.data(), bins, MPI_DOUBLE, MPI_SUM, comm);
    double total = 0;
    for (double v : g) total += v;
    std::vector<double>& cut = cuts[d];
    double acc = 0;
    int r = 1;
    for (int b = 0; b < bins && r < parts; ++b) {
      while (r < parts && acc + g[b] >= total * r / parts) {
        const double frac = g[b] > 0 ? (total * r / parts - acc) / g[b] : 0.0;
        cut[r] = lo0 + L * (b + frac) / bins;
        ++r;
      }
      acc += g[b];
    }
    for (; r < parts; ++r) cut[r] = hi[d];
    for (int q = 1; q < parts; ++q) cut[q] = std::max(cut[q], cut[q - 1]);  // ordered, possibly empty regions
  }
  return before;
}

std::size_t Decomposition::cell_of(const Vec3& x) const {
  int c[3];
  for (int d = 0; d < 3; ++d)
    c[d] = std::clamp(static_cast<int>(std::floor((x[d] - lo[d]) / cell_size[d])), 0, ncell[d] - 1);
  return (std::size_t(c[2]) * ncell[1] + c[1]) * ncell[0] + c[0];
}

int Decomposition::region_along(int d, double v) const {
  const std::vector<double>& cut = cuts[d];
  if (v >= cut[place[d]] && v < cut[place[d] + 1]) return place[d];  // most asks, at every rebuild
  // upper_bound: the region [cut[r], cut[r+1]) containing the coordinate
  return static_cast<int>(std::upper_bound(cut.begin() + 1, cut.end() - 1, v) - (cut.begin() + 1));
}

int Decomposition::owner(const Vec3& x) const {
  if (cells()) return cell_owner[cell_of(x)];
  int r = 0;
  for (int d = 3; d-- > 0;) r = r * grid[d] + (grid[d] > 1 ? region_along(d, x[d]) : 0);
  return r;
}

void Decomposition::ranks_near(const Vec3& x, double reach, std::vector<int>& out) const {
  out.clear();
  if (!cells()) {
    bool mine = true;  // within this rank's own region, `reach` from its cuts: most asks
    for (int d = 0; d < 3; ++d)
      if (grid[d] > 1 && (x[d] - reach < cuts[d][place[d]] || x[d] + reach >= cuts[d][place[d] + 1])) mine = false;
    if (mine) {
      out.push_back(rank);
      return;
    }
    // Along each axis the regions whose extent widened by `reach` holds x; every combination.
    int first[3], last[3];
    for (int d = 0; d < 3; ++d) {
      first[d] = last[d] = 0;
      if (grid[d] == 1) continue;
      const std::vector<double>& cut = cuts[d];
      first[d] = region_along(d, x[d] - reach);
      last[d] = region_along(d, x[d] + reach);
      while (first[d] <= last[d] && !(x[d] >= cut[first[d]] - reach && x[d] < cut[first[d] + 1] + reach)) ++first[d];
      while (last[d] >= first[d] && !(x[d] >= cut[last[d]] - reach && x[d] < cut[last[d] + 1] + reach)) --last[d];
      if (first[d] > last[d]) return;
    }
    for (int k = first[2]; k <= last[2]; ++k)
      for (int j = first[1]; j <= last[1]; ++j)
        for (int i = first[0]; i <= last[0]; ++i) out.push_back((k * grid[1] + j) * grid[0] + i);
    return;
  }
  // Cells inside the box that the cube of half-width `reach` around x touches (an image far
  // outside the box touches none: its partners are reached through another image).
  int c0[3], c1[3];
  for (int d = 0; d < 3; ++d) {
    c0[d] = std::max(0, static_cast<int>(std::floor((x[d] - reach - lo[d]) / cell_size[d])));
    c1[d] = std::min(ncell[d] - 1, static_cast<int>(std::floor((x[d] + reach - lo[d]) / cell_size[d])));
    if (d >= dims) c0[d] = c1[d] = 0;
    if (c0[d] > c1[d]) return;
  }
  for (int k = c0[2]; k <= c1[2]; ++k)
    for (int j = c0[1]; j <= c1[1]; ++j)
      for (int i = c0[0]; i <= c1[0]; ++i) out.push_back(cell_owner[(k * ncell[1] + j) * ncell[0] + i]);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

void Decomposition::local_box(Vec3& box_lo, Vec3& box_hi) const {
  box_lo = lo;
  box_hi = hi;
  if (!cells()) {
    for (int d = 0; d < 3; ++d) {
      box_lo[d] = cuts[d][place[d]];
      box_hi[d] = cuts[d][place[d] + 1];
    }
    return;
  }
  int c0[3] = {ncell[0], ncell[1], ncell[2]}, c1[3] = {-1, -1, -1};
  for (int k = 0; k < ncell[2]; ++k)
    for (int j = 0; j < ncell[1]; ++j)
      for (int i = 0; i < ncell[0]; ++i) {
        if (cell_owner[(k * ncell[1] + j) * ncell[0] + i] != rank) continue;
        const int c[3] = {i, j, k};
        for (int d = 0; d < 3; ++d) c0[d] = std::min(c0[d], c[d]), c1[d] = std::max(c1[d], c[d]);
      }
  if (c1[0] < 0) return;  // owns nothing
  for (int d = 0; d < dims; ++d) {
    box_lo[d] = lo[d] + c0[d] * cell_size[d];
    box_hi[d] = c1[d] == ncell[d] - 1 ? hi[d] : lo[d] + (c1[d] + 1) * cell_size[d];
  }
}

}  // namespace cassini
