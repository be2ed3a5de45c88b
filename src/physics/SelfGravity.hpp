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
// Long and short range (P3M with a Gaussian split, as Ewald summation splits): the mesh carries
// the pull of Gaussian spheres of width eps (self_gravity.split; default two grid spacings), and
// pairs closer than r_s = 4 sqrt(2) eps add the rest, Newton's law minus the Gaussians',
//   g_short(r) = G m / r^2 (erfc(x) + 2 x exp(-x^2) / sqrt(pi)),  x = r / (eps sqrt 2),
// which is 5e-7 of Newton's at r_s. Together: Newton's law between the particles' centres at
// every distance (exact for non-overlapping spheres: no softening is needed), including
// particles resting on each other in a wake. Why eps = 2 h by default: at eps = h the mesh's CIC
// error on the Gaussian part is 5-10 % of it at 1-3 h, 2-5 % of the total force there, and the
// error is not a gradient: a binary at 1.5 h spirals in while gaining kinetic energy; at 2 h the
// total is within 1 % of Newton's everywhere and binaries keep r and KE to 1e-4
// (tests/test_self_gravity.cpp). The halo is widened to r_s + skin for the pairs; each
// particle's partners within r_s + skin are listed at every rebuild in id order (a Verlet list:
// the rebuild rule covers the halo's range), so its sum is the same on any rank count and after
// a restart, whenever the list was built. Without the short range (self_gravity.short_range =
// false) every particle is a Gaussian of width eps: cheaper, right only on scales well above
// eps. A Gaussian sphere pulls as Newton's law outside a few eps (a flat disc, as 2D-softened
// sheet codes use, would pull ~3 eps^2 / r^2 too hard).
//
// Accuracy of the mesh part: the cloud-in-cell (CIC) windows of assignment and interpolation
// are divided out of every mode. Both use the same weights and the force kernels are odd, so
// the mesh's pair forces are antisymmetric: total momentum is conserved to round-off and there
// is no self-force (Hockney & Eastwood); the Nyquist modes, where a derivative cannot be odd,
// are dropped. Against the Gaussian law its error is ~10 % at r = h, ~4 % at 2-3 h and ~1 %
// beyond 5 h for eps = h, and 4 %, 2-4 %, < 1 % for eps = 2 h (tests/test_self_gravity.cpp);
// with the short range, where the Gaussian's pull is a small part of Newton's, the errors of
// the total are a fraction of these (docs/rings.md).
//
// In parallel every rank deposits its owned particles as integers (units of 2^-40 of the
// heaviest particle's mass), one integer all-reduce sums the grid exactly (order-independent),
// and every rank transforms the same grid with the same FFTW plan: forces are bitwise the same
// on any rank count. The redundant transform is cheap at the grids one rank-pair machine runs
// (docs/rings.md); a distributed FFT is what a large run would need (docs/scaling.md).
//
// Multiple time stepping (self_gravity.every = n): the mesh's smooth field is solved every n
// steps and applied as n times its force (the impulse, r-RESPA form: symplectic). The short
// range is applied every step: it holds the stiff part (touching particles' full pull), and as
// an impulse every n dt it drives a resting pair's contact oscillation, in resonance where n dt
// is a multiple of the oscillation's period 2 t_c (cases/gravity-wakes: 20 steps = 2 t_c pumped
// a resting pair from 1.4e-6 to 6.4e-5 m/s, which the Bridges law leaves undamped).
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/ParticleStore.hpp"

namespace cassini {

struct Decomposition;

class SelfGravity : public Module {
 public:
  // [self_gravity]: a particle-mesh solve on an nx x ny x nz grid (nz = 1 when planar) for
  // the long range, split from the short range (pairs, Newton minus the mesh's part) by a
  // Gaussian of width `split`; solved every `every` steps (impulse multiple time stepping).
  struct Settings {
    std::array<int, 3> grid{0, 0, 0};
    double split = 0;
    bool short_range = true;
    long every = 1;
    // Pairs closer than this get the short-range part (0 without it): 4 sqrt 2 split, where
    // the Gaussian's complement has fallen to 5e-7 of Newton's force.
    double reach() const { return short_range ? 4 * std::sqrt(2.0) * split : 0.0; }
  };
  static ModuleKind kind();
  SelfGravity(const Config& cfg, const Decomposition& domain);
  ~SelfGravity() override;
  SelfGravity(const SelfGravity&) = delete;
  SelfGravity& operator=(const SelfGravity&) = delete;
  std::string name() const override { return "self-gravity"; }
  unsigned stages() const override { return kForce | kRebuild; }
  // A rebuild reorders the particles: the values kept from the last solve no longer apply, and
  // the short range's partners are listed again.
  void pre_rebuild(Simulation&) override { cached_step_ = -1; }
  void post_rebuild(Simulation& sim) override;
  void force(Simulation& sim) override;
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  // 1/2 sum m phi over the owned particles.
  double potential_energy(const Simulation& sim) const override;
  bool image_invariant_potential() const override { return true; }

  // Solves the mesh field of the owned particles of every rank (collective); then field() and
  // potential() give its acceleration and potential at any point of the box (every_layer) or
  // in the layers holding particles and next to them (force()'s solves).
  void solve(const Simulation& sim, bool every_layer = true);
  Vec3 field(const Vec3& x) const;
  double potential(const Vec3& x) const;
  // The short-range acceleration of particle i (owned) from its partners within r_s, owned or
  // ghosts, and (if asked) its short-range potential: from the partners listed at the last rebuild.
  Vec3 short_range(const ParticleStore& p, std::size_t i, double* phi = nullptr) const;

  long solves() const { return solves_; }
  double solve_seconds() const { return solve_seconds_; }

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
  bool planar_, sheared_, short_;
  double reach_;      // r_s
  double list_range_;  // r_s + skin: the partners listed at a rebuild
  double cell_size_;   // of the cells binning them, >= list_range_
  // Each owned particle's partners (owned or ghost, within list_range_ at the last rebuild),
  // in id order: partner_[partner_start_[i] .. partner_start_[i + 1]).
  std::vector<std::uint32_t> partner_start_, partner_;
  void list_partners(const ParticleStore& p);
  // The short-range law against s = r^2 / r_s^2 on a uniform table (linear interpolation: error
  // < 1e-6 of w for r > 0.1 r_s): w = erfc(x) + 2 x exp(-x^2) / sqrt(pi) and erfc(x).
  std::vector<double> w_table_, erfc_table_;
  // The mesh kernels against |k| (uniform in k): [k][layer distance][k phi, a_z].
  std::vector<double> kernel_table_;
  double inv_dk_ = 1;
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
  void* backward_ = nullptr;
  long solves_ = 0;
  double solve_seconds_ = 0, apply_seconds_ = 0;  // mesh solves; interpolation and short range
  double reduced_bytes_ = 0;  // the mesh deposit's all-reduce payload, per rank, since the run started
  // The last force() solve's accelerations (per owned particle) and potential energy, valid
  // until the step ends or a rebuild reorders the particles.
  long cached_step_ = -1;
  std::vector<Vec3> cached_accel_;
  double cached_potential_ = 0;
};

}  // namespace cassini
