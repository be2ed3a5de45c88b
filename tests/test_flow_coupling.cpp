// Two-way coupling (flow.coupling = "two-way") against independent answers: the Stokes-Brinkman
// solve against the analytic duct series and against a separate solve of fully developed flow
// through a half-filled channel, and the coupled beads' pressure drop against Carman-Kozeny
// with Newton's third law between beads and fluid.
#include <cmath>
#include <numbers>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <gtest/gtest.h>

#include "ChannelScene.hpp"
#include "TestScene.hpp"
#include "physics/channel/DuctFlow.hpp"
#include "physics/channel/FlowCoupling.hpp"
#include "physics/channel/StokesDrag.hpp"
#include "physics/channel/StokesSolver.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

// A straight duct of nx x ny x nz cubic cells, all fluid, the given inflow at both ends.
StokesGrid duct(int nx, int ny, int nz, double dx, double eta, const std::vector<double>& inflow) {
  StokesGrid g;
  g.nx = nx; g.ny = ny; g.nz = nz; g.dx = dx; g.viscosity = eta;
  g.fluid.assign(std::size_t(nx) * ny * nz, 1);
  g.inflow = inflow;
  return g;
}

// Mean pressure of the layer of cells i.
double layer_pressure(const StokesSolution& s, int i, int ny, int nz) {
  double p = 0;
  for (int c = 0; c < ny * nz; ++c) p += s.p[std::size_t(i) * ny * nz + c];
  return p / (ny * nz);
}

// Fully developed flow -eta lap u + B(j) u = G in the cross-section (ny x nz cells, no slip all
// round), solved directly in the plane: the flow rate per unit G, and the part of it in the
// rows j < ny / 2.
struct Conductance { double total, lower_half; };
Conductance conductance(int ny, int nz, double dx, double eta, const std::vector<double>& B_of_row) {
  using SpMat = Eigen::SparseMatrix<double>;
  std::vector<Eigen::Triplet<double>> t;
  auto id = [&](int j, int k) { return j * nz + k; };
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nz; ++k) {
      double diag = B_of_row[j];
      const int nb[4][2] = {{j - 1, k}, {j + 1, k}, {j, k - 1}, {j, k + 1}};
      for (const auto& b : nb) {
        if (b[0] >= 0 && b[0] < ny && b[1] >= 0 && b[1] < nz) {
          diag += eta / (dx * dx);
          t.emplace_back(id(j, k), id(b[0], b[1]), -eta / (dx * dx));
        } else {
          diag += 2 * eta / (dx * dx);  // the wall half a cell away
        }
      }
      t.emplace_back(id(j, k), id(j, k), diag);
    }
  SpMat A(ny * nz, ny * nz);
  A.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<SpMat> solver(A);
  const Eigen::VectorXd u = solver.solve(Eigen::VectorXd::Ones(ny * nz));
  return {u.sum() * dx * dx, u.head(ny / 2 * nz).sum() * dx * dx};
}

}  // namespace

TEST(StokesBrinkman, UniformDragInADuctGivesTheFullyDevelopedGradient) {
  // -eta lap u + B u = G in a W x H duct. The 3D solve starts from the plain duct profile at the
  // ends and develops; its gradient in the middle must be the cross-section solve's (the same
  // 5-point stencil, solved directly in the plane). That plane solve in turn converges at second
  // order to the analytic series u = sum over odd m, n of 16 G sin(m pi y/W) sin(n pi z/H) /
  // (pi^2 m n (eta k^2 + B)), k^2 = (m pi/W)^2 + (n pi/H)^2, mean U = G sum 64 / (pi^4 m^2 n^2
  // (eta k^2 + B)).
  const int ny = 16, nz = 8, nx = 48;
  const double dx = 1.0 / 16, W = ny * dx, H = nz * dx, eta = 1.0, U = 1.0;
  const std::vector<char> all(ny * nz, 1);
  for (double B : {0.0, 10.0, 100.0}) {  // Brinkman length sqrt(eta / B) = inf, 5 and 1.6 cells
    StokesProblem problem(duct(nx, ny, nz, dx, eta, duct_profile(ny, nz, dx, all, U * W * H)), true);
    problem.set_brinkman(std::vector<double>(std::size_t(nx) * ny * nz, B));
    const StokesSolution s = problem.solve(1.0, nullptr, 1e-10);
    const double measured = (layer_pressure(s, nx / 2 - 8, ny, nz) - layer_pressure(s, nx / 2 + 8, ny, nz)) / (16 * dx);
    const double plane = U * W * H / conductance(ny, nz, dx, eta, std::vector<double>(ny, B)).total;
    EXPECT_NEAR(measured / plane, 1.0, 1e-4) << "B = " << B;
    double sum = 0;
    for (int m = 1; m < 400; m += 2)
      for (int n = 1; n < 400; n += 2) {
        const double k2 = std::pow(m * std::numbers::pi / W, 2) + std::pow(n * std::numbers::pi / H, 2);
        sum += 64 / (std::pow(std::numbers::pi, 4) * m * m * n * n * (eta * k2 + B));
      }
    const double series = U / sum;
    double error[2];
    for (int r : {1, 2}) {
      const double h = dx / r;
      error[r - 1] = std::abs(U * W * H / conductance(ny * r, nz * r, h, eta, std::vector<double>(ny * r, B)).total / series - 1);
    }
    EXPECT_LT(error[1], 0.015) << "B = " << B;
    EXPECT_NEAR(error[0] / error[1], 4.0, 0.6) << "B = " << B;  // second order
  }
}

TEST(StokesBrinkman, FlowGoesAroundADenseHalfAsTheCrossSectionSolveSays) {
  // The lower half of the duct's width holds a porous bed: the flow diverts into the open half.
  // The plain duct profile enters at the ends; in the middle the flow is fully developed, so
  // the pressure gradient and the bed's share of the flow are those of a direct 2D solve of the
  // cross-section with the same B.
  const int ny = 16, nz = 8, nx = 96;
  const double dx = 1.0 / 16, W = ny * dx, H = nz * dx, eta = 1.0, U = 1.0;
  const std::vector<char> all(ny * nz, 1);
  for (double B_bed : {30.0, 300.0}) {  // Darcy numbers eta / (B H^2) of 1/8 and 1/80
    std::vector<double> B_row(ny), B_cell(std::size_t(nx) * ny * nz);
    for (int j = 0; j < ny; ++j) B_row[j] = j < ny / 2 ? B_bed : 0.0;
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j)
        for (int k = 0; k < nz; ++k) B_cell[(std::size_t(i) * ny + j) * nz + k] = B_row[j];
    StokesProblem problem(duct(nx, ny, nz, dx, eta, duct_profile(ny, nz, dx, all, U * W * H)), true);
    problem.set_brinkman(B_cell);
    const StokesSolution s = problem.solve(1.0, nullptr, 1e-10);
    const double G = (layer_pressure(s, nx / 2 - 8, ny, nz) - layer_pressure(s, nx / 2 + 8, ny, nz)) / (16 * dx);
    const Conductance plane = conductance(ny, nz, dx, eta, B_row);
    EXPECT_NEAR(G / (U * W * H / plane.total), 1.0, 1e-3) << "B = " << B_bed;
    double bed = 0, total = 0;
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        const double u = s.u[(std::size_t(nx / 2) * ny + j) * nz + k];
        total += u;
        if (j < ny / 2) bed += u;
      }
    EXPECT_NEAR(bed / total, plane.lower_half / plane.total, 1e-3) << "B = " << B_bed;
    EXPECT_LT(bed / total, 0.45) << "B = " << B_bed;  // the flow goes around the bed
  }
}

TEST(StokesBrinkman, AnOlderPreconditionerGivesTheSameFlow) {
  // The coupled solve keeps CG's pressure preconditioner across re-solves (FlowCoupling): built
  // for an earlier B, it must change the iterations only, never the answer. The half-filled duct
  // again, its bed's B raised 10x (30 -> 300) with the preconditioner left from the first: the
  // flow must be the freshly preconditioned solve's and the cross-section solve's.
  const int ny = 16, nz = 8, nx = 96;
  const double dx = 1.0 / 16, W = ny * dx, H = nz * dx, eta = 1.0, U = 1.0;
  const std::vector<char> all(ny * nz, 1);
  auto bed_of = [&](double B_bed) {
    std::vector<double> B_row(ny), B_cell(std::size_t(nx) * ny * nz);
    for (int j = 0; j < ny; ++j) B_row[j] = j < ny / 2 ? B_bed : 0.0;
    for (std::size_t c = 0; c < B_cell.size(); ++c) B_cell[c] = B_row[(c / nz) % ny];
    return std::pair{B_row, B_cell};
  };
  const StokesGrid g = duct(nx, ny, nz, dx, eta, duct_profile(ny, nz, dx, all, U * W * H));
  StokesProblem fresh(g, true), kept(g, true);
  fresh.set_brinkman(bed_of(300.0).second);
  kept.set_brinkman(bed_of(30.0).second);
  kept.set_brinkman(bed_of(300.0).second, /*refresh_preconditioner=*/false);
  const StokesSolution a = fresh.solve(1.0, nullptr, 1e-10), b = kept.solve(1.0, nullptr, 1e-10);
  ASSERT_LT(b.residual, 1e-10);
  EXPECT_NE(a.iterations, b.iterations);  // the older preconditioner is in use
  double largest = 0, difference = 0;
  for (std::size_t f = 0; f < a.u.size(); ++f) {
    largest = std::max(largest, std::abs(a.u[f]));
    difference = std::max(difference, std::abs(a.u[f] - b.u[f]));
  }
  EXPECT_LT(difference, 1e-7 * largest);
  const double G = (layer_pressure(b, nx / 2 - 8, ny, nz) - layer_pressure(b, nx / 2 + 8, ny, nz)) / (16 * dx);
  EXPECT_NEAR(G / (U * W * H / conductance(ny, nz, dx, eta, bed_of(300.0).first).total), 1.0, 1e-3);
}

namespace {

// A straight channel 800 x 800 x 100 um filled by a cubic lattice of beads (spacing 25 um:
// 32 x 32 x 4), volume fraction phi, a fixed flow rate unless `overrides` set flow.drive; the
// coupling grid's cells are the lattice's. Every bead moves at `velocity` (the set-up's forced
// solve takes that as given; nothing steps).
std::unique_ptr<Simulation> packed_bed(double phi, const std::vector<std::string>& overrides = {},
                                       const Vec3& velocity = Vec3::Zero()) {
  const std::string text = R"(modules = ["channel", "drag"]
seed = 1
[domain]
lo = [-4.0e-4, -4.0e-4, 0.0]
hi = [4.0e-4, 4.0e-4, 1.0e-4]
boundary = ["open", "open", "wall"]
[channel]
upper = [[-4.0e-4, 4.0e-4], [4.0e-4, 4.0e-4]]
lower = [[-4.0e-4, -4.0e-4], [4.0e-4, -4.0e-4]]
[[species]]
density = 1050.0
radius = 1.0e-5
t_c = 1.0e-7
e = 0.1
[particles]
init = "none"
[flow]
mean_velocity = 1.0e-3
resolution = 64
solve_half_length = 1.0e-4
cache = "flow-cache"
coupling = "two-way"
coupling_resolution = 32
[drag]
width = 2.5e-5
[time]
end = 1.0
)";
  auto sim = make_sim(text, overrides);
  const double L = 2.5e-5, d = L * std::cbrt(6 * phi / std::numbers::pi), a = d / 2;
  const double m = 1050 * 4.0 / 3.0 * std::numbers::pi * a * a * a;
  std::int64_t id = 0;
  for (int i = 0; i < 32; ++i)
    for (int j = 0; j < 32; ++j)
      for (int k = 0; k < 4; ++k)
        sim->particles.add(id++, 0, a, m, Vec3(-4e-4 + (i + 0.5) * L, -4e-4 + (j + 0.5) * L, (k + 0.5) * L), velocity);
  sim->setup();
  return sim;
}

// Darcy's pressure drop through packed_bed at the flow rate the coupling grid holds for the mean
// velocity 1 mm/s (the bead-free duct flow sampled at the lattice's 4 layers: 3 % above it, a
// second-order error of the 4 cells over the height; from the duct series): the flow is flat in
// each column of beads but for Brinkman layers far thinner than a cell, so -dp/dx = Q' / sum_j
// (A_j / B_j) over the bed's 32 columns across the width (parallel resistances), B_j the beads'
// drag coefficients per volume in column j.
double darcy_pressure_drop(const Simulation& sim) {
  const double L = 2.5e-5, W = 8e-4, H = 1e-4, bed = 8e-4;
  const double length = bed - L;  // between the first and the last layer of coupling cells
  const auto* drag = sim.find<StokesDrag>();
  const ParticleStore& p = sim.particles;
  std::vector<double> column(32, 0.0);
  for (std::size_t i = 0; i < p.nlocal; ++i) column[static_cast<int>((p.x[i][1] + 4e-4) / L)] += drag->drag_coefficient(i);
  double conductance = 0;
  for (double b : column) conductance += L * H / (b / (bed * L * H));
  const DuctFlow clean(W, H, 1.0e-3, 40);
  double sampled = 0;
  for (int j = 0; j < 32; ++j)
    for (int k = 0; k < 4; ++k) sampled += clean.velocity(-0.5 * W + (j + 0.5) * L, (k + 0.5) * L) / (32 * 4);
  return sampled * W * H / conductance * length;
}

}  // namespace

TEST(FlowCoupling, PressureDropThroughAFixedBedIsCarmanKozenysAndBalancesTheDrag) {
  // A fixed bed filling the channel, at a fixed flow rate Q. Three independent checks:
  //  - Darcy with the beads' own coefficients in parallel columns (darcy_pressure_drop). The
  //    walls' shear over unresolved Brinkman layers adds ~1 %: tolerance 2.5 %.
  //  - Carman-Kozeny, -dp/dx = 180 eta U phi^2 / (d^2 (1 - phi)^3) at the superficial velocity U:
  //    the coupled drag is Beetstra's f / (1 - phi), above it by (1-phi)^4 (1 + 1.5 sqrt(phi)) /
  //    (10 phi): 6.3 % at phi = 0.4, 2.6 % at 0.5; the 3 % of the sampled flow rate and ~1 % of
  //    the walls add to it (measured: +13 %, +10 %): tolerance [0.97, 1.2], the correlation's own
  //    scatter against packed-bed data being of that order.
  //  - Newton's third law: what the beads take from the fluid is the pressure drop's push on
  //    the channel's section less the walls' share (at most the bead-free channel's).
  for (double phi : {0.4, 0.5}) {
    auto sim = packed_bed(phi);
    const auto* drag = sim->find<StokesDrag>();
    ASSERT_NE(drag->coupling(), nullptr);
    const FlowCoupling& c = *drag->coupling();
    const ParticleStore& p = sim->particles;
    const double d = 2.5e-5 * std::cbrt(6 * phi / std::numbers::pi), eta = 1.8e-3, U = 1.0e-3, L = 2.5e-5;
    const double W = 8e-4, H = 1e-4, A = W * H, bed = 8e-4;
    const double length = bed - L;  // between the first and the last layer of coupling cells
    const double dp = c.pressure_drop();
    const double darcy = darcy_pressure_drop(*sim);
    EXPECT_NEAR(dp / darcy, 1.0, 0.025) << "phi " << phi << ": " << dp << " Pa against " << darcy;

    const double carman_kozeny = 180 * eta * U * phi * phi / (d * d * std::pow(1 - phi, 3)) * length;
    EXPECT_GT(dp / carman_kozeny, 0.97) << "phi " << phi << ": " << dp << " Pa against " << carman_kozeny;
    EXPECT_LT(dp / carman_kozeny, 1.2) << "phi " << phi << ": " << dp << " Pa against " << carman_kozeny;
    EXPECT_GT(dp / c.bead_free_pressure_drop(), 50.0);

    double on_beads = 0;
    for (std::size_t i = 0; i < p.nlocal; ++i) on_beads += drag->drag_coefficient(i) * drag->fluid_velocity(p.x[i])[0];
    const double per_length = bed / length;  // the beads fill the whole length
    EXPECT_GT(on_beads, 0.98 * (dp - c.bead_free_pressure_drop()) * A * per_length) << phi;
    EXPECT_LT(on_beads, 1.02 * dp * A * per_length) << phi;
  }
}

TEST(FlowCoupling, APressureDriveLetsThroughWhatDarcyAndTheRateDriveAllow) {
  // flow.drive = "pressure" holds the bead-free channel's pressure drop dp0 (at Q0); the flow
  // rate is the unknown, found from two solves (the responses to the beads' standstill drag and
  // to their motion). Two checks against other calculations:
  //  - Darcy: through the fixed bed of the test above (phi = 0.4), whose pressure drop at Q0
  //    Darcy's parallel columns give (dp_darcy, checked there to 2.5 %), the flow is linear in
  //    the drop: Q = Q0 dp0 / dp_darcy, to the same 2.5 %.
  //  - The rate drive, one solve of another right-hand side: the pressure drop is affine in the
  //    flow rate and the beads' velocity, dp = a Q + b V. Two rate-driven beds, at rest and
  //    translating at V, give a Q0 and b V; the pressure drive with the bed translating must then
  //    pass Q = (dp0 - b V) / a, to the solves' tolerance (relative residual 1e-4): 1e-3. The bed
  //    moving with the mean flow drags the fluid along, so this Q is ~240x the resting bed's: a
  //    sign wrong in either response fails it.
  const double phi = 0.4, U = 1.0e-3, q0 = U * 8e-4 * 1e-4;
  const std::vector<std::string> pressure = {"flow.drive=\"pressure\""};
  auto rest = packed_bed(phi, pressure);
  const FlowCoupling& c = *rest->find<StokesDrag>()->coupling();
  const double darcy = darcy_pressure_drop(*rest), dp0 = c.bead_free_pressure_drop();
  EXPECT_NEAR(c.flow_rate() / (q0 * dp0 / darcy), 1.0, 0.025) << c.flow_rate() << " m^3/s against " << q0 * dp0 / darcy;
  EXPECT_NEAR(c.pressure_drop() / dp0, 1.0, 1e-9);

  const Vec3 V(U, 0, 0);
  const double aQ0 = packed_bed(phi)->find<StokesDrag>()->coupling()->pressure_drop();
  const double bV = packed_bed(phi, {}, V)->find<StokesDrag>()->coupling()->pressure_drop() - aQ0;
  const double expected = q0 * (dp0 - bV) / aQ0;
  const double q = packed_bed(phi, pressure, V)->find<StokesDrag>()->coupling()->flow_rate();
  EXPECT_NEAR(q / expected, 1.0, 1e-3) << q << " m^3/s against " << expected;
  EXPECT_GT(q, 20 * c.flow_rate());
}

TEST(FlowCoupling, AStalePreconditionerIsRebuiltAfterAColdSolve) {
  // The coupled re-solves keep CG's pressure preconditioner until a solve needs 1.5x (+2) the
  // iterations of a solve on it when fresh. A cold solve (set-up, snapshot, restart: it starts
  // from zero pressure) takes more iterations than a warm one, so its count must not be that
  // reference: against it, the rule would stay silent for the preconditioner's 16 solves. The
  // fixed bed of the tests above, its drag 100x lower in the upper half (y > 0): a cold solve, a
  // warm one after a change of 1e-3 (the reference), then the lower half's drag doubled (the
  // iterations rise beyond 1.5x the warm reference but not beyond 1.5x the cold count), and one
  // more solve, which must rebuild the preconditioner.
  auto sim = packed_bed(0.4, {"flow.coupling_tolerance=1e-6"});
  const auto* drag = sim->find<StokesDrag>();
  const ParticleStore& p = sim->particles;
  FlowCoupling c(sim->cfg);
  std::vector<double> beta(p.nlocal);
  for (std::size_t i = 0; i < p.nlocal; ++i) beta[i] = drag->drag_coefficient(i);
  const std::vector<Vec3> one_way(p.nlocal, Vec3(1e-3, 0, 0));
  auto solve_with = [&](double lower, bool force) {
    std::vector<double> b(beta);
    for (std::size_t i = 0; i < p.nlocal; ++i) b[i] *= p.x[i][1] < 0 ? lower : 0.01;
    EXPECT_TRUE(c.update(p, b, one_way, drag->fraction(), 1.0, force, MPI_COMM_WORLD)) << lower;
    return c.last_iterations();
  };
  const int cold = solve_with(1.0, true);
  const int fresh = solve_with(1.001, false);
  const int stale = solve_with(2.0, false);
  EXPECT_EQ(c.preconditioner_builds(), 1);
  solve_with(2.6, false);
  const std::string counts =
      "cold " + std::to_string(cold) + ", warm " + std::to_string(fresh) + ", after the change " + std::to_string(stale);
  ASSERT_GT(stale, 1.5 * fresh + 2) << "the scene no longer needs a rebuild: " << counts;
  ASSERT_LE(stale, 1.5 * cold + 2) << "the scene no longer tells the two references apart: " << counts;
  EXPECT_EQ(c.preconditioner_builds(), 2) << counts;
}

TEST(FlowCoupling, BadSettingsAreRefusedByName) {
  auto error_of = [](const std::vector<std::string>& overrides) -> std::string {
    try {
      auto sim = make_sim(channel_case(R"(["channel", "drag"])"), overrides);
      sim->setup();
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  const std::string unknown = error_of({"flow.coupling=\"both\""});
  EXPECT_NE(unknown.find("flow.coupling"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("two-way"), std::string::npos) << unknown;
  const std::string drive = error_of({"flow.drive=\"pressure\""});  // one-way: the flow cannot answer
  EXPECT_NE(drive.find("flow.drive"), std::string::npos) << drive;
  EXPECT_NE(drive.find("two-way"), std::string::npos) << drive;
  const std::string grid = error_of({"flow.coupling=\"two-way\"", "flow.coupling_resolution=0"});
  EXPECT_NE(grid.find("flow.coupling_resolution"), std::string::npos) << grid;
  EXPECT_EQ(error_of({"flow.coupling=\"two-way\"", "flow.drive=\"pressure\""}), "");
}
