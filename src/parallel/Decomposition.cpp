#include "parallel/Decomposition.hpp"

#include <algorithm>

#include "parallel/MetisPartition.hpp"

namespace cassini {

Decomposition::Decomposition(const Config& cfg, MPI_Comm c) : comm(c) {
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &nranks);
  axis = cfg.slab_axis;
  dims = cfg.planar ? 2 : 3;
  lo = cfg.lo;
  hi = cfg.hi;
  length = hi - lo;
  boundary = cfg.boundary;
  cuts.resize(nranks + 1);
  for (int r = 0; r <= nranks; ++r) cuts[r] = lo[axis] + length[axis] * r / nranks;
  cuts[nranks] = hi[axis];
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
  // Slabs: a cost histogram along the axis, summed over ranks; cuts at its equal-cost
  // quantiles (linear within a bin). Periodic wrap-around is not exploited: slabs stay ordered.
  const int bins = 64 * nranks;
  const double lo0 = lo[axis], L = length[axis];
  std::vector<double> h(bins, 0.0), g(bins);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const int b = std::clamp(static_cast<int>((x[i][axis] - lo0) / L * bins), 0, bins - 1);
    h[b] += cost[i];
  }
  MPI_Allreduce(h.data(), g.data(), bins, MPI_DOUBLE, MPI_SUM, comm);
  double total = 0;
  for (double v : g) total += v;
  double acc = 0;
  int r = 1;
  for (int b = 0; b < bins && r < nranks; ++b) {
    while (r < nranks && acc + g[b] >= total * r / nranks) {
      const double frac = g[b] > 0 ? (total * r / nranks - acc) / g[b] : 0.0;
      cuts[r] = lo0 + L * (b + frac) / bins;
      ++r;
    }
    acc += g[b];
  }
  for (; r < nranks; ++r) cuts[r] = hi[axis];
  for (int q = 1; q < nranks; ++q) cuts[q] = std::max(cuts[q], cuts[q - 1]);  // ordered, possibly empty slabs
  return before;
}

std::size_t Decomposition::cell_of(const Vec3& x) const {
  int c[3];
  for (int d = 0; d < 3; ++d)
    c[d] = std::clamp(static_cast<int>(std::floor((x[d] - lo[d]) / cell_size[d])), 0, ncell[d] - 1);
  return (std::size_t(c[2]) * ncell[1] + c[1]) * ncell[0] + c[0];
}

int Decomposition::owner(const Vec3& x) const {
  if (cells()) return cell_owner[cell_of(x)];
  if (x[axis] >= cuts[rank] && x[axis] < cuts[rank + 1]) return rank;  // most asks, at every rebuild
  // upper_bound: the slab [cuts[r], cuts[r+1]) containing the coordinate
  const auto it = std::upper_bound(cuts.begin() + 1, cuts.end() - 1, x[axis]);
  return static_cast<int>(it - (cuts.begin() + 1));
}

void Decomposition::ranks_near(const Vec3& x, double reach, std::vector<int>& out) const {
  out.clear();
  if (!cells()) {
    const double ya = x[axis];
    if (ya - reach >= cuts[rank] && ya + reach < cuts[rank + 1]) {  // deep inside this slab: most asks
      out.push_back(rank);
      return;
    }
    Vec3 a = x, b = x;
    a[axis] = ya - reach;
    b[axis] = ya + reach;
    for (int r = owner(a); r <= owner(b); ++r)
      if (ya >= cuts[r] - reach && ya < cuts[r + 1] + reach) out.push_back(r);
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
    box_lo[axis] = slab_lo();
    box_hi[axis] = slab_hi();
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
