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
// the pull of Gaussian spheres of width eps (self_gravity.split; default 2.5 grid spacings), and
// pairs closer than r_s = c sqrt(2) eps (c = self_gravity.cutoff, 4 by default) add the rest,
// Newton's law minus the Gaussians',
//   g_short(r) = G m / r^2 (erfc(x) + 2 x exp(-x^2) / sqrt(pi)),  x = r / (eps sqrt 2),
// which is 5e-7 of Newton's at r_s for c = 4 (4.4e-4 for c = 3). Together: Newton's law
// between the particles' centres at every distance (exact for non-overlapping spheres: no
// softening is needed), including
// particles resting on each other in a wake. Why eps = 2.5 h by default: at eps = h the mesh's
// CIC error on the Gaussian part is 5-10 % of it at 1-3 h, 2-5 % of the total force there, and
// the error is not a gradient: a binary at 1.5 h spirals in while gaining kinetic energy; at 2 h
// the total is within 1 % of Newton's everywhere, but a binary at 3 h, where the mesh carries
// half the pull, still drifts by 2.4e-4 in r and 6.2e-4 in KE over 10 orbits; at 2.5 h binaries
// at 1-3 h keep r and KE to 1e-4 (tests/test_self_gravity.cpp), and the 400 m wakes' Q matches
// REBOUND's, where at 2 h it sat 6 % below (docs/rings.md). The halo is widened to r_s + skin for the pairs; each
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
// In parallel the mesh is distributed (a slab FFT written on FFTW's 1D transforms): rank r owns
// a block of grid rows (y) in real space and a block of mode columns (x wave numbers) in Fourier
// space. A solve:
//   1. each rank deposits its owned particles as integers (units of 2^-40 of the heaviest
//      particle's mass) into a box of the grid covering their stencils (a slab along y: its
//      rows; along x: its columns, widened by the shear), and sends each row of the box to the
//      row's owner, which adds them: integer sums, exact in any order;
//   2. every owned row is transformed along x, the rows are transposed to mode columns
//      (all-to-all), every column is transformed along y, the layers are coupled per mode, and
//      the four fields go back the same way;
//   3. each rank receives the field rows of its box from their owners.
// Memory and transform work per rank fall as 1/P, and nothing is all-reduced but two scalars.
// Why not FFTW's MPI transforms: their arithmetic (the plan's split of the 2D transform) may
// differ with the process count, while here every 1D transform sees the same data through the
// same plan on any rank count, so forces are bitwise the same on 1 or P ranks.
//
// Modified Lees-Edwards boundaries (two copies of the box in the same coordinates: LE1, the main
// box, and LE2, the moonlet-free feed): each copy's mass is deposited on its own mesh and pulls
// its own particles only (two solves a step). LE2 is an ordinary self-gravitating sheared
// patch. LE1 feels its own mass, with its own x images on the mesh; in the pairs, its own
// particles and the LE2 material the halo shows it beyond its inflow faces (the ghosts it
// touches), and nothing beyond its outflow faces, where only the mesh's smooth part of its
// images remains. Both copies there hold the unperturbed ring, far from the moonlet.
//
// Multiple time stepping (self_gravity.every = n): the mesh's smooth field is solved every n
// steps and applied as n times its force (the impulse, r-RESPA form: symplectic). The short
// range is applied every step: it holds the stiff part (touching particles' full pull), and as
// an impulse every n dt it drives a resting pair's contact oscillation, in resonance where n dt
// is a multiple of the oscillation's period 2 t_c (cases/gravity-wakes: 20 steps = 2 t_c pumped
// a resting pair from 1.4e-6 to 6.4e-5 m/s, which the Bridges law leaves undamped).
//
// Under the multi-rate integrator (time.integrator = "multirate", MultiRateHill.hpp) the long
// step takes the place of `every`. At its ends, where every particle is synchronised, the mesh
// is solved and the short range summed for all. The mesh is a slow force for everyone: a kick
// of Delta/2 at each end (r-RESPA, as above with n dt = Delta). A free particle also gets its
// short range as those kicks (its whole gravity is then smooth on the long step: the pull of a
// neighbour changes on the ring's gravitational time ~ 1/sqrt(G rho) ~ 1/Omega, ~150 long steps).
// A particle on contact steps gets its short range every contact step, as under the plain
// scheme, from its partners where they are now: free partners are brought forward on their
// epicycles (MultiRateHill::present_positions). A particle woken mid long step had Delta/2 of
// its short range at the start and is owed `since` of it (as the moonlet's impulse).
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/ParticleStore.hpp"

#include <mpi.h>

namespace cassini {

struct Decomposition;
class MultiRateHill;

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
    // Where the pairs end, in units of sqrt(2) split: the short-range part of a pair's force is
    // w(x) = erfc(x) + 2 x exp(-x^2) / sqrt(pi) of Newton's at x = r / (sqrt(2) split), and the
    // pairs beyond the cut-off are dropped: w = 5.2e-7 at 4 (the default), 2.0e-5 at 3.5,
    // 4.4e-4 at 3. The pairs' number goes as the cut-off squared in a ring (cubed in 3D).
    double cutoff = 4;
    // Pairs closer than this get the short-range part (0 without it).
    double reach() const { return short_range ? cutoff * std::sqrt(2.0) * split : 0.0; }
  };
  static ModuleKind kind();
  SelfGravity(const Config& cfg, const Decomposition& domain);
  ~SelfGravity() override;
  SelfGravity(const SelfGravity&) = delete;
  SelfGravity& operator=(const SelfGravity&) = delete;
  std::string name() const override { return "self-gravity"; }
  void setup(Simulation& sim) override;
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
  // copy: under modified Lees-Edwards boundaries, 0 = LE1 (the main box), 1 = LE2 (the feed).
  Vec3 field(const Vec3& x, int copy = 0) const;
  double potential(const Vec3& x, int copy = 0) const;
  // Grid nodes per layer in this rank's part of the mesh (its box) at the last solve.
  long box_nodes(int copy = 0) const { return box(copy, rank_)[1] * box(copy, rank_)[2]; }
  // The short-range acceleration of particle i (owned) from its partners within r_s, owned or
  // ghosts, and (if asked) its short-range potential: from the partners listed at the last rebuild.
  Vec3 short_range(const ParticleStore& p, std::size_t i, double* phi = nullptr) const {
    return short_range(p, p.x.data(), i, phi);
  }
  // ... with the partners at positions X (indexed as the particles).
  Vec3 short_range(const ParticleStore& p, const Vec3* X, std::size_t i, double* phi = nullptr) const;

  // For the multi-rate integrator. At a long step's boundary (every particle synchronised, the
  // step after the one that ended the last long step): the mesh and short-range accelerations
  // of every owned particle, from the last step's forces or solved now (collective); returns the
  // largest |acceleration| over all ranks (the same on any rank count: a maximum).
  double synchronise(Simulation& sim);
  const Vec3& mesh_acceleration(std::size_t i) const { return cached_mesh_[i]; }
  const Vec3& short_acceleration(std::size_t i) const { return cached_short_[i]; }
  // The short range of an owned particle on contact steps, from this step's force().
  const Vec3& short_acceleration_now(std::size_t i) const { return short_now_[i]; }

  long solves() const { return solves_; }
  double solve_seconds() const { return solve_seconds_; }

 private:
  struct Cell {  // where a point falls: the grid cell (unwrapped) and its CIC weights
    long i, j;
    int k0, k1;
    double wx, wy, wz;
  };
  struct Stencil {  // cloud-in-cell: 2 x 2 (x 2) nodes of this rank's box and weights
    std::size_t node[8];
    double w[8];
    int n;
  };
  Cell locate(const Vec3& x) const;
  Stencil stencil(const Vec3& x, int copy) const;
  int copy_of(const ParticleStore& p, std::size_t i) const { return copies_ > 1 ? p.le_copy[i] : 0; }
  void solve_copy(const ParticleStore& p, bool every_layer, double unit, int zlo, int zhi);
  double interpolate(const std::vector<double>& g, const Stencil& s) const;
  void kernels(double k, double d, double& phi, double& az) const;
  // The box of grid nodes this rank deposits into and interpolates from, per copy (every rank's,
  // after set_box): layers first_..last_ of the solve, box rows r = 0 .. b[1] - 1 holding grid row
  // wrap(b[0] + r), and in box row r the columns b[3 + r] + [0, b[2]) (cyclic), b = box(copy, rank).
  // Each box row has its own first column: on the sheared grid a slab's particles cover a band
  // that shifts along x from row to row, and the particles of the top row reach the bottom row
  // at columns a shear away (a grid row may then appear twice, the box's first and last). A
  // bounding rectangle would reach half the grid.
  void set_box(const ParticleStore& p, bool whole);
  const long* box(int copy, int rank) const { return &boxes_[copy][static_cast<std::size_t>(box_stride_[copy]) * rank]; }
  // The rank that owns grid row g of the real-space mesh; rows owned by `rank`: [row_lo(rank), row_lo(rank + 1)).
  int row_owner(long g) const { return row_owner_[g]; }
  // Rows and mode columns owned by `rank`: [row_lo(rank), row_lo(rank + 1)).
  long row_lo(int rank) const { return static_cast<long>(ny_) * rank / nranks_; }
  long col_lo(int rank) const { return static_cast<long>(nx_ / 2 + 1) * rank / nranks_; }
  // All-to-all of `send` (counts per rank, in doubles) into `recv` (on one rank they trade places);
  // returns the bytes this rank sent to others.
  double exchange(std::vector<double>& send, const std::vector<int>& scount, std::vector<double>& recv,
                  const std::vector<int>& rcount) const;

  int nx_, ny_, nz_;
  bool planar_, sheared_, short_;
  double reach_;      // r_s
  double list_range_;  // r_s + skin: the partners listed at a rebuild
  double cell_size_;   // of the cells binning them, >= list_range_
  // Each owned particle's partners (owned or ghost, within list_range_ at the last rebuild),
  // in id order: partner_[partner_at_[i] .. partner_at_[i] + partner_count_[i]), listed cell
  // by cell. These and the listing's scratch keep their storage from one rebuild to the next:
  // in a dense ring the list is tens of MB, and a fresh one was a mapping whose every page
  // faulted, twice (grown, then copied into particle order), at every rebuild.
  std::vector<std::uint32_t> partner_at_, partner_count_, partner_;
  struct ListScratch {
    std::vector<std::array<long, 3>> key;
    std::vector<std::uint32_t> start, items, fill, by_id, id_rank;
    std::vector<std::uint64_t> candidates;
    std::vector<double> cx, cy, cz, r2;
    std::vector<int> copy;  // the candidates' copies (modified Lees-Edwards boundaries)
  } scratch_;
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
  MPI_Comm comm_;
  int rank_, nranks_;
  int first_ = 0, last_ = -1;            // the layers of the last solve's fields
  int copies_ = 1, copy_ = 0;            // fields solved (2 under modified Lees-Edwards), the one in hand
  std::vector<long> boxes_[2];           // per copy, box_stride_[copy] per rank: first grid row, rows, columns, first column per row
  long box_stride_[2] = {0, 0};          // per copy: the longs per rank in boxes_
  std::vector<int> row_owner_;           // per grid row of the real-space mesh: the rank owning it
  std::vector<double> box_field_[2][4];  // per copy: a_x, a_y, a_z, phi on this rank's box
  std::vector<std::int64_t> box_mass_;   // the deposit on this rank's box
  std::vector<std::int64_t> row_mass_;   // the summed deposit on the owned rows
  std::vector<std::complex<double>> row_spec_;   // [source layer][owned row][m], after the x transforms
  std::vector<std::complex<double>> col_spec_;   // [source layer][owned column][n], the sources' modes
  std::vector<std::complex<double>> col_out_;    // [owned column][potential, a_z][layer][n], coupled
  std::vector<double> send_, recv_;              // all-to-all staging
  double mesh_bytes_ = 0;                        // this rank's mesh buffers at their largest
  double moved_bytes_ = 0;                       // sent to other ranks, since the run started
  // FFTW's 1D plans (FFTW_ESTIMATE: a function of the sizes only, the same on every rank and
  // run), made on and run only on fft_'s aligned scratch: r2c / c2r along x, c2c along y.
  struct FftScratch {
    double* real = nullptr;       // one row, real (nx)
    double (*spec)[2] = nullptr;  // one row, its modes (nx / 2 + 1)
    double (*col_in)[2] = nullptr, (*col_out)[2] = nullptr;  // one column (ny)
  } fft_;
  void* row_forward_ = nullptr;
  void* row_backward_ = nullptr;
  void* col_forward_ = nullptr;
  void* col_backward_ = nullptr;
  long solves_ = 0;
  double solve_seconds_ = 0, apply_seconds_ = 0;  // mesh solves; interpolation and short range
  // The last force() solve's accelerations (per owned particle: mesh and short range) and
  // potential energy, valid until the step ends or a rebuild reorders the particles.
  long cached_step_ = -1;
  std::vector<Vec3> cached_mesh_, cached_short_;
  double cached_potential_ = 0;
  // Under the multi-rate integrator: its present positions, and the short range of this step's targets.
  MultiRateHill* multirate_ = nullptr;
  std::vector<Vec3> short_now_;
  // Positions now of the particles the targets' pairs need, valid where stamped with the step.
  std::vector<Vec3> present_;
  std::vector<long> present_step_;
  double synced_potential_ = 0;  // at the last long step's end (solve_all), kept through rebuilds
  bool synced_ = false;
  void force_multirate(Simulation& sim);
  void solve_all(Simulation& sim, long step, bool add_short_to_forces);  // mesh + short for every owned particle, cached
  void report(Simulation& sim) const;  // summary.json's "self_gravity"
};

}  // namespace cassini
