#pragma once
// Two-way coupling of beads and fluid (flow.coupling = "two-way"): the fluid feels the beads.
//
// Model (volume-averaged, unresolved CFD-DEM in Stokes-Brinkman form). The fluid unknown is the
// mixture's volume flux U (what the one-way solve computes; div U = 0 because both phases are
// incompressible). A bead i takes F_i = beta_i (U(x_i) - v_i) from the fluid, and the fluid
// loses the same momentum where the bead is:
//   -eta lap U + B U + grad p = S,   B = sum_i beta_i W(x - x_i),   S = sum_i beta_i v_i W(x - x_i),
// with W the phi kernel in the plane (Gaussian of width drag.width, the same deposit as phi:
// VolumeFraction) and linear between the two layers of coupling cells around the bead's centre
// across the height. beta_i = f(phi) K 6 pi eta a / (1 - phi):
// the relative velocity between fluid and bead is (U - v) / (1 - phi), and f is van der Hoef's
// and Beetstra's drag without the mean pressure gradient's share; with the 1 / (1 - phi) a fixed
// bed's pressure drop is Carman-Kozeny's but for Beetstra's own 3-6 % above it at phi = 0.4-0.5
// (tests/test_flow_coupling.cpp).
//
// Numerics. The one-way field U0 is kept as it is (fine grid near the neck, series beyond) and
// the beads' effect is a correction d from a coarser solve over the whole channel (cells of
// D / flow.coupling_resolution; B and S are smooth on the kernel's 100 um): u = s U0 + d with
//   -eta lap d + B d + grad p' = S - s G,   G = sum_i beta_i U0(x_i) W(x - x_i),
// no flow through the ends, s the drive. The explicit forcing uses U0 where each bead is, so a
// bead moving with the flow forces nothing (a coarse U0 under a kernel would not vanish: beads
// ride the centre-line flow); B d, the implicit part, keeps the solve stable however dense the
// pile. The coarse problem is re-solved (numeric refactorisation, the ordering kept; Eigen's
// simplicial Cholesky, so every rank gets the same bits; CG warm-started from the last
// pressures) when the forcing has moved by more than flow.coupling_tolerance of the size of
// B U0 since the last solve, at a snapshot and at a restart.
//
// Drive (flow.drive): "rate" keeps the flow rate Q0 (the pressure behind an arch rises);
// "pressure" keeps the pressure drop of the bead-free channel at Q0, dp0 (the flow falls as the
// neck closes). d is linear in s: two solves with one factorisation (right-hand sides -G and S)
// give s (dp0 + dp_G) + dp_S = dp0 for the pressure drive, and the pressure drop for either.
#include <vector>

#include <mpi.h>

#include "core/Config.hpp"
#include "core/ParticleStore.hpp"
#include "physics/channel/FlowField.hpp"
#include "physics/channel/StokesSolver.hpp"
#include "physics/channel/VolumeFraction.hpp"

namespace cassini {

class FlowCoupling {
 public:
  explicit FlowCoupling(const Config& cfg);
  // Deposits the owned beads' drag coefficients beta_i (kg/s), velocities and the one-way field
  // at their centres (one_way[i] = U0(x_i)) with the phi kernel
  // and re-solves if the forcing moved by more than the tolerance, the flow's sign changed, or
  // `force_solve` (collective). Returns whether it solved.
  bool update(const ParticleStore& p, const std::vector<double>& beta, const std::vector<Vec3>& one_way,
              const VolumeFraction& kernel, double sign, bool force_solve, MPI_Comm comm);
  // The fluid velocity at x, given the one-way field's value there.
  Vec3 velocity(const Vec3& x, const Vec3& one_way) const { return drive_ * one_way + correction_.at(x); }
  double flow_rate() const { return drive_ * q0_; }          // m^3/s
  double pressure_drop() const { return pressure_drop_; }    // Pa, over the channel's length
  double bead_free_pressure_drop() const { return dp0_; }    // Pa, at Q0
  long solves() const { return solves_; }
  long preconditioner_builds() const { return preconditioner_builds_; }  // CG's pressure preconditioner
  int last_iterations() const { return last_iterations_; }                // CG's, in the last solve

 private:
  // A forced solve (set-up, snapshot, restart) starts cold, so that a restarted run repeats it bit
  // for bit; the others start from the last pressures.
  void solve(double sign, bool warm_start);
  bool pressure_drive_;
  double tolerance_, q0_ = 0, dp0_ = 0;
  double drive_ = 1, pressure_drop_ = 0, solved_sign_ = 0;
  long solves_ = 0, preconditioner_builds_ = 0;
  int preconditioner_age_ = 0, iterations_when_fresh_ = -1, last_iterations_ = 0;  // CG's, of the last solves (-1: not yet measured)
  StokesGrid grid_;
  std::unique_ptr<StokesProblem> problem_;
  StokesSolution clean_;                   // the coarse solve without beads, at Q0
  std::vector<double> clean_at_cell_;      // its velocity at the cell centres (3 per cell)
  std::vector<double> units_;              // fixed-point quanta of the deposit's channels
  std::vector<double> values_, field_;     // per bead and layer: beta, beta v, beta U0; the node field
  std::vector<double> column_;             // the node field's channels sampled at one column of cells
  std::vector<double> B_, S_, G_, solved_B_, solved_S_, solved_G_, rhs_;  // per cell (S, G: 3 per cell)
  std::vector<double> pressure_G_, pressure_S_;  // the last solves' pressures: the next ones start there
  NodeField correction_;
};

}  // namespace cassini
