#include "physics/ring/SelfGravity.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>

#include <fftw3.h>
#include <unistd.h>
#include <mpi.h>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/ring/MultiRateHill.hpp"

namespace cassini {

namespace {
constexpr double kPi = 3.141592653589793;
constexpr int kTable = 1 << 14;  // entries of the short-range tables
constexpr int kTableK = 1 << 14;  // entries of the mesh kernels' tables in k
std::size_t wrap(long i, int n) { return static_cast<std::size_t>(((i % n) + n) % n); }
double sinc2(double x) {
  const double s = x == 0 ? 1.0 : std::sin(x) / x;
  return s * s;
}
// exp(s) erfc(x) without overflow or underflow of the factors: for x > 0 as exp(s - x^2) erfcx(x).
double exp_erfc(double s, double x) {
  if (x <= 0) return std::exp(s) * std::erfc(x);
  const double erfcx = x < 25 ? std::exp(x * x) * std::erfc(x)
                              : 1 / (x * std::sqrt(kPi)) * (1 - 0.5 / (x * x) + 0.75 / (x * x * x * x));
  return std::exp(s - x * x) * erfcx;
}
}  // namespace

// Mode k of the potential and of a_z at height d above a layer of unit surface density made of
// Gaussian spheres of width eps (the in-plane Gaussian is exp(-k^2 eps^2 / 2); convolving the
// sheet's exp(-k |d|) with the vertical Gaussian gives the erfc terms):
//   phi = -2 pi G / k * (e^{-kd} erfc(A) + e^{kd} erfc(B)) / 2,   a_z = pi G (e^{kd} erfc(B) - e^{-kd} erfc(A)),
//   A = (k eps^2 - d) / (eps sqrt 2), B = (k eps^2 + d) / (eps sqrt 2);
// at k = 0 the sheet's phi = 2 pi G E|d - s| and a_z = -2 pi G erf(d / (eps sqrt 2)). Planar
// scenes take d = 0: phi = -2 pi G erfc(k eps / sqrt 2) / k.
void SelfGravity::kernels(double k, double d, double& phi, double& az) const {
  const double two_pi_g = 2 * kPi * kGravitationalConstant, e2 = eps_ * std::sqrt(2.0);
  if (k == 0) {
    phi = two_pi_g * (d * std::erf(d / e2) + eps_ * std::sqrt(2 / kPi) * std::exp(-d * d / (e2 * e2)));
    az = -two_pi_g * std::erf(d / e2);
    return;
  }
  const double A = (k * eps_ * eps_ - d) / e2, B = (k * eps_ * eps_ + d) / e2;
  const double down = exp_erfc(-k * d, A), up = exp_erfc(k * d, B);
  phi = -two_pi_g / k * 0.5 * (down + up);
  az = 0.5 * two_pi_g * (up - down);
}

ModuleKind SelfGravity::kind() {
  auto read = [](CaseFile& f, Config& c) {
    const std::string g = "self_gravity.";
    if (c.boundary[0] != Boundary::Periodic || !c.periodic_like(1))
      f.fail("domain.boundary", "x \"periodic\" and y \"periodic\" or \"lees_edwards\" with module \"self-gravity\" (its mesh solve is periodic in the plane)");
    if (!c.planar && c.periodic_like(2))
      f.fail("domain.boundary", "z \"open\" or \"wall\" with module \"self-gravity\" (gravity is isolated in z: a ring has no vertical images)");
    Settings s;
    const std::vector<double> grid = f.numbers(g + "grid");
    if (grid.size() != 3) f.fail(g + "grid", "[nx, ny, nz]: grid nodes along x, y and z");
    for (int d = 0; d < 3; ++d) {
      const double n = grid[d];
      const bool in_plane = d < 2;
      if (n != std::floor(n) || n < 1 || n > 4096 || (in_plane && (n < 4 || std::fmod(n, 2.0) != 0)))
        f.fail(g + "grid", in_plane ? "even node counts 4..4096 along x and y" : "a node count 1..4096 along z");
      s.grid[d] = static_cast<int>(n);
    }
    if (c.planar && s.grid[2] != 1) f.fail(g + "grid", "nz = 1 in a planar scene");
    {  // every rank holds the whole mesh: 6 real fields and 5 half spectra, ~88 bytes a node
      const double need = 88.0 * grid[0] * grid[1] * grid[2];
      const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
      if (need > 0.8 * ram) {
        std::ostringstream os;
        os << "a mesh that fits in memory: " << grid[0] << " x " << grid[1] << " x " << grid[2] << " nodes need about "
           << need / 1e9 << " GB on every rank, more than this machine's " << ram / 1e9 << " GB";
        f.fail(g + "grid", os.str());
      }
    }
    const double spacing = std::max((c.hi[0] - c.lo[0]) / grid[0], (c.hi[1] - c.lo[1]) / grid[1]);
    s.split = f.number(g + "split", 2.5 * spacing);  // binaries at 1-3 h held to 1e-4 (SelfGravity.hpp)
    if (!(s.split > 0)) f.fail(g + "split", "a length > 0 (m): the width of the Gaussian splitting mesh and pairs");
    s.short_range = f.boolean(g + "short_range", true);
    s.cutoff = f.number(g + "cutoff", 4.0);
    if (!(s.cutoff >= 2 && s.cutoff <= 6))
      f.fail(g + "cutoff", "a number in [2, 6]: where the pairs end, in units of sqrt(2) split (4: the pairs' short-range "
                           "part has fallen to 5e-7 of Newton's force there; 3: 4e-4)");
    s.every = f.integer(g + "every", 1);
    if (s.every < 1) f.fail(g + "every", "an integer >= 1 (steps between solves)");
    c.set(s);
    c.halo_reach = s.reach();
  };
  return {"self-gravity", {}, read, [](Simulation& sim) { return std::make_unique<SelfGravity>(sim.cfg, sim.domain); }};
}

SelfGravity::SelfGravity(const Config& cfg, const Decomposition& domain)
    : nx_(cfg.get<Settings>().grid[0]),
      ny_(cfg.get<Settings>().grid[1]),
      nz_(cfg.planar ? 1 : cfg.get<Settings>().grid[2]),
      planar_(cfg.planar),
      sheared_(domain.shear.enabled),
      short_(cfg.get<Settings>().short_range),
      reach_(cfg.get<Settings>().reach()),
      list_range_(reach_ + cfg.skin),
      // at least the list's range, and at most ~500 cells across the largest box side (with its halo)
      cell_size_(std::max(list_range_, (domain.length.maxCoeff() + 2 * cfg.halo_range()) / 500)),
      lx_(domain.length[0]),
      ly_(domain.length[1]),
      eps_(cfg.get<Settings>().split),
      every_(cfg.get<Settings>().every),
      shear_(0) {
  for (int d = 0; d < 3; ++d) lo_[d] = domain.lo[d];
  if (short_) {
    const int n = kTable;
    w_table_.resize(n + 2);
    erfc_table_.resize(n + 2);
    for (int k = 0; k <= n + 1; ++k) {
      const double x = reach_ * std::sqrt(static_cast<double>(k) / n) / (eps_ * std::sqrt(2.0));
      erfc_table_[k] = std::erfc(x);
      w_table_[k] = std::erfc(x) + 2 / std::sqrt(kPi) * x * std::exp(-x * x);
    }
  }
  h_[0] = lx_ / nx_;
  h_[1] = ly_ / ny_;
  h_[2] = domain.length[2] / nz_;
  // The mesh kernels per layer distance as functions of |k| up to the largest |k| any shear
  // offset gives (|S| <= Lx/2), tabulated once: the solve then costs no erfc. k phi (finite at
  // k -> 0) and a_z are smooth on the scale 1/(d + eps) >> the spacing; linear interpolation
  // errs by < 1e-6 of their k -> 0 scale 2 pi G within 25 m of a layer, 1.5e-5 at 100 m (16,384
  // entries up to |k| = 1.8 / m, the wakes scene's mesh; checked against the closed form).
  {
    const double kx = kPi / h_[0], ky = kPi / h_[1] + kx * 0.5 * lx_ / ly_;
    const double kmax = std::hypot(kx, ky) * 1.001;
    inv_dk_ = kTableK / kmax;
    kernel_table_.resize(static_cast<std::size_t>(kTableK + 2) * nz_ * 2);
    for (int i = 0; i <= kTableK + 1; ++i)
      for (int d = 0; d < nz_; ++d) {
        const double k = i / inv_dk_;
        double phi = 0, az = 0;
        if (i == 0) {  // the k -> 0 limits: k phi -> -2 pi G, a_z -> -2 pi G erf(d / (eps sqrt 2))
          phi = -2 * kPi * kGravitationalConstant;
          az = -2 * kPi * kGravitationalConstant * std::erf(d * h_[2] / (eps_ * std::sqrt(2.0)));
        } else {
          kernels(k, d * h_[2], phi, az);
          phi *= k;
        }
        kernel_table_[(static_cast<std::size_t>(i) * nz_ + d) * 2] = phi;
        kernel_table_[(static_cast<std::size_t>(i) * nz_ + d) * 2 + 1] = az;
      }
  }
  comm_ = domain.comm;
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &nranks_);
  copies_ = domain.fed_x ? 2 : 1;
  // Every 1D transform runs on these aligned scratch arrays, through plans made on them: one
  // code path (FFTW's SIMD codelets, which need aligned arrays: 2-3x faster than the unaligned
  // scalar ones) for every row and column, the same on any rank count and run.
  const int mx = nx_ / 2 + 1;
  fft_.real = fftw_alloc_real(nx_);
  fft_.spec = fftw_alloc_complex(mx);
  fft_.col_in = fftw_alloc_complex(ny_);
  fft_.col_out = fftw_alloc_complex(ny_);
  const unsigned flags = FFTW_ESTIMATE;
  row_forward_ = fftw_plan_dft_r2c_1d(nx_, fft_.real, fft_.spec, flags);
  row_backward_ = fftw_plan_dft_c2r_1d(nx_, fft_.spec, fft_.real, flags);  // overwrites spec: scratch
  col_forward_ = fftw_plan_dft_1d(ny_, fft_.col_in, fft_.col_out, FFTW_FORWARD, flags);
  col_backward_ = fftw_plan_dft_1d(ny_, fft_.col_in, fft_.col_out, FFTW_BACKWARD, flags);
}

SelfGravity::~SelfGravity() {
  for (void* plan : {row_forward_, row_backward_, col_forward_, col_backward_}) fftw_destroy_plan(static_cast<fftw_plan>(plan));
  for (void* a : {static_cast<void*>(fft_.real), static_cast<void*>(fft_.spec), static_cast<void*>(fft_.col_in),
                  static_cast<void*>(fft_.col_out)})
    fftw_free(a);
}

SelfGravity::Cell SelfGravity::locate(const Vec3& x) const {
  Cell c{};
  const double xs = sheared_ ? x[0] - shear_ * (x[1] - lo_[1]) / ly_ : x[0];
  const double u = (xs - lo_[0]) / h_[0], v = (x[1] - lo_[1]) / h_[1];
  const double fu = std::floor(u), fv = std::floor(v);
  c.i = static_cast<long>(fu);
  c.j = static_cast<long>(fv);
  c.wx = u - fu;
  c.wy = v - fv;
  if (!planar_) {  // layer centres at lo_z + (k + 1/2) h_z; beyond the outer centres, the outer layer
    const double t = (x[2] - lo_[2]) / h_[2] - 0.5;
    if (t <= 0) {
      c.k0 = c.k1 = 0;
    } else if (t >= nz_ - 1) {
      c.k0 = c.k1 = nz_ - 1;
    } else {
      c.k0 = static_cast<int>(t);
      c.k1 = c.k0 + 1;
      c.wz = t - static_cast<double>(c.k0);
    }
  }
  return c;
}

SelfGravity::Stencil SelfGravity::stencil(const Vec3& x, int copy) const {
  const Cell c = locate(x);
  const long* b = box(copy, rank_);
  const std::size_t rows = b[1], cols = b[2];
  const std::size_t j0 = static_cast<std::size_t>(c.j - b[0]), j1 = j0 + 1;  // box rows
  const std::size_t i0s[2] = {wrap(c.i - b[3 + j0], nx_), wrap(c.i - b[3 + j1], nx_)};
  const std::size_t i1s[2] = {wrap(c.i + 1 - b[3 + j0], nx_), wrap(c.i + 1 - b[3 + j1], nx_)};
  const std::size_t ks[2] = {static_cast<std::size_t>(c.k0 - first_), static_cast<std::size_t>(c.k1 - first_)};
  const double wzs[2] = {1 - c.wz, c.wz};
  Stencil s{};
  for (int l = 0; l < (planar_ ? 1 : 2); ++l)
    for (int bj = 0; bj < 2; ++bj)
      for (int a = 0; a < 2; ++a) {
        s.node[s.n] = (ks[l] * rows + (bj ? j1 : j0)) * cols + (a ? i1s[bj] : i0s[bj]);
        s.w[s.n] = (a ? c.wx : 1 - c.wx) * (bj ? c.wy : 1 - c.wy) * wzs[l];
        ++s.n;
      }
  return s;
}

double SelfGravity::interpolate(const std::vector<double>& g, const Stencil& s) const {
  double r = 0;
  for (int q = 0; q < s.n; ++q) r += s.w[q] * g[s.node[q]];
  return r;
}

Vec3 SelfGravity::field(const Vec3& x, int copy) const {
  const Stencil s = stencil(x, copy);
  const auto& f = box_field_[copy];
  return Vec3(interpolate(f[0], s), interpolate(f[1], s), planar_ ? 0.0 : interpolate(f[2], s));
}

double SelfGravity::potential(const Vec3& x, int copy) const { return interpolate(box_field_[copy][3], stencil(x, copy)); }

// This rank's box for copy_: the grid rows its owned particles' stencils touch, counted from
// the lowest without wrapping (with `whole` every row and one beyond), and in each the cyclic
// run of columns they touch; the box is as wide as its widest row (the whole grid when a run
// goes all around, or with `whole`). Gathered from every rank.
void SelfGravity::set_box(const ParticleStore& p, bool whole) {
  if (row_owner_.empty()) {
    row_owner_.resize(ny_);
    for (int q = 0; q < nranks_; ++q)
      for (long g = row_lo(q); g < row_lo(q + 1); ++g) row_owner_[g] = q;
  }
  long lo = 0, hi = whole ? ny_ : -1;
  bool any = whole;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (copy_of(p, i) != copy_) continue;
    const long j = locate(p.x[i]).j;
    lo = any ? std::min(lo, j) : j;
    hi = any ? std::max(hi, j + 1) : j + 1;
    any = true;
  }
  const long rows = any ? hi - lo + 1 : 0;
  std::vector<char> touched(static_cast<std::size_t>(rows) * nx_, 0);  // per box row and column
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (copy_of(p, i) != copy_) continue;
    const Cell c = locate(p.x[i]);
    for (long r = c.j - lo; r <= c.j + 1 - lo; ++r)
      for (long col = c.i; col <= c.i + 1; ++col) touched[r * nx_ + wrap(col, nx_)] = 1;
  }
  // Per row, the shortest cyclic run holding every touched column: all but the longest gap.
  std::vector<long> start(rows, 0);
  long cols = any ? 1 : 0;
  for (long r = 0; r < rows; ++r) {
    const char* t = &touched[r * nx_];
    long gap = 0, best = 0, best_end = 0;
    for (long c = 0; c < 2 * nx_; ++c) {
      gap = t[c % nx_] ? 0 : gap + 1;
      if (gap > best) {
        best = std::min(gap, static_cast<long>(nx_));
        best_end = c + 1;
      }
    }
    if (best == nx_) continue;  // nothing touched in this row
    start[r] = best_end % nx_;
    cols = std::max(cols, nx_ - best);
  }
  const bool all_columns = whole || cols >= nx_;
  long stride = 3 + rows;
  MPI_Allreduce(MPI_IN_PLACE, &stride, 1, MPI_LONG, MPI_MAX, comm_);
  box_stride_[copy_] = stride;
  std::vector<long> mine(stride, 0);
  mine[0] = lo;
  mine[1] = rows;
  mine[2] = all_columns ? nx_ : cols;
  for (long r = 0; r < rows; ++r) mine[3 + r] = all_columns ? 0 : start[r];
  boxes_[copy_].resize(static_cast<std::size_t>(stride) * nranks_);
  MPI_Allgather(mine.data(), static_cast<int>(stride), MPI_LONG, boxes_[copy_].data(), static_cast<int>(stride), MPI_LONG,
                comm_);
}

namespace {
// Sizes a mesh buffer to n (filled with `value` if given), growing its storage by a quarter more
// than asked: the layers a ring's particles span grow a little at a time, and each exact-size
// reallocation of these megabyte buffers is a fresh mapping whose every page faults (main.cpp).
template <class T>
void fit(std::vector<T>& v, std::size_t n) {
  if (n > v.capacity()) v.reserve(n + n / 4);
  v.resize(n);
}
template <class T>
void fit(std::vector<T>& v, std::size_t n, T value) {
  if (n > v.capacity()) v.reserve(n + n / 4);
  v.assign(n, value);
}
template <class T>
void append(std::vector<T>& v, const T* from, long n) {
  v.insert(v.end(), from, from + n);
}
}  // namespace

namespace {
// Eight doubles as one value (GCC's vector extension): the layer coupling's sums in registers.
typedef double Lanes __attribute__((vector_size(64)));
inline Lanes load_lanes(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store_lanes(const Lanes& v, double* p) { std::memcpy(p, &v, sizeof v); }
}  // namespace

double SelfGravity::exchange(std::vector<double>& send, const std::vector<int>& scount, std::vector<double>& recv,
                             const std::vector<int>& rcount) const {
  if (nranks_ == 1) {  // what is sent is what is received: no copy
    recv.swap(send);
    return 0;
  }
  std::vector<int> sdispl(nranks_, 0), rdispl(nranks_, 0);
  for (int q = 1; q < nranks_; ++q) {
    sdispl[q] = sdispl[q - 1] + scount[q - 1];
    rdispl[q] = rdispl[q - 1] + rcount[q - 1];
  }
  fit(recv, static_cast<std::size_t>(rdispl.back()) + rcount.back());
  MPI_Alltoallv(send.data(), scount.data(), sdispl.data(), MPI_DOUBLE, recv.data(), rcount.data(), rdispl.data(),
                MPI_DOUBLE, comm_);
  double sent = 0;
  for (int q = 0; q < nranks_; ++q)
    if (q != rank_) sent += scount[q];
  return sent * sizeof(double);
}

void SelfGravity::solve(const Simulation& sim, bool every_layer) {
  const auto start = std::chrono::steady_clock::now();
  const ParticleStore& p = sim.particles;
  // The least tilted of the equivalent sheared grids: S in [-Lx/2, Lx/2).
  if (sheared_) {
    shear_ = sim.domain.shear.wrapped(lx_);
    if (shear_ >= 0.5 * lx_) shear_ -= lx_;
  }
  // Deposit in fixed point: the sums are exact, so independent of the rank count.
  double heaviest = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) heaviest = std::max(heaviest, p.mass[i]);
  // The layers the particles touch (a ring fills a few): only those are deposited and
  // transformed, and the fields computed there and one layer beyond (every layer if asked).
  int span[2] = {nz_, nz_};  // min layer, -max layer
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Cell c = locate(p.x[i]);
    span[0] = std::min(span[0], c.k0);
    span[1] = std::min(span[1], -c.k1);
  }
  {
    double h[3] = {heaviest, static_cast<double>(-span[0]), static_cast<double>(-span[1])};  // mass, -min, max layer
    MPI_Allreduce(MPI_IN_PLACE, h, 3, MPI_DOUBLE, MPI_MAX, comm_);
    heaviest = h[0];
    span[0] = static_cast<int>(-h[1]);
    span[1] = static_cast<int>(-h[2]);
  }
  const double unit = heaviest > 0 ? std::ldexp(heaviest, -40) : 1.0;
  const int zlo = std::min(span[0], nz_ - 1), zhi = std::min(nz_ - 1, std::max(-span[1], zlo));
  first_ = every_layer ? 0 : std::max(0, zlo - 1);
  last_ = every_layer ? nz_ - 1 : std::min(nz_ - 1, zhi + 1);
  for (copy_ = 0; copy_ < copies_; ++copy_) solve_copy(p, every_layer, unit, zlo, zhi);
  double bytes = 0;
  for (const auto& c : box_field_)
    for (const auto& v : c) bytes += v.capacity() * sizeof(double);
  bytes += (box_mass_.capacity() + row_mass_.capacity()) * sizeof(std::int64_t) + 
           (row_spec_.capacity() + col_spec_.capacity() + col_out_.capacity()) * sizeof(std::complex<double>) +
           (send_.capacity() + recv_.capacity()) * sizeof(double);
  mesh_bytes_ = std::max(mesh_bytes_, bytes);
  ++solves_;
  solve_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One copy's field (copy_: all particles, or under modified Lees-Edwards boundaries those of
// LE1 or LE2) on the layers first_..last_.
void SelfGravity::solve_copy(const ParticleStore& p, bool every_layer, double unit, int zlo, int zhi) {
  const int L = last_ - first_ + 1;
  set_box(p, every_layer);
  const long* mine = box(copy_, rank_);
  const std::size_t rows = mine[1], cols = mine[2];
  // Box row r of rank q holds grid row grid_row(q, r) (owned by row_owner() of it) from column box(q)[3 + r] on.
  auto grid_row = [&](int q, long r) { return static_cast<long>(wrap(box(copy_, q)[0] + r, ny_)); };

  // 1. Deposit on the box, then to the rows' owners (as doubles: integers below 2^53 are exact).
  fit(box_mass_, static_cast<std::size_t>(L) * rows * cols, std::int64_t{0});
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (copy_of(p, i) != copy_) continue;
    const Stencil s = stencil(p.x[i], copy_);
    for (int q = 0; q < s.n; ++q) box_mass_[s.node[q]] += std::llround(p.mass[i] * s.w[q] / unit);
  }
  const long r0 = row_lo(rank_), r1 = row_lo(rank_ + 1), my_rows = r1 - r0;
  std::vector<int> scount(nranks_, 0), rcount(nranks_, 0);
  send_.clear();
  for (int q = 0; q < nranks_; ++q) {
    const std::size_t before = send_.size();
    for (int b = zlo; b <= zhi; ++b)
      for (std::size_t r = 0; r < rows; ++r)
        if (row_owner(grid_row(rank_, r)) == q) {
          const std::int64_t* row = &box_mass_[((b - first_) * rows + r) * cols];
          for (std::size_t c = 0; c < cols; ++c) send_.push_back(static_cast<double>(row[c]));
        }
    scount[q] = static_cast<int>(send_.size() - before);
    long n = 0;
    for (long r = 0; r < box(copy_, q)[1]; ++r) n += row_owner(grid_row(q, r)) == rank_ ? box(copy_, q)[2] : 0;
    rcount[q] = static_cast<int>(n * (zhi - zlo + 1));
  }
  moved_bytes_ += exchange(send_, scount, recv_, rcount);
  const int Ld = zhi - zlo + 1;
  fit(row_mass_, static_cast<std::size_t>(Ld) * my_rows * nx_, std::int64_t{0});
  {
    std::size_t at = 0;
    for (int q = 0; q < nranks_; ++q)
      for (int b = zlo; b <= zhi; ++b)
        for (long r = 0; r < box(copy_, q)[1]; ++r)
          if (row_owner(grid_row(q, r)) == rank_) {
            std::int64_t* row = &row_mass_[((b - zlo) * my_rows + (grid_row(q, r) - r0)) * nx_];
            for (long c = 0, i = box(copy_, q)[3 + r]; c < box(copy_, q)[2]; ++c, i = i + 1 == nx_ ? 0 : i + 1)
              row[i] += static_cast<std::int64_t>(recv_[at++]);
          }
  }
  // The source layers: those holding mass anywhere.
  std::vector<int> has(Ld, 0);
  for (int b = 0; b < Ld; ++b)
    has[b] = std::any_of(row_mass_.begin() + static_cast<std::size_t>(b) * my_rows * nx_,
                         row_mass_.begin() + static_cast<std::size_t>(b + 1) * my_rows * nx_, [](std::int64_t q) { return q != 0; });
  MPI_Allreduce(MPI_IN_PLACE, has.data(), Ld, MPI_INT, MPI_MAX, comm_);
  std::vector<int> sources;
  for (int b = 0; b < Ld; ++b)
    if (has[b]) sources.push_back(zlo + b);
  const int S = static_cast<int>(sources.size());

  // 2. Rows along x, transposed to mode columns, columns along y.
  const int mx = nx_ / 2 + 1;
  const long c0 = col_lo(rank_), c1 = col_lo(rank_ + 1), my_cols = c1 - c0;
  const double to_sigma = unit / (h_[0] * h_[1]);  // each layer a sheet of surface density
  fit(row_spec_, static_cast<std::size_t>(S) * my_rows * mx);
  for (int s = 0; s < S; ++s)
    for (long j = 0; j < my_rows; ++j) {
      const std::int64_t* m = &row_mass_[((sources[s] - zlo) * my_rows + j) * nx_];
      for (int i = 0; i < nx_; ++i) fft_.real[i] = static_cast<double>(m[i]) * to_sigma;
      fftw_execute(static_cast<fftw_plan>(row_forward_));
      std::memcpy(static_cast<void*>(&row_spec_[(s * my_rows + j) * mx]), fft_.spec, sizeof(fftw_complex) * mx);
    }
  send_.clear();
  for (int q = 0; q < nranks_; ++q) {
    const std::size_t before = send_.size();
    for (int s = 0; s < S; ++s)
      for (long j = 0; j < my_rows; ++j)
        append(send_, reinterpret_cast<const double*>(&row_spec_[(s * my_rows + j) * mx + col_lo(q)]),
               2 * (col_lo(q + 1) - col_lo(q)));  // (re, im) pairs: std::complex's layout
    scount[q] = static_cast<int>(send_.size() - before);
    rcount[q] = static_cast<int>(2 * S * (row_lo(q + 1) - row_lo(q)) * my_cols);
  }
  moved_bytes_ += exchange(send_, scount, recv_, rcount);
  fit(col_spec_, static_cast<std::size_t>(S) * my_cols * ny_);
  {
    std::size_t at = 0;
    for (int q = 0; q < nranks_; ++q)
      for (int s = 0; s < S; ++s)
        for (long j = row_lo(q); j < row_lo(q + 1); ++j)
          for (long m = 0; m < my_cols; ++m, at += 2)
            col_spec_[(s * my_cols + m) * ny_ + j] = {recv_[at], recv_[at + 1]};
  }
  auto transform_column = [&](void* plan, std::complex<double>* c) {
    std::memcpy(fft_.col_in, c, sizeof(fftw_complex) * ny_);
    fftw_execute(static_cast<fftw_plan>(plan));
    std::memcpy(static_cast<void*>(c), fft_.col_out, sizeof(fftw_complex) * ny_);
  };
  for (int s = 0; s < S; ++s)
    for (long m = 0; m < my_cols; ++m) transform_column(col_forward_, &col_spec_[(s * my_cols + m) * ny_]);

  // Per mode: the layers' Gaussian sheets coupled exactly, the CIC windows divided out.
  const int first = first_, last = last_;
  int reach = 0;  // the largest layer distance from a source to a computed layer
  if (S) reach = std::max(last - sources.front(), sources.back() - first);
  const double norm = 1.0 / (static_cast<double>(nx_) * ny_);
  const int R = reach + 1;
  const std::complex<double> I(0, 1);
  const int F = planar_ ? 3 : 4;
  const int fields[4] = {0, 1, planar_ ? 3 : 2, 3};  // a_z skipped in planar scenes
  // Per column and computed layer: the potential's modes and (3D) a_z's; a_x and a_y are -i k_x
  // and -i k_y times the potential's, formed as each field goes back.
  const int G = planar_ ? 1 : 2;
  fit(col_out_, static_cast<std::size_t>(G) * my_cols * L * ny_);  // every entry is written below
  auto out = [&](int g, long ml, int a) { return &col_out_[((static_cast<std::size_t>(ml) * G + g) * L + (a - first)) * ny_]; };
  auto wave_numbers = [&](long ml, std::vector<double>& ky) {  // k_x, and k_y per n, of column ml
    const double KX = 2 * kPi * (c0 + ml) / lx_;
    for (int j = 0; j < ny_; ++j) {
      const int n = j <= ny_ / 2 ? j : j - ny_;
      ky[j] = 2 * kPi * n / ly_ - KX * shear_ / ly_;
    }
    return KX;
  };
  // Per mode column: the kernels of every mode in it by layer distance, then each computed layer
  // sums its sources, eight doubles of the column at a time (the n are contiguous there).
  const int n2 = 2 * ny_;  // a column's doubles
  std::vector<double> P(static_cast<std::size_t>(R) * ny_), Z(P.size()), KY(ny_);
  std::vector<double> P2(static_cast<std::size_t>(2 * R) * n2), Z2(P2.size()), column_sources(static_cast<std::size_t>(S) * n2);
  std::vector<std::ptrdiff_t> source_at(S);  // a source layer's offset in the signed kernel tables
  for (int s = 0; s < S; ++s) source_at[s] = static_cast<std::ptrdiff_t>(sources[s]) * n2;
  for (long ml = 0; ml < my_cols; ++ml) {
    const long m = c0 + ml;
    const double KX = wave_numbers(ml, KY);
    for (int j = 0; j < ny_; ++j) {
      const int n = j <= ny_ / 2 ? j : j - ny_;
      // Assignment and interpolation each multiply mode (m, n) by the CIC window of the grid.
      const double w = sinc2(kPi * m / nx_) * sinc2(kPi * n / ny_);
      const double scale = norm / (w * w);
      const double k = std::hypot(KX, KY[j]);
      if (k == 0) {
        for (int d = 0; d < R; ++d) {
          double p, z;
          kernels(0.0, d * h_[2], p, z);
          P[d * ny_ + j] = p * scale;
          Z[d * ny_ + j] = z * scale;
        }
      } else {  // from the tables: k phi and a_z are smooth in k at every layer distance
        const double t = k * inv_dk_;
        const std::size_t i = static_cast<std::size_t>(t);
        const double f = t - static_cast<double>(i);
        const double* lo = &kernel_table_[i * nz_ * 2];
        const double* hi = lo + nz_ * 2;
        for (int d = 0; d < R; ++d) {
          P[d * ny_ + j] = (lo[2 * d] + f * (hi[2 * d] - lo[2 * d])) / k * scale;
          Z[d * ny_ + j] = (lo[2 * d + 1] + f * (hi[2 * d + 1] - lo[2 * d + 1])) * scale;
        }
      }
    }
    // The kernels by signed layer distance a - s + R - 1, each mode's value twice (its real and
    // imaginary parts take the same factor), a_z's with its sign.
    for (int e = 0; e < 2 * R - 1; ++e) {
      const int d = std::abs(e - (R - 1));
      const double sign = e >= R - 1 ? 1.0 : -1.0;
      for (int j = 0; j < ny_; ++j) {
        const std::size_t to = (static_cast<std::size_t>(e) * ny_ + j) * 2;
        P2[to] = P2[to + 1] = P[d * ny_ + j];
        Z2[to] = Z2[to + 1] = sign * Z[d * ny_ + j];
      }
    }
    // The column's sources side by side (in col_spec_ they lie a whole layer of columns apart).
    for (int s = 0; s < S; ++s) {
      const double* from = reinterpret_cast<const double*>(&col_spec_[(s * my_cols + ml) * ny_]);
      std::copy(from, from + n2, &column_sources[static_cast<std::size_t>(s) * n2]);
    }
    // Eight doubles at a time through every layer and source: a layer's sums stay in registers
    // (1.35x on the stirred propeller's coupling against whole columns per source), each in
    // source order as before (the same bits).
    constexpr int kW = 8;
    const double* sources_at = column_sources.data();
    for (int t0 = 0; t0 < n2; t0 += kW) {
      const int w = std::min(kW, n2 - t0);
      for (int a = first; a <= last; ++a) {
        if (w == kW) {
          Lanes u = {}, v = {};
          const double* pa = &P2[static_cast<std::size_t>(a + R - 1) * n2 + t0];
          const double* za = &Z2[static_cast<std::size_t>(a + R - 1) * n2 + t0];
          for (int s = 0; s < S; ++s) {
            const Lanes src = load_lanes(sources_at + s * n2 + t0);
            u += load_lanes(pa - source_at[s]) * src;
            v += load_lanes(za - source_at[s]) * src;
          }
          store_lanes(u, reinterpret_cast<double*>(out(0, ml, a)) + t0);
          if (!planar_) store_lanes(v, reinterpret_cast<double*>(out(1, ml, a)) + t0);
          continue;
        }
        double u[kW] = {}, v[kW] = {};
        for (int s = 0; s < S; ++s) {
          const double* src = sources_at + s * n2 + t0;
          const double* p = &P2[static_cast<std::size_t>(a + R - 1) * n2 + t0] - source_at[s];
          const double* z = &Z2[static_cast<std::size_t>(a + R - 1) * n2 + t0] - source_at[s];
          for (int t = 0; t < w; ++t) {
            u[t] += p[t] * src[t];
            v[t] += z[t] * src[t];
          }
        }
        std::copy(u, u + w, reinterpret_cast<double*>(out(0, ml, a)) + t0);
        if (!planar_) std::copy(v, v + w, reinterpret_cast<double*>(out(1, ml, a)) + t0);
      }
    }
  }
  // Back, one field at a time (a fourth of the staging): along y, straight into the all-to-all's
  // send buffer (by destination rank, layer, row, column), to rows, along x, and each rank's box
  // from the rows' owners.
  // Where each owned row's values go in the last all-to-all: for each rank q, the rows of q's box
  // this rank owns, in q's order, each a run of columns (layer 0's offset, the layer stride).
  struct BoxRun {
    std::size_t at, layer_stride;
    long from, n;
  };
  std::vector<std::vector<BoxRun>> box_runs(my_rows);
  std::vector<int> box_scount(nranks_), box_rcount(nranks_);
  std::size_t box_send = 0;
  for (int q = 0; q < nranks_; ++q) {
    const long* b = box(copy_, q);
    long mine_q = 0;
    for (long r = 0; r < b[1]; ++r) mine_q += row_owner(grid_row(q, r)) == rank_ ? 1 : 0;
    for (long r = 0, k = 0; r < b[1]; ++r)
      if (row_owner(grid_row(q, r)) == rank_)
        box_runs[grid_row(q, r) - r0].push_back({box_send + static_cast<std::size_t>(k++) * b[2],
                                                 static_cast<std::size_t>(mine_q) * b[2], b[3 + r], b[2]});
    box_scount[q] = static_cast<int>(L * mine_q * b[2]);
    box_send += box_scount[q];
    long n = 0;
    for (std::size_t r = 0; r < rows; ++r) n += row_owner(grid_row(rank_, r)) == q ? 1 : 0;
    box_rcount[q] = static_cast<int>(L * n * cols);
  }
  std::vector<std::size_t> row_at(ny_), layer_stride(ny_);  // where column entry n goes in send_
  std::vector<int> col_scount(nranks_), col_rcount(nranks_);
  {
    std::size_t at = 0;
    for (int q = 0; q < nranks_; ++q) {
      const long rows_q = row_lo(q + 1) - row_lo(q);
      for (long j = row_lo(q); j < row_lo(q + 1); ++j) {
        row_at[j] = at + static_cast<std::size_t>(j - row_lo(q)) * my_cols * 2;
        layer_stride[j] = static_cast<std::size_t>(rows_q) * my_cols * 2;
      }
      col_scount[q] = static_cast<int>(2 * L * rows_q * my_cols);
      col_rcount[q] = static_cast<int>(2 * L * my_rows * (col_lo(q + 1) - col_lo(q)));
      at += col_scount[q];
    }
  }
  auto* column = reinterpret_cast<std::complex<double>*>(fft_.col_in);
  // Columns go back kBlock at a time: their results are neighbours in send_, so the transpose
  // writes whole cache lines instead of one value per line.
  constexpr long kBlock = 8;
  std::vector<std::complex<double>> tile(kBlock * ny_);
  std::vector<double> ky(kBlock * ny_), kx(kBlock);
  for (int f = 0; f < F; ++f) {
    fit(send_, static_cast<std::size_t>(2) * L * ny_ * my_cols);
    for (long ml0 = 0; ml0 < my_cols; ml0 += kBlock) {
      const long nb = std::min(kBlock, my_cols - ml0);
      for (long b = 0; b < nb; ++b) {
        kx[b] = wave_numbers(ml0 + b, KY);
        std::copy(KY.begin(), KY.end(), &ky[b * ny_]);
      }
      for (int a = first; a <= last; ++a) {
        for (long b = 0; b < nb; ++b) {
          const long ml = ml0 + b, m = c0 + ml;
          const double KX = kx[b];
          const double* KYb = &ky[b * ny_];
          const std::complex<double>* phi = out(0, ml, a);
          switch (fields[f]) {
            case 0: for (int j = 0; j < ny_; ++j) column[j] = -I * KX * phi[j]; break;
            case 1: for (int j = 0; j < ny_; ++j) column[j] = -I * KYb[j] * phi[j]; break;
            case 2: std::copy(out(1, ml, a), out(1, ml, a) + ny_, column); break;
            default: std::copy(phi, phi + ny_, column);
          }
          // Nyquist: no odd derivative there (zeros)
          if (m == nx_ / 2) std::fill(column, column + ny_, 0.0);
          else column[ny_ / 2] = 0.0;
          fftw_execute(static_cast<fftw_plan>(col_backward_));
          std::memcpy(static_cast<void*>(&tile[b * ny_]), fft_.col_out, sizeof(fftw_complex) * ny_);
        }
        const std::size_t layer = static_cast<std::size_t>(a - first);
        for (int j = 0; j < ny_; ++j) {
          double* to = &send_[row_at[j] + layer * layer_stride[j] + 2 * ml0];
          for (long b = 0; b < nb; ++b) {
            to[2 * b] = tile[b * ny_ + j].real();
            to[2 * b + 1] = tile[b * ny_ + j].imag();
          }
        }
      }
    }
    moved_bytes_ += exchange(send_, col_scount, recv_, col_rcount);
    std::vector<std::size_t> recv_at(nranks_, 0);  // where rank q's columns of (layer, row) begin in recv_
    for (int q = 1; q < nranks_; ++q) recv_at[q] = recv_at[q - 1] + col_rcount[q - 1];
    fit(send_, box_send);
    for (int a = 0; a < L; ++a)
      for (long j = 0; j < my_rows; ++j) {
        double* spec = &fft_.spec[0][0];
        for (int q = 0; q < nranks_; ++q) {
          const long n = col_lo(q + 1) - col_lo(q);
          const double* in = &recv_[recv_at[q] + (static_cast<std::size_t>(a) * my_rows + j) * n * 2];
          std::copy(in, in + 2 * n, spec + 2 * col_lo(q));
        }
        fftw_execute(static_cast<fftw_plan>(row_backward_));
        for (const BoxRun& run : box_runs[j]) {  // the box's run of columns, wrapping at most once
          double* to = &send_[run.at + a * run.layer_stride];
          const long first_part = std::min(run.n, nx_ - run.from);
          std::copy(fft_.real + run.from, fft_.real + run.from + first_part, to);
          std::copy(fft_.real, fft_.real + (run.n - first_part), to + first_part);
        }
      }
    moved_bytes_ += exchange(send_, box_scount, recv_, box_rcount);
    std::vector<double>& field = box_field_[copy_][fields[f]];
    if (nranks_ == 1) {  // all rows this rank's own: received already in the box's layout
      field.swap(recv_);
      continue;
    }
    fit(field, static_cast<std::size_t>(L) * rows * cols);
    std::size_t at = 0;
    for (int q = 0; q < nranks_; ++q)
      for (int a = 0; a < L; ++a)
        for (std::size_t r = 0; r < rows; ++r)
          if (row_owner(grid_row(rank_, r)) == q) {
            std::copy(&recv_[at], &recv_[at] + cols, &field[(a * rows + r) * cols]);
            at += cols;
          }
  }
}

// Each owned particle's partners within r_s + skin, owned or ghosts (binned in cells of at
// least that size), sorted by id: the order of each particle's sum then depends neither on
// the decomposition nor on when the list was built, so runs are bitwise the same on any rank
// count and across restarts. Two images of one partner within reach would tie on id: the
// halo's rule (box sides >= 2 x its range) rules that out.
void SelfGravity::list_partners(const ParticleStore& p) {
  const std::size_t n = p.size();
  ListScratch& s = scratch_;
  fit(s.key, n);
  auto& key = s.key;
  std::array<long, 3> lo{0, 0, 0}, hi{0, 0, 0};
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      key[i][d] = static_cast<long>(std::floor((p.x[i][d] - lo_[d]) / cell_size_));
      lo[d] = i ? std::min(lo[d], key[i][d]) : key[i][d];
      hi[d] = i ? std::max(hi[d], key[i][d]) : key[i][d];
    }
  int cells[3];
  std::size_t total = 1;
  for (int d = 0; d < 3; ++d) {
    cells[d] = static_cast<int>(hi[d] - lo[d] + 1);
    total *= cells[d];
  }
  auto cell_of = [&](long x, long y, long z) { return (static_cast<std::size_t>(z) * cells[1] + y) * cells[0] + x; };
  fit(s.start, total + 1, std::uint32_t{0});
  fit(s.items, n);
  auto &start = s.start, &items = s.items, &fill = s.fill;
  for (std::size_t i = 0; i < n; ++i) ++start[cell_of(key[i][0] - lo[0], key[i][1] - lo[1], key[i][2] - lo[2]) + 1];
  for (std::size_t c = 0; c < total; ++c) start[c + 1] += start[c];
  fill.assign(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    items[fill[cell_of(key[i][0] - lo[0], key[i][1] - lo[1], key[i][2] - lo[2])]++] = static_cast<std::uint32_t>(i);

  // Each particle's place in the id order (owned and ghosts). The particles of one cell share
  // their candidates (the cells around it): sorted by id once per cell, as one integer key per
  // entry, every particle's partners come out of them already in id order. (A sort per particle,
  // through the indices to the ids, was half the cost of the wakes scene's rebuilds.)
  fit(s.by_id, n);
  fit(s.id_rank, n);
  auto &by_id = s.by_id, &id_rank = s.id_rank;
  for (std::size_t i = 0; i < n; ++i) by_id[i] = static_cast<std::uint32_t>(i);
  std::sort(by_id.begin(), by_id.end(), [&p](std::uint32_t a, std::uint32_t b) { return p.id[a] < p.id[b]; });
  for (std::size_t k = 0; k < n; ++k) id_rank[by_id[k]] = static_cast<std::uint32_t>(k);

  const double r2max = list_range_ * list_range_;
  fit(partner_count_, p.nlocal, std::uint32_t{0});
  fit(partner_at_, p.nlocal, std::uint32_t{0});
  partner_.clear();
  auto &count = partner_count_, &where = partner_at_, &found = partner_;
  auto &candidates = s.candidates;
  auto &cx = s.cx, &cy = s.cy, &cz = s.cz, &r2 = s.r2;
  auto& copy = s.copy;
  for (std::size_t cell = 0; cell < total; ++cell) {
    bool owned = false;
    for (std::uint32_t q = start[cell]; q < start[cell + 1] && !owned; ++q) owned = items[q] < p.nlocal;
    if (!owned) continue;
    const long c[3] = {static_cast<long>(cell % cells[0]), static_cast<long>(cell / cells[0] % cells[1]),
                       static_cast<long>(cell / (static_cast<std::size_t>(cells[0]) * cells[1]))};
    candidates.clear();
    for (long z = std::max(0L, c[2] - 1); z <= std::min<long>(cells[2] - 1, c[2] + 1); ++z)
      for (long y = std::max(0L, c[1] - 1); y <= std::min<long>(cells[1] - 1, c[1] + 1); ++y)
        for (long x = std::max(0L, c[0] - 1); x <= std::min<long>(cells[0] - 1, c[0] + 1); ++x) {
          const std::size_t near = cell_of(x, y, z);
          for (std::uint32_t q = start[near]; q < start[near + 1]; ++q)
            candidates.push_back(std::uint64_t(id_rank[items[q]]) << 32 | items[q]);
        }
    std::sort(candidates.begin(), candidates.end());
    const std::size_t m = candidates.size();
    cx.resize(m);
    cy.resize(m);
    cz.resize(m);
    r2.resize(m);
    copy.resize(m);
    for (std::size_t k = 0; k < m; ++k) {  // contiguous coordinates: the distance loop vectorises
      const std::uint32_t j = static_cast<std::uint32_t>(candidates[k]);
      const Vec3& x = p.x[j];
      cx[k] = x[0];
      cy[k] = x[1];
      cz[k] = x[2];
      copy[k] = copy_of(p, j);
    }
    for (std::uint32_t q = start[cell]; q < start[cell + 1]; ++q) {
      const std::uint32_t i = items[q];
      if (i >= p.nlocal) continue;
      const double xi = p.x[i][0], yi = p.x[i][1], zi = p.x[i][2];
      for (std::size_t k = 0; k < m; ++k) {
        const double dx = cx[k] - xi, dy = cy[k] - yi, dz = cz[k] - zi;
        r2[k] = dx * dx + dy * dy + dz * dz;
      }
      // Every candidate is written and the end moves on only for a partner: no branch to
      // mispredict (about half the candidates are partners, in no pattern).
      const std::size_t at = found.size();
      const int own = copy_of(p, i);
      fit(found, at + m);
      std::uint32_t* out = found.data() + at;
      std::size_t kept = 0;
      for (std::size_t k = 0; k < m; ++k) {
        const auto j = static_cast<std::uint32_t>(candidates[k]);
        out[kept] = j;
        kept += static_cast<std::size_t>((r2[k] < r2max) & (j != i) & (copy[k] == own));
      }
      found.resize(at + kept);
      where[i] = static_cast<std::uint32_t>(at);
      count[i] = static_cast<std::uint32_t>(kept);
    }
  }
}

void SelfGravity::setup(Simulation& sim) { multirate_ = sim.find<MultiRateHill>(); }

void SelfGravity::post_rebuild(Simulation& sim) {
  if (short_) list_partners(sim.particles);
}

// Partners in list (id) order; the cost is the square root and the division per partner
// (~6 ns here): ~150 partners within 35 m in cases/gravity-wakes, every step.
Vec3 SelfGravity::short_range(const ParticleStore& p, const Vec3* X, std::size_t i, double* phi) const {
  const double xi = X[i][0], yi = X[i][1], zi = X[i][2];
  const double r2max = reach_ * reach_, G = kGravitationalConstant, to_s = kTable / r2max;
  const double* w_table = w_table_.data();
  double ax = 0, ay = 0, az = 0, u = 0;
  for (std::uint32_t q = partner_at_[i], end = q + partner_count_[i]; q < end; ++q) {
    const std::uint32_t j = partner_[q];
    const double dx = X[j][0] - xi, dy = X[j][1] - yi, dz = X[j][2] - zi;
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= r2max) continue;
    const double r = std::sqrt(r2), s = r2 * to_s;
    const std::size_t k = static_cast<std::size_t>(s);
    const double f = s - static_cast<double>(k);
    const double w = w_table[k] + f * (w_table[k + 1] - w_table[k]);
    const double c = G * p.mass[j] * w / (r2 * r);
    ax += c * dx;
    ay += c * dy;
    az += c * dz;
    if (phi) u -= G * p.mass[j] * (erfc_table_[k] + f * (erfc_table_[k + 1] - erfc_table_[k])) / r;
  }
  if (phi) *phi = u;
  return Vec3(ax, ay, az);
}

void SelfGravity::force(Simulation& sim) {
  if (multirate_) {
    force_multirate(sim);
    return;
  }
  ParticleStore& p = sim.particles;
  const Simulation::TargetList T = sim.target_list();
  const bool mesh = sim.step_count % every_ == 0;
  if (mesh) solve(sim, false);
  const auto start = std::chrono::steady_clock::now();
  const double weight = static_cast<double>(every_);  // the mesh's impulse of `every` steps
  // Kept for the bookkeeping later in this step (the energy guard, a snapshot's body forces):
  // the positions do not change before the step ends.
  if (mesh) {
    cached_mesh_.assign(p.nlocal, Vec3::Zero());
    cached_short_.assign(p.nlocal, Vec3::Zero());
  }
  double u = 0;
  for (std::size_t t = 0; t < T.count; ++t) {
    const std::size_t i = T[t];
    double near = 0;
    const Vec3 a_short = short_ ? short_range(p, i, mesh ? &near : nullptr) : Vec3(Vec3::Zero());
    p.f[i] += p.mass[i] * a_short;
    if (!mesh) continue;
    const Vec3 a_mesh = field(p.x[i], copy_of(p, i));
    p.f[i] += weight * p.mass[i] * a_mesh;
    cached_mesh_[i] = a_mesh;
    cached_short_[i] = a_short;
    u += 0.5 * p.mass[i] * (potential(p.x[i], copy_of(p, i)) + near);
  }
  apply_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!mesh) return;
  cached_potential_ = u;
  cached_step_ = sim.stepping.all_targets ? sim.step_count : -1;
  report(sim);
}

void SelfGravity::report(Simulation& sim) const {
  std::ostringstream os;
  os << "{\"solves\": " << solves_ << ", \"mesh_seconds\": " << solve_seconds_
     << ", \"interpolation_and_pairs_seconds\": " << apply_seconds_ << ", \"mesh_bytes_per_rank\": " << mesh_bytes_
     << ", \"bytes_moved_per_solve\": " << moved_bytes_ / std::max(1L, solves_)
     << ", \"grid\": [" << nx_ << ", " << ny_
     << ", " << nz_ << "], \"split\": " << eps_ << ", \"short_range\": " << (short_ ? "true" : "false") << "}";
  sim.set_result("self_gravity", os.str());
}

// The mesh and the short range of every owned particle at the present positions (all
// synchronised), kept as the state of `step`; the short range also goes into the forces if asked.
void SelfGravity::solve_all(Simulation& sim, long step, bool add_short_to_forces) {
  ParticleStore& p = sim.particles;
  solve(sim, false);
  const auto start = std::chrono::steady_clock::now();
  cached_mesh_.resize(p.nlocal);
  cached_short_.resize(p.nlocal);
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    double near = 0;
    cached_short_[i] = short_ ? short_range(p, i, &near) : Vec3(Vec3::Zero());
    cached_mesh_[i] = field(p.x[i], copy_of(p, i));
    if (add_short_to_forces) p.f[i] += p.mass[i] * cached_short_[i];
    u += 0.5 * p.mass[i] * (potential(p.x[i], copy_of(p, i)) + near);
  }
  apply_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  cached_potential_ = synced_potential_ = u;
  synced_ = true;
  cached_step_ = step;
  report(sim);
}

// A long step's end (every particle synchronised: all are targets) solves for everyone; the
// integrator gives the kicks. Between, the particles on contact steps get their short range.
void SelfGravity::force_multirate(Simulation& sim) {
  if (sim.stepping.all_targets) {
    solve_all(sim, sim.step_count, true);  // the short range enters the contact steps' Verlet kicks; free particles' f is unused
    short_now_ = cached_short_;             // a particle woken at this step is owed its short range
    return;
  }
  if (!short_) return;
  ParticleStore& p = sim.particles;
  const auto start = std::chrono::steady_clock::now();
  // The targets and their partners where they are now: a free particle's stored state lags, and
  // is brought forward once a step, only where a pair needs it (a few percent of the particles).
  const MultiRateHill::Present now = multirate_->present(sim);
  const long step = sim.step_count;
  present_.resize(p.size());
  present_step_.resize(p.size(), -1);
  auto need = [&](std::size_t j) {
    if (present_step_[j] == step) return;
    present_[j] = now(j);
    present_step_[j] = step;
  };
  short_now_.resize(p.nlocal);
  const Simulation::TargetList T = sim.target_list();
  for (std::size_t t = 0; t < T.count; ++t) {
    const std::size_t i = T[t];
    need(i);
    for (std::uint32_t q = partner_at_[i], end = q + partner_count_[i]; q < end; ++q) need(partner_[q]);
    short_now_[i] = short_range(p, present_.data(), i);
    p.f[i] += p.mass[i] * short_now_[i];
  }
  apply_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double SelfGravity::synchronise(Simulation& sim) {
  // The last step's force() solved at these very positions, unless a rebuild came between.
  if (cached_step_ != sim.step_count - 1) solve_all(sim, sim.step_count - 1, false);
  double largest = 0;
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i)
    largest = std::max(largest, (cached_mesh_[i] + cached_short_[i]).norm());
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, comm_);
  return largest;
}

// Stress and energy bookkeeping (collective calls) solve the field at the present positions
// first: between solves the particles have moved, perhaps into layers the last solve left out.
// That does not change the run: force() solves again at its own steps.
void SelfGravity::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  if (cached_step_ == sim.step_count) {  // force() solved at these very positions
    for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * (cached_mesh_[i] + cached_short_[i]);
    return;
  }
  const_cast<SelfGravity*>(this)->solve(sim, false);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    F[i] += p.mass[i] * (short_ ? Vec3(field(p.x[i], copy_of(p, i)) + short_range(p, i)) : field(p.x[i], copy_of(p, i)));
}

double SelfGravity::potential_energy(const Simulation& sim) const {
  if (cached_step_ == sim.step_count) return cached_potential_;
  // Under the multi-rate integrator the free particles' stored states are of another time
  // between long steps: the potential is that of the last long step's end (the energy guard's
  // bound holds it to within a long step; a solve here cost 20 % of the wakes scene's mesh time).
  if (multirate_ && synced_) return synced_potential_;
  const_cast<SelfGravity*>(this)->solve(sim, false);
  const ParticleStore& p = sim.particles;
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    double near = 0;
    if (short_) short_range(p, i, &near);
    u += 0.5 * p.mass[i] * (potential(p.x[i], copy_of(p, i)) + near);
  }
  return u;
}

}  // namespace cassini
