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
#include <functional>
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
  double seconds = 0;
};

StokesSolution solve_stokes(const StokesGrid& g, double tolerance = 1e-10, int max_iterations = 5000);

// Fully developed flow in the cross-section: -lap u = 1 on ny x nz cells with no-slip walls
// (same discretisation as the 3D solve), scaled to the flow rate q. Solid cells: 0.
std::vector<double> duct_profile(int ny, int nz, double dx, const std::vector<char>& fluid_section, double q);

}  // namespace cassini
