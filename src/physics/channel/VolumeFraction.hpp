#pragma once
// The local solid volume fraction phi that the drag's voidage function needs, coarse-grained
// over the channel (spec section 3: Gaussian, width 100 um). The channel is one particle
// high, so phi is depth-averaged: a 2D field over (x, y) on nodes spaced width/4 inside the
// fluid. Each particle spreads its volume over the fluid nodes within 3 widths with Gaussian
// weights normalised to 1 on those nodes (so walls do not swallow volume and the field
// integrates to the particles' volume exactly); a particle's own phi is the field at its
// centre, interpolated bilinearly from the surrounding fluid nodes. Node sums are accumulated in 64-bit fixed point across ranks: integer sums do
// not depend on the order, so phi is bitwise the same on any number of ranks.
#include <cstdint>
#include <vector>

#include <mpi.h>

#include "core/ParticleStore.hpp"
#include "physics/channel/ChannelGeometry.hpp"

namespace cassini {

class VolumeFraction {
 public:
  VolumeFraction(const ChannelGeometry& geo, double x0, double x1, double y0, double y1, double height, double width);
  // Recomputes the node field from the owned particles of every rank (collective).
  void update(const ParticleStore& p, MPI_Comm comm);
  // phi seen by a particle at (x, y): the node field interpolated bilinearly over fluid nodes.
  double at(double x, double y) const;
  // The part of at(x, y) that a particle of this volume centred at (x, y) deposits itself: the
  // same kernel, normalisation and interpolation, so at() - own() is phi without the bead.
  double own(double x, double y, double volume) const;
  double node_spacing() const { return h_; }
  // Sum of phi * node area * height over the nodes: the particles' total volume.
  double integral() const;

  // The same kernel for other per-particle quantities (the two-way coupled drag): `channels`
  // values per owned particle (values[i * channels + c]) spread as densities per unit volume
  // (depth-averaged like phi) into out[node * channels + c], summed over ranks in fixed point
  // with quantum unit[c] * 2^-50 (values up to ~1e3 unit per node), so bitwise the same on any
  // number of ranks (collective).
  void deposit(const ParticleStore& p, const std::vector<double>& values, const std::vector<double>& unit,
               std::vector<double>& out, MPI_Comm comm) const;
  // Every channel of such a field at (x, y) into out[0 .. channels): bilinear over the
  // surrounding fluid nodes, as at().
  void sample(const std::vector<double>& field, int channels, double x, double y, double* out) const;

 private:
  template <class F> void for_nodes(double x, double y, F&& f) const;  // f(node, normalised weight)
  const ChannelGeometry& geo_;
  double x0_, y0_, h_, height_, width_;
  int nx_, ny_, reach_;
  std::vector<char> fluid_;
  std::vector<double> phi_;
  std::vector<std::int64_t> sum_, total_;
  mutable std::vector<std::pair<int, double>> scratch_;
  mutable std::vector<double> wx_, wy_;  // the kernel's x and y factors around one particle
  mutable std::vector<std::int64_t> deposit_sum_, deposit_total_;
};

}  // namespace cassini
