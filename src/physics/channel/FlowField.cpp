#include "physics/channel/FlowField.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <sstream>

#include "core/CaseFile.hpp"
#include "io/Hdf5Handle.hpp"
#include "physics/channel/ChannelGeometry.hpp"
#include "physics/channel/DuctFlow.hpp"
#include "physics/channel/StokesSolver.hpp"

namespace fs = std::filesystem;

namespace cassini {
namespace {

using h5::Handle;
using h5::check;

// Nearest point of the side walls (the two polylines, continued straight beyond their ends)
// to a point in the xy plane, with the unit normal from the wall towards the point's side.
struct WallPoint { double distance, x, y, nx, ny; };
class WallDistance {
 public:
  explicit WallDistance(const ChannelConfig& ch) {
    for (const auto* line : {&ch.upper, &ch.lower}) {
      const double side = line == &ch.upper ? -1 : 1;  // the fluid lies below the upper wall
      std::vector<Point2> p = *line;
      p.insert(p.begin(), Point2{p.front()[0] - 1.0, p.front()[1]});  // 1 m: beyond any channel
      p.push_back(Point2{p.back()[0] + 1.0, p.back()[1]});
      for (std::size_t k = 0; k + 1 < p.size(); ++k) segments_.push_back({p[k], p[k + 1], side});
    }
  }
  WallPoint nearest(double x, double y) const {
    WallPoint best{1e300, 0, 0, 0, 0};
    for (const auto& [a, b, side] : segments_) {
      const double tx = b[0] - a[0], ty = b[1] - a[1], len = std::hypot(tx, ty);
      const double t = std::clamp(((x - a[0]) * tx + (y - a[1]) * ty) / (len * len), 0.0, 1.0);
      const double px = a[0] + t * tx, py = a[1] + t * ty, dist = std::hypot(x - px, y - py);
      if (dist < best.distance) best = {dist, px, py, -side * ty / len, side * tx / len};
    }
    return best;
  }
 private:
  struct Segment { Point2 a, b; double side; };
  std::vector<Segment> segments_;
};

// The solve region's grid, derived from the case: cubic cells of D / resolution, aligned so
// that the neck's ends and the channel's side and floor lie on cell faces.
struct SolveBox {
  double dx, x0, y0, z0;
  int nx, ny, nz;
};

SolveBox solve_box(const Config& cfg) {
  const ChannelConfig& ch = cfg.get<ChannelConfig>();
  SolveBox b;
  b.dx = ch.neck_width / ch.resolution;
  const int half = static_cast<int>(std::lround(ch.solve_half_length / b.dx));
  b.x0 = ch.neck_x0 - half * b.dx;
  b.nx = half * 2 + static_cast<int>(std::lround((ch.neck_x1 - ch.neck_x0) / b.dx));
  b.y0 = cfg.lo[1];
  b.z0 = cfg.lo[2];
  const double ny = (cfg.hi[1] - cfg.lo[1]) / b.dx, nz = (cfg.hi[2] - cfg.lo[2]) / b.dx;
  b.ny = static_cast<int>(std::lround(ny));
  b.nz = static_cast<int>(std::lround(nz));
  if (std::abs(ny - b.ny) > 1e-6 || std::abs(nz - b.nz) > 1e-6 || b.nz < 2)
    throw ConfigError(cfg.source + ": key 'flow.resolution': the channel's width and height must be whole numbers of cells "
                      "(D / resolution = " + std::to_string(b.dx) + " m)");
  return b;
}

// Everything the solve depends on, as text: the cache is keyed by its hash and checked
// against the full text.
std::string cache_key(const Config& cfg, const SolveBox& b) {
  std::ostringstream os;
  os.precision(17);
  os << "stokes-v2 dx=" << b.dx << " x0=" << b.x0 << " y0=" << b.y0 << " z0=" << b.z0 << " n=" << b.nx << "," << b.ny
     << "," << b.nz << " v=" << cfg.get<ChannelConfig>().mean_velocity << " terms=" << cfg.get<ChannelConfig>().series_terms
     << " walls=" << (cfg.get<ChannelConfig>().embedded_walls ? "embedded" : "staircase") << " upper=";
  for (const auto& p : cfg.get<ChannelConfig>().upper) os << p[0] << ":" << p[1] << ";";
  os << " lower=";
  for (const auto& p : cfg.get<ChannelConfig>().lower) os << p[0] << ":" << p[1] << ";";
  return os.str();
}

}  // namespace

StokesGrid channel_stokes_grid(const Config& cfg, double x0, int nx, double dx) {
  const ChannelConfig& ch = cfg.get<ChannelConfig>();
  auto geo = std::make_shared<const ChannelGeometry>(ch);
  auto walls = std::make_shared<const WallDistance>(ch);
  const double y0 = cfg.lo[1];
  StokesGrid g;
  g.nx = nx;
  g.ny = static_cast<int>(std::lround((cfg.hi[1] - cfg.lo[1]) / dx));
  g.nz = static_cast<int>(std::lround((cfg.hi[2] - cfg.lo[2]) / dx));
  g.dx = dx;
  g.viscosity = ch.viscosity;
  // A point is fluid when it is inside by more than rounding: points on a wall (the 45 degree
  // walls pass through cell centres and corners) are wall on both sides of the axis, whatever
  // the last bit of their coordinates, so the grid and the field stay mirror-symmetric.
  auto fluid_xy = [geo, walls, dx](double x, double y) { return geo->inside(x, y) && walls->nearest(x, y).distance > 1e-9 * dx; };
  if (ch.embedded_walls) g.fluid_at = [fluid_xy, x0, y0, dx](double X, double Y) { return fluid_xy(x0 + X * dx, y0 + Y * dx); };
  g.fluid.assign(std::size_t(g.nx) * g.ny * g.nz, 0);
  for (int i = 0; i < g.nx; ++i)
    for (int j = 0; j < g.ny; ++j) {
      const bool in = fluid_xy(x0 + (i + 0.5) * dx, y0 + (j + 0.5) * dx);
      for (int k = 0; k < g.nz; ++k) g.fluid[(std::size_t(i) * g.ny + j) * g.nz + k] = in;
    }
  std::vector<char> first(g.fluid.begin(), g.fluid.begin() + g.ny * g.nz);
  std::vector<char> last(g.fluid.end() - g.ny * g.nz, g.fluid.end());
  if (first != last)
    throw ConfigError(cfg.source + ": key 'flow.solve_half_length': the solve region must end where the channel has "
                      "the same cross-section at both ends");
  const double W = cfg.hi[1] - cfg.lo[1], H = cfg.hi[2] - cfg.lo[2];
  g.inflow = duct_profile(g.ny, g.nz, dx, first, ch.mean_velocity * W * H);
  return g;
}

namespace {

struct Solved {
  std::vector<double> u, v, w;  // nodes of the solve region (nx+1)(ny+1)(nz+1)
  FlowReport report;
};

Solved compute(const Config& cfg, const SolveBox& b) {
  const ChannelConfig& ch = cfg.get<ChannelConfig>();
  const ChannelGeometry geo(ch);
  const WallDistance walls(ch);
  const StokesGrid g = channel_stokes_grid(cfg, b.x0, b.nx, b.dx);
  const double W = cfg.hi[1] - cfg.lo[1], H = cfg.hi[2] - cfg.lo[2];
  const double Q = ch.mean_velocity * W * H;
  const StokesSolution s = solve_stokes(g);

  Solved out;
  FlowReport& r = out.report;
  r.solve_seconds = s.seconds;
  r.iterations = s.iterations;
  r.residual = s.residual;
  r.max_divergence = s.max_divergence;
  const int nx = b.nx, ny = b.ny, nz = b.nz;
  auto U = [&](int i, int j, int k) { return s.u[(std::size_t(i) * ny + j) * nz + k]; };
  auto V = [&](int i, int j, int k) { return s.v[(std::size_t(i) * (ny + 1) + j) * nz + k]; };
  auto Wf = [&](int i, int j, int k) { return s.w[(std::size_t(i) * ny + j) * (nz + 1) + k]; };
  auto fluid = [&](int i, int j, int k) {
    return i >= 0 && i < nx && j >= 0 && j < ny && k >= 0 && k < nz && g.fluid[(std::size_t(i) * ny + j) * nz + k];
  };
  // Flow rate through every cross-section of faces.
  for (int i = 0; i <= nx; ++i) {
    double q = 0;
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) q += U(i, j, k) * b.dx * b.dx;
    r.flux_error = std::max(r.flux_error, std::abs(q - Q) / Q);
  }
  const int ineck = static_cast<int>(std::lround((ch.neck_x0 - b.x0) / b.dx));
  {
    double q = 0;
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) q += U(ineck, j, k) * b.dx * b.dx;
    r.neck_mean_over_mean = q / (ch.neck_width * H) / ch.mean_velocity;
  }
  // Far field: the face plane 4 D upstream of the neck against the series.
  const DuctFlow duct(W, H, ch.mean_velocity, ch.series_terms);
  const int ifar = std::max(0, ineck - static_cast<int>(std::lround(4 * ch.neck_width / b.dx)));
  double e2 = 0, n2 = 0;
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nz; ++k) {
      const double exact = duct.velocity(b.y0 + (j + 0.5) * b.dx - (cfg.lo[1] + 0.5 * W), (k + 0.5) * b.dx);
      e2 += (U(ifar, j, k) - exact) * (U(ifar, j, k) - exact);
      n2 += exact * exact;
    }
  r.far_field_error = std::sqrt(e2 / n2);

  // Node values. Interior nodes (all eight cells around them fluid): each component
  // interpolated from its faces to the node, along each of the two directions across it, with
  // the fourth-order midpoint rule (-1, 9, 9, -1)/16; at the floor, the ceiling and any wall on
  // a cell face the faces beyond are mirrored (u = 0 on the wall); where an angled wall cuts the
  // stencil, the two-point mean. (The two-point mean everywhere, as before, put the nodes 1.5 %
  // (x) per direction below the faces at 10 cells per D: the sampled flow rate fell 6.5 % short
  // in the neck.) Nodes on the floor and ceiling: zero. Nodes next to a side wall, on either
  // side of it: the velocity that vanishes linearly at the wall, taken from the interior at
  // L = 2.5 cells along the wall normal, u(p) = u(foot + L n) s / L with s the signed distance
  // from the wall (negative behind it: a ghost value, so that interpolating between the nodes
  // puts the zero on the wall itself, not on the staircase).
  const std::size_t nn = std::size_t(nx + 1) * (ny + 1) * (nz + 1);
  out.u.assign(nn, 0.0); out.v.assign(nn, 0.0); out.w.assign(nn, 0.0);
  std::vector<char> interior(nn, 0);
  auto node = [&](int i, int j, int k) { return (std::size_t(i) * (ny + 1) + j) * (nz + 1) + k; };
  // Faces (cell rows) and weights across one direction, for the node between rows c - 1 and c:
  // rows c - 2 .. c + 1; a row is `open` when its face is fluid, `flat_wall(r, toward)` when a
  // wall lies on the face between solid row r and its neighbour toward the node.
  struct Stencil { int row[4]; double w[4]; };
  auto stencil = [](int c, int n, const std::function<bool(int)>& open, const std::function<bool(int, int)>& flat_wall,
                    bool mirror_outside) {
    Stencil st{{c - 2, c - 1, c, c + 1}, {-1.0 / 16, 9.0 / 16, 9.0 / 16, -1.0 / 16}};
    for (int e : {0, 3}) {
      const int r = st.row[e], inner = e == 0 ? c - 1 : c;
      if (r >= 0 && r < n && open(r)) continue;
      const bool outside = r < 0 || r >= n;
      if ((outside && mirror_outside) || (!outside && flat_wall(r, inner))) { st.row[e] = inner; st.w[e] = 1.0 / 16; }
      else return Stencil{{c - 1, c - 1, c, c}, {0, 0.5, 0.5, 0}};  // the two-point mean
    }
    return st;
  };
  auto x_of = [&](int i) { return b.x0 + i * b.dx; };
  auto y_of = [&](int j) { return b.y0 + j * b.dx; };
  // A wall on the y face between rows r and inner at x: the wall passes through that face's line.
  auto flat_y = [&](double x, int r, int inner) {
    return walls.nearest(x, y_of(std::max(r, inner))).distance < 1e-9 * b.dx;
  };
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ny; ++j)
      for (int k = 0; k <= nz; ++k) {
        bool wall = false;
        for (int dj = -1; dj <= 0; ++dj)
          for (int dk = -1; dk <= 0; ++dk)
            for (int di = -1; di <= 0; ++di) {
              const int ii = std::clamp(i + di, 0, nx - 1);  // beyond the ends: the straight duct
              if (!fluid(ii, j + dj, k + dk)) wall = true;
            }
        if (wall) continue;
        const std::size_t n = node(i, j, k);
        interior[n] = 1;
        const int ia = std::clamp(i - 1, 0, nx - 1), ib = std::clamp(i, 0, nx - 1);
        const Stencil sz = stencil(k, nz, [](int) { return true; }, [](int, int) { return true; }, true);
        // u: across y and z.
        const Stencil suy = stencil(j, ny, [&](int r) { return fluid(ia, r, k) && fluid(ib, r, k); },
                                    [&](int r, int inner) { return flat_y(x_of(i), r, inner); }, true);
        double u = 0;
        for (int p = 0; p < 4; ++p)
          for (int q = 0; q < 4; ++q) u += suy.w[p] * sz.w[q] * U(i, suy.row[p], sz.row[q]);
        out.u[n] = u;
        // v: across x and z; w: across x and y. Beyond the solve region's ends v = w = 0.
        const Stencil sx = stencil(i, nx, [&](int r) { return fluid(r, j - 1, k) && fluid(r, j, k); },
                                   [](int, int) { return false; }, false);
        double v = 0, wz = 0;
        for (int p = 0; p < 4; ++p) {
          if (sx.row[p] < 0 || sx.row[p] >= nx) continue;
          for (int q = 0; q < 4; ++q) v += sx.w[p] * sz.w[q] * V(sx.row[p], j, sz.row[q]);
          const int r = sx.row[p];
          const Stencil swy = stencil(j, ny, [&](int jr) { return fluid(r, jr, k); },
                                      [&](int jr, int inner) { return flat_y(x_of(r) + 0.5 * b.dx, jr, inner); }, true);
          for (int q = 0; q < 4; ++q) wz += sx.w[p] * swy.w[q] * Wf(r, swy.row[q], k);
        }
        out.v[n] = v;
        out.w[n] = wz;
      }
  for (int i = 0; i <= (ch.embedded_walls ? nx : -1); ++i)
    for (int j = 0; j <= ny; ++j) {
      const double x = b.x0 + i * b.dx, y = b.y0 + j * b.dx;
      const WallPoint w = walls.nearest(x, y);
      const double s = geo.inside(x, y) ? w.distance : -w.distance;
      if (w.distance > 1.5 * b.dx) continue;
      double nxw = w.nx, nyw = w.ny;  // unit normal into the fluid: radial from the foot, or the face's
      if (w.distance > 1e-9 * b.dx) { nxw = (x - w.x) / s; nyw = (y - w.y) / s; }
      // Bilinear weights of the point L along the normal, if its four nodes are interior.
      for (double L : {2.5 * b.dx, 3.5 * b.dx}) {
        const double X = (w.x + L * nxw - b.x0) / b.dx, Y = (w.y + L * nyw - b.y0) / b.dx;
        const int ci = static_cast<int>(std::floor(X)), cj = static_cast<int>(std::floor(Y));
        if (ci < 0 || ci >= nx || cj < 0 || cj >= ny) continue;
        const double fx = X - ci, fy = Y - cj;
        const double wt[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
        const int at[4][2] = {{ci, cj}, {ci + 1, cj}, {ci, cj + 1}, {ci + 1, cj + 1}};
        bool ok = true;
        for (int k = 1; k < nz && ok; ++k)
          for (const auto& q : at) ok = ok && interior[node(q[0], q[1], k)];
        if (!ok) continue;
        for (int k = 1; k < nz; ++k) {
          const std::size_t n = node(i, j, k);
          if (interior[n] && s > 0) break;  // inside the fluid's staircase: the faces are better
          double u = 0, v = 0, wz = 0;
          for (int c = 0; c < 4; ++c) {
            const std::size_t m = node(at[c][0], at[c][1], k);
            u += wt[c] * out.u[m]; v += wt[c] * out.v[m]; wz += wt[c] * out.w[m];
          }
          out.u[n] = u * s / L; out.v[n] = v * s / L; out.w[n] = wz * s / L;
        }
        break;
      }
    }
  // Far-field centre-line over mean, from the node on the centre line 4 D upstream.
  const std::size_t centre = (std::size_t(ifar) * (ny + 1) + ny / 2) * (nz + 1) + nz / 2;
  r.centre_over_mean = out.u[centre] / ch.mean_velocity;
  return out;
}

void write_cache(const std::string& file, const std::string& key, const SolveBox& b, const Solved& s) {
  const std::string tmp = file + ".partial";
  {
    Handle f(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, "create " + tmp);
    const hsize_t dims[3] = {hsize_t(b.nx + 1), hsize_t(b.ny + 1), hsize_t(b.nz + 1)};
    for (auto [name, data] : {std::pair{"u", &s.u}, std::pair{"v", &s.v}, std::pair{"w", &s.w}}) {
      Handle space(H5Screate_simple(3, dims, nullptr), H5Sclose, "space");
      Handle d(H5Dcreate2(f, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose, name);
      check(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data->data()), name);
    }
    h5::attr_string(f, "key", key);
    h5::attr_string(f, "layout", "node velocities [i][j][k] at (x0 + i dx, y0 + j dx, z0 + k dx), SI units");
    const FlowReport& r = s.report;
    h5::attr_array<double>(f, "origin_and_spacing", H5T_NATIVE_DOUBLE, {b.x0, b.y0, b.z0, b.dx});
    h5::attr_array<double>(f, "report", H5T_NATIVE_DOUBLE,
                           {r.solve_seconds, double(r.iterations), r.residual, r.max_divergence, r.flux_error,
                            r.far_field_error, r.centre_over_mean, r.neck_mean_over_mean});
  }
  fs::rename(tmp, file);
}

bool read_cache(const std::string& file, const std::string& key, Solved& s) {
  if (!fs::exists(file)) return false;
  H5E_BEGIN_TRY {
    hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return false;
    Handle fh(f, H5Fclose, "open");
    Handle a(H5Aopen(fh, "key", H5P_DEFAULT), H5Aclose, "key");
    Handle t(H5Aget_type(a), H5Tclose, "type");
    std::string stored(H5Tget_size(t), '\0');
    check(H5Aread(a, t, stored.data()), "read key");
    stored.resize(std::strlen(stored.c_str()));
    if (stored != key) return false;  // a hash collision or a stale file: recompute
    for (auto [name, data] : {std::pair{"u", &s.u}, std::pair{"v", &s.v}, std::pair{"w", &s.w}}) {
      Handle d(H5Dopen2(fh, name, H5P_DEFAULT), H5Dclose, name);
      Handle sp(H5Dget_space(d), H5Sclose, "space");
      data->resize(H5Sget_simple_extent_npoints(sp));
      check(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data->data()), name);
    }
    Handle r(H5Aopen(fh, "report", H5P_DEFAULT), H5Aclose, "report");
    double v[8];
    check(H5Aread(r, H5T_NATIVE_DOUBLE, v), "report");
    s.report = {v[0], int(v[1]), v[2], v[3], v[4], v[5], v[6], v[7], true};
  } H5E_END_TRY;
  return true;
}

}  // namespace

FlowField::FlowField(const Config& cfg, MPI_Comm comm) {
  const ChannelConfig& ch = cfg.get<ChannelConfig>();
  const SolveBox b = solve_box(cfg);
  const std::string key = cache_key(cfg, b);
  std::ostringstream name;
  name << ch.cache_dir << "/flow_" << std::hex << std::hash<std::string>{}(key) << ".h5";
  cache_file_ = name.str();
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  Solved s;
  if (rank == 0 && !read_cache(cache_file_, key, s)) {
    s = compute(cfg, b);
    std::error_code ec;
    fs::create_directories(ch.cache_dir, ec);
    try {
      write_cache(cache_file_, key, b, s);
    } catch (const std::exception&) {
      // A read-only case directory only costs the next run the solve again.
    }
  }
  MPI_Barrier(comm);
  if (rank != 0 && !read_cache(cache_file_, key, s)) s = compute(cfg, b);  // cache not writable
  report_ = s.report;

  // Nodes over the whole domain: the solve's nodes, and the duct series outside them.
  dx_ = b.dx;
  nodes_.inv_dx = 1 / b.dx;
  const int ilo = static_cast<int>(std::floor((cfg.lo[0] - b.x0) / b.dx)) - 1;
  const int ihi = std::max(static_cast<int>(std::ceil((cfg.hi[0] - b.x0) / b.dx)) + 1, b.nx);
  const int first = std::min(ilo, 0);
  int* n_ = nodes_.n;
  n_[0] = ihi - first + 1;
  n_[1] = b.ny + 1;
  n_[2] = b.nz + 1;
  nodes_.origin = Vec3(b.x0 + first * b.dx, b.y0, b.z0);
  const std::size_t plane = std::size_t(n_[1]) * n_[2];
  std::vector<Vec3>& node_ = nodes_.node;
  node_.assign(n_[0] * plane, Vec3::Zero());
  const double W = cfg.hi[1] - cfg.lo[1];
  const DuctFlow duct(W, cfg.hi[2] - cfg.lo[2], ch.mean_velocity, ch.series_terms);
  std::vector<double> series(plane);
  for (int j = 0; j < n_[1]; ++j)
    for (int k = 0; k < n_[2]; ++k) series[j * n_[2] + k] = duct.velocity(j * b.dx - 0.5 * W, k * b.dx);
  for (int i = 0; i < n_[0]; ++i) {
    const int is = i + first;  // index in the solve region
    const std::size_t at = i * plane;
    if (is >= 0 && is <= b.nx) {
      for (std::size_t n = 0; n < plane; ++n) node_[at + n] = Vec3(s.u[is * plane + n], s.v[is * plane + n], s.w[is * plane + n]);
    } else {
      for (std::size_t n = 0; n < plane; ++n) node_[at + n][0] = series[n];
    }
  }
}

Vec3 NodeField::at(const Vec3& x) const {
  double f[3];
  int c[3];
  for (int d = 0; d < 3; ++d) {
    const double s = std::clamp((x[d] - origin[d]) * inv_dx, 0.0, double(n[d] - 1) - 1e-9);
    c[d] = static_cast<int>(s);
    f[d] = s - c[d];
  }
  // Trilinear as nested linear interpolations: z, then y, then x.
  const std::size_t sz = 1, sy = n[2], sx = std::size_t(n[1]) * n[2];
  const Vec3* p = &node[c[0] * sx + c[1] * sy + c[2]];
  auto lerp = [](const Vec3& a, const Vec3& b, double t) { return a + t * (b - a); };
  const Vec3 y0 = lerp(lerp(p[0], p[sz], f[2]), lerp(p[sy], p[sy + sz], f[2]), f[1]);
  const Vec3 y1 = lerp(lerp(p[sx], p[sx + sz], f[2]), lerp(p[sx + sy], p[sx + sy + sz], f[2]), f[1]);
  return lerp(y0, y1, f[0]);
}

}  // namespace cassini
