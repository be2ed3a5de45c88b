#pragma once
// The fluid velocity the drag sees: a steady Stokes solve on the channel's real geometry
// near the neck (|x - neck| < flow.solve_half_length), the rectangular-duct series beyond,
// both stored on one grid of nodes spaced D / flow.resolution and sampled by trilinear
// interpolation. The solve runs once per geometry and resolution and is cached as HDF5 in
// flow.cache (flow_<hash>.h5): a later run with the same geometry reads it in milliseconds.
//
// Accuracy where clogs form (tests/test_channel.cpp, docs/clogging.md): the angled walls are
// seen at their true position by the solve (flow.walls = "embedded") and by the node values
// (ghost values behind them), the nodes take the faces' values to fourth order, so the sampled
// field converges at second order at bead positions in the neck, at the neck's edges and in
// the far field. The edges themselves are re-entrant corners where Stokes flow is singular
// (u ~ r^0.52); their immediate vicinity (closer than a bead radius) converges more slowly.
#include <string>

#include <mpi.h>

#include "core/Config.hpp"
#include "core/Vec3.hpp"
#include "physics/channel/StokesSolver.hpp"

namespace cassini {

// Velocities on a regular grid of nodes, sampled by trilinear interpolation (clamped to the grid).
struct NodeField {
  Vec3 origin;            // position of node (0, 0, 0)
  double inv_dx = 0;
  int n[3] = {0, 0, 0};   // nodes per direction
  std::vector<Vec3> node; // node (i * n[1] + j) * n[2] + k
  Vec3 at(const Vec3& x) const;
};

// The channel's Stokes grid over [x0, x0 + nx dx] and the domain's cross-section: cubic cells of
// dx, fluid by their centres, the angled walls embedded where flow.walls says so, and the duct
// profile at the case's flow rate prescribed at both ends.
StokesGrid channel_stokes_grid(const Config& cfg, double x0, int nx, double dx);

struct FlowReport {
  double solve_seconds = 0;
  int iterations = 0;
  double residual = 0, max_divergence = 0;
  double flux_error = 0;          // max over cross-sections of |Q(x) - Q| / Q
  double far_field_error = 0;     // relative L2 error of u against the series at 4 D upstream
  double centre_over_mean = 0;    // far-field centre-line velocity / mean velocity
  double neck_mean_over_mean = 0; // mean velocity through the neck / far-field mean
  bool from_cache = false;
};

class FlowField {
 public:
  // Loads the cached solve or computes it on rank 0 of comm and caches it (collective).
  FlowField(const Config& cfg, MPI_Comm comm);
  Vec3 velocity(const Vec3& x) const { return nodes_.at(x); }
  const FlowReport& report() const { return report_; }
  std::string cache_file() const { return cache_file_; }
  double spacing() const { return dx_; }

 private:
  double dx_ = 0;
  NodeField nodes_;
  std::string cache_file_;
  FlowReport report_;
};

}  // namespace cassini
