// The lubrication pair force against Reynolds' film theory: the spec's formula for equal
// beads, the cut-offs, and two beads squeezing the film between them to a stop at the gap
// that the analytic solution of m* dV/dt = -6 pi eta a*^2 V / h gives.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "physics/channel/Lubrication.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

// Two 1 mm glass beads (kPair) in a viscous liquid, nothing but the film between them.
const std::vector<std::string> kFilm = {"modules=[\"lubrication\"]", "lubrication.viscosity=0.01",
                                        "lubrication.roughness=1.0e-6", "domain.boundary=[\"open\",\"open\",\"open\"]"};

}  // namespace

TEST(Lubrication, PairForceIsTheSpecsReynoldsForceWithItsCutoffs) {
  auto sim = make_sim(kPair, kFilm);
  sim->setup();
  const auto* lub = sim->find<Lubrication>();
  ASSERT_NE(lub, nullptr);
  const double a = 1e-3, d = 2 * a, m = 2500 * 4.0 / 3.0 * std::numbers::pi * a * a * a, eta = 0.01;
  const Vec3 n(0.6, 0.8, 0.0);
  const Vec3 dv = -0.01 * n + Vec3(0.0, 0.0, 0.003);  // approaching, plus a tangential part
  for (double h : {1e-5, 1e-4, 5e-4, 0.99e-3}) {
    const Vec3 f = lub->pair_force((d + h) * n, dv, a, a, m, m);
    const double spec = 3 * std::numbers::pi * eta * d * d / (8 * h) * 0.01;  // along +n: resists approach
    const double beta_dt = spec / 0.01 / (m / 2) * sim->dt;
    EXPECT_NEAR(f.dot(n), spec, spec * beta_dt) << "h = " << h;
    EXPECT_LT((f - f.dot(n) * n).norm(), 1e-15 * spec) << "normal only";
  }
  EXPECT_TRUE(lub->pair_force((d + 1.01e-3) * n, dv, a, a, m, m).isZero(0)) << "beyond d/2 no film force";
  // Below 2 eps_r (and in contact) the gap is held at 2 eps_r.
  const Vec3 capped = lub->pair_force((d + 2e-6) * n, dv, a, a, m, m);
  EXPECT_EQ(lub->pair_force((d + 1e-7) * n, dv, a, a, m, m), capped);
  EXPECT_EQ(lub->pair_force((d - 1e-5) * n, dv, a, a, m, m), capped);
}

TEST(Lubrication, ApproachingBeadsStopAtTheAnalyticGap) {
  // Head-on, each at V0/2 from a gap h0 = d/2: V(h) = V0 - (c/m*) ln(h0/h), c = 6 pi eta a*^2,
  // so they stop at h0 exp(-m* V0 / c). V0 is chosen for a factor e^2.
  const double a = 1e-3, m = 2500 * 4.0 / 3.0 * std::numbers::pi * a * a * a, eta = 0.01;
  const double a_star = a / 2, m_star = m / 2, c = 6 * std::numbers::pi * eta * a_star * a_star;
  const double h0 = a, V0 = 2 * c / m_star, h_stop = h0 * std::exp(-2.0);
  auto sim = make_sim(kPair, kFilm);
  sim->particles.add(0, 0, a, m, Vec3(-(a + 0.5 * h0), 0, 0), Vec3(0.5 * V0, 0, 0));
  sim->particles.add(1, 0, a, m, Vec3(a + 0.5 * h0, 0, 0), Vec3(-0.5 * V0, 0, 0));
  sim->setup();
  double mid_error = 0;
  while (sim->time < 0.5) {
    sim->step();
    const double gap = sim->particles.x[1][0] - sim->particles.x[0][0] - 2 * a;
    const double V = sim->particles.v[0][0] - sim->particles.v[1][0];
    if (gap > 1.5 * h_stop) mid_error = std::max(mid_error, std::abs(V - (V0 - c / m_star * std::log(h0 / gap))) / V0);
  }
  const double gap = sim->particles.x[1][0] - sim->particles.x[0][0] - 2 * a;
  // First-order in beta dt (< 2e-4 here) and in the half-step velocity lag: 0.5 % is generous.
  EXPECT_NEAR(gap, h_stop, 5e-3 * h_stop);
  EXPECT_LT(mid_error, 5e-3);
  EXPECT_NEAR(sim->particles.v[0][0] + sim->particles.v[1][0], 0.0, 1e-15) << "momentum";
}

// A film only dissipates: with nothing but lubrication, the kinetic energy never grows. In a
// dense cluster whose films are stiff (beta dt ~ 90 at the roughness cut-off) each bead has
// many films, and their relaxations, exact for an isolated pair, add up: summed naively they
// overshoot and the energy grows geometrically (the instability of issue 19 at eps_r = 0.1 %
// of d). The relaxations are scaled so that none can (see Lubrication.hpp).
TEST(Lubrication, ADenseStiffClusterOnlyDissipates) {
  const double a = 1e-3, m = 2500 * 4.0 / 3.0 * std::numbers::pi * a * a * a, gap = 1.5e-7;
  auto sim = make_sim(kPair, {"modules=[\"lubrication\"]", "lubrication.viscosity=1.0", "lubrication.roughness=1.0e-7",
                              "domain.boundary=[\"open\",\"open\",\"open\"]", "time.n_c=5"});
  std::uint64_t state = 12345;  // a fixed pseudo-random sequence for the velocities
  auto uniform = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(state >> 11) / double(1ULL << 53) - 0.5;
  };
  // Face-centred cubic: twelve films per interior bead, in directions that are not orthogonal.
  const double h = (2 * a + gap) / std::sqrt(2.0);  // nearest neighbours at sqrt(2) h = 2 a + gap
  int id = 0;
  for (int x = 0; x < 5; ++x)
    for (int y = 0; y < 5; ++y)
      for (int z = 0; z < 5; ++z)
        if ((x + y + z) % 2 == 0)
          sim->particles.add(id++, 0, a, m, h * Vec3(x - 2, y - 2, z - 2), 2e-3 * Vec3(uniform(), uniform(), uniform()));
  sim->setup();
  const double beta_dt = 6 * std::numbers::pi * 1.0 * (a / 2) * (a / 2) / (2e-7 * m / 2) * sim->dt;
  ASSERT_GT(beta_dt, 50) << "the films must be stiff";
  double ke = sim->kinetic_energy(), worst_growth = 0;
  const double ke0 = ke;
  for (int s = 0; s < 200; ++s) {
    sim->step();
    const double now = sim->kinetic_energy();
    worst_growth = std::max(worst_growth, now / ke - 1);
    ke = now;
  }
  EXPECT_LE(worst_growth, 1e-12) << "the kinetic energy grew in a step (beta dt = " << beta_dt << ")";
  EXPECT_LT(ke, ke0);
}
