// The same case on 1 and on 2 ranks gives bitwise the same trajectories: each particle sums
// its contact forces in partner-id order and ghosts carry exact copies, so the arithmetic is
// identical whatever the decomposition. Run with 2 ranks: rank 0 also runs the 1-rank case.
#include <map>

#include <gtest/gtest.h>

#include "TestScene.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

StateById run(const std::string& text, const std::vector<std::string>& over, MPI_Comm comm, int steps) {
  auto sim = make_sim(text, over, comm);
  sim->setup();
  for (int s = 0; s < steps; ++s) sim->step();
  return gather_state(*sim, true);  // forces too: a last-bit difference in a kick rounds away in v
}

void compare(const std::string& text, const std::vector<std::string>& over, int steps) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  StateById one;
  int ok = 1;  // a guard stop in rank 0's 1-rank run is a failure, not a hang of rank 1
  if (rank == 0) {
    try {
      one = run(text, over, MPI_COMM_SELF, steps);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "1-rank run: " << e.what();
      ok = 0;
    }
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) return;
  const auto two = run(text, over, MPI_COMM_WORLD, steps);
  if (rank != 0) return;
  ASSERT_GT(one.size(), 100u);
  EXPECT_EQ(differing(one, two), 0) << "particles whose state differs bitwise between 1 and 2 ranks after " << steps
                                     << " steps";
}

// Frictional grains under gravity between z walls, periodic in x and y: exercises migration
// across slabs and across the periodic seam, tangential history in transit, wall contacts.
const char* kScene = R"(
seed = 5
modules = ["contact", "gravity"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.016, 0.008, 0.008]
boundary = ["periodic", "periodic", "wall"]
[[species]]
density = 2500.0
radius_min = 0.0004
radius_max = 0.0005
t_c = 1.0e-5
e = 0.7
mu_s = 0.5
mu_d = 0.4
[particles]
init = "random"
volume_fraction = 0.25
velocity = [3.0, 0.0, 0.0]
velocity_sigma = 5.0
[gravity]
g = [0.0, 0.0, -200.0]
[time]
n_c = 50
end = 1.0
)";

}  // namespace

TEST(RankEquivalence, FrictionalGasWithWallsSlabsAlongX) { compare(kScene, {}, 2000); }

TEST(RankEquivalence, BridgesRestitutionGasWithWalls) {
  // Contacts carry their impact speed (pairs across rank boundaries and migrations, walls).
  compare(with_bridges(kScene, 0.05), {}, 2000);
}

TEST(RankEquivalence, HertzMindlinGasWithWalls) {
  std::string hertz = kScene;
  const std::string tc = "t_c = 1.0e-5\n";
  hertz.replace(hertz.find(tc), tc.size(), "model = \"hertz\"\nyoungs_modulus = 1.0e9\nimpact_speed = 15.0\n");
  compare(hertz, {}, 2000);
}

TEST(RankEquivalence, RollingAndTwistingResistanceGasWithWalls) {
  // Torque springs per contact and per (particle, wall), carried like the tangential springs.
  compare(kScene, {"species.0.mu_r=0.1", "species.0.mu_o=0.05"}, 2000);
}

TEST(RankEquivalence, AdhesiveFrictionalGasWithWalls) {
  // DMT adhesion (Adhesion.hpp) strong enough that impacts slower than ~3 m/s stick (the grains
  // start at 5 m/s per component): clusters form and break across slab faces, grains stick to walls.
  compare(kScene, {"species.0.surface_energy=100.0"}, 2000);
}

TEST(RankEquivalence, FrictionalGasWithWallsSlabsAlongY) { compare(kScene, {"domain.slab_axis=\"y\""}, 2000); }

TEST(RankEquivalence, DenseFrictionalPackingWithManyContactsPerParticle) {
  // Sums of three or more contact forces are where the summation order shows.
  compare(kScene, {"particles.init=\"lattice\"", "particles.volume_fraction=0.35", "particles.jitter=0.5",
                   "domain.hi=[0.016, 0.008, 0.016]"}, 2000);
}

TEST(RankEquivalence, PlanarFrictionlessGas) {
  compare(kScene, {"gravity.g=[0.0, 0.0, 0.0]", "domain.planar=true", "domain.hi=[0.032, 0.016, 0.008]", "domain.boundary=[\"periodic\",\"periodic\",\"periodic\"]",
                   "species.0.mu_s=0.0", "species.0.mu_d=0.0", "particles.volume_fraction=0.4"},
          2000);
}

TEST(RankEquivalence, LoadBalancedSlabsMoveAndKeepTrajectoriesBitwise) {
  // Grains pressed against the x = lo wall by strong gravity: without balancing the first
  // slab holds most of them. Balancing every rebuild moves the cut towards the wall; the
  // trajectories stay bitwise those of the 1-rank run.
  const std::vector<std::string> crowded = {"domain.boundary=[\"wall\", \"periodic\", \"wall\"]",
                                            "gravity.g=[-20000.0, 0.0, 0.0]", "particles.velocity=[-3.0, 0.0, 0.0]",
                                            "domain.balance_every=1"};
  compare(kScene, crowded, 3000);
  auto sim = make_sim(kScene, crowded);
  sim->setup();
  for (int s = 0; s < 3000; ++s) sim->step();
  // Cost as the balancer counts it: 1 + neighbour entries per particle; per rank, and as it
  // would be with the static midpoint cut.
  const double midpoint = 0.5 * (sim->domain.lo[0] + sim->domain.hi[0]);
  double mine = 0, left = 0;
  for (std::size_t i = 0; i < sim->particles.nlocal; ++i) {
    const double c = 1.0 + sim->neighbors.start[i + 1] - sim->neighbors.start[i];
    mine += c;
    if (sim->particles.x[i][0] < midpoint) left += c;
  }
  double most = 0, total = 0, left_all = 0;
  MPI_Allreduce(&mine, &most, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  MPI_Allreduce(&mine, &total, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(&left, &left_all, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  const double balanced = most / (total / 2), unbalanced = std::max(left_all, total - left_all) / (total / 2);
  std::printf("imbalance (max/mean cost): static midpoint cut %.3f, balanced %.3f\n", unbalanced, balanced);
  EXPECT_LT(sim->domain.cuts[0][1], midpoint) << "the cut moves towards the crowded wall";
  EXPECT_LT(balanced, 1.1);
  EXPECT_GT(unbalanced, 1.3) << "the scene must actually be unbalanced";
}

TEST(RankEquivalence, MetisCellPartitionFrictionalGasWithWalls) {
  compare(kScene, {"domain.decomposition=\"metis\""}, 2000);
}

TEST(RankEquivalence, MetisRebalancedEveryRebuildKeepsTrajectoriesBitwise) {
  // The same crowded scene as above, re-partitioned by METIS from the measured cost at every
  // rebuild: particles change owner often and must not notice.
  const std::vector<std::string> crowded = {"domain.boundary=[\"wall\", \"periodic\", \"wall\"]",
                                            "gravity.g=[-20000.0, 0.0, 0.0]", "particles.velocity=[-3.0, 0.0, 0.0]",
                                            "domain.balance_every=1", "domain.decomposition=\"metis\""};
  compare(kScene, crowded, 3000);
  auto sim = make_sim(kScene, crowded);
  sim->setup();
  for (int s = 0; s < 3000; ++s) sim->step();
  double mine = 0;
  for (std::size_t i = 0; i < sim->particles.nlocal; ++i)
    mine += 1.0 + sim->neighbors.start[i + 1] - sim->neighbors.start[i];
  const double balanced = sim->domain.imbalance(mine);
  std::printf("METIS cells, balanced every rebuild: imbalance %.3f\n", balanced);
  EXPECT_LT(balanced, 1.15);
}

// The ghost update of a few changed particles (the multi-rate integrator's wake-ups: one round
// of neighbour messages, no collective) leaves every ghost as the full update would.
TEST(GhostUpdate, ChangedOnlyGivesTheFullUpdatesGhosts) {
  auto sim = make_sim(kScene, {});
  sim->setup();
  for (int s = 0; s < 50; ++s) sim->step();
  ParticleStore& p = sim->particles;
  sim->halo.update_ghosts(p);  // the step's last half kick came after its ghost update
  auto ghosts = [&] {
    std::vector<double> g;
    for (std::size_t j = p.nlocal; j < p.size(); ++j) {
      g.insert(g.end(), p.x[j].data(), p.x[j].data() + 3);
      g.insert(g.end(), p.v[j].data(), p.v[j].data() + 3);
      g.insert(g.end(), p.omega[j].data(), p.omega[j].data() + 3);
    }
    return g;
  };
  std::vector<std::uint32_t> changed;
  for (std::size_t i = 0; i < p.nlocal; i += 3) {
    changed.push_back(static_cast<std::uint32_t>(i));
    p.x[i] += Vec3(1e-6, -2e-6, 3e-6);
    p.v[i] += Vec3(0.1, 0.2, -0.3);
    p.omega[i] += Vec3(5.0, 0.0, -5.0);
  }
  const std::vector<double> before = ghosts();
  sim->halo.update_ghosts_of(p, changed);
  const std::vector<double> sparse = ghosts();
  sim->halo.update_ghosts(p);
  const std::vector<double> full = ghosts();
  long moved = 0, local_moved = 0, wrong = 0;
  for (std::size_t k = 0; k < full.size(); ++k) {
    local_moved += before[k] != full[k];
    wrong += sparse[k] != full[k];
  }
  MPI_Allreduce(&local_moved, &moved, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_GT(moved, 100) << "the changes must reach ghosts, or the test shows nothing";
  EXPECT_EQ(wrong, 0) << "ghost values differing from the full update";
  // Nothing changed: nothing moves (and every rank still takes part).
  sim->halo.update_ghosts_of(p, {});
  EXPECT_EQ(ghosts(), full);
}
