// H5MD snapshots: exact round trip, restart equivalence (same and other rank count), and a
// truncated file reported instead of misread. Run with 2 ranks.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <map>

#include <gtest/gtest.h>

#include <hdf5.h>

#include "ChannelScene.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "TestScene.hpp"
#include "physics/ring/MultiRateHill.hpp"
#include "io/Snapshot.hpp"
#include "physics/channel/ClogMonitor.hpp"
#include "physics/channel/Inlet.hpp"
#include "physics/channel/StokesDrag.hpp"

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

// A fresh directory per test inside one directory rank 0 made with mkdtemp and removes when
// the process ends: a test never deletes anything it did not create.
struct ScratchRoot {
  std::string path;  // rank 0 only: the directory it created
  ~ScratchRoot() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

std::string scratch() {
  static ScratchRoot owned;
  static std::string base;
  static int count = 0;
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (base.empty()) {
    char name[4096] = {0};
    if (rank == 0) {
      const std::string pattern = (fs::temp_directory_path() / "cassini-snapshot-test-XXXXXX").string();
      std::snprintf(name, sizeof name, "%s", pattern.c_str());
      if (!mkdtemp(name)) throw std::runtime_error("mkdtemp failed for " + pattern);
      owned.path = name;
    }
    MPI_Bcast(name, sizeof name, MPI_CHAR, 0, MPI_COMM_WORLD);
    base = name;
  }
  const std::string dir = base + "/t" + std::to_string(count++);
  if (rank == 0) fs::create_directories(dir);
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
  const StateById before = gather_state(*a, true);
  auto b = make_sim(kScene);
  read_snapshot(*b, file);
  b->setup();
  const StateById after = gather_state(*b, true);
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) {
    EXPECT_GT(before.size(), 300u);
    EXPECT_EQ(differing(before, after), 0);
  }
  EXPECT_EQ(b->step_count, a->step_count);
  EXPECT_EQ(b->time, a->time);
}

namespace {
// An attribute of a snapshot's /results: its value read as a double, and its stored size in
// bytes (a string's length plus its NUL). number -1, bytes 0: missing.
struct ResultAttribute {
  double number = -1;
  std::size_t bytes = 0;
};
ResultAttribute result_attribute(const std::string& file, const char* key) {
  ResultAttribute r;
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return r;
  hid_t attr = H5Aopen_by_name(f, "results", key, H5P_DEFAULT, H5P_DEFAULT);
  if (attr >= 0) {
    hid_t type = H5Aget_type(attr);
    r.bytes = H5Tget_size(type);
    if (H5Tget_class(type) == H5T_FLOAT) H5Aread(attr, H5T_NATIVE_DOUBLE, &r.number);
    H5Tclose(type);
    H5Aclose(attr);
  }
  H5Fclose(f);
  return r;
}

// Snapshot after 500 steps, then 700 more steps: uninterrupted, restarted on the same rank
// count (2), restarted on 1 rank. All three bitwise the same.
void expect_restart_bitwise(const std::string& scene) {
  const std::string dir = scratch();
  auto a = make_sim(scene);
  a->setup();
  for (int s = 0; s < 500; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# case text");
  for (int s = 0; s < 700; ++s) a->step();
  const StateById uninterrupted = gather_state(*a, true);

  auto b = make_sim(scene);  // same rank count (2)
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 700; ++s) b->step();
  const StateById same = gather_state(*b, true);

  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  StateById other;
  if (rank == 0) {  // 1 rank from the 2-rank snapshot
    auto c = make_sim(scene, {}, MPI_COMM_SELF);
    read_snapshot(*c, file);
    c->setup();
    for (int s = 0; s < 700; ++s) c->step();
    other = gather_state(*c, true);
  }
  if (rank == 0) {
    EXPECT_EQ(differing(uninterrupted, same), 0) << "restart on the same rank count";
    EXPECT_EQ(differing(uninterrupted, other), 0) << "restart on 1 rank";
  }
}

}  // namespace

TEST(Snapshot, RestartContinuesBitwiseOnTheSameAndOnAnotherRankCount) { expect_restart_bitwise(kScene); }

TEST(Snapshot, DampingLimitedPileRestartsBitwise) {
  // e = 0.1 at N_c = 5: crowded beads' dashpots are limited by their contact loads of the
  // previous step (DampingLimit.hpp, particles/grains/damping_load), which the snapshot must
  // carry. The scene must actually crowd: some bead over the bound at the end.
  std::string scene = kScene;
  scene.replace(scene.find("e = 0.7"), 7, "e = 0.1");
  scene.replace(scene.find("n_c = 50"), 8, "n_c = 5");
  expect_restart_bitwise(scene);
  auto sim = make_sim(scene);
  sim->setup();
  for (int s = 0; s < 1200; ++s) sim->step();
  const auto& p = sim->particles;
  const std::size_t load = p.find_column("damping_load");
  ASSERT_NE(load, ParticleStore::kNoColumn);
  int crowded = 0, total = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) crowded += p.column(load, i)[0] + 2 * p.column(load, i)[1] > DampingLimit::kBound;
  MPI_Allreduce(&crowded, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  std::printf("beads over the damping bound after 1,200 steps: %d\n", total);
  EXPECT_GT(total, 0);
}

TEST(Snapshot, RollingResistanceRestartsBitwise) {
  // The rolling and twisting torque springs of the contacts open at the snapshot (pairs and the
  // floor) travel in it (contacts/roll, particles/grains/wall_roll).
  std::string scene = kScene;
  const std::string at = "mu_d = 0.4\n";
  scene.insert(scene.find(at) + at.size(), "mu_r = 0.1\nmu_o = 0.05\n");
  expect_restart_bitwise(scene);
}

TEST(Snapshot, AdhesiveContactsRestartBitwise) {
  // DMT adhesion (capture speed ~3 m/s against 5 m/s grains): contacts that stick across the
  // snapshot, and their onset and exit steps, continue as in the uninterrupted run.
  std::string scene = kScene;
  const std::string at = "mu_d = 0.4\n";
  scene.insert(scene.find(at) + at.size(), "surface_energy = 100.0\n");
  expect_restart_bitwise(scene);
}

TEST(Snapshot, LubricatedPileRestartsBitwise) {
  // Stiff films in a settling pile: the many-film scaling reads each bead's film load from the
  // previous step (particles/grains/lubrication_load), which the snapshot must carry.
  std::string scene = kScene;
  scene.replace(scene.find("modules = [\"contact\", \"gravity\"]"), 32,
                "modules = [\"contact\", \"gravity\", \"lubrication\"]");
  scene += "[lubrication]\nviscosity = 100.0\nroughness = 1.0e-7\n";
  auto probe = make_sim(scene);
  probe->setup();
  for (int s = 0; s < 500; ++s) probe->step();
  const ParticleStore& p = probe->particles;
  double load = 0, most = 0;
  for (const auto& c : p.module_columns)
    if (c.name == "lubrication_load")
      for (std::size_t i = 0; i < p.nlocal; ++i) load = std::max(load, c.data[i]);
  MPI_Allreduce(&load, &most, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_GT(most, 2.0) << "the test needs beads whose films are scaled (a load above 2 scales every film of the bead)";
  expect_restart_bitwise(scene);
}

TEST(Snapshot, BridgesContactsRestartBitwise) {
  // Under the Bridges law every contact's e was fixed at its impact: the impact speeds of the
  // contacts open at the snapshot (pairs, and particles on the floor wall) travel in it.
  // Impacts of ~1-5 m/s against v_c = 0.05 m/s: e ~ 0.3-0.5.
  expect_restart_bitwise(with_bridges(kScene, 0.05));
}

TEST(Snapshot, ChannelRestartKeepsInletIdsOutletCountsAndClogTimer) {
  // An open scene: beads come in and leave. Beyond the particles a restart must carry the
  // inlet's next id (the newest bead may have left), the outlet counts and the clog timer;
  // the snapshot also holds the run's results so far.
  const std::vector<std::string> over = {"inlet.x=-2.5e-4", "species[0].radius=2.5e-5"};
  const std::string dir = scratch();
  auto counts = [](Simulation& sim, long& inserted, long& removed, long& escapees) {
    inserted = sim.find<Inlet>()->inserted();
    long mine = sim.halo.removed;
    MPI_Allreduce(&mine, &removed, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    escapees = sim.find<ClogMonitor>()->escapees();
  };
  auto a = make_sim(channel_case(), over);
  a->setup();
  for (int s = 0; s < 110000; ++s) a->step();  // 0.22 s: the first beads have left
  const std::string file = write_snapshot(*a, dir, "# channel");
  long i0, r0, e0;
  counts(*a, i0, r0, e0);
  for (int s = 0; s < 50000; ++s) a->step();
  const StateById uninterrupted = gather_state(*a, true);
  long i1, r1, e1;
  counts(*a, i1, r1, e1);

  auto b = make_sim(channel_case(), over);
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 50000; ++s) b->step();
  const StateById restarted = gather_state(*b, true);
  long i2, r2, e2;
  counts(*b, i2, r2, e2);

  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank != 0) return;
  EXPECT_GT(r0, 0) << "no bead had left before the snapshot: the outlet count is not tested";
  EXPECT_GT(i1, i0) << "no bead came in after the snapshot: the inlet ids are not tested";
  EXPECT_EQ(differing(uninterrupted, restarted), 0);
  EXPECT_EQ(i1, i2);
  EXPECT_EQ(r1, r2);
  EXPECT_EQ(e1, e2);
  // The results at the snapshot, readable as attributes of /results.
  EXPECT_EQ(result_attribute(file, "escapees").number, static_cast<double>(e0));
}

TEST(Snapshot, TwoWayCoupledChannelRestartsBitwise) {
  // Beads larger than the neck pile up behind it under a fixed pressure drop: the coupled flow
  // is re-solved as the pile grows, and at the snapshot; a restart solves again there, from the
  // same beads, and goes on bitwise.
  const std::vector<std::string> over = {"inlet.x=-2.5e-4", "species[0].radius=4.5e-5", "flow.coupling=\"two-way\"",
                                         "flow.drive=\"pressure\""};
  const std::string dir = scratch();
  auto a = make_sim(channel_case(), over);
  a->setup();
  for (int s = 0; s < 60000; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# coupled channel");
  const long solves_before = a->find<StokesDrag>()->coupling()->solves();
  for (int s = 0; s < 30000; ++s) a->step();
  const StateById uninterrupted = gather_state(*a, true);
  const FlowCoupling& ca = *a->find<StokesDrag>()->coupling();

  auto b = make_sim(channel_case(), over);
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 30000; ++s) b->step();
  const StateById restarted = gather_state(*b, true);
  const FlowCoupling& cb = *b->find<StokesDrag>()->coupling();

  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank != 0) return;
  EXPECT_GT(ca.solves(), solves_before + 2) << "the flow was not re-solved after the snapshot";
  EXPECT_LT(ca.flow_rate(), 0.95 * 4e-4 * 1e-4 * 1.47e-3)
      << "the pile did not slow the flow";
  EXPECT_EQ(differing(uninterrupted, restarted), 0);
  EXPECT_EQ(ca.flow_rate(), cb.flow_rate());
  EXPECT_EQ(ca.pressure_drop(), cb.pressure_drop());
}

TEST(Snapshot, ContinuousChannelRestartedDuringARecoveryCountsTheSameAvalanches) {
  // Continuous mode with a cleared pile and a recovery (clog.clear_length, clog.recover): a
  // snapshot taken after a clearing, before the next avalanche's count starts, restarts into
  // the same run: the same beads, avalanches, their start and clog times, and recovery clogs.
  const std::vector<std::string> over = {"clog.window=0.2",       "clog.rest_speed=0",      "clog.mode=\"continuous\"",
                                         "clog.avalanches=3",     "clog.clear_length=3.0e-4", "clog.recover=0.1",
                                         "time.end=8.0"};
  const std::string dir = scratch();
  auto a = make_sim(channel_case(), over);
  a->setup();
  const auto* ca = a->find<ClogMonitor>();
  while (ca->removed() == 0 && a->time < 4.0) a->step();
  ASSERT_GT(ca->removed(), 0) << "no clog to clear";
  for (int s = 0; s < 200; ++s) a->step();  // inside the 0.1 s recovery (dt = 1e-5 s)
  ASSERT_EQ(ca->avalanche_starts().size(), 1u) << "the count already resumed: the snapshot would not test a recovery";
  const std::string file = write_snapshot(*a, dir, "# continuous channel");
  const double t_snap = a->time;
  while (!a->record.finished && a->time < 8.0) a->step();
  const StateById uninterrupted = gather_state(*a, true);

  auto b = make_sim(channel_case(), over);
  read_snapshot(*b, file);
  b->setup();
  ASSERT_EQ(b->time, t_snap);
  while (!b->record.finished && b->time < 8.0) b->step();
  const StateById restarted = gather_state(*b, true);
  const auto* cb = b->find<ClogMonitor>();
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank != 0) return;
  ASSERT_EQ(ca->avalanches().size(), 3u);
  EXPECT_EQ(a->time, b->time);
  EXPECT_EQ(differing(uninterrupted, restarted), 0);
  EXPECT_EQ(ca->avalanches(), cb->avalanches());
  EXPECT_EQ(ca->avalanche_starts(), cb->avalanche_starts());
  EXPECT_EQ(ca->avalanche_clogs(), cb->avalanche_clogs());
  EXPECT_EQ(ca->recovery_clogs(), cb->recovery_clogs());
  EXPECT_EQ(ca->removed(), cb->removed());
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

TEST(Snapshot, ResultsThatDifferByRankAreWrittenAsRankZeroHasThem) {
  // A module's result may carry per-rank numbers (self-gravity's timings). HDF5 creates
  // attributes collectively: a string of another length on one rank left the ranks' metadata
  // caches different, and both hung inside H5Fclose (gravity-wakes after 3 orbits). The
  // snapshot writes rank 0's results on every rank.
  const std::string dir = scratch();
  auto a = make_sim(kScene);
  a->setup();
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  a->set_result("timing", rank == 0 ? "{\"seconds\": 1.5}" : "{\"seconds\": 12.25}");
  a->set_result("count", rank == 0 ? "7" : "8");
  const std::string file = write_snapshot(*a, dir, "# case text");
  if (rank != 0) return;
  EXPECT_EQ(result_attribute(file, "count").number, 7.0);
  // attr_string stores the terminating NUL
  EXPECT_EQ(result_attribute(file, "timing").bytes, std::string("{\"seconds\": 1.5}").size() + 1);
}

TEST(Snapshot, MultiRateRingRestartsBitwiseAtALongStepBoundary) {
  // Snapshots of the multi-rate integrator fall on long-step ends (output steps end a long
  // step), where every particle is synchronised: the restart reclassifies and continues alike.
  const std::vector<std::string> ring = {"seed=5", "species.0.t_c=4.0", "particles.count=2000", "time.n_c=10",
                                         "time.integrator=\"multirate\"", "time.long_step=20.0"};
  const std::string dir = scratch();
  auto a = make_sim(kPropellerPatch, ring);
  a->setup();
  for (int s = 0; s < 2000; ++s) a->step();  // 40 long steps of 50
  const std::string file = write_snapshot(*a, dir, "# case text");
  for (int s = 0; s < 3000; ++s) a->step();
  const StateById uninterrupted = gather_state(*a, true);
  const long wakes = a->find<MultiRateHill>()->wakes;
  auto b = make_sim(kPropellerPatch, ring);
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 3000; ++s) b->step();
  const StateById restarted = gather_state(*b, true);
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  long all_wakes = 0;
  MPI_Reduce(&wakes, &all_wakes, 1, MPI_LONG, MPI_SUM, 0, MPI_COMM_WORLD);
  if (rank == 0) {
    EXPECT_GT(all_wakes, 0) << "the run should exercise wake-ups";
    EXPECT_EQ(differing(uninterrupted, restarted), 0);
  }
}

TEST(Snapshot, ModifiedLeesEdwardsRestartsBitwise) {
  // The feed's next id and the copy of every particle travel in the snapshot: clones made after
  // the restart get the ids (and hence the contact sums) of the uninterrupted run.
  const std::vector<std::string> fed = {"seed=5", "species.0.t_c=4.0", "time.n_c=10", "time.integrator=\"multirate\"",
                                        "time.long_step=20.0", "domain.modified_lees_edwards=true"};
  const std::string dir = scratch();
  auto a = make_sim(kPropellerPatch, fed);
  a->setup();
  for (int s = 0; s < 2000; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# case text");
  const std::int64_t fed_before = a->halo.fed;
  for (int s = 0; s < 3000; ++s) a->step();
  const StateById uninterrupted = gather_state(*a, true);
  std::int64_t fed_after = a->halo.fed - fed_before, all_fed = 0;
  MPI_Reduce(&fed_after, &all_fed, 1, MPI_INT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
  auto b = make_sim(kPropellerPatch, fed);
  read_snapshot(*b, file);
  b->setup();
  for (int s = 0; s < 3000; ++s) b->step();
  const StateById restarted = gather_state(*b, true);
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) {
    EXPECT_GT(all_fed, 20) << "clones must be made after the snapshot";
    EXPECT_EQ(differing(uninterrupted, restarted), 0);
  }
}

namespace {
const char* kGravityRing = R"(
seed = 4
modules = ["contact", "hill", "self-gravity"]
[domain]
lo = [-100.0, -100.0, -25.0]
hi = [100.0, 100.0, 25.0]
boundary = ["periodic", "lees_edwards", "open"]
[hill]
orbit_radius = 1.3e8
[self_gravity]
grid = [32, 32, 16]
every = 3
[[species]]
density = 400.0
radius_min = 1.0
radius_max = 2.5
size_distribution = "power_law"
restitution = "bridges"
t_c = 20.0
[particles]
init = "random"
count = 800
layer = 6.0
shear_flow = true
velocity_sigma = 0.002
[time]
n_c = 10
end = 1.0e6
)";
}  // namespace

TEST(Snapshot, SelfGravityRestartsBitwise) {
  // The mesh and pair forces are recomputed from the positions at the solve steps (every 3rd
  // here; the snapshot at step 500 falls between two): nothing beyond the particles and the
  // forces they carry needs to travel.
  expect_restart_bitwise(kGravityRing);
}

TEST(Snapshot, SelfGravityUnderModifiedLeesEdwardsRestartsBitwise) {
  // Two copies of the box, each with its own mesh field; LE1 drains and is fed clones of LE2.
  std::string scene = kGravityRing;
  scene.replace(scene.find("boundary = "), 0, "modified_lees_edwards = true\n");
  expect_restart_bitwise(scene);
}

// Self-gravity under the multi-rate integrator: the snapshot (step 500) falls on a long step's
// end (10 steps); the restart solves the mesh and the short range there afresh and must kick
// with the same bits as the uninterrupted run's forces of that step; then under the modified
// Lees-Edwards boundaries too.
std::string multirate_gravity_ring(bool fed) {
  std::string scene = kGravityRing;
  scene.replace(scene.find("every = 3"), 9, "");
  scene.replace(scene.find("n_c = 10"), 8, "n_c = 10\nintegrator = \"multirate\"\nlong_step = 20.0");
  if (fed) scene.replace(scene.find("boundary = "), 0, "modified_lees_edwards = true\n");
  return scene;
}

TEST(Snapshot, SelfGravityUnderTheMultiRateIntegratorRestartsBitwise) { expect_restart_bitwise(multirate_gravity_ring(false)); }

TEST(Snapshot, SelfGravityUnderMultiRateAndModifiedLeesEdwardsRestartsBitwise) {
  expect_restart_bitwise(multirate_gravity_ring(true));
}

// A module's own per-particle column (ParticleStore::declare) needs no code of its own to
// travel: with its particle between the ranks, to the ghosts every step, and through a
// snapshot and a restart. The values are a known function of the id and the step (the owner
// sets them after each step; the next step carries them to the ghosts), so any particle that
// lost, swapped or kept stale values is found.
TEST(ModuleColumns, TravelWithTheirParticlesThroughMigrationGhostsAndRestart) {
  auto tag = [](std::int64_t id, int k, long step) {
    return k == 0 ? 3.0 * double(id) + 0.5 + double(step) : -double(id) - 1000.0 * double(step);
  };
  auto set = [&](Simulation& s, std::size_t c, long step) {
    for (std::size_t i = 0; i < s.particles.nlocal; ++i)
      for (int k = 0; k < 2; ++k) s.particles.column(c, i)[k] = tag(s.particles.id[i], k, step);
  };
  auto wrong = [&](const Simulation& s, std::size_t c, long step) {
    long bad = 0;
    for (std::size_t i = 0; i < s.particles.size(); ++i)  // owned and ghosts
      for (int k = 0; k < 2; ++k) bad += s.particles.column(c, i)[k] != tag(s.particles.id[i], k, step);
    return bad;
  };
  const std::string dir = scratch();
  auto a = make_sim(kScene);
  const std::size_t c = a->particles.declare("tag", 2, ParticleStore::Ghosts::carry);
  a->setup();
  std::set<std::int64_t> first;
  for (std::size_t i = 0; i < a->particles.nlocal; ++i) first.insert(a->particles.id[i]);
  set(*a, c, 0);
  for (long s = 1; s <= 800; ++s) {
    a->step();
    if (s % 50 == 0) {
      EXPECT_EQ(wrong(*a, c, s - 1), 0) << "step " << s;
    }
    set(*a, c, s);
  }
  long arrived = 0, migrated = 0;  // particles this rank owns now that another rank owned at the start
  for (std::size_t i = 0; i < a->particles.nlocal; ++i) arrived += !first.count(a->particles.id[i]);
  MPI_Allreduce(&arrived, &migrated, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_GT(migrated, 10) << "the test needs particles that changed rank";
  EXPECT_GT(a->particles.nghost(), 10u) << "the test needs ghosts";

  const std::string file = write_snapshot(*a, dir, "# case text");  // rebuilds: ghosts get step 800's values
  auto b = make_sim(kScene);
  const std::size_t cb = b->particles.declare("tag", 2, ParticleStore::Ghosts::carry);
  read_snapshot(*b, file);
  b->setup();
  EXPECT_EQ(wrong(*b, cb, 800), 0) << "after the restart";
  EXPECT_THROW(b->particles.declare("late", 1, ParticleStore::Ghosts::zero), std::logic_error);  // particles exist already
}

// The wall modules keep their springs in their own columns (WallHistory: plane_wall_xi,
// moonlet_xi, ...). Snapshots written before that kept every wall module's springs side by side
// in one column, wall_xi, in the order the modules were made. Such a file, made here from a new
// one by joining the modules' columns, restarts into the same state as the file it came from.
TEST(Snapshot, OlderSharedWallSpringColumnsRestartIntoEachWallModule) {
  // Two wall modules with friction: the floor and ceiling (plane walls) and a sphere (the
  // moonlet's surface) half sunk in the floor at the middle of the box, which the grains hit.
  const std::vector<std::string> over = {"modules=[\"contact\", \"gravity\", \"moonlet\"]", "moonlet.mass=1.0",
                                         "moonlet.radius=0.003", "domain.lo=[-0.008, -0.004, 0.0]",
                                         "domain.hi=[0.008, 0.004, 0.016]", "particles.volume_fraction=0.2"};
  std::string scene = kScene;  // random placement: it keeps clear of the sphere
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"init = \"lattice\"", "init = \"random\""},
                                 {"jitter = 0.5\n", ""}})
    scene.replace(scene.find(from), from.size(), to);
  const std::string dir = scratch();
  auto a = make_sim(scene, over);
  a->setup();
  for (int s = 0; s < 2000; ++s) a->step();
  const std::string file = write_snapshot(*a, dir, "# case text");
  std::vector<std::string> shares;  // the wall columns in the order they were declared
  for (const auto& c : a->particles.module_columns)
    if (c.former.name == "wall_xi") shares.push_back(c.name);
  ASSERT_EQ(shares.size(), 2u);
  long loaded[2] = {0, 0}, all[2] = {0, 0};  // particles with a spring in each module
  for (int m = 0; m < 2; ++m)
    for (const Vec3& spring : [&] {
           std::vector<Vec3> v;
           for (std::size_t i = 0; i < a->particles.nlocal; ++i)
             for (const Vec3& s : wall_vectors(a->particles, shares[m], i)) v.push_back(s);
           return v;
         }())
      loaded[m] += spring.norm() > 0;
  MPI_Allreduce(loaded, all, 2, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_GT(all[0], 0) << shares[0] << ": no spring to carry";
  EXPECT_GT(all[1], 0) << shares[1] << ": no spring to carry";

  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const std::string older = dir + "/older.h5md";
  if (rank == 0) {  // the older layout: one wall_xi, the modules' columns gone
    fs::copy_file(file, older);
    hid_t f = H5Fopen(older.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    std::vector<std::vector<double>> parts;
    std::vector<hsize_t> widths;
    hsize_t n = 0, total = 0;
    for (const std::string& name : shares) {
      const std::string path = "particles/grains/" + name + "/value";
      hid_t d = H5Dopen2(f, path.c_str(), H5P_DEFAULT);
      hid_t sp = H5Dget_space(d);
      hsize_t dims[3];
      H5Sget_simple_extent_dims(sp, dims, nullptr);
      n = dims[1];
      widths.push_back(dims[2]);
      total += dims[2];
      parts.emplace_back(n * dims[2]);
      H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, parts.back().data());
      H5Sclose(sp);
      H5Dclose(d);
      H5Ldelete(f, ("particles/grains/" + name).c_str(), H5P_DEFAULT);
    }
    std::vector<double> joined;
    for (hsize_t k = 0; k < n; ++k)
      for (std::size_t m = 0; m < parts.size(); ++m)
        joined.insert(joined.end(), &parts[m][k * widths[m]], &parts[m][(k + 1) * widths[m]]);
    hid_t g = H5Gcreate2(f, "particles/grains/wall_xi", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[3] = {1, n, total};
    hid_t sp = H5Screate_simple(3, dims, nullptr);
    hid_t d = H5Dcreate2(g, "value", H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, joined.data());
    H5Dclose(d);
    H5Sclose(sp);
    H5Gclose(g);
    H5Fclose(f);
  }
  MPI_Barrier(MPI_COMM_WORLD);

  auto from_new = make_sim(scene, over), from_older = make_sim(scene, over);
  read_snapshot(*from_new, file);
  read_snapshot(*from_older, older);
  from_new->setup();
  from_older->setup();
  for (int s = 0; s < 200; ++s) {
    from_new->step();
    from_older->step();
  }
  const StateById expected = gather_state(*from_new, true), got = gather_state(*from_older, true);
  if (rank == 0) EXPECT_EQ(differing(expected, got), 0);
}
