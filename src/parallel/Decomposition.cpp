#include "parallel/Decomposition.hpp"

#include <algorithm>

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
}

double Decomposition::balance(const std::vector<double>& coord, const std::vector<double>& cost) {
  // A cost histogram along the axis, summed over ranks; cuts at its equal-cost quantiles
  // (linear within a bin). Periodic wrap-around is not exploited: slabs stay ordered.
  const int bins = 64 * nranks;
  const double lo0 = lo[axis], L = length[axis];
  std::vector<double> h(bins, 0.0), g(bins);
  double mine = 0;
  for (std::size_t i = 0; i < coord.size(); ++i) {
    const int b = std::clamp(static_cast<int>((coord[i] - lo0) / L * bins), 0, bins - 1);
    h[b] += cost[i];
    mine += cost[i];
  }
  MPI_Allreduce(h.data(), g.data(), bins, MPI_DOUBLE, MPI_SUM, comm);
  double worst = 0, total = 0;
  MPI_Allreduce(&mine, &worst, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(&mine, &total, 1, MPI_DOUBLE, MPI_SUM, comm);
  if (nranks == 1 || total <= 0) return 1.0;
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
  return worst / (total / nranks);
}

int Decomposition::owner(double coord) const {
  // upper_bound: the slab [cuts[r], cuts[r+1]) containing coord
  const auto it = std::upper_bound(cuts.begin() + 1, cuts.end() - 1, coord);
  return static_cast<int>(it - (cuts.begin() + 1));
}

}  // namespace cassini
