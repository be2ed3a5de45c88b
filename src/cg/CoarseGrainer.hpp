#pragma once
// Coarse-grained continuum fields on a regular grid from particle data (thesis ch. 3):
//   density   rho = sum m psi
//   momentum  p = sum m v psi,  velocity V = p / rho
//   kinetic stress (fluctuations about the local mean)  sum m v v psi - rho V V
//   fluctuations about a given background flow U(x)    sum m (v - U)(v - U) psi
//   contact stress (3.27) and wall stress (3.32), wall traction density t (3.31), body-force
//   density (3.34); for a system at rest they balance: d_b sigma_ab = t_a + F_a
// Each particle's kernel weights on the grid (with its periodic and Lees-Edwards images) are
// normalised to sum to 1 / cell volume, so the grid integral of rho is exactly the mass even
// across periodic and sheared boundaries (the discrete form of int psi = 1).
#include <array>
#include <string>
#include <vector>

#include "cg/Kernel.hpp"

namespace cassini::cg {

struct Frame {
  std::vector<double> x, v, m;      // x, v: 3 per particle
  std::vector<double> body;         // non-contact force per particle (3 each; empty: none)
  // Contacts, each pair once: position of i, branch r_i - r_j, force on i (3 each).
  std::vector<double> contact_x, contact_branch, contact_force;
  // Wall contacts: contact point c, branch b = r_i - c, force on i (3 each).
  std::vector<double> wall_point, wall_branch, wall_force;
  std::array<double, 3> lo{}, length{};
  std::array<bool, 3> periodic{};
  double le_offset = 0;             // Lees-Edwards: image across y shifted by this in x
  double le_rate = 0;               // ... and moving faster by le_rate * Ly
  bool sheared = false;
};

struct Grid {
  int dims = 3;                  // 2: fields on x-y (surface densities), 1: along x
  std::array<int, 3> n{1, 1, 1};
  std::array<double, 3> lo{}, hi{};
  double h(int d) const { return (hi[d] - lo[d]) / n[d]; }
  double cell_volume() const {
    double v = 1;
    for (int d = 0; d < dims; ++d) v *= h(d);
    return v;
  }
  std::size_t size() const { return std::size_t(n[0]) * n[1] * n[2]; }
  double centre(int d, int k) const { return lo[d] + (k + 0.5) * h(d); }
};

struct Fields {
  // per point: 1, 3, 6, 6, 9, 9, 3, 3 values; symmetric tensors as (xx yy zz xy xz yz), the
  // contact and wall stresses in full (row-major ab) since f_a r_b need not be symmetric.
  std::vector<double> density, momentum, kinetic, background, contact, wall, traction, body;
  std::vector<std::vector<double>*> all() { return {&density, &momentum, &kinetic, &background, &contact, &wall, &traction, &body}; }
  void resize(std::size_t n) {
    const int width[8] = {1, 3, 6, 6, 9, 9, 3, 3};
    auto a = all();
    for (int k = 0; k < 8; ++k) a[k]->assign(width[k] * n, 0);
  }
  void add(Fields& o, double weight);
};

// Background flow: v_x = shear * y (e.g. 1.5 Omega0 in the ring); zero for none.
struct Background {
  double shear = 0;
};

// Accumulates the particles [begin, end) of a frame (raw sums, before dividing by rho).
void accumulate(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k,
                const Background& bg, Fields& out);
// Contact stress (3.27), compression positive: sigma_ab = sum_pairs f_a r_b int_0^1 psi(r - r_i + s r_ij) ds
// (each unordered pair once = half the sum over ordered pairs of the thesis's form). The line
// integral uses 8 points along the branch, normalised on the grid like the particles' kernels,
// so the grid integral of sigma is exactly sum f r (the virial).
void accumulate_contacts(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k, Fields& out);
// Wall contacts [begin, end): traction density t = sum f psi(r - c) (3.31) and wall stress
// (3.32), compression positive: sigma_ab = sum f_a b_b int_0^1 psi(r - r_i + s b) ds, the line
// running from the centre r_i to the contact point c. Normalised on the grid like the above.
void accumulate_walls(const Frame& f, std::size_t begin, std::size_t end, const Grid& g, const Kernel& k, Fields& out);
// Turns raw sums into fields: kinetic = sum m v v psi - rho V V; background stays as summed.
void finish(Fields& f, std::size_t points);

}  // namespace cassini::cg
