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

int Decomposition::owner(double coord) const {
  // upper_bound: the slab [cuts[r], cuts[r+1]) containing coord
  const auto it = std::upper_bound(cuts.begin() + 1, cuts.end() - 1, coord);
  return static_cast<int>(it - (cuts.begin() + 1));
}

}  // namespace cassini
