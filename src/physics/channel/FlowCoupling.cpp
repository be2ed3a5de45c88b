#include "physics/channel/FlowCoupling.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/CaseFile.hpp"
#include "physics/channel/ChannelConfig.hpp"

namespace cassini {
namespace {
// Relative CG residual of the coarse solves (to a cold start's): the correction then lies within
// ~1e-4 of the converged one, far inside the re-solve tolerance (5 % of the forcing).
constexpr double kSolveTolerance = 1e-4;
constexpr int kMaxIterations = 5000;
constexpr int kPreconditionerAge = 16;  // solves between rebuilds of CG's preconditioner, at most
constexpr int kChannels = 7;              // deposited per bead and layer: beta, beta v, beta U0(x_i)
}

FlowCoupling::FlowCoupling(const Config& cfg)
    : pressure_drive_(cfg.get<ChannelConfig>().pressure_drive), tolerance_(cfg.get<ChannelConfig>().coupling_tolerance) {
  const ChannelConfig& ch = cfg.get<ChannelConfig>();
  const double dx = ch.neck_width / ch.coupling_resolution;
  const double cells = (cfg.hi[0] - cfg.lo[0]) / dx;
  const int nx = static_cast<int>(std::lround(cells));
  for (double n : {cells, (cfg.hi[1] - cfg.lo[1]) / dx, (cfg.hi[2] - cfg.lo[2]) / dx})
    if (std::abs(n - std::lround(n)) > 1e-6 || n < 2)
      throw ConfigError(cfg.source + ": key 'flow.coupling_resolution': the domain's length, width and height must be "
                        "whole numbers of coupling cells (D / coupling_resolution = " + std::to_string(dx) + " m), at least 2");
  grid_ = channel_stokes_grid(cfg, cfg.lo[0], nx, dx);
  problem_ = std::make_unique<StokesProblem>(grid_, /*repeatable=*/true);
  clean_ = problem_->solve(1.0, nullptr);  // once: to the default 1e-10
  dp0_ = clean_.pressure_drop;
  q0_ = ch.mean_velocity * (cfg.hi[1] - cfg.lo[1]) * (cfg.hi[2] - cfg.lo[2]);
  pressure_drop_ = dp0_;

  const int ny = grid_.ny, nz = grid_.nz;
  const std::size_t cells_n = std::size_t(nx) * ny * nz;
  clean_at_cell_.assign(3 * cells_n, 0.0);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        const std::size_t c = (std::size_t(i) * ny + j) * nz + k;
        clean_at_cell_[3 * c + 0] = 0.5 * (clean_.u[c] + clean_.u[c + std::size_t(ny) * nz]);
        clean_at_cell_[3 * c + 1] = 0.5 * (clean_.v[(std::size_t(i) * (ny + 1) + j) * nz + k] +
                                           clean_.v[(std::size_t(i) * (ny + 1) + j + 1) * nz + k]);
        clean_at_cell_[3 * c + 2] = 0.5 * (clean_.w[(std::size_t(i) * ny + j) * (nz + 1) + k] +
                                           clean_.w[(std::size_t(i) * ny + j) * (nz + 1) + k + 1]);
      }
  B_.assign(cells_n, 0.0);
  S_.assign(3 * cells_n, 0.0);
  G_ = S_;
  rhs_ = S_;
  // Fixed-point quanta: no bead's beta reaches 6 pi eta D x 1e3 (f <= 78 at phi <= 0.7, / 0.3), nor
  // its speed 1e3 mean velocities.
  const double beta_unit = 6 * std::numbers::pi * ch.viscosity * ch.neck_width * 1e3;
  const double v_unit = 1e3 * ch.mean_velocity;
  for (int k = 0; k < nz; ++k)
    for (int c = 0; c < kChannels; ++c) units_.push_back(c == 0 ? beta_unit : beta_unit * v_unit);
  correction_.origin = Vec3(cfg.lo[0] + 0.5 * dx, cfg.lo[1] + 0.5 * dx, cfg.lo[2] + 0.5 * dx);  // cell centres
  correction_.inv_dx = 1 / dx;
  correction_.n[0] = nx;
  correction_.n[1] = ny;
  correction_.n[2] = nz;
  correction_.node.assign(std::size_t(nx) * ny * nz, Vec3::Zero());
}

bool FlowCoupling::update(const ParticleStore& p, const std::vector<double>& beta, const std::vector<Vec3>& one_way,
                          const VolumeFraction& kernel, double sign, bool force_solve, MPI_Comm comm) {
  // Seven channels per layer of cells (beta, beta v, beta U0(x_i)): in the plane the phi kernel,
  // across the height linear between the two layers around the bead's centre.
  const int nx = grid_.nx, ny = grid_.ny, nz = grid_.nz;
  const int channels = kChannels * nz;
  const double dx = grid_.dx;
  const double x0 = correction_.origin[0] - 0.5 * dx, y0 = correction_.origin[1] - 0.5 * dx, z0 = correction_.origin[2] - 0.5 * dx;
  values_.assign(std::size_t(channels) * p.nlocal, 0.0);
  column_.resize(channels);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double t = (p.x[i][2] - z0) / dx - 0.5;
    const int k0 = std::clamp(static_cast<int>(std::floor(t)), 0, nz - 2);
    const double f = std::clamp(t - k0, 0.0, 1.0);
    for (auto [k, w] : {std::pair{k0, 1 - f}, std::pair{k0 + 1, f}}) {
      double* v = &values_[i * channels + kChannels * k];
      v[0] = beta[i] * w * nz;  // nz: the deposit divides by the whole height, a layer is 1/nz of it
      for (int a = 0; a < 3; ++a) {
        v[1 + a] = v[0] * p.v[i][a];
        v[4 + a] = v[0] * one_way[i][a];
      }
    }
  }
  kernel.deposit(p, values_, units_, field_, comm);
  // B, S and G at the cell centres, and how far the forcing moved since the last solve: the
  // explicit part S - s G and the implicit part B times the last correction, against the size of
  // B U0 (what the beads would take if they all stood still).
  double moved = 0, size = 0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      const std::size_t c0 = (std::size_t(i) * ny + j) * nz;
      if (!grid_.fluid[c0]) continue;
      kernel.sample(field_, channels, x0 + (i + 0.5) * dx, y0 + (j + 0.5) * dx, column_.data());
      for (int k = 0; k < nz; ++k) {
        const std::size_t c = c0 + k;
        const double* at = &column_[kChannels * k];
        const double b = at[0];
        B_[c] = b;
        const Vec3& last = correction_.node[c];  // the correction's nodes are the cell centres
        for (int a = 0; a < 3; ++a) {
          S_[3 * c + a] = at[1 + a];
          G_[3 * c + a] = at[4 + a];
          if (solved_B_.empty()) continue;
          const double now = S_[3 * c + a] - drive_ * G_[3 * c + a], before = solved_S_[3 * c + a] - drive_ * solved_G_[3 * c + a];
          moved += std::abs(now - before) + std::abs((b - solved_B_[c]) * last[a]);
          size += std::abs(std::max(b, solved_B_[c]) * clean_at_cell_[3 * c + a]);
        }
      }
    }
  const bool needed = force_solve || solved_B_.empty() || sign != solved_sign_ || moved > tolerance_ * size;
  if (needed) solve(sign, !force_solve);
  return needed;
}

void FlowCoupling::solve(double sign, bool warm_start) {
  // The correction d solves -eta lap d + B d + grad p = S - s G with no flow through the ends.
  // Rate: s = sign, one solve. Pressure: d is linear in s, d = s d_G + d_S from the right-hand
  // sides -G and S (one factorisation), and s (dp0 + dp_G) + dp_S = sign dp0.
  const bool warm = warm_start && solves_ > 0;
  StokesSolution dG, dS;
  auto run = [&](bool refresh) {
    problem_->set_brinkman(B_, refresh);
    if (pressure_drive_) {
      for (std::size_t k = 0; k < G_.size(); ++k) rhs_[k] = -G_[k];
      dG = problem_->solve(0.0, &rhs_, kSolveTolerance, kMaxIterations, warm ? &pressure_G_ : nullptr);
    }
    for (std::size_t k = 0; k < G_.size(); ++k) rhs_[k] = pressure_drive_ ? S_[k] : S_[k] - sign * G_[k];
    dS = problem_->solve(0.0, &rhs_, kSolveTolerance, kMaxIterations, warm ? &pressure_S_ : nullptr);
    if (refresh) {
      ++preconditioner_builds_;
      preconditioner_age_ = 0;
      iterations_when_fresh_ = warm ? dS.iterations : -1;  // a cold solve's count is no warm one's reference
    } else if (iterations_when_fresh_ < 0) {
      iterations_when_fresh_ = dS.iterations;  // the first warm solve on a preconditioner a cold solve built
    }
    return std::max(dG.residual, dS.residual) <= kSolveTolerance;
  };
  // CG's pressure preconditioner (an assembly and a factorisation, 45 % of a re-solve's
  // factorising) is rebuilt only at a forced solve (so that a restart repeats the run's choices),
  // after kPreconditionerAge solves, or once the last solve needed 1.5x the iterations it took
  // when fresh (warm: a cold start takes several times a warm one's iterations, so a preconditioner
  // built at a cold solve is measured by the first warm solve on it); an older one costs a few
  // iterations, not accuracy (CG stops at the same residual).
  const bool refresh = !warm || ++preconditioner_age_ >= kPreconditionerAge ||
                       (iterations_when_fresh_ >= 0 && last_iterations_ > 1.5 * iterations_when_fresh_ + 2);
  if (!run(refresh) && (refresh || !run(true)))
    throw std::runtime_error("two-way coupling: the coarse Stokes-Brinkman solve did not converge in " +
                             std::to_string(kMaxIterations) + " CG iterations (relative residual " +
                             std::to_string(std::max(dG.residual, dS.residual)) + ")");
  last_iterations_ = dS.iterations;
  pressure_G_ = dG.p;
  pressure_S_ = dS.p;
  if (pressure_drive_) {
    drive_ = (sign * dp0_ - dS.pressure_drop) / (dp0_ + dG.pressure_drop);
    pressure_drop_ = drive_ * (dp0_ + dG.pressure_drop) + dS.pressure_drop;
  } else {
    drive_ = sign;
    pressure_drop_ = sign * dp0_ + dS.pressure_drop;
  }
  // The correction at the cell centres (the mean of each component's two faces), where the
  // deposit puts the beads' layers; beyond the outermost centres it is held constant. (Corner
  // nodes would halve it at the floor and ceiling: in a dense pile, where the total flow is flat
  // but for Brinkman layers far thinner than a cell, beads near the walls would feel too little.)
  const int nx = grid_.nx, ny = grid_.ny, nz = grid_.nz;
  auto face = [&](const std::vector<double>& g, const std::vector<double>& s, std::size_t f) {
    return pressure_drive_ ? drive_ * g[f] + s[f] : s[f];
  };
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        Vec3& out = correction_.node[(std::size_t(i) * ny + j) * nz + k];
        const std::size_t u0 = (std::size_t(i) * ny + j) * nz + k, u1 = u0 + std::size_t(ny) * nz;
        const std::size_t v0 = (std::size_t(i) * (ny + 1) + j) * nz + k, v1 = v0 + nz;
        const std::size_t w0 = (std::size_t(i) * ny + j) * (nz + 1) + k, w1 = w0 + 1;
        out[0] = 0.5 * (face(dG.u, dS.u, u0) + face(dG.u, dS.u, u1));
        out[1] = 0.5 * (face(dG.v, dS.v, v0) + face(dG.v, dS.v, v1));
        out[2] = 0.5 * (face(dG.w, dS.w, w0) + face(dG.w, dS.w, w1));
      }
  solved_B_ = B_;
  solved_S_ = S_;
  solved_G_ = G_;
  solved_sign_ = sign;
  ++solves_;
}

}  // namespace cassini
