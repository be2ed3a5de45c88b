// The same case on 1 and on 2 ranks gives bitwise the same trajectories: each particle sums
// its contact forces in partner-id order and ghosts carry exact copies, so the arithmetic is
// identical whatever the decomposition. Run with 2 ranks: rank 0 also runs the 1-rank case.
#include <map>

#include <gtest/gtest.h>

#include "TestScene.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

struct State {
  Vec3 x, v, w;
};

// Runs the case for `steps` on `comm` and returns every particle's state on rank 0 of comm.
std::map<std::int64_t, State> run(const std::string& text, const std::vector<std::string>& over, MPI_Comm comm,
                                  int steps) {
  auto sim = make_sim(text, over, comm);
  sim->setup();
  for (int s = 0; s < steps; ++s) sim->step();
  const auto& p = sim->particles;
  std::vector<double> mine;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    mine.push_back(double(p.id[i]));
    for (const Vec3* q : {&p.x[i], &p.v[i]}) mine.insert(mine.end(), q->data(), q->data() + 3);
    const Vec3 w = p.rotation ? p.omega[i] : Vec3::Zero();
    mine.insert(mine.end(), w.data(), w.data() + 3);
  }
  int n = static_cast<int>(mine.size()), size = 0, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  std::vector<int> counts(size), displ(size);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  int total = 0;
  for (int r = 0; r < size; ++r) { displ[r] = total; total += counts[r]; }
  std::vector<double> all(rank == 0 ? total : 0);
  MPI_Gatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displ.data(), MPI_DOUBLE, 0, comm);
  std::map<std::int64_t, State> out;
  for (std::size_t k = 0; k + 10 <= all.size(); k += 10)
    out[std::int64_t(all[k])] = {Vec3(all[k + 1], all[k + 2], all[k + 3]), Vec3(all[k + 4], all[k + 5], all[k + 6]),
                                 Vec3(all[k + 7], all[k + 8], all[k + 9])};
  return out;
}

void compare(const std::string& text, const std::vector<std::string>& over, int steps) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  std::map<std::int64_t, State> one;
  if (rank == 0) one = run(text, over, MPI_COMM_SELF, steps);
  const auto two = run(text, over, MPI_COMM_WORLD, steps);
  if (rank != 0) return;
  ASSERT_EQ(one.size(), two.size());
  ASSERT_GT(one.size(), 100u);
  long differ = 0;
  for (const auto& [id, s] : one) {
    const State& t = two.at(id);
    if (s.x != t.x || s.v != t.v || s.w != t.w) ++differ;  // bitwise
  }
  EXPECT_EQ(differ, 0) << "particles whose state differs between 1 and 2 ranks after " << steps << " steps";
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
