#include "core/NeighborList.hpp"

#include <algorithm>
#include <cmath>

namespace cassini {

NeighborList::Grid NeighborList::make_grid(const Decomposition& dom, double range, std::size_t particles) {
  Grid g;
  double len[3];
  Vec3 box_lo, box_hi;
  dom.local_box(box_lo, box_hi);
  for (int d = 0; d < 3; ++d) {
    const double lo = box_lo[d] - range;
    const double hi = box_hi[d] + range;
    g.lo[d] = lo;
    len[d] = hi - lo;
  }
  const double max_cells = 8.0 * static_cast<double>(particles) + 1000.0;
  double size = range;
  for (;;) {
    double cells = 1;
    for (int d = 0; d < dom.dims; ++d) cells *= std::max(1.0, std::floor(len[d] / size));
    if (cells <= max_cells) break;
    size *= 1.5;
  }
  for (int d = 0; d < 3; ++d) {
    g.n[d] = d < dom.dims ? std::max(1, static_cast<int>(len[d] / size)) : 1;
    g.inv_size[d] = g.n[d] / len[d];
  }
  return g;
}

int NeighborList::Grid::cell(const Vec3& x) const {
  int c[3];
  for (int d = 0; d < 3; ++d)  // clamped: particles slightly past a wall or open face still bin
    c[d] = std::clamp(static_cast<int>(std::floor((x[d] - lo[d]) * inv_size[d])), 0, n[d] - 1);
  return (c[2] * n[1] + c[1]) * n[0] + c[0];
}

std::vector<std::size_t> NeighborList::spatial_order(const ParticleStore& p, const Decomposition& dom, double range) {
  const Grid g = make_grid(dom, range, p.nlocal);
  const std::size_t ncell = std::size_t(g.n[0]) * g.n[1] * g.n[2];
  std::vector<std::uint32_t> cell(p.nlocal), count(ncell + 1, 0);
  for (std::size_t i = 0; i < p.nlocal; ++i) ++count[(cell[i] = g.cell(p.x[i])) + 1];
  for (std::size_t c = 0; c < ncell; ++c) count[c + 1] += count[c];
  std::vector<std::size_t> order(p.nlocal);
  for (std::size_t i = 0; i < p.nlocal; ++i) order[count[cell[i]]++] = i;
  return order;
}

namespace {
// Sum order = partner id order (insertion sort: lists are short).
void sort_by_id(const ParticleStore& p, std::uint32_t* b, std::size_t len) {
  for (std::size_t a = 1; a < len; ++a) {
    const std::uint32_t key = b[a];
    std::size_t q = a;
    while (q > 0 && p.id[b[q - 1]] > p.id[key]) {
      b[q] = b[q - 1];
      --q;
    }
    b[q] = key;
  }
}
}  // namespace

void NeighborList::sort_into_cells(std::size_t ncells) {
  // Counting sort by cell_of_: cell c's particles are cell_items_[cell_start_[c], cell_start_[c + 1]).
  const std::size_t n = cell_of_.size();
  cell_start_.assign(ncells + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++cell_start_[cell_of_[i] + 1];
  for (std::size_t c = 0; c < ncells; ++c) cell_start_[c + 1] += cell_start_[c];
  cell_items_.resize(n);
  std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) cell_items_[fill[cell_of_[i]]++] = static_cast<std::uint32_t>(i);
}

void NeighborList::build(const ParticleStore& p, const Decomposition& dom, double range, double skin) {
  double amin = 1e300, amax = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    amin = std::min(amin, p.radius[i]);
    amax = std::max(amax, p.radius[i]);
  }
  if (amax > 2 * amin) return build_by_size_class(p, dom, range, skin, amin, amax);
  const Grid g = make_grid(dom, range, p.size());
  const std::size_t n = p.size(), ncell = std::size_t(g.n[0]) * g.n[1] * g.n[2];
  // Under modified Lees-Edwards boundaries each copy of the box has its own cells: particles of
  // different copies are never candidates.
  const std::size_t blocks = p.copies ? 2 : 1;
  cell_of_.resize(n);
  for (std::size_t i = 0; i < n; ++i) cell_of_[i] = g.cell(p.x[i]) + (p.copies ? p.le_copy[i] * ncell : 0);
  sort_into_cells(blocks * ncell);

  // Half stencil: each pair is tested once, from the particle whose cell comes first (13 of the
  // 26 neighbouring cells, and the later particles of its own cell), and listed on both sides
  // that are owned. Half the distance tests of a full stencil, and the list is symmetric by
  // construction. Ghosts are scanned too (a pair with a ghost may be found from the ghost's
  // side); pairs of two ghosts are not listed.
  // Positions and radii copied in cell order: the candidate loop then streams through memory.
  // The candidate ranges are scanned two at a time, past their end (masked; padding at the
  // end of the arrays): a cell holds about one particle in a gas, and a loop that stops after
  // each one mispredicts its exit several times per particle. The hits are written without a
  // branch for the same reason. (Four at a time tested more pairs than it saved.)
  constexpr std::uint32_t kBlock = 2;
  const Vec3* X = p.x.data();
  const double* A = p.radius.data();
  cell_items_.resize(n + kBlock, 0);
  const std::uint32_t* items = cell_items_.data();
  const std::uint32_t* cstart = cell_start_.data();
  sorted_.resize(n + kBlock);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t j = items[k];
    sorted_[k] = Eigen::Vector4d(X[j][0], X[j][1], X[j][2], A[j]);
  }
  for (std::size_t k = n; k < n + kBlock; ++k) sorted_[k] = Eigen::Vector4d(1e300, 1e300, 1e300, 0.0);
  const Eigen::Vector4d* C = sorted_.data();
  const int zr = g.n[2] > 1 ? 1 : 0;
  const std::uint32_t nlocal = static_cast<std::uint32_t>(p.nlocal);
  pairs_.resize(std::max<std::size_t>(pairs_.capacity(), 1024));  // room the last build needed
  std::size_t npairs = 0;
  candidates = 0;
  for (std::size_t q = 0; q < n; ++q) {  // particles in cell order
    const std::uint32_t i = items[q];
    const bool owned = i < nlocal;
    const std::size_t block = cell_of_[i] / ncell * ncell;
    const std::uint32_t c = cell_of_[i] - block;
    const int cx = c % g.n[0], cy = (c / g.n[0]) % g.n[1], cz = c / (g.n[0] * g.n[1]);
    const Eigen::Vector4d& ci = C[q];
    const double ri = ci[3] + skin;
    auto scan = [&](std::uint32_t from, std::uint32_t to) {
      candidates += to - from;
      for (std::uint32_t k0 = from; k0 < to; k0 += kBlock) {
        if (npairs + kBlock > pairs_.size()) pairs_.resize(2 * pairs_.size());
        auto* out = pairs_.data();
        for (std::uint32_t k = k0; k < k0 + kBlock; ++k) {
          const Eigen::Vector4d& cj = C[k];
          const double cut = ri + cj[3];
          const double dx = ci[0] - cj[0], dy = ci[1] - cj[1], dz = ci[2] - cj[2];
          out[npairs] = {i, items[k]};
          npairs += (k < to) & (dx * dx + dy * dy + dz * dz < cut * cut) & (owned | (items[k] < nlocal));
        }
      }
    };
    scan(static_cast<std::uint32_t>(q + 1), cstart[block + c + 1]);  // the rest of its own cell
    for (int dz = 0; dz <= zr; ++dz) {
      const int z = cz + dz;
      if (z >= g.n[2]) continue;
      for (int dy = dz ? -1 : 0; dy <= 1; ++dy) {
        const int y = cy + dy;
        if (y < 0 || y >= g.n[1]) continue;
        // The forward cells of this row: x + 1 alone in its own row, x - 1 .. x + 1 in later rows.
        const int x0 = dz || dy ? std::max(cx - 1, 0) : cx + 1, x1 = std::min(cx + 1, g.n[0] - 1);
        if (x0 > x1) continue;
        const std::size_t row = block + (std::size_t(z) * g.n[1] + y) * g.n[0];
        scan(cstart[row + x0], cstart[row + x1 + 1]);  // cells x0..x1 of a row are contiguous
      }
    }
  }
  pairs_.resize(npairs);
  // Both owned sides of every pair, then each particle's partners in id order.
  start.assign(p.nlocal + 1, 0);
  for (const auto& [i, j] : pairs_) {
    if (i < nlocal) ++start[i + 1];
    if (j < nlocal) ++start[j + 1];
  }
  for (std::size_t i = 0; i < p.nlocal; ++i) start[i + 1] += start[i];
  partner.resize(start[p.nlocal]);
  fill_.assign(start.begin(), start.end() - 1);
  for (const auto& [i, j] : pairs_) {
    if (i < nlocal) partner[fill_[i]++] = j;
    if (j < nlocal) partner[fill_[j]++] = i;
  }
  for (std::size_t i = 0; i < p.nlocal; ++i) sort_by_id(p, partner.data() + start[i], start[i + 1] - start[i]);
  fill_rows();
}

void NeighborList::fill_rows() {
  row.resize(partner.size());
  for (std::size_t i = 0; i + 1 < start.size(); ++i)
    std::fill(row.begin() + start[i], row.begin() + start[i + 1], static_cast<std::uint32_t>(i));
}

void NeighborList::build_by_size_class(const ParticleStore& p, const Decomposition& dom, double range, double skin,
                                       double amin, double amax) {
  // Class c holds radii in [amin 2^c, amin 2^(c+1)); its pairs reach at most a_i + 2^(c+1) amin + skin.
  const int nclass = std::max(1, static_cast<int>(std::ceil(std::log2(amax / amin) + 1e-12)));
  auto class_of = [&](double a) { return std::clamp(static_cast<int>(std::log2(a / amin)), 0, nclass - 1); };
  const double reach_extra = range - 2 * amax;  // skin (and lubrication reach) beyond contact
  const std::size_t n = p.size();
  const std::size_t blocks = p.copies ? 2 : 1;
  std::vector<Grid> grids(nclass);
  std::vector<double> top(nclass);  // largest radius a class may hold
  std::vector<std::size_t> offset(nclass * blocks + 1, 0);
  for (int c = 0; c < nclass; ++c) {
    top[c] = std::min(amax, amin * std::ldexp(1.0, c + 1));
    grids[c] = make_grid(dom, std::max(2 * top[c] + reach_extra, 1e-300), n);
  }
  // Each (copy, class) block of cells after the previous one.
  std::size_t total = 0;
  for (std::size_t b = 0; b < blocks; ++b)
    for (int c = 0; c < nclass; ++c) {
      offset[b * nclass + c] = total;
      total += std::size_t(grids[c].n[0]) * grids[c].n[1] * grids[c].n[2];
    }
  offset[blocks * nclass] = total;
  cell_of_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int c = class_of(p.radius[i]);
    const std::size_t b = p.copies ? p.le_copy[i] : 0;
    cell_of_[i] = static_cast<std::uint32_t>(offset[b * nclass + c] + grids[c].cell(p.x[i]));
  }
  sort_into_cells(total);
  start.resize(p.nlocal + 1);
  partner.clear();
  partner.reserve(p.nlocal * 4);
  candidates = 0;
  const int dims = dom.dims;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    start[i] = static_cast<std::uint32_t>(partner.size());
    const Vec3 xi = p.x[i];
    const double ri = p.radius[i] + skin;
    const std::size_t b = p.copies ? p.le_copy[i] : 0;
    for (int c = 0; c < nclass; ++c) {
      const Grid& g = grids[c];
      const double reach = ri + top[c];
      int lo[3], hi[3];
      for (int d = 0; d < 3; ++d) {
        if (d >= dims) { lo[d] = hi[d] = 0; continue; }
        lo[d] = std::max(0, static_cast<int>(std::floor((xi[d] - reach - g.lo[d]) * g.inv_size[d])));
        hi[d] = std::min(g.n[d] - 1, static_cast<int>(std::floor((xi[d] + reach - g.lo[d]) * g.inv_size[d])));
      }
      const std::size_t base = offset[b * nclass + c];
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y) {
          const std::size_t row = base + (std::size_t(z) * g.n[1] + y) * g.n[0];
          for (std::uint32_t k = cell_start_[row + lo[0]]; k < cell_start_[row + hi[0] + 1]; ++k) {
            const std::uint32_t j = cell_items_[k];
            const double cut = ri + p.radius[j];
            ++candidates;
            if ((xi - p.x[j]).squaredNorm() < cut * cut && j != i) partner.push_back(j);
          }
        }
    }
    sort_by_id(p, partner.data() + start[i], partner.size() - start[i]);
  }
  start[p.nlocal] = static_cast<std::uint32_t>(partner.size());
  fill_rows();
}

}  // namespace cassini
