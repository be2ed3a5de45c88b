#include "physics/SelfGravity.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>

#include <fftw3.h>
#include <unistd.h>
#include <mpi.h>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"

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
    if (c.modified_lees_edwards)
      f.fail("domain.modified_lees_edwards", "false with module \"self-gravity\" (the two copies would need one field each)");
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
    s.split = f.number(g + "split", 2 * spacing);  // within 1 % of Newton's law (SelfGravity.hpp)
    if (!(s.split > 0)) f.fail(g + "split", "a length > 0 (m): the width of the Gaussian splitting mesh and pairs");
    s.short_range = f.boolean(g + "short_range", true);
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
  const std::size_t nodes = static_cast<std::size_t>(nx_) * ny_ * nz_;
  const std::size_t modes = static_cast<std::size_t>(nx_ / 2 + 1) * ny_ * nz_;
  ax_.assign(nodes, 0.0);
  ay_.assign(nodes, 0.0);
  az_.assign(nodes, 0.0);
  phi_.assign(nodes, 0.0);
  mass_.assign(nodes, 0);
  real_ = fftw_alloc_real(nodes);
  spec_ = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(modes));
  for (auto*& o : out_) o = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(modes));
  // One 2D transform per layer, run on the layers that matter (fftw_execute_dft_* on each).
  // FFTW_ESTIMATE | FFTW_UNALIGNED: the plan is a function of the sizes only and takes one code
  // path for any layer's address, the same on every rank and run.
  const unsigned flags = FFTW_ESTIMATE | FFTW_UNALIGNED;
  forward_ = fftw_plan_dft_r2c_2d(ny_, nx_, real_, reinterpret_cast<fftw_complex*>(spec_), flags);
  backward_ = fftw_plan_dft_c2r_2d(ny_, nx_, reinterpret_cast<fftw_complex*>(out_[0]), real_, flags);
}

SelfGravity::~SelfGravity() {
  fftw_destroy_plan(static_cast<fftw_plan>(forward_));
  fftw_destroy_plan(static_cast<fftw_plan>(backward_));
  fftw_free(real_);
  fftw_free(spec_);
  for (auto* o : out_) fftw_free(o);
}

SelfGravity::Stencil SelfGravity::stencil(const Vec3& x) const {
  Stencil s{};
  const double xs = sheared_ ? x[0] - shear_ * (x[1] - lo_[1]) / ly_ : x[0];
  const double u = (xs - lo_[0]) / h_[0], v = (x[1] - lo_[1]) / h_[1];
  const double fu = std::floor(u), fv = std::floor(v);
  const double wx = u - fu, wy = v - fv;
  const std::size_t i0 = wrap(static_cast<long>(fu), nx_), i1 = wrap(static_cast<long>(fu) + 1, nx_);
  const std::size_t j0 = wrap(static_cast<long>(fv), ny_), j1 = wrap(static_cast<long>(fv) + 1, ny_);
  const std::size_t nx = nx_, plane = static_cast<std::size_t>(nx_) * ny_;
  std::size_t k0 = 0, k1 = 0;
  double wz = 0;
  if (!planar_) {  // layer centres at lo_z + (k + 1/2) h_z; beyond the outer centres, the outer layer
    const double t = (x[2] - lo_[2]) / h_[2] - 0.5;
    if (t <= 0) {
      k0 = k1 = 0;
    } else if (t >= nz_ - 1) {
      k0 = k1 = nz_ - 1;
    } else {
      k0 = static_cast<std::size_t>(t);
      k1 = k0 + 1;
      wz = t - static_cast<double>(k0);
    }
  }
  const std::size_t ks[2] = {k0, k1};
  const double wzs[2] = {1 - wz, wz};
  for (int c = 0; c < (planar_ ? 1 : 2); ++c)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        s.node[s.n] = ks[c] * plane + (b ? j1 : j0) * nx + (a ? i1 : i0);
        s.w[s.n] = (a ? wx : 1 - wx) * (b ? wy : 1 - wy) * wzs[c];
        ++s.n;
      }
  return s;
}

double SelfGravity::interpolate(const std::vector<double>& g, const Stencil& s) const {
  double r = 0;
  for (int q = 0; q < s.n; ++q) r += s.w[q] * g[s.node[q]];
  return r;
}

Vec3 SelfGravity::field(const Vec3& x) const {
  const Stencil s = stencil(x);
  return Vec3(interpolate(ax_, s), interpolate(ay_, s), planar_ ? 0.0 : interpolate(az_, s));
}

double SelfGravity::potential(const Vec3& x) const { return interpolate(phi_, stencil(x)); }

void SelfGravity::solve(const Simulation& sim, bool every_layer) {
  const auto start = std::chrono::steady_clock::now();
  const ParticleStore& p = sim.particles;
  // The least tilted of the equivalent sheared grids: S in [-Lx/2, Lx/2).
  if (sheared_) {
    shear_ = sim.domain.shear.wrapped(lx_);
    if (shear_ >= 0.5 * lx_) shear_ -= lx_;
  }

  // Deposit in fixed point: the all-reduced sum is exact, so independent of the rank count.
  double heaviest = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) heaviest = std::max(heaviest, p.mass[i]);
  MPI_Allreduce(MPI_IN_PLACE, &heaviest, 1, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  const double unit = heaviest > 0 ? std::ldexp(heaviest, -40) : 1.0;
  // The layers the particles touch (a ring fills a few): only those are deposited, reduced and
  // transformed, and only those are sources (the same on every rank).
  const std::size_t plane = static_cast<std::size_t>(nx_) * ny_;
  int span[2] = {nz_, -nz_};  // min layer, -max layer
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Stencil s = stencil(p.x[i]);
    span[0] = std::min(span[0], static_cast<int>(s.node[0] / plane));
    span[1] = std::min(span[1], -static_cast<int>(s.node[s.n - 1] / plane));
  }
  MPI_Allreduce(MPI_IN_PLACE, span, 2, MPI_INT, MPI_MIN, sim.domain.comm);
  const int zlo = std::min(span[0], nz_ - 1), zhi = std::min(nz_ - 1, std::max(-span[1], zlo));
  const std::size_t from = zlo * plane, count = (zhi - zlo + 1) * plane;
  std::fill(mass_.begin() + from, mass_.begin() + from + count, 0);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Stencil s = stencil(p.x[i]);
    for (int q = 0; q < s.n; ++q) mass_[s.node[q]] += std::llround(p.mass[i] * s.w[q] / unit);
  }
  MPI_Allreduce(MPI_IN_PLACE, mass_.data() + from, static_cast<int>(count), MPI_INT64_T, MPI_SUM, sim.domain.comm);
  reduced_bytes_ += static_cast<double>(count) * sizeof(std::int64_t);
  const double to_sigma = unit / (h_[0] * h_[1]);  // each layer a sheet of surface density
  for (std::size_t g = from; g < from + count; ++g) real_[g] = static_cast<double>(mass_[g]) * to_sigma;
  std::vector<int> sources;
  for (int b = zlo; b <= zhi; ++b)
    if (std::any_of(mass_.begin() + b * plane, mass_.begin() + (b + 1) * plane, [](std::int64_t q) { return q != 0; }))
      sources.push_back(b);
  const int mx = nx_ / 2 + 1;
  const std::size_t cplane = static_cast<std::size_t>(mx) * ny_;
  for (const int b : sources)
    fftw_execute_dft_r2c(static_cast<fftw_plan>(forward_), real_ + b * plane,
                         reinterpret_cast<fftw_complex*>(spec_ + b * cplane));
  int first = 0, last = nz_ - 1;  // the layers whose field is computed
  if (!every_layer && !sources.empty()) {
    first = std::max(0, sources.front() - 1);
    last = std::min(nz_ - 1, sources.back() + 1);
  }
  int reach = 0;  // the largest layer distance from a source to a computed layer
  if (!sources.empty()) reach = std::max(last - sources.front(), sources.back() - first);

  // Per mode: the layers' Gaussian sheets coupled exactly, the CIC windows divided out. One
  // row of modes (fixed n) at a time, so every layer's modes are read and written in
  // contiguous runs; the kernels of the row (per mode and layer distance) stay in cache.
  const double norm = 1.0 / (static_cast<double>(nx_) * ny_);
  const int R = reach + 1;
  std::vector<double> P(static_cast<std::size_t>(mx) * R), Z(P.size()), KX(mx), KY(mx);
  std::vector<std::complex<double>> phi(mx), az(mx);
  const std::complex<double> I(0, 1);
  for (int j = 0; j < ny_; ++j) {
    const int n = j <= ny_ / 2 ? j : j - ny_;
    for (int m = 0; m < mx; ++m) {
      double* p = &P[static_cast<std::size_t>(m) * R];
      double* z = &Z[static_cast<std::size_t>(m) * R];
      KX[m] = 2 * kPi * m / lx_;
      KY[m] = 2 * kPi * n / ly_ - KX[m] * shear_ / ly_;
      if (m == nx_ / 2 || j == ny_ / 2) {  // Nyquist: no odd derivative there
        std::fill(p, p + R, 0.0);
        std::fill(z, z + R, 0.0);
        continue;
      }
      // Assignment and interpolation each multiply mode (m, n) by the CIC window of the grid.
      const double w = sinc2(kPi * m / nx_) * sinc2(kPi * n / ny_);
      const double scale = norm / (w * w);
      const double k = std::hypot(KX[m], KY[m]);
      if (k == 0) {
        for (int d = 0; d < R; ++d) {
          kernels(0.0, d * h_[2], p[d], z[d]);
          p[d] *= scale;
          z[d] *= scale;
        }
      } else {  // from the tables: k phi and a_z are smooth in k at every layer distance
        const double t = k * inv_dk_;
        const std::size_t i = static_cast<std::size_t>(t);
        const double f = t - static_cast<double>(i);
        const double* lo = &kernel_table_[i * nz_ * 2];
        const double* hi = lo + nz_ * 2;
        for (int d = 0; d < R; ++d) {
          p[d] = (lo[2 * d] + f * (hi[2 * d] - lo[2 * d])) / k * scale;
          z[d] = (lo[2 * d + 1] + f * (hi[2 * d + 1] - lo[2 * d + 1])) * scale;
        }
      }
    }
    const std::size_t row = static_cast<std::size_t>(j) * mx;
    for (int a = first; a <= last; ++a) {
      std::fill(phi.begin(), phi.end(), 0.0);
      std::fill(az.begin(), az.end(), 0.0);
      for (const int b : sources) {
        const std::complex<double>* s = spec_ + b * cplane + row;
        const int d = std::abs(a - b);
        const double sign = a >= b ? 1.0 : -1.0;
        for (int m = 0; m < mx; ++m) {
          phi[m] += P[static_cast<std::size_t>(m) * R + d] * s[m];
          az[m] += sign * Z[static_cast<std::size_t>(m) * R + d] * s[m];
        }
      }
      const std::size_t at = a * cplane + row;
      for (int m = 0; m < mx; ++m) {
        out_[0][at + m] = -I * KX[m] * phi[m];
        out_[1][at + m] = -I * KY[m] * phi[m];
        out_[2][at + m] = az[m];
        out_[3][at + m] = phi[m];
      }
    }
  }
  std::vector<double>* fields[4] = {&ax_, &ay_, &az_, &phi_};
  for (int f = 0; f < 4; ++f) {
    if (f == 2 && planar_) continue;
    for (int a = first; a <= last; ++a) {
      fftw_execute_dft_c2r(static_cast<fftw_plan>(backward_), reinterpret_cast<fftw_complex*>(out_[f] + a * cplane),
                           real_ + a * plane);
      std::copy(real_ + a * plane, real_ + (a + 1) * plane, fields[f]->begin() + a * plane);
    }
  }
  ++solves_;
  solve_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Each owned particle's partners within r_s + skin, owned or ghosts (binned in cells of at
// least that size), sorted by id: the order of each particle's sum then depends neither on
// the decomposition nor on when the list was built, so runs are bitwise the same on any rank
// count and across restarts. Two images of one partner within reach would tie on id: the
// halo's rule (box sides >= 2 x its range) rules that out.
void SelfGravity::list_partners(const ParticleStore& p) {
  const std::size_t n = p.size();
  std::vector<std::array<long, 3>> key(n);
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
  std::vector<std::uint32_t> start(total + 1, 0), items(n);
  for (std::size_t i = 0; i < n; ++i) ++start[cell_of(key[i][0] - lo[0], key[i][1] - lo[1], key[i][2] - lo[2]) + 1];
  for (std::size_t c = 0; c < total; ++c) start[c + 1] += start[c];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    items[fill[cell_of(key[i][0] - lo[0], key[i][1] - lo[1], key[i][2] - lo[2])]++] = static_cast<std::uint32_t>(i);

  const double r2max = list_range_ * list_range_;
  partner_start_.assign(p.nlocal + 1, 0);
  partner_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const std::size_t first = partner_.size();
    long c[3];
    for (int d = 0; d < 3; ++d) c[d] = key[i][d] - lo[d];
    for (long z = std::max(0L, c[2] - 1); z <= std::min<long>(cells[2] - 1, c[2] + 1); ++z)
      for (long y = std::max(0L, c[1] - 1); y <= std::min<long>(cells[1] - 1, c[1] + 1); ++y)
        for (long x = std::max(0L, c[0] - 1); x <= std::min<long>(cells[0] - 1, c[0] + 1); ++x) {
          const std::size_t cell = cell_of(x, y, z);
          for (std::uint32_t q = start[cell]; q < start[cell + 1]; ++q) {
            const std::uint32_t j = items[q];
            if (j != i && (p.x[j] - p.x[i]).squaredNorm() < r2max) partner_.push_back(j);
          }
        }
    std::sort(partner_.begin() + first, partner_.end(), [&p](std::uint32_t a, std::uint32_t b) { return p.id[a] < p.id[b]; });
    partner_start_[i + 1] = static_cast<std::uint32_t>(partner_.size());
  }
}

void SelfGravity::post_rebuild(Simulation& sim) {
  if (short_) list_partners(sim.particles);
}

Vec3 SelfGravity::short_range(const ParticleStore& p, std::size_t i, double* phi) const {
  const Vec3& xi = p.x[i];
  const double r2max = reach_ * reach_, G = kGravitationalConstant, to_s = kTable / r2max;
  Vec3 a = Vec3::Zero();
  double u = 0;
  for (std::uint32_t q = partner_start_[i]; q < partner_start_[i + 1]; ++q) {
    const std::uint32_t j = partner_[q];
    const Vec3 d = p.x[j] - xi;
    const double r2 = d.squaredNorm();
    if (r2 >= r2max) continue;
    const double r = std::sqrt(r2), s = r2 * to_s;
    const std::size_t k = static_cast<std::size_t>(s);
    const double f = s - static_cast<double>(k);
    const double w = w_table_[k] + f * (w_table_[k + 1] - w_table_[k]);
    a += (G * p.mass[j] * w / (r2 * r)) * d;
    if (phi) u -= G * p.mass[j] * (erfc_table_[k] + f * (erfc_table_[k + 1] - erfc_table_[k])) / r;
  }
  if (phi) *phi = u;
  return a;
}

void SelfGravity::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const Simulation::TargetList T = sim.target_list();
  const bool mesh = sim.step_count % every_ == 0;
  if (mesh) solve(sim, false);
  const auto start = std::chrono::steady_clock::now();
  const double weight = static_cast<double>(every_);  // the mesh's impulse of `every` steps
  // Kept for the bookkeeping later in this step (the energy guard, a snapshot's body forces):
  // the positions do not change before the step ends.
  if (mesh) cached_accel_.assign(p.nlocal, Vec3::Zero());
  double u = 0;
  for (std::size_t t = 0; t < T.count; ++t) {
    const std::size_t i = T[t];
    double near = 0;
    const Vec3 a_short = short_ ? short_range(p, i, mesh ? &near : nullptr) : Vec3(Vec3::Zero());
    p.f[i] += p.mass[i] * a_short;
    if (!mesh) continue;
    const Vec3 a_mesh = field(p.x[i]);
    p.f[i] += weight * p.mass[i] * a_mesh;
    cached_accel_[i] = a_mesh + a_short;
    u += 0.5 * p.mass[i] * (potential(p.x[i]) + near);
  }
  apply_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!mesh) return;
  cached_potential_ = u;
  cached_step_ = sim.all_targets ? sim.step_count : -1;
  std::ostringstream os;
  os << "{\"solves\": " << solves_ << ", \"mesh_seconds\": " << solve_seconds_
     << ", \"interpolation_and_pairs_seconds\": " << apply_seconds_ << ", \"allreduce_bytes\": " << reduced_bytes_
     << ", \"grid\": [" << nx_ << ", " << ny_
     << ", " << nz_ << "], \"split\": " << eps_ << ", \"short_range\": " << (short_ ? "true" : "false") << "}";
  sim.set_result("self_gravity", os.str());
}

// Stress and energy bookkeeping (collective calls) solve the field at the present positions
// first: between solves the particles have moved, perhaps into layers the last solve left out.
// That does not change the run: force() solves again at its own steps.
void SelfGravity::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  if (cached_step_ == sim.step_count) {  // force() solved at these very positions
    for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * cached_accel_[i];
    return;
  }
  const_cast<SelfGravity*>(this)->solve(sim, false);
  for (std::size_t i = 0; i < p.nlocal; ++i)
    F[i] += p.mass[i] * (short_ ? Vec3(field(p.x[i]) + short_range(p, i)) : field(p.x[i]));
}

double SelfGravity::potential_energy(const Simulation& sim) const {
  if (cached_step_ == sim.step_count) return cached_potential_;
  const_cast<SelfGravity*>(this)->solve(sim, false);
  const ParticleStore& p = sim.particles;
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    double near = 0;
    if (short_) short_range(p, i, &near);
    u += 0.5 * p.mass[i] * (potential(p.x[i]) + near);
  }
  return u;
}

}  // namespace cassini
