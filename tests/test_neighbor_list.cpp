// The neighbour list against an independent brute-force search: every pair within
// a_i + a_j + skin (minimum image across periodic faces), on both owned sides, in id order.
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "TestScene.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

// Radii uniform in [1, 1.8] mm (one size class: the half-stencil cell search), dense enough that
// every particle has partners, periodic on the axes given.
std::string scene(const std::string& boundary, bool planar) {
  return std::string(R"(
seed = 5
modules = ["contact"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.06, 0.05, )") + (planar ? "0.004" : "0.04") + R"(]
boundary = )" + boundary + R"(
)" + (planar ? "planar = true\n" : "") + R"(
[[species]]
density = 2500.0
radius_min = 0.001
radius_max = 0.0018
size_distribution = "uniform"
t_c = 1.0e-4
e = 0.5
[particles]
init = "random"
volume_fraction = )" + (planar ? "0.4" : "0.22") + R"(
velocity_sigma = 0.1
[time]
end = 1.0
)";
}

// x_build holds the positions of the last build (ghosts' too: they are built from them).
void expect_every_pair_listed(Simulation& sim, const bool periodic[3]) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  std::set<std::pair<std::int64_t, std::int64_t>> listed, all;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      listed.insert({p.id[i], p.id[nl.partner[k]]});
      if (k > nl.start[i]) EXPECT_LT(p.id[nl.partner[k - 1]], p.id[nl.partner[k]]) << "partners in id order";
    }
  const Vec3 L = sim.domain.length;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::size_t j = 0; j < p.nlocal; ++j) {
      if (i == j) continue;
      Vec3 d = p.x_build[i] - p.x_build[j];  // the positions the list was built from
      for (int a = 0; a < 3; ++a)
        if (periodic[a]) d[a] -= L[a] * std::round(d[a] / L[a]);
      const double cut = p.radius[i] + p.radius[j] + sim.skin;
      if (d.squaredNorm() < cut * cut) all.insert({p.id[i], p.id[j]});
    }
  std::printf("%zu particles, %zu list entries, %lld candidates tested\n", p.nlocal, nl.size(), nl.candidates);
  EXPECT_GT(all.size(), p.nlocal / 2);
  EXPECT_EQ(listed, all);
}

}  // namespace

TEST(NeighborList, PeriodicBoxListsEveryPairOnBothSides) {
  auto sim = make_sim(scene(R"(["periodic", "periodic", "periodic"])", false));
  sim->setup();
  const bool periodic[3] = {true, true, true};
  expect_every_pair_listed(*sim, periodic);
  for (int s = 0; s < 300; ++s) sim->step();  // after rebuilds, migration and reordering
  expect_every_pair_listed(*sim, periodic);
}

TEST(NeighborList, WallsAndPlanarListEveryPairOnBothSides) {
  auto sim = make_sim(scene(R"(["periodic", "wall", "wall"])", false));
  sim->setup();
  const bool walls[3] = {true, false, false};
  expect_every_pair_listed(*sim, walls);
  auto flat = make_sim(scene(R"(["periodic", "periodic", "periodic"])", true));
  flat->setup();
  const bool planar[3] = {true, true, false};
  expect_every_pair_listed(*flat, planar);
}
