#pragma once
// Steady incompressible Stokes flow, -eta lap u + grad p = 0, div u = 0, on a box of cubic
// cells (marker-and-cell grid: pressure at cell centres, each velocity component on the
// faces normal to it). Cells are fluid or solid; no-slip on solid cells and on the box's
// y and z faces; at the x faces the inflow and outflow velocity is prescribed (the same
// profile at both ends, so the flow rate balances exactly).
//
// Side walls that cut through cells (fluid_at set): cells are still fluid or solid by their
// centre, but each velocity unknown next to a wall sees it at its true distance theta dx along
// x or y, not on the staircase of cell faces: the wall term of the Laplacian becomes
// u / (theta dx^2) (the symmetric embedded-boundary discretisation of Gibou et al., J. Comput.
// Phys. 176, 2002: O(1) local truncation error in that one row, second-order solution), so A
// stays symmetric positive definite. Faces whose centre lies in a wall are held at zero.
//
// Solution: the pressure Schur complement S = D A^-1 D^T is solved by conjugate gradients,
// with the three velocity Laplacians A factorised once (sparse Cholesky). S is well
// conditioned on MAC grids (its condition number does not grow with resolution), so CG
// needs tens of iterations; each costs six triangular solves.
//
// Stokes-Brinkman: StokesProblem adds a drag coefficient per cell, -eta lap u + B u + grad p = f
// (the momentum the particles of a two-way coupled suspension take from the fluid, B u - f,
// FlowCoupling.hpp). B only adds to the diagonal of A, which stays symmetric positive definite
// with the same sparsity: a new B costs a numeric refactorisation, the ordering is kept.
#include <functional>
#include <memory>
#include <vector>

namespace cassini {

struct StokesGrid {
  int nx = 0, ny = 0, nz = 0;
  double dx = 0;               // cubic cells
  std::vector<char> fluid;     // nx*ny*nz, index (i*ny + j)*nz + k
  std::vector<double> inflow;  // ny*nz: u on the x faces at both ends (0 where solid)
  double viscosity = 1;
  // Optional: is the point (X, Y), in cell units from the box's low corner, fluid? (Walls
  // extruded over z; the box's own faces stay walls.) Empty: the staircase of cells is the wall.
  std::function<bool(double, double)> fluid_at;
};

struct StokesSolution {
  // Face velocities: u (nx+1, ny, nz), v (nx, ny+1, nz), w (nx, ny, nz+1), row-major.
  std::vector<double> u, v, w;
  std::vector<double> p;  // nx*ny*nz, zero in solid cells
  int iterations = 0;
  double residual = 0;        // relative, of the Schur system
  double max_divergence = 0;  // max |div u| dx / (inflow scale) over fluid cells
  double pressure_drop = 0;   // mean p of the first layer of cells minus that of the last
  double seconds = 0;
};

StokesSolution solve_stokes(const StokesGrid& g, double tolerance = 1e-10, int max_iterations = 5000);

// One grid's operator, built once and solved for many Brinkman fields and forces.
class StokesProblem {
 public:
  // repeatable: factorise with Eigen's simplicial Cholesky (no threaded BLAS), so every rank that
  // solves the same problem gets the same bits; otherwise CHOLMOD's supernodal one (faster).
  explicit StokesProblem(const StokesGrid& g, bool repeatable = false);
  ~StokesProblem();
  // B per cell (nx*ny*nz, kg m^-3 s^-1; a face takes the mean of its two cells); empty: none.
  // refresh_preconditioner = false keeps CG's pressure preconditioner from an earlier B (still
  // symmetric positive definite, so CG converges to the same answer, in a few more iterations
  // while B has moved little) and saves its assembly and factorisation; the velocity blocks are
  // always refactorised (the Schur complement needs them exact).
  void set_brinkman(const std::vector<double>& per_cell, bool refresh_preconditioner = true);
  // The inflow profile scaled by inflow_scale, and a body force per cell (3 per cell, N m^-3;
  // null: none). The solution is linear in both. pressure_guess (a StokesSolution::p) starts the
  // iteration; the tolerance stays relative to a cold start's residual.
  StokesSolution solve(double inflow_scale, const std::vector<double>* force, double tolerance = 1e-10,
                       int max_iterations = 5000, const std::vector<double>* pressure_guess = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_;
};

// Fully developed flow in the cross-section: -lap u = 1 on ny x nz cells with no-slip walls
// (same discretisation as the 3D solve), scaled to the flow rate q. Solid cells: 0.
std::vector<double> duct_profile(int ny, int nz, double dx, const std::vector<char>& fluid_section, double q);

}  // namespace cassini
