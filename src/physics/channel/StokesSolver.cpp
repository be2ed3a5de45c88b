#include "physics/channel/StokesSolver.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "physics/channel/SparseCholesky.hpp"

namespace cassini {
namespace {

using SpMat = Eigen::SparseMatrix<double>;
using Triplet = Eigen::Triplet<double>;
using Vec = Eigen::VectorXd;

// One velocity component on its faces: which faces are unknowns, and their numbering.
struct Component {
  int axis;
  int n[3];                  // face counts per direction
  std::vector<int> unknown;  // face -> unknown index, or -1
  std::vector<double> known; // prescribed value of faces that are not unknowns
  int count = 0;
  int index(int i, int j, int k) const { return (i * n[1] + j) * n[2] + k; }
};

// Position of face (i, j, k) of component a, in cell units from the box's low corner.
std::array<double, 3> face_centre(int a, int i, int j, int k) {
  std::array<double, 3> p = {i + 0.5, j + 0.5, k + 0.5};
  p[a] -= 0.5;
  return p;
}

// Distance in cells from p along direction d (0: x, 1: y) with sign s to the first wall
// point, if one lies within `reach` cells (scan at 1/16 cell, then bisection); else -1.
double wall_distance(const std::function<bool(double, double)>& fluid_at, const std::array<double, 3>& p, int d, int s,
                     double reach) {
  auto fluid = [&](double t) {
    return fluid_at(p[0] + (d == 0 ? s * t : 0.0), p[1] + (d == 1 ? s * t : 0.0));
  };
  const double h = 1.0 / 16;
  for (double t = h; t <= reach + 1e-12; t += h) {
    if (fluid(t)) continue;
    double lo = t - h, hi = t;
    for (int it = 0; it < 40; ++it) (fluid(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
  }
  return -1;
}

}  // namespace

std::vector<double> duct_profile(int ny, int nz, double dx, const std::vector<char>& fluid, double q) {
  std::vector<int> id(ny * nz, -1);
  int m = 0;
  for (int c = 0; c < ny * nz; ++c)
    if (fluid[c]) id[c] = m++;
  std::vector<Triplet> t;
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nz; ++k) {
      const int r = id[j * nz + k];
      if (r < 0) continue;
      double diag = 0;
      const int nb[4][2] = {{j - 1, k}, {j + 1, k}, {j, k - 1}, {j, k + 1}};
      for (const auto& b : nb) {
        const bool in = b[0] >= 0 && b[0] < ny && b[1] >= 0 && b[1] < nz && id[b[0] * nz + b[1]] >= 0;
        if (in) { diag += 1; t.emplace_back(r, id[b[0] * nz + b[1]], -1.0); }
        else diag += 2;  // wall half a cell away: ghost value -u
      }
      t.emplace_back(r, r, diag);
    }
  SpMat A(m, m);
  A.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<SpMat> ldlt(A);
  Vec u = ldlt.solve(Vec::Ones(m));
  const double flux = u.sum() * dx * dx;
  std::vector<double> out(ny * nz, 0.0);
  for (int c = 0; c < ny * nz; ++c)
    if (id[c] >= 0) out[c] = u[id[c]] * q / flux;
  return out;
}

struct StokesProblem::Impl {
  StokesGrid g;
  Component comp[3];
  SpMat laplacian[3];  // eta / dx^2 times the velocity Laplacian, without the Brinkman term
  SpMat A[3];          // what is factorised: the Laplacian plus the Brinkman diagonal
  Vec inflow_rhs[3];   // the prescribed inflow's part of the right-hand side, per unit inflow
  SpMat Dm[3];         // divergence, fluid cells x unknown faces
  Vec inflow_div;      // the prescribed faces' part of the divergence
  std::vector<int> pid;  // cell -> pressure unknown, or -1
  int np = 0;
  bool repeatable = false;
  std::unique_ptr<SparseCholesky> velocity[3];  // supernodal, or simplicial where repeatable
  // With a Brinkman term S is no longer well conditioned (its eigenvalues fall as 1 / B in a
  // dense pile): CG is then preconditioned by D diag(A)^-1 D^T, a variable-coefficient pressure
  // Poisson operator that carries the same 1 / (eta / dx^2 + B) weights.
  bool preconditioned = false, poisson_analysed = false;
  Eigen::SimplicialLLT<SpMat> pressure_poisson;
  Vec solve_velocity(int a, const Vec& rhs) const { return velocity[a]->solve(rhs); }
  int cell(int i, int j, int k) const { return (i * g.ny + j) * g.nz + k; }
  // f(unknown, the cell below the face, the cell above it) for every unknown face of component a.
  template <class F> void for_unknown_faces(int a, F&& f) const {
    const Component& c = comp[a];
    for (int i = 0; i < c.n[0]; ++i)
      for (int j = 0; j < c.n[1]; ++j)
        for (int k = 0; k < c.n[2]; ++k) {
          const int r = c.unknown[c.index(i, j, k)];
          if (r < 0) continue;
          int lo[3] = {i, j, k};
          lo[a] -= 1;
          f(r, cell(lo[0], lo[1], lo[2]), cell(i, j, k));
        }
  }
};

StokesProblem::~StokesProblem() = default;

StokesProblem::StokesProblem(const StokesGrid& g, bool repeatable) : m_(std::make_unique<Impl>()) {
  Impl& m = *m_;
  m.g = g;
  m.repeatable = repeatable;
  const int nx = g.nx, ny = g.ny, nz = g.nz;
  auto fluid = [&](int i, int j, int k) {
    return i >= 0 && i < nx && j >= 0 && j < ny && k >= 0 && k < nz && g.fluid[m.cell(i, j, k)];
  };

  // ---- unknowns: faces between two fluid cells; inflow/outflow faces are prescribed.
  for (int a = 0; a < 3; ++a) {
    Component& c = m.comp[a];
    c.axis = a;
    c.n[0] = nx + (a == 0);
    c.n[1] = ny + (a == 1);
    c.n[2] = nz + (a == 2);
    c.unknown.assign(c.n[0] * c.n[1] * c.n[2], -1);
    c.known.assign(c.unknown.size(), 0.0);
    for (int i = 0; i < c.n[0]; ++i)
      for (int j = 0; j < c.n[1]; ++j)
        for (int k = 0; k < c.n[2]; ++k) {
          int lo[3] = {i, j, k};
          lo[a] -= 1;  // the cell on the low side of this face
          const bool below = fluid(lo[0], lo[1], lo[2]), above = fluid(i, j, k);
          if (a == 0 && (i == 0 || i == nx)) {  // inflow / outflow
            if (below || above) c.known[c.index(i, j, k)] = g.inflow[j * nz + k];
          } else if (below && above) {
            const auto p = face_centre(a, i, j, k);
            if (!g.fluid_at || g.fluid_at(p[0], p[1])) c.unknown[c.index(i, j, k)] = c.count++;
          }
        }
  }

  // ---- velocity Laplacians (times eta / dx^2) and their right-hand sides.
  const double scale = g.viscosity / (g.dx * g.dx);
  for (int a = 0; a < 3; ++a) {
    Component& c = m.comp[a];
    std::vector<Triplet> t;
    Vec& b = m.inflow_rhs[a];
    b = Vec::Zero(c.count);
    for (int i = 0; i < c.n[0]; ++i)
      for (int j = 0; j < c.n[1]; ++j)
        for (int k = 0; k < c.n[2]; ++k) {
          const int r = c.unknown[c.index(i, j, k)];
          if (r < 0) continue;
          double diag = 0;
          for (int d = 0; d < 3; ++d)
            for (int s = -1; s <= 1; s += 2) {
              int q[3] = {i, j, k};
              q[d] += s;
              const bool in = q[d] >= 0 && q[d] < c.n[d];
              const int nb = in ? c.unknown[c.index(q[0], q[1], q[2])] : -1;
              const bool inflow = a == 0 && d == 0 && in && (q[0] == 0 || q[0] == nx);
              double theta = -1;  // the wall's true distance in cells, where it cuts the cells
              if (nb < 0 && !inflow && d < 2 && g.fluid_at) theta = wall_distance(g.fluid_at, face_centre(a, i, j, k), d, s, 2.0);
              if (nb >= 0) { diag += 1; t.emplace_back(r, nb, -scale); }
              else if (theta > 0) diag += 1 / std::max(theta, 1e-3);  // no-slip at the wall itself
              else if (d == a) { diag += 1; b[r] += scale * (in ? c.known[c.index(q[0], q[1], q[2])] : 0.0); }
              else diag += 2;  // tangential neighbour behind a wall: no-slip half a cell away
            }
          t.emplace_back(r, r, diag * scale);
        }
    m.laplacian[a].resize(c.count, c.count);
    m.laplacian[a].setFromTriplets(t.begin(), t.end());
  }

  // ---- divergence D (fluid cells x unknown faces) and its prescribed part.
  m.pid.assign(nx * ny * nz, -1);
  for (int c = 0; c < nx * ny * nz; ++c)
    if (g.fluid[c]) m.pid[c] = m.np++;
  m.inflow_div = Vec::Zero(m.np);
  for (int a = 0; a < 3; ++a) {
    const Component& c = m.comp[a];
    std::vector<Triplet> t;
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j)
        for (int k = 0; k < nz; ++k) {
          const int r = m.pid[m.cell(i, j, k)];
          if (r < 0) continue;
          int hi[3] = {i, j, k};
          hi[a] += 1;
          const int fl = c.index(i, j, k), fh = c.index(hi[0], hi[1], hi[2]);
          for (auto [f, sign] : {std::pair{fl, -1.0}, std::pair{fh, 1.0}}) {
            if (c.unknown[f] >= 0) t.emplace_back(r, c.unknown[f], sign / g.dx);
            else m.inflow_div[r] -= sign * c.known[f] / g.dx;
          }
        }
    m.Dm[a].resize(m.np, c.count);
    m.Dm[a].setFromTriplets(t.begin(), t.end());
  }
  for (int a = 0; a < 3; ++a) {
    m.A[a] = m.laplacian[a];
    m.velocity[a] = repeatable ? make_simplicial_cholesky() : make_supernodal_cholesky();
    m.velocity[a]->analyze(m.A[a]);
  }
  set_brinkman({});
}

void StokesProblem::set_brinkman(const std::vector<double>& per_cell, bool refresh_preconditioner) {
  Impl& m = *m_;
  const bool had_preconditioner = m.preconditioned;
  m.preconditioned = !per_cell.empty();
  for (int a = 0; a < 3; ++a) {
    if (!per_cell.empty()) {
      // A face's coefficient is the mean of the two cells it separates (both fluid).
      m.A[a] = m.laplacian[a];
      m.for_unknown_faces(a, [&](int r, int below, int above) {
        m.A[a].coeffRef(r, r) += 0.5 * (per_cell[below] + per_cell[above]);
      });
    }
    if (!m.velocity[a]->factorize(m.A[a])) throw std::runtime_error("Stokes solve: velocity operator not positive definite");
  }
  if (!m.preconditioned || (had_preconditioner && !refresh_preconditioner)) return;
  SpMat P(m.np, m.np);
  for (int a = 0; a < 3; ++a) {
    Vec inverse_diagonal = m.A[a].diagonal().cwiseInverse();
    P += m.Dm[a] * inverse_diagonal.asDiagonal() * SpMat(m.Dm[a].transpose());
  }
  // The pure-Neumann operator is singular (constant pressures): a shift of 1e-10 of its diagonal
  // makes it definite; the constant part of the preconditioned residual is projected out.
  const double shift = 1e-10 * P.diagonal().mean();
  for (int c = 0; c < m.np; ++c) P.coeffRef(c, c) += shift;
  if (!m.poisson_analysed) { m.pressure_poisson.analyzePattern(P); m.poisson_analysed = true; }
  m.pressure_poisson.factorize(P);
  if (m.pressure_poisson.info() != Eigen::Success) throw std::runtime_error("Stokes solve: pressure preconditioner failed");
}

StokesSolution StokesProblem::solve(double inflow_scale, const std::vector<double>* force, double tolerance,
                                    int max_iterations, const std::vector<double>* pressure_guess) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *m_;
  const StokesGrid& g = m.g;
  const int nx = g.nx, ny = g.ny, nz = g.nz, np = m.np;
  // Right-hand sides: the inflow's part, and the body force (the mean of the two cells).
  Vec b[3];
  for (int a = 0; a < 3; ++a) {
    b[a] = inflow_scale == 1 ? m.inflow_rhs[a] : Vec(inflow_scale * m.inflow_rhs[a]);
    if (!force) continue;
    m.for_unknown_faces(a, [&](int r, int below, int above) {
      b[a][r] += 0.5 * ((*force)[3 * below + a] + (*force)[3 * above + a]);
    });
  }
  auto velocity = [&](const Vec& p, Vec* U) {  // U = A^-1 (b + D^T p)
    for (int a = 0; a < 3; ++a) U[a] = m.solve_velocity(a, b[a] + m.Dm[a].transpose() * p);
  };
  auto schur = [&](const Vec& p, Vec* Y = nullptr) {  // S p = D A^-1 D^T p; Y: A^-1 D^T p
    Vec out = Vec::Zero(np);
    for (int a = 0; a < 3; ++a) {
      Vec y = m.solve_velocity(a, m.Dm[a].transpose() * p);
      out += m.Dm[a] * y;
      if (Y) Y[a] = std::move(y);
    }
    return out;
  };
  // With a Brinkman term (the coupled re-solves) the velocity is carried along with p, U = A^-1 b
  // + sum alpha A^-1 D^T dir, from the solves each iteration makes anyway: no final velocity
  // solve. The plain solve computes it at the end, as it always has (its cached fields keep their bits).
  const bool track = m.preconditioned;
  Vec U[3], Y[3];

  // ---- CG on S p = c - D A^-1 b; the pressure is fixed up to a constant (kept at mean 0).
  Vec r = inflow_scale == 1 ? m.inflow_div : Vec(inflow_scale * m.inflow_div);
  velocity(Vec::Zero(np), U);
  for (int a = 0; a < 3; ++a) r -= m.Dm[a] * U[a];
  r.array() -= r.mean();
  Vec p = Vec::Zero(np);
  const double norm0 = std::max(r.norm(), 1e-300);  // the tolerance is relative to a cold start's residual
  if (pressure_guess) {
    for (int c = 0; c < nx * ny * nz; ++c)
      if (m.pid[c] >= 0) p[m.pid[c]] = (*pressure_guess)[c];
    r -= schur(p, Y);
    r.array() -= r.mean();
    if (track)
      for (int a = 0; a < 3; ++a) U[a] += Y[a];
  }
  StokesSolution sol;
  int it = 0;
  if (!m.preconditioned) {
    Vec dir = r;
    double rr = r.squaredNorm();
    for (; it < max_iterations && std::sqrt(rr) > tolerance * norm0; ++it) {
      Vec Sd = schur(dir);
      const double alpha = rr / dir.dot(Sd);
      p += alpha * dir;
      r -= alpha * Sd;
      r.array() -= r.mean();
      const double rr_new = r.squaredNorm();
      dir = r + (rr_new / rr) * dir;
      rr = rr_new;
    }
  } else {
    auto precondition = [&](const Vec& x) {
      Vec z = m.pressure_poisson.solve(x);
      z.array() -= z.mean();
      return z;
    };
    Vec z = precondition(r), dir = z;
    double rz = r.dot(z);
    for (; it < max_iterations && r.norm() > tolerance * norm0; ++it) {
      Vec Sd = schur(dir, Y);
      const double alpha = rz / dir.dot(Sd);
      p += alpha * dir;
      for (int a = 0; a < 3; ++a) U[a] += alpha * Y[a];
      r -= alpha * Sd;
      r.array() -= r.mean();
      z = precondition(r);
      const double rz_new = r.dot(z);
      dir = z + (rz_new / rz) * dir;
      rz = rz_new;
    }
  }
  sol.iterations = it;
  sol.residual = r.norm() / norm0;

  if (!track) velocity(p, U);
  std::vector<double>* out[3] = {&sol.u, &sol.v, &sol.w};
  for (int a = 0; a < 3; ++a) {
    const Component& c = m.comp[a];
    out[a]->assign(c.unknown.size(), 0.0);
    for (std::size_t f = 0; f < c.unknown.size(); ++f)
      (*out[a])[f] = c.unknown[f] >= 0 ? U[a][c.unknown[f]] : inflow_scale * c.known[f];
  }
  sol.p.assign(nx * ny * nz, 0.0);
  for (int c = 0; c < nx * ny * nz; ++c)
    if (m.pid[c] >= 0) sol.p[c] = p[m.pid[c]];
  // Pressure drop between the first and the last layer of cells (means over their fluid cells).
  double p_in = 0, p_out = 0;
  int n_in = 0, n_out = 0;
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nz; ++k) {
      if (g.fluid[m.cell(0, j, k)]) { p_in += sol.p[m.cell(0, j, k)]; ++n_in; }
      if (g.fluid[m.cell(nx - 1, j, k)]) { p_out += sol.p[m.cell(nx - 1, j, k)]; ++n_out; }
    }
  sol.pressure_drop = p_in / std::max(n_in, 1) - p_out / std::max(n_out, 1);
  // Discrete divergence of the final field, relative to the inflow scale.
  double umax = 1e-300;
  for (double x : g.inflow) umax = std::max(umax, std::abs(inflow_scale * x));
  const Component* comp = m.comp;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        if (!g.fluid[m.cell(i, j, k)]) continue;
        const double div = sol.u[comp[0].index(i + 1, j, k)] - sol.u[comp[0].index(i, j, k)] +
                           sol.v[comp[1].index(i, j + 1, k)] - sol.v[comp[1].index(i, j, k)] +
                           sol.w[comp[2].index(i, j, k + 1)] - sol.w[comp[2].index(i, j, k)];
        sol.max_divergence = std::max(sol.max_divergence, std::abs(div) / umax);
      }
  sol.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sol;
}

StokesSolution solve_stokes(const StokesGrid& g, double tolerance, int max_iterations) {
  const auto t0 = std::chrono::steady_clock::now();
  StokesSolution s = StokesProblem(g).solve(1.0, nullptr, tolerance, max_iterations);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace cassini
