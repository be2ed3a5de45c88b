#pragma once
// Self-gravity of the particles (module "self-gravity"): a particle-mesh (PM) solve on the
// box's own shear-periodic images, O(N + G log G) per solve for N particles on G grid nodes.
//
// The grid. x is periodic and y periodic or Lees-Edwards: an image across y + Ly sits at x + S
// (S the shear offset). In the sheared coordinate x' = x - S (y - lo_y) / Ly the density is
// periodic in x' and y (local ring codes' shearing-sheet transform), so a plain 2D FFT over
// (x', y) serves every image lattice; mode (m, n) has the physical wave vector
//   k = (2 pi m / Lx, 2 pi n / Ly - 2 pi m S / (Lx Ly))
// (S wrapped into [-Lx/2, Lx/2): the least tilted grid). z is isolated (the ring's vertical
// images are not real): each z layer of the grid is a sheet, and per mode the layers are coupled
// exactly by the sheet's Green's function (kernels() in the .cpp): no padding, no vertical
// images, O(N_z^2) per mode. Planar scenes use one layer and only the in-plane force.
//
// Softening: every particle is a Gaussian sphere of width eps (self_gravity.softening; default
// the larger of the smallest radius and the grid spacing). Outside a few eps its pull is
// Newton's exactly (a sphere, not the flat disc a 2D-softened sheet code uses, whose in-plane
// pull exceeds Newton's by ~3 eps^2 / r^2). The cloud-in-cell (CIC) windows of assignment and
// interpolation are divided out of every mode. Both use the same weights and the force kernels
// are odd, so pair forces are antisymmetric: total momentum is conserved to round-off and
// there is no self-force (Hockney & Eastwood); the Nyquist modes, where a derivative cannot be
// odd, are dropped. Measured accuracy (tests/test_self_gravity.cpp, docs/rings.md): with
// eps = h, a few per cent at 2-3 h, ~1 % beyond 5 h.
//
// In parallel every rank deposits its owned particles as integers (units of 2^-40 of the
// heaviest particle's mass), one integer all-reduce sums the grid exactly (order-independent),
// and every rank transforms the same grid with the same FFTW plan: forces are bitwise the same
// on any rank count. The redundant transform is cheap at the grids one rank-pair machine runs
// (docs/rings.md); a distributed FFT is what a large run would need (docs/scaling.md).
//
// Multiple time stepping (self_gravity.every = n): the slowly varying field is solved every
// n steps and applied as n times its force (the impulse, r-RESPA form: symplectic, the kicks
// n dt F at the solve steps).
#include <complex>
#include <cstdint>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"

namespace cassini {

struct Decomposition;

class SelfGravity : public Module {
 public:
  SelfGravity(const Config& cfg, const Decomposition& domain);
  ~SelfGravity() override;
  SelfGravity(const SelfGravity&) = delete;
  SelfGravity& operator=(const SelfGravity&) = delete;
  std::string name() const override { return "self-gravity"; }
  unsigned stages() const override { return kForce; }
  void setup(Simulation& sim) override;
  void force(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  // 1/2 sum m phi over the owned particles, from the last solve's field.
  double potential_energy(const Simulation& sim) const override;

  // Solves the field of the owned particles of every rank (collective); then field() and
  // potential() give acceleration and potential at any point of the box.
  void solve(const Simulation& sim);
  Vec3 field(const Vec3& x) const;
  double potential(const Vec3& x) const;

  long solves() const { return solves_; }
  double solve_seconds() const { return solve_seconds_; }
  long outside() const { return outside_; }  // owned particles found beyond the grid's z range

 private:
  struct Stencil {  // cloud-in-cell: 2 x 2 (x 2) nodes and weights
    std::size_t node[8];
    double w[8];
    int n;
  };
  Stencil stencil(const Vec3& x) const;
  double interpolate(const std::vector<double>& g, const Stencil& s) const;
  void kernels(double k, double d, double& phi, double& az) const;

  int nx_, ny_, nz_;
  bool planar_, sheared_;
  double lx_, ly_, lo_[3], h_[3];
  double eps_;
  long every_;
  double shear_;  // wrapped offset S of the last solve
  std::vector<double> ax_, ay_, az_, phi_;  // fields on the grid (real space)
  std::vector<std::int64_t> mass_;          // deposit in fixed point
  // FFTW buffers and plans (fftw_malloc'ed: the same alignment, hence the same code path, on
  // every rank).
  double* real_ = nullptr;
  std::complex<double>* spec_ = nullptr;   // Sigma_k per layer
  std::complex<double>* out_[4] = {};      // a_x, a_y, a_z, phi per layer
  void* forward_ = nullptr;
  void* backward_[4] = {};
  long solves_ = 0, outside_ = 0;
  double solve_seconds_ = 0;
};

}  // namespace cassini
