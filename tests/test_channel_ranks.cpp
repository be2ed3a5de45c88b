// The clogging scene on 1 and on 2 ranks gives bitwise the same beads: insertion is drawn
// identically on every rank, phi is summed in fixed point (order-free), and contact and
// wall forces are summed per particle in a fixed order; the two-way coupled flow is solved alike
// on every rank. Also the inlet/outlet bookkeeping
// on 2 ranks: inserted = present + removed. Run with 2 ranks.
#include <gtest/gtest.h>

#include "ChannelScene.hpp"
#include "TestScene.hpp"
#include "physics/channel/Inlet.hpp"


using namespace cassini;
using namespace cassini::test;

namespace {

void one_vs_two_ranks(std::vector<std::string> over) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  // Beads inserted near the neck so that some pass it and leave through the outlet soon.
  over.insert(over.end(), {"inlet.x=-2.5e-4", "species[0].radius=2.5e-5"});
  const long steps = 150000;  // 0.3 s
  auto run = [&](MPI_Comm comm, long& inserted, long& present, long& removed) {
    auto sim = make_sim(channel_case(), over, comm);
    sim->setup();
    for (long s = 0; s < steps; ++s) sim->step();
    inserted = sim->find<Inlet>()->inserted();
    present = sim->total_particles();
    long mine = sim->halo.removed;
    MPI_Allreduce(&mine, &removed, 1, MPI_LONG, MPI_SUM, comm);
    return gather_state(*sim, true);
  };
  long i1 = 0, p1 = 0, r1 = 0, i2 = 0, p2 = 0, r2 = 0;
  StateById one;
  if (rank == 0) one = run(MPI_COMM_SELF, i1, p1, r1);
  const StateById two = run(MPI_COMM_WORLD, i2, p2, r2);
  if (rank != 0) return;
  EXPECT_GT(r2, 0) << "no bead reached the outlet: the test would not check removal";
  EXPECT_EQ(i2, p2 + r2);
  EXPECT_EQ(i1, p1 + r1);
  EXPECT_EQ(i1, i2);
  ASSERT_GT(one.size(), 10u);
  EXPECT_EQ(differing(one, two), 0);
}

}  // namespace

TEST(ChannelRanks, OneAndTwoRanksAgreeBitwiseAndCountEveryBead) { one_vs_two_ranks({}); }

TEST(ChannelRanks, MetisCellsBalancedEveryRebuildWithLubricationAgreeBitwise) {
  // Lubrication widens the pair range to a + a + d/2: ghosts reach further.
  one_vs_two_ranks({"domain.decomposition=\"metis\"", "domain.balance_every=1",
                    "modules=[\"contact\", \"channel\", \"drag\", \"inlet\", \"clog\", \"lubrication\"]"});
}

TEST(ChannelRanks, TwoWayCoupledFlowUnderAPressureDriveAgreesBitwise) {
  // The coupled flow is deposited in fixed point and solved on every rank with Eigen's own
  // Cholesky: every rank holds the same correction, whatever the split (a low tolerance makes it
  // re-solve often).
  one_vs_two_ranks({"flow.coupling=\"two-way\"", "flow.drive=\"pressure\"", "flow.coupling_tolerance=0.01"});
}

TEST(ChannelRanks, PrefilledChannelAgreesBitwise) {
  // The prefill draws every candidate on every rank alike and each rank adds the beads it owns.
  one_vs_two_ranks({"inlet.prefill=true"});
}
