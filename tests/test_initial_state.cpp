// The initial state is one random sequence, whatever the rank count: a lattice start's sites
// draw their jitter and radius first, then every particle its velocity, from the case's seed.
// Each rank reaches its own sites' draws by skipping the stream ahead instead of drawing all
// of them; these tests check the skip against plain sequential draws (the rank-equivalence
// tests check that 1 and 2 ranks agree).
#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "core/Initializer.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

const char* kLattice = R"(
seed = 11
modules = ["contact"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.012, 0.01, 0.008]
boundary = ["periodic", "periodic", "wall"]
[[species]]
density = 2500.0
radius_min = 0.0003
radius_max = 0.0005
t_c = 1.0e-5
e = 0.9
[particles]
init = "lattice"
count = 700
jitter = 0.6
velocity = [0.5, 0.0, -0.25]
velocity_sigma = 2.0
[time]
end = 1.0e-4
)";

}  // namespace

TEST(Random, SkipIsThatManyDraws) {
  for (std::uint64_t n : {0ull, 1ull, 7ull, 1000ull, 123457ull}) {
    Random a(42), b(42);
    a.skip(n);
    for (std::uint64_t k = 0; k < n; ++k) b.next();
    EXPECT_EQ(a.next(), b.next()) << n << " draws";
  }
}

// On rank 0 alone: sites k = 0..N-1 take (jitter per axis, radius) in turn, then the
// velocities (two uniforms per Gaussian, one Gaussian per axis), drawn here one after another.
void expect_sequential(const std::vector<std::string>& over, int dims) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank != 0) return;
  auto sim = make_sim(kLattice, over, MPI_COMM_SELF);
  sim->setup();
  const Config& c = sim->cfg;
  const Species& s = c.species[0];
  const long n = 700;
  ASSERT_EQ(long(sim->particles.nlocal), n);
  Random r(c.seed);
  std::vector<double> radius(n);
  for (long k = 0; k < n; ++k) {
    for (int d = 0; d < dims; ++d) r.uniform();
    radius[k] = s.sizes.quantile(s.radius_min, s.radius_max, r.uniform());
  }
  const auto state = gather_state(*sim);
  long wrong_v = 0, wrong_a = 0;
  for (long k = 0; k < n; ++k) {
    Vec3 v = c.velocity_mean;
    for (int d = 0; d < dims; ++d) v[d] += c.velocity_sigma * r.gaussian();
    if (dims == 2) v[2] = 0;
    const auto& got = state.at(k);
    if (got[3] != v[0] || got[4] != v[1] || got[5] != v[2]) ++wrong_v;
    if (sim->particles.radius[local_index(*sim, k)] != radius[k]) ++wrong_a;
  }
  EXPECT_EQ(wrong_v, 0) << "velocities not those of the sequential stream";
  EXPECT_EQ(wrong_a, 0) << "radii not those of the sequential stream";
}

TEST(InitialState, LatticeStartIsTheSequentialStream3D) { expect_sequential({}, 3); }

TEST(InitialState, LatticeStartIsTheSequentialStreamPlanar) {
  expect_sequential({"domain.planar=true", "domain.hi=[0.04, 0.03, 0.008]",
                     "domain.boundary=[\"periodic\", \"wall\", \"periodic\"]"}, 2);
}

// Each rank keeps only its own sites, and between them the ranks hold every site once.
TEST(InitialState, RanksSplitTheLatticeWithoutOverlap) {
  auto sim = make_sim(kLattice, {});
  sim->setup();
  long mine = long(sim->particles.nlocal), total = 0;
  MPI_Allreduce(&mine, &total, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(total, 700);
  EXPECT_LT(mine, 700) << "a rank holds particles of another's slab";
  for (std::size_t i = 0; i < sim->particles.nlocal; ++i)
    ASSERT_EQ(sim->domain.owner(sim->particles.x[i]), sim->domain.rank);
}
