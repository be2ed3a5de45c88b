// partition_cells against what a partition must be: every cell in a valid part, no part
// empty, cost shared to METIS's tolerance, the same answer twice, and METIS 5.1's edge cases
// (one part; more parts than cells) answered without calling it.
#include <algorithm>
#include <numeric>

#include <gtest/gtest.h>

#include "parallel/MetisPartition.hpp"

using namespace cassini;

namespace {

std::vector<double> part_weights(const std::vector<int>& part, const std::vector<double>& w, int parts) {
  std::vector<double> sum(parts, 0.0);
  for (std::size_t c = 0; c < part.size(); ++c) sum[part[c]] += w[c];
  return sum;
}

}  // namespace

TEST(MetisPartition, OnePartNeedsNoMetis) {
  const auto part = partition_cells({4, 3, 2}, {false, false, false}, std::vector<double>(24, 1.0), 1);
  EXPECT_EQ(part, std::vector<int>(24, 0));
}

TEST(MetisPartition, MorePartsThanCellsGivesOneCellEach) {
  const auto part = partition_cells({3, 1, 1}, {true, false, false}, std::vector<double>(3, 1.0), 5);
  EXPECT_EQ(part, (std::vector<int>{0, 1, 2}));
}

TEST(MetisPartition, UniformGridSplitsEvenlyIntoNonEmptyParts) {
  const std::array<int, 3> n{26, 5, 1};
  const std::vector<double> w(130, 1.0);
  for (int parts : {2, 3, 4, 7}) {
    const auto part = partition_cells(n, {false, false, false}, w, parts);
    const auto sum = part_weights(part, w, parts);
    for (int p = 0; p < parts; ++p) EXPECT_GT(sum[p], 0) << parts << " parts: part " << p << " empty";
    EXPECT_LT(*std::max_element(sum.begin(), sum.end()) / (130.0 / parts), 1.1) << parts << " parts";
    EXPECT_EQ(part, partition_cells(n, {false, false, false}, w, parts)) << "not deterministic";
  }
}

TEST(MetisPartition, CrowdedCellsAreSharedByCost) {
  // A channel whose cost sits in its first quarter (the pile upstream of a clog): a cut by
  // cell count would give one rank almost everything; METIS weighs the cells.
  const std::array<int, 3> n{40, 6, 1};
  std::vector<double> w(240, 0.0);
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 10; ++i) w[j * 40 + i] = 50.0 + i + j;
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  for (int parts : {2, 4}) {
    const auto sum = part_weights(partition_cells(n, {false, false, false}, w, parts), w, parts);
    // METIS's default tolerance is 3 % on its integer weights; the +1 per cell adds a little.
    EXPECT_LT(*std::max_element(sum.begin(), sum.end()) / (total / parts), 1.1) << parts << " parts";
  }
}

TEST(MetisPartition, PeriodicAxesOfOneAndTwoCellsMakeAValidGraph) {
  // Wrapping an axis of 2 cells would list a neighbour twice, of 1 cell the cell itself;
  // METIS rejects or mis-handles both.
  const auto part = partition_cells({2, 1, 8}, {true, true, true}, std::vector<double>(16, 1.0), 4);
  const auto sum = part_weights(part, std::vector<double>(16, 1.0), 4);
  for (double s : sum) EXPECT_GT(s, 0);
}
