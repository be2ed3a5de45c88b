// H5MD snapshots: exact round trip, restart equivalence (same and other rank count), and a
// truncated file reported instead of misread. Run with 2 ranks.
#include <filesystem>
#include <map>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "io/Snapshot.hpp"

using namespace cassini;
using namespace cassini::test;
namespace fs = std::filesystem;

namespace {

const char* kScene = R"(
seed = 9
modules = ["contact", "gravity"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.016, 0.008, 0.016]
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
init = "lattice"
volume_fraction = 0.35
jitter = 0.5
velocity = [3.0, 0.0, 0.0]
velocity_sigma = 5.0
[gravity]
g = [0.0, 0.0, -200.0]
[time]
n_c = 50
end = 1.0
)";

using State = std::map<std::int64_t, std::vector<double>>;

// Every owned particle's full state, gathered on rank 0 of comm.
State gather(const Simulation& sim) {
  const auto& p = sim.particles;
  std::vector<double> mine;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    mine.push_back(double(p.id[i]));
    for (const Vec3* q : {&p.x[i], &p.v[i], &p.f[i], &p.omega[i], &p.torque[i]}) mine.insert(mine.end(), q->data(), q->data() + 3);
    for (int w = 0; w < p.walls; ++w) mine.insert(mine.end(), p.wall_xi[i * p.walls + w].data(), p.wall_xi[i * p.walls + w].data() + 3);
  }
  const int width = 1 + 15 + 3 * p.walls;
  int n = int(mine.size()), size, rank;
  MPI_Comm_size(sim.domain.comm, &size);
  MPI_Comm_rank(sim.domain.comm, &rank);
  std::vector<int> counts(size), displ(size);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, sim.domain.comm);
  int total = 0;
  for (int r = 0; r < size; ++r) { displ[r] = total; total += counts[r]; }
  std::vector<double> all(rank == 0 ? total : 0);
  MPI_Gatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displ.data(), MPI_DOUBLE, 0, sim.domain.comm);
  State out;
  for (std::size_t k = 0; k + width <= all.size(); k += width)
    out[std::int64_t(all[k])] = std::vector<double>(all.begin() + k + 1, all.begin() + k + width);
  return out;
}

long differing(const State& a, const State& b) {
  if (a.size() != b.size()) return -1;
  long d = 0;
  for (const auto& [id, s] : a)
    if (!b.count(id) || b.at(id) != s) ++d;
  return d;
}

std::string scratch() {
  const std::string dir = "snapshot_test_tmp";
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return dir;
}

}  // namespace

TEST(Snapshot, RoundTripIsExactAndRowsAreOrderedById) {
  const std::string dir = scratch();
  auto a = make_sim(kScene);
  a->setup();
  for (int s = 0; s < 300; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# case text");
  const State before = gather(*a);
  auto b = make_sim(kScene);
  read_snapshot(*b, file);
  b->setup();
  const State after = gather(*b);
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) {
    EXPECT_GT(before.size(), 300u);
    EXPECT_EQ(differing(before, after), 0);
  }
  EXPECT_EQ(b->step_count, a->step_count);
  EXPECT_EQ(b->time, a->time);
}

TEST(Snapshot, RestartContinuesBitwiseOnTheSameAndOnAnotherRankCount) {
  const std::string dir = scratch();
  auto a = make_sim(kScene);
  a->setup();
  for (int s = 0; s < 500; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# case text");
  for (int s = 0; s < 700; ++s) a->step();
  const State uninterrupted = gather(*a);

  auto b = make_sim(kScene);  // same rank count (2)
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 700; ++s) b->step();
  const State same = gather(*b);

  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  State other;
  if (rank == 0) {  // 1 rank from the 2-rank snapshot
    auto c = make_sim(kScene, {}, MPI_COMM_SELF);
    read_snapshot(*c, file);
    c->setup();
    for (int s = 0; s < 700; ++s) c->step();
    other = gather(*c);
  }
  if (rank == 0) {
    EXPECT_EQ(differing(uninterrupted, same), 0) << "restart on the same rank count";
    EXPECT_EQ(differing(uninterrupted, other), 0) << "restart on 1 rank";
  }
}

TEST(Snapshot, TruncatedFileIsReportedNotMisread) {
  const std::string dir = scratch();
  auto a = make_sim(kScene);
  a->setup();
  const std::string file = write_snapshot(*a, dir, "# case text");
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const std::string cut = dir + "/truncated.h5md";
  if (rank == 0) {
    fs::copy_file(file, cut);
    fs::resize_file(cut, fs::file_size(cut) / 2);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  auto b = make_sim(kScene);
  try {
    read_snapshot(*b, cut);
    ADD_FAILURE() << "truncated snapshot was read";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("not a complete cassini snapshot"), std::string::npos) << e.what();
  }
}
