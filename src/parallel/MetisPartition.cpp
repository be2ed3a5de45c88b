#include "parallel/MetisPartition.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include <metis.h>

namespace cassini {

std::vector<int> partition_cells(const std::array<int, 3>& n, const std::array<bool, 3>& periodic,
                                 const std::vector<double>& weight, int parts) {
  const int cells = n[0] * n[1] * n[2];
  std::vector<int> part(cells, 0);
  if (parts <= 1) return part;  // METIS 5.1 crashes when asked for one part
  if (parts >= cells) {         // one cell each; the remaining parts stay empty
    std::iota(part.begin(), part.end(), 0);
    return part;
  }

  // CSR adjacency: up to 6 face neighbours, wrapped on periodic axes, without duplicates
  // (an axis of 2 cells would list the same neighbour twice) or self loops (an axis of 1).
  std::vector<idx_t> xadj{0}, adj;
  auto index = [&](int i, int j, int k) { return (k * n[1] + j) * n[0] + i; };
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        const int c[3] = {i, j, k}, self = index(i, j, k);
        const std::size_t first = adj.size();
        for (int d = 0; d < 3; ++d)
          for (int s : {-1, 1}) {
            int q[3] = {c[0], c[1], c[2]};
            q[d] += s;
            if (q[d] < 0 || q[d] >= n[d]) {
              if (!periodic[d]) continue;
              q[d] = (q[d] + n[d]) % n[d];
            }
            const idx_t nb = index(q[0], q[1], q[2]);
            if (nb != self && std::find(adj.begin() + first, adj.end(), nb) == adj.end()) adj.push_back(nb);
          }
        xadj.push_back(static_cast<idx_t>(adj.size()));
      }

  // Integer vertex weights: cost relative to the mean cell, plus one so that empty cells
  // still count (they cost a little: cell loops, ghosts).
  const double total = std::accumulate(weight.begin(), weight.end(), 0.0);
  const double unit = total > 0 ? 1000.0 * cells / total : 0.0;
  std::vector<idx_t> vwgt(cells);
  for (int c = 0; c < cells; ++c) vwgt[c] = 1 + static_cast<idx_t>(std::llround(weight[c] * unit));

  idx_t nv = cells, ncon = 1, np = parts, cut = 0;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 1;  // the same partition on every rank and every run
  std::vector<idx_t> result(cells);
  const int rc = METIS_PartGraphKway(&nv, &ncon, xadj.data(), adj.data(), vwgt.data(), nullptr, nullptr, &np,
                                     nullptr, nullptr, options, &cut, result.data());
  if (rc != METIS_OK) throw std::runtime_error("METIS_PartGraphKway failed with code " + std::to_string(rc));
  for (int c = 0; c < cells; ++c) part[c] = static_cast<int>(result[c]);

  // Empty parts: METIS 5.1 may return them for small or very uneven graphs.
  std::vector<int> count(parts, 0);
  for (int p : part) ++count[p];
  for (int p = 0; p < parts; ++p) {
    if (count[p] > 0) continue;
    const int donor = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
    for (int c = cells - 1; c >= 0; --c)  // the donor's last cell, deterministically
      if (part[c] == donor) {
        part[c] = p;
        --count[donor];
        ++count[p];
        break;
      }
  }
  return part;
}

}  // namespace cassini
