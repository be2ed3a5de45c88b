#pragma once
// Partition of a box's cell grid into `parts` pieces of about equal weight with short borders
// (few ghosts): METIS k-way on the graph of face-adjacent cells, periodic axes wrapped.
// METIS 5.1's edge cases are handled here, not left to the caller: one part (it crashes)
// is answered without it, more parts than cells leaves the extra parts empty, and an empty
// part in a METIS answer is given one cell from the largest part.
#include <array>
#include <vector>

namespace cassini {

// weight[c] >= 0 for cell c = (k * n[1] + j) * n[0] + i. Returns the part of every cell.
// Deterministic: the same input gives the same partition on every rank.
std::vector<int> partition_cells(const std::array<int, 3>& n, const std::array<bool, 3>& periodic,
                                 const std::vector<double>& weight, int parts);

}  // namespace cassini
