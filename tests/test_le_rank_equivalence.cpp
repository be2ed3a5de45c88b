// Lees-Edwards scenes on 1, 2, 3 and 4 ranks give bitwise identical trajectories. With slabs
// along x, the ranks facing a slab across the sheared boundary change as the offset grows
// and an image region can straddle several ranks; the runs below last long enough for the
// offset to sweep the whole box (4 slab widths at 4 ranks). Run with 4 ranks: communicators
// of 1, 2, 3 and 4 ranks are split off and compared with the 1-rank result.
#include <map>

#include <gtest/gtest.h>

#include "TestScene.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

StateById run(const std::string& text, const std::vector<std::string>& over, MPI_Comm comm, int steps, double* offset) {
  auto sim = make_sim(text, over, comm);
  sim->setup();
  for (int s = 0; s < steps; ++s) sim->step();
  *offset = sim->domain.shear.offset;
  return gather_state(*sim, true);  // forces too: a last-bit difference in a kick rounds away in v
}

void compare_rank_counts(const std::string& text, const std::vector<std::string>& over, int steps, double sweep) {
  int rank = 0, size = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  ASSERT_EQ(size, 4) << "run this test with 4 ranks";
  StateById reference;
  for (int k = 1; k <= 4; ++k) {
    MPI_Comm sub;
    MPI_Comm_split(MPI_COMM_WORLD, rank < k ? 0 : MPI_UNDEFINED, rank, &sub);
    if (sub == MPI_COMM_NULL) continue;
    double offset = 0;
    StateById s;
    // A guard stops every rank of `sub` together; caught here, so that all ranks still meet at
    // the next split (a test that throws on some ranks only would hang the others).
    try {
      s = run(text, over, sub, steps, &offset);
    } catch (const std::exception& e) {
      ADD_FAILURE() << k << " rank(s): " << e.what();
    }
    MPI_Comm_free(&sub);
    if (rank != 0) continue;
    EXPECT_GT(offset, sweep) << "the offset must sweep the box";
    // No ASSERT here: returning early on rank 0 would leave the others in the next collective.
    if (k == 1) {
      reference = s;
      EXPECT_GT(s.size(), 50u);
      continue;
    }
    EXPECT_EQ(differing(reference, s), 0) << "particles differing bitwise between 1 and " << k << " ranks";
  }
}

// A grid of regions needs more ranks than the automatic shape gives at 4 (in 2D, 4 slabs have
// no more surface than 2 x 2): the 2 x 2 grid (domain.grid) on 4 ranks against 1 rank.
void compare_grid_2x2(const std::string& text, const std::vector<std::string>& over, int steps) {
  int rank = 0, size = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  ASSERT_EQ(size, 4) << "run this test with 4 ranks";
  StateById one, four;
  double offset = 0;
  MPI_Comm sub;
  MPI_Comm_split(MPI_COMM_WORLD, rank == 0 ? 0 : MPI_UNDEFINED, rank, &sub);
  if (sub != MPI_COMM_NULL) {
    try {
      one = run(text, over, sub, steps, &offset);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "1 rank: " << e.what();
    }
    MPI_Comm_free(&sub);
  }
  std::vector<std::string> grid = over;
  grid.insert(grid.end(), {"domain.decomposition=\"grid\"", "domain.grid=[2, 2, 1]"});
  try {
    four = run(text, grid, MPI_COMM_WORLD, steps, &offset);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "4 ranks, 2 x 2: " << e.what();
  }
  if (rank != 0) return;
  EXPECT_GT(one.size(), 50u);
  EXPECT_EQ(differing(one, four), 0) << "particles differing bitwise between 1 rank and a 2 x 2 grid";
}

// Frictional sheared gas: contact history must survive crossings of the sheared boundary.
const char* kShearedGas = R"(
seed = 77
modules = ["contact"]
[domain]
lo = [0.0, -0.005, 0.0]
hi = [0.02, 0.005, 0.01]
boundary = ["periodic", "lees_edwards", "periodic"]
shear_rate = 500.0
[[species]]
density = 2500.0
radius = 0.0005
t_c = 2.0e-5
e = 0.8
mu_s = 0.4
mu_d = 0.3
[particles]
init = "random"
volume_fraction = 0.25
velocity_sigma = 1.0
[time]
n_c = 50
end = 1.0
)";


}  // namespace

TEST(LeesEdwardsRanks, FrictionalShearedGasSlabsAlongX) {
  // offset after 10,000 steps: 500 1/s x 0.01 m x 4e-3 s = 0.02 m = Lx
  compare_rank_counts(kShearedGas, {}, 10000, 0.02 * 0.99);
}

TEST(LeesEdwardsRanks, FrictionalShearedGasSlabsAlongY) {
  compare_rank_counts(kShearedGas, {"domain.slab_axis=\"y\"", "domain.hi=[0.02, 0.0075, 0.01]",
                                    "domain.lo=[0.0, -0.0075, 0.0]"},
                      4000, 0.0);
}

TEST(LeesEdwardsRanks, PropellerPatchWithMoonlet) {
  // offset after 11,000 steps of 0.4 s: 1.5 Omega0 x 1000 m x 4400 s = 1015 m > Lx
  compare_rank_counts(kPropellerPatch, {}, 11000, 1000.0);
}

TEST(LeesEdwardsRanks, MoreRanksThanCells) {
  // 4 ranks in a box 2.3 interaction ranges long: every slab is thinner than the range, so
  // images reach across several ranks.
  compare_rank_counts(kShearedGas, {"domain.hi=[0.0025, 0.005, 0.01]", "particles.volume_fraction=0.2"}, 3000, 0.0);
}

TEST(LeesEdwardsRanks, FrictionalShearedGasMetisCells) {
  // Cells owned by METIS parts: the ranks across the sheared boundary are a patchwork.
  compare_rank_counts(kShearedGas, {"domain.decomposition=\"metis\""}, 10000, 0.02 * 0.99);
}

TEST(LeesEdwardsRanks, FrictionalShearedGasGridRebalanced) {
  // A 2 x 2 grid of regions, cut across the sheared boundary too, its cuts moved along each
  // axis at every fifth rebuild; the automatic shape on 1-4 ranks (slabs here) as well.
  const std::vector<std::string> square = {"domain.lo=[0.0, -0.01, 0.0]", "domain.hi=[0.02, 0.01, 0.01]",
                                           "domain.balance_every=5"};
  compare_grid_2x2(kShearedGas, square, 2000);
  std::vector<std::string> automatic = square;
  automatic.push_back("domain.decomposition=\"grid\"");
  compare_rank_counts(kShearedGas, automatic, 500, 0.0);
}

TEST(LeesEdwardsRanks, PropellerPatchModifiedBoundariesMultiRateGrid) {
  // The fed patch on a 2 x 2 grid: clones, drains and inflow images cross region corners.
  compare_grid_2x2(kPropellerPatch, {"domain.modified_lees_edwards=true", "time.integrator=\"multirate\"",
                                     "time.long_step=20.0"},
                   2500);
}

TEST(LeesEdwardsRanks, SelfGravityGrid) {
  // A self-gravitating 3D ring patch (tests/test_self_gravity.cpp's, contacts, the short range,
  // a solve every 2 steps) on a 2 x 2 grid: each rank's mesh box is a block of rows and
  // columns, sheared; 300 steps.
  compare_grid_2x2(kSelfGravityPatch,
                   {"particles.init=\"random\"", "particles.count=600", "particles.shear_flow=true",
                    "particles.velocity_sigma=0.001", "self_gravity.split=3.0", "self_gravity.every=2"},
                   300);
}

TEST(LeesEdwardsRanks, PropellerPatchMultiRate) {
  // The multi-rate integrator: classification and wake-ups are made from each particle's own
  // side, so they too are the same on any rank count (long steps of 50 steps). The slab cuts
  // move every second rebuild, weighted by each particle's contact steps.
  compare_rank_counts(kPropellerPatch, {"time.integrator=\"multirate\"", "time.long_step=20.0", "domain.balance_every=2"},
                      11000, 1000.0);
}

TEST(LeesEdwardsRanks, PropellerPatchBridgesMultiRate) {
  // The Bridges law in the ring (impacts of ~1e-3 m/s against v_c = 1e-4 m/s: e ~ 0.6) under
  // the multi-rate integrator: impact speeds travel with the contacts on any rank count.
  compare_rank_counts(with_bridges(kPropellerPatch, 1e-4), {"time.integrator=\"multirate\"", "time.long_step=20.0"},
                      11000, 1000.0);
}

TEST(LeesEdwardsRanks, PropellerPatchModifiedBoundariesMultiRate) {
  // Modified Lees-Edwards boundaries: LE2 particles crossing x are cloned into LE1 with ids
  // every rank agrees on, LE1 particles leaving x are removed, LE1 sees LE2 beyond its inflow
  // faces. 5,000 steps (2,000 s): the patch's edges move 230 m, a few hundred clones are made.
  compare_rank_counts(kPropellerPatch, {"domain.modified_lees_edwards=true", "time.integrator=\"multirate\"",
                                        "time.long_step=20.0"},
                      5000, 0.0);
}

TEST(LeesEdwardsRanks, ThickRingMultiRateSlabsAlongX) {
  // A 3D ring gas (vertical tide, 1 mm/s) under the multi-rate integrator. The free particles'
  // drift bound decides the rebuild steps, and with them when the free particles are moved to
  // the present (exact epicycle maps over other intervals differ in the last bits): it must
  // combine maxima over all ranks. Built from each rank's own maxima it was smaller on more
  // ranks, rebuilt at other steps, and 423 of the ~600 particles differed after 1,000 steps.
  const char* ring = R"(
seed = 11
modules = ["contact", "hill"]
[domain]
lo = [-100.0, -100.0, -16.0]
hi = [100.0, 100.0, 16.0]
boundary = ["periodic", "lees_edwards", "open"]
slab_axis = "x"
[hill]
saturn_mass = 5.68e26
orbit_radius = 1.3e8
[[species]]
density = 400.0
radius = 1.0
t_c = 50.0
e = 0.5
[particles]
init = "random"
count = 600
shear_flow = true
velocity_sigma = 0.001
[time]
dt = 2.0
end = 1.0e6
integrator = "multirate"
long_step = 20.0
)";
  compare_rank_counts(ring, {}, 1000, 0.0);
}
