#include "cg/CoarseGrainer.hpp"

#include <cmath>

namespace cassini::cg {

void Fields::add(Fields& o, double w) {
  auto mine = all(), theirs = o.all();
  for (std::size_t k = 0; k < mine.size(); ++k)
    for (std::size_t i = 0; i < mine[k]->size(); ++i) (*mine[k])[i] += w * (*theirs[k])[i];
}

namespace {

struct Hit {
  std::size_t point;
  double w;
  int image_y;  // which Lees-Edwards image the weight belongs to (-1, 0, +1 box heights in y)
};

// Kernel weights of the point x and of its periodic (and sheared) images on the grid.
double gather_hits(const Frame& f, const double* x, const Grid& g, const Kernel& k, std::vector<Hit>& hits) {
  const double c = k.cutoff();
  double total = 0;
  for (int iy = -1; iy <= 1; ++iy) {
    if (iy != 0 && (g.dims < 2 || !f.periodic[1])) continue;
    for (int ix = -2; ix <= 2; ++ix) {
      if (ix != 0 && !f.periodic[0]) continue;
      for (int iz = -1; iz <= 1; ++iz) {
        if (iz != 0 && (g.dims < 3 || !f.periodic[2])) continue;
        double im[3] = {x[0] + ix * f.length[0], x[1] + iy * f.length[1], x[2] + iz * f.length[2]};
        if (f.sheared) im[0] += iy * f.le_offset;
        int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
        bool outside = false;
        for (int d = 0; d < g.dims; ++d) {
          lo[d] = std::max(0, int(std::floor((im[d] - c - g.lo[d]) / g.h(d) - 0.5)));
          hi[d] = std::min(g.n[d] - 1, int(std::ceil((im[d] + c - g.lo[d]) / g.h(d) - 0.5)));
          if (lo[d] > hi[d]) outside = true;
        }
        if (outside) continue;
        for (int kz = lo[2]; kz <= hi[2]; ++kz)
          for (int ky = lo[1]; ky <= hi[1]; ++ky)
            for (int kx = lo[0]; kx <= hi[0]; ++kx) {
              const int kk[3] = {kx, ky, kz};
              double r2 = 0;
              for (int d = 0; d < g.dims; ++d) {
                const double dd = g.centre(d, kk[d]) - im[d];
                r2 += dd * dd;
              }
              const double w = k(r2);
              if (w <= 0) continue;
              hits.push_back({(std::size_t(kz) * g.n[1] + ky) * g.n[0] + kx, w, iy});
              total += w;
            }
      }
    }
  }
  return total;
}

// Kernel weights of 8 midpoints along the segment from x to x - branch (the line integral
// int_0^1 psi(r - x + s branch) ds of the stress formulas), with their images.
double gather_line(const Frame& f, const double* x, const double* branch, const Grid& g, const Kernel& k, std::vector<Hit>& hits) {
  const int samples = 8;
  double total = 0;
  for (int s = 0; s < samples; ++s) {
    const double t = (s + 0.5) / samples;
    const double pt[3] = {x[0] - t * branch[0], x[1] - t * branch[1], x[2] - t * branch[2]};
    total += gather_hits(f, pt, g, k, hits);
  }
  return total;
}

// Adds force_a branch_b int_0^1 psi(r - x + s branch) ds, normalised on the grid, to a 3x3 field.
void add_line_stress(const Frame& f, const double* x, const double* branch, const double* force, const Grid& g,
                     const Kernel& k, std::vector<Hit>& hits, std::vector<double>& field) {
  hits.clear();
  const double total = gather_line(f, x, branch, g, k, hits);
  if (total <= 0) return;
  const double scale = 1 / (total * g.cell_volume());
  for (const Hit& h : hits)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) field[9 * h.point + 3 * a + b] += scale * h.w * force[a] * branch[b];
}

}  // namespace

void accumulate(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k,
                const Background& bg, Fields& out) {
  const double dv = g.cell_volume();
  std::vector<Hit> hits;
  for (std::size_t p = begin; p < end; ++p) {
    const double* x = &f.x[3 * p];
    const double* v = &f.v[3 * p];
    hits.clear();
    const double total = gather_hits(f, x, g, k, hits);
    if (total <= 0) continue;  // outside the grid entirely
    const double m = f.m[p], scale = m / (total * dv);
    const double* F = f.body.empty() ? nullptr : &f.body[3 * p];
    for (const Hit& h : hits) {
      const double s = scale * h.w;
      // A Lees-Edwards image one box height up moves faster by rate * Ly: it is the particle
      // as seen across the sheared boundary (the solver's ghosts carry the same jump).
      const double jump = f.sheared ? h.image_y * f.le_rate * f.length[1] : 0.0;
      const double vi[3] = {v[0] + jump, v[1], v[2]};
      // Fluctuation about the background flow at the image's position (unchanged by the jump
      // when the background is the run's own shear).
      const double b[3] = {vi[0] - bg.shear * (x[1] + h.image_y * f.length[1]), v[1], v[2]};
      if (F)
        for (int d = 0; d < 3; ++d) out.body[3 * h.point + d] += h.w / (total * dv) * F[d];
      out.density[h.point] += s;
      for (int d = 0; d < 3; ++d) out.momentum[3 * h.point + d] += s * vi[d];
      const int a[6] = {0, 1, 2, 0, 0, 1}, bb[6] = {0, 1, 2, 1, 2, 2};
      for (int q = 0; q < 6; ++q) {
        out.kinetic[6 * h.point + q] += s * vi[a[q]] * vi[bb[q]];
        out.background[6 * h.point + q] += s * b[a[q]] * b[bb[q]];
      }
    }
  }
}

void accumulate_contacts(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k, Fields& out) {
  std::vector<Hit> hits;
  for (std::size_t c = begin; c < end; ++c)  // from r_i to r_j
    add_line_stress(f, &f.contact_x[3 * c], &f.contact_branch[3 * c], &f.contact_force[3 * c], g, k, hits, out.contact);
}

void accumulate_walls(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k, Fields& out) {
  const double dv = g.cell_volume();
  std::vector<Hit> hits;
  for (std::size_t c = begin; c < end; ++c) {
    const double* pt = &f.wall_point[3 * c];
    const double* b = &f.wall_branch[3 * c];
    const double* fc = &f.wall_force[3 * c];
    hits.clear();
    const double total = gather_hits(f, pt, g, k, hits);
    if (total > 0)
      for (const Hit& h : hits)
        for (int a = 0; a < 3; ++a) out.traction[3 * h.point + a] += h.w / (total * dv) * fc[a];
    const double centre[3] = {pt[0] + b[0], pt[1] + b[1], pt[2] + b[2]};
    add_line_stress(f, centre, b, fc, g, k, hits, out.wall);  // from r_i = c + b to c
  }
}

void finish(Fields& f, std::size_t points) {
  const int a[6] = {0, 1, 2, 0, 0, 1}, b[6] = {0, 1, 2, 1, 2, 2};
  for (std::size_t i = 0; i < points; ++i) {
    const double rho = f.density[i];
    if (rho <= 0) continue;
    for (int q = 0; q < 6; ++q)
      f.kinetic[6 * i + q] -= f.momentum[3 * i + a[q]] * f.momentum[3 * i + b[q]] / rho;
  }
}

}  // namespace cassini::cg
