// Self-gravity (particle-mesh on the sheared box, physics/ring/SelfGravity.hpp) against analytic
// fields and an independent direct sum over the shear-periodic images. Run with 2 ranks: the
// analytic checks run on rank 0 alone, the rank-count check on 1 and 2 ranks.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "physics/ring/HillFrame.hpp"
#include "physics/ring/MultiRateHill.hpp"
#include "physics/ring/SelfGravity.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double G = kGravitationalConstant;

// A 200 m x 200 m ring patch in the Hill frame (the shear gives the Lees-Edwards images), 3D
// with z in [-16, 16] m and a 32 x 32 x 16 mesh (h = 6.25 m in the plane, 2 m in z).
const char* kPatch = kSelfGravityPatch;

// The same box and mesh without the Hill frame: x and y periodic (no shear), so that a pair's
// orbit and infall have closed forms (Newton plus the square lattice of images).
std::string free_patch() {
  std::string t = kPatch;
  auto cut = [&t](const std::string& from, const std::string& to) {
    const auto a = t.find(from), b = t.find(to, a);
    if (a == std::string::npos || b == std::string::npos) throw std::logic_error("kPatch changed: update free_patch()");
    t.erase(a, b - a);
  };
  cut("[hill]", "[self_gravity]");
  const std::string hill = "\"contact\", \"hill\"", sheared = "\"lees_edwards\"";
  t.replace(t.find(hill), hill.size(), "\"contact\"");
  t.replace(t.find(sheared), sheared.size(), "\"periodic\"");
  return t;
}
const std::string kFree = free_patch();

bool root() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r == 0;
}

SelfGravity& gravity_of(Simulation& sim) { return *sim.find<SelfGravity>(); }

// Attraction (per unit source mass) between Gaussian spheres of width eps at distance r, the
// self-gravity module's pair law: Newton's for the Gaussian's mass inside r,
//   g(r) = G / r^2 (erf(x) - 2 x exp(-x^2) / sqrt(pi)),  x = r / (eps sqrt 2).
double softened(double r, double eps) {
  const double x = r / (eps * std::sqrt(2.0));
  return G / (r * r) * (std::erf(x) - 2 * x * std::exp(-x * x) / std::sqrt(kPi));
}

// The acceleration at `at` from unit-mass sources at `src` and every image (x + p Lx + q S, y + q Ly),
// truncated at a disk of radius R about the probe: the sheet outside such a disk pulls neither
// in-plane nor (at |z| << R) vertically differently from the mesh's mean sheet.
Vec3 image_sum(const std::vector<Vec3>& src, const std::vector<double>& m, const Vec3& at, double L, double S,
               double R, double eps, long skip = -1) {
  Vec3 a = Vec3::Zero();
  const int Q = static_cast<int>(R / L) + 1;
  for (std::size_t j = 0; j < src.size(); ++j)
    for (int q = -Q; q <= Q; ++q)
      for (int p = -Q - 1; p <= Q + 1; ++p) {
        if (static_cast<long>(j) == skip && p == 0 && q == 0) continue;
        const Vec3 d = src[j] + Vec3(p * L + q * S, q * L, 0) - at;
        if (std::hypot(d[0], d[1]) > R) continue;
        const double r = d.norm();
        a += m[j] * softened(r, eps) * d / r;
      }
  return a;
}

}  // namespace

TEST(SelfGravity, UniformSheetPullsAtTwoPiGSigma) {
  // One particle per mesh column, all in one z layer, placed on the sheared grid's nodes at an
  // arbitrary shear offset: the deposit is exactly uniform, so the field is the infinite
  // sheet's, a_z = -2 pi G Sigma sign(z - z_sheet), a_xy = 0, beyond one layer of the sheet.
  if (!root()) return;
  auto sim = make_sim(kPatch, {"self_gravity.split=0.3", "self_gravity.short_range=false"}, MPI_COMM_SELF);
  const double m = 1.0e6, h = 200.0 / 32, S = 37.3, z_sheet = -16.0 + 7.5 * 2.0;
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 32; ++i) {
      const double y = -100.0 + j * h, x = -100.0 + i * h + S * (y + 100.0) / 200.0;
      sim->particles.add(j * 32 + i, 0, 1.0, m, Vec3(x - 200.0 * std::floor((x + 100.0) / 200.0), y, z_sheet), Vec3::Zero());
    }
  sim->setup();
  sim->domain.shear.offset = S;
  SelfGravity& g = gravity_of(*sim);
  g.solve(*sim);
  const double sigma = 1024 * m / (200.0 * 200.0), expect = 2 * kPi * G * sigma;
  double worst = 0;
  for (const double dz : {-9.0, -5.5, -2.0, 2.0, 3.3, 8.0})
    for (const Vec3& at : {Vec3(0, 0, 0), Vec3(-73.1, 41.7, 0), Vec3(99.0, -99.0, 0)}) {
      const Vec3 a = g.field(at + Vec3(0, 0, z_sheet + dz));
      worst = std::max({worst, std::abs(a[2] + std::copysign(expect, dz)) / expect, std::abs(a[0]) / expect,
                        std::abs(a[1]) / expect});
    }
  std::printf("uniform sheet: 2 pi G Sigma = %.6e m/s^2, worst relative deviation %.2e\n", expect, worst);
  EXPECT_LT(worst, 1e-9);
}

TEST(SelfGravity, PointMassMatchesNewtonWithItsShearedImages) {
  // The field of one particle (a Gaussian sphere of width eps) against the same law summed over
  // its sheared images, in and off the particle's layer, at distances r from the grid spacing
  // h = 6.25 m up. The mesh is exact for the Gaussian at long range; CIC aliasing leaves errors
  // near the source that shrink as eps / h grows (the control a user has): the bounds are the
  // ones an independent NumPy model of the same scheme gives, with ~30 % margin.
  if (!root()) return;
  const double m = 1.0e9, S = -61.0, h = 6.25;
  const Vec3 src(13.0, -22.0, 1.0);
  struct Bound { double eps_h, r_h, worst; };
  const Bound bounds[] = {{1, 1, 0.25}, {1, 2, 0.07}, {1, 3, 0.09}, {1, 5, 0.03}, {1, 9, 0.01},
                          {2, 1, 0.06}, {2, 2, 0.05}, {2, 3, 0.03}, {2, 5, 0.01}, {2, 9, 0.008}};
  std::printf("point mass with images: rms (worst) relative deviation\n");
  double eps_done = 0;
  std::unique_ptr<Simulation> sim;
  for (const Bound& b : bounds) {
    const double eps = b.eps_h * h;
    if (eps != eps_done) {
      sim = make_sim(kPatch, {"self_gravity.split=" + std::to_string(eps), "self_gravity.short_range=false"}, MPI_COMM_SELF);
      sim->particles.add(0, 0, 1.0, m, src, Vec3::Zero());
      sim->setup();
      sim->domain.shear.offset = S;
      gravity_of(*sim).solve(*sim);
      eps_done = eps;
    }
    double worst = 0, sum2 = 0;
    int n = 0;
    for (const double angle : {0.3, 1.1, 1.9, 2.8, 4.0, 5.3})
      for (const double dz : {-3.0, 0.0, 4.0}) {
        const Vec3 at = src + Vec3(b.r_h * h * std::cos(angle), b.r_h * h * std::sin(angle), dz);
        const Vec3 pm = gravity_of(*sim).field(at), ref = image_sum({src}, {m}, at, 200.0, S, 12000.0, eps);
        const double e = (pm - ref).norm() / ref.norm();
        worst = std::max(worst, e);
        sum2 += e * e;
        ++n;
      }
    std::printf("  eps = %.0f h, r = %.0f h: %.4f (%.4f)\n", b.eps_h, b.r_h, std::sqrt(sum2 / n), worst);
    EXPECT_LT(worst, b.worst) << "eps = " << b.eps_h << " h, r = " << b.r_h << " h";
  }
}

TEST(SelfGravity, PlanarPatchMatchesTheDirectSumOverImages) {
  // 150 particles of a planar sheared patch: the mesh (64 x 64, h = 3.1 m, eps = 1.5 h = 4.7 m) against
  // the O(N^2) sum of the same Gaussian-sphere pair law over every particle's sheared images.
  if (!root()) return;
  auto sim = make_sim(kPatch, {"domain.planar=true", "domain.boundary=[\"periodic\", \"lees_edwards\", \"periodic\"]",
                               "self_gravity.grid=[64, 64, 1]", "self_gravity.split=4.7", "self_gravity.short_range=false"},
                      MPI_COMM_SELF);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-100.0, 100.0), mass(0.5e8, 2e8);
  std::vector<Vec3> x;
  std::vector<double> ms;
  for (int i = 0; i < 150; ++i) {
    x.emplace_back(u(rng), u(rng), 0.0);
    ms.push_back(mass(rng));
    sim->particles.add(i, 0, 0.01, ms.back(), x.back(), Vec3::Zero());
  }
  sim->setup();
  const double S = 83.0;
  sim->domain.shear.offset = S;
  SelfGravity& g = gravity_of(*sim);
  g.solve(*sim);
  double err2 = 0, ref2 = 0, worst = 0;
  for (int i = 0; i < 150; ++i) {
    const Vec3 a = image_sum(x, ms, x[i], 200.0, S, 4000.0, 4.7, i);
    const Vec3 pm = g.field(x[i]);
    err2 += (pm - a).squaredNorm();
    ref2 += a.squaredNorm();
    worst = std::max(worst, (pm - a).norm() / a.norm());
  }
  const double rms = std::sqrt(err2 / ref2);
  std::printf("planar patch: rms relative deviation from the direct image sum %.4f (worst particle %.4f)\n", rms, worst);
  EXPECT_LT(rms, 0.03);  // measured 0.021 (the single-source errors above, summed over the patch)
}

TEST(SelfGravity, MeshPlusPairsIsNewtonAtEveryDistanceAtTheDefaultSplit) {
  // Two particles, mesh (the default split, eps = 2.5 h = 15.6 m) plus the short range: the force
  // on each is Newton's law summed over the other's sheared images (and its own images, whose
  // pull the mesh carries too), from touching spheres (r = 2.1 m) to across the box. Goal: within
  // 2 % everywhere. At eps = h (the default before) the mesh's CIC error on the Gaussian part
  // made 4.2 % at 1-3 h.
  if (!root()) return;
  double worst_near = 0, worst_mid = 0, worst_far = 0;
  const double m = 1.0e9, S = 29.0;
  for (const double r : {2.1, 3.0, 5.0, 8.0, 12.0, 19.0, 31.0, 56.0, 90.0})
    for (const double angle : {0.4, 2.2, 4.1}) {
      auto sim = make_sim(kPatch, {}, MPI_COMM_SELF);
      const Vec3 a(7.0, 3.0, 0.5), b = a + Vec3(r * std::cos(angle), r * std::sin(angle), 0.3 * std::sin(3 * angle));
      sim->particles.add(0, 0, 1.0, m, a, Vec3::Zero());
      sim->particles.add(1, 0, 1.0, m, b, Vec3::Zero());
      sim->domain.shear.offset = S;  // before the first rebuild: ghosts and mesh see the same images
      sim->setup();
      const auto& p = sim->particles;
      // the total body force on particle 0 (contact forces are zero: the spheres do not touch)
      std::vector<Vec3> F(p.nlocal, Vec3::Zero());
      gravity_of(*sim).add_body_forces(*sim, F);
      const long i0 = local_index(*sim, 0);
      // Newton over b's images and a's own images (the latter's sum vanishes by symmetry except
      // for the sheared lattice's, which the direct sum includes too)
      const Vec3 ref = m * (image_sum({b}, {m}, a, 200.0, S, 12000.0, 1e-9) + image_sum({a}, {m}, a, 200.0, S, 12000.0, 1e-9, 0));
      const double e = (F[i0] - ref).norm() / ref.norm();
      double& worst = r < 6.25 ? worst_near : r < 20 ? worst_mid : worst_far;
      worst = std::max(worst, e);
    }
  std::printf("mesh + pairs against Newton: worst relative error %.4f (r < h), %.4f (h..3h), %.4f (> 3h)\n", worst_near,
              worst_mid, worst_far);
  // measured 0.0002, 0.0051, 0.0075 (the far values relative to a pull the images nearly cancel;
  // split = 2 h, the default until 2026-11-29: 0.0007, 0.0093, 0.012);
  // split = h: 0.016, 0.042, 0.026
  EXPECT_LT(worst_near, 0.02);
  EXPECT_LT(worst_mid, 0.02);
  EXPECT_LT(worst_far, 0.02);
}

TEST(SelfGravity, AShorterCutOffDropsOnlyTheGaussiansTail) {
  // self_gravity.cutoff = 3 ends the pairs at 3 sqrt(2) eps = 66 m instead of 88 m: a pair just
  // beyond loses its short-range part, w(x) = erfc(x) + 2 x exp(-x^2) / sqrt(pi) of its Newton
  // force at x = r / (sqrt(2) eps) (4.4e-4 at the cut-off), and a pair within keeps every term.
  if (!root()) return;
  const double m = 1.0e9;
  auto pull = [&](double r, const std::vector<std::string>& over, double* eps) {
    auto sim = make_sim(kPatch, over, MPI_COMM_SELF);
    const Vec3 a(7.0, 3.0, 0.5), b = a + Vec3(r * std::cos(0.4), r * std::sin(0.4), 0.0);
    sim->particles.add(0, 0, 1.0, m, a, Vec3::Zero());
    sim->particles.add(1, 0, 1.0, m, b, Vec3::Zero());
    sim->domain.shear.offset = 29.0;
    sim->setup();
    std::vector<Vec3> F(sim->particles.nlocal, Vec3::Zero());
    gravity_of(*sim).add_body_forces(*sim, F);
    *eps = sim->cfg.get<SelfGravity::Settings>().split;
    return Vec3(F[local_index(*sim, 0)]);
  };
  double eps = 0;
  for (const double r : {56.0, 62.0, 68.0, 75.0}) {
    const Vec3 full = pull(r, {}, &eps), cut = pull(r, {"self_gravity.cutoff=3"}, &eps);
    const double x = r / (std::sqrt(2.0) * eps), newton = G * m * m / (r * r);
    const double w = std::erfc(x) + 2 * x * std::exp(-x * x) / std::sqrt(M_PI);
    const double lost = (full - cut).norm() / newton;
    std::printf("r = %.0f m (x = %.2f): cut-off 3 loses %.3e of the pair's Newton force; w(x) = %.3e\n", r, x, lost, w);
    if (x < 3)
      EXPECT_LT(lost, 1e-6);  // the same pair terms (tables for another reach interpolate to ~1e-7 of w)
    else
      EXPECT_NEAR(lost, w, 0.02 * w);  // exactly the dropped pair's short-range part
  }
  EXPECT_NEAR(eps, 15.625, 1e-9);  // the default split of kPatch, for which the separations above were chosen
}

namespace {
// Two equal particles (1e9 kg) at separation r0 in kFree's box, the relative vector at `angle`
// in the plane; returns the simulation after setup.
std::unique_ptr<Simulation> two_bodies(double r0, double angle, double dt, const std::vector<std::string>& extra,
                                       double v_circular_fraction, const std::string& scene = kFree) {
  std::vector<std::string> over = {"time.dt=" + std::to_string(dt)};
  over.insert(over.end(), extra.begin(), extra.end());
  const double m = 1.0e9;
  const Vec3 c(3.0, -7.0, 0.7), u(std::cos(angle), std::sin(angle), 0.0), t(-std::sin(angle), std::cos(angle), 0.0);
  auto make = [&](double v) {
    auto sim = make_sim(scene, over, MPI_COMM_SELF);
    sim->particles.add(0, 0, 1.0, m, c - 0.5 * r0 * u, -v * t);
    sim->particles.add(1, 0, 1.0, m, c + 0.5 * r0 * u, v * t);
    sim->setup();
    return sim;
  };
  if (v_circular_fraction == 0) return make(0.0);
  // circular from the scheme's own initial pull (the images add an isotropic in-plane tide):
  // v^2 / (r0 / 2) = |F| / m
  auto probe = make(0.0);
  std::vector<Vec3> F(2, Vec3::Zero());
  gravity_of(*probe).add_body_forces(*probe, F);
  return make(v_circular_fraction * std::sqrt(0.5 * r0 * std::abs(F[local_index(*probe, 0)].dot(u)) / m));
}

double separation(const Simulation& sim) {
  const auto& p = sim.particles;
  Vec3 d = p.x[local_index(sim, 1)] - p.x[local_index(sim, 0)];
  for (int k = 0; k < 2; ++k) d[k] -= 200.0 * std::round(d[k] / 200.0);
  return d.norm();
}

// The drop of Newton's potential energy of particles 0 and 1 (mass m each) from separation d0 to
// their present one, summed over the square lattice of 200 m images (the terms fall as |n|^-3):
//   -Delta U = G m^2 sum_n (1/|d + n L| - 1/|d0 + n L|).
double newton_drop(const Simulation& sim, const Vec3& d0, double m) {
  const auto& p = sim.particles;
  Vec3 d = p.x[local_index(sim, 1)] - p.x[local_index(sim, 0)];
  for (int k = 0; k < 2; ++k) d[k] -= 200.0 * std::round(d[k] / 200.0);
  double drop = 0;
  for (int q = -100; q <= 100; ++q)
    for (int n = -100; n <= 100; ++n) {
      const Vec3 shift(200.0 * n, 200.0 * q, 0.0);
      drop += 1 / (d + shift).norm() - 1 / (d0 + shift).norm();
    }
  return drop * G * m * m;
}

double kinetic(const Simulation& sim) {
  double ke = 0;
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i) ke += 0.5 * sim.particles.mass[i] * sim.particles.v[i].squaredNorm();
  return ke;
}
}  // namespace

TEST(SelfGravity, CircularBinaryKeepsItsRadiusAndEnergy) {
  // A circular binary at 1-3 grid spacings (h = 6.25 m), 10 orbits at 2,000 steps an orbit (the
  // integrator's own error is ~1e-7 there): the pair force must be central and a gradient for
  // the orbit-averaged r and KE to stay put. Goal 1e-4. At split = h the mesh's error is neither:
  // r/r0 fell by 4 % at 1.5 h.
  // At the default split, 2.5 h. At 2 h (the default until 2026-11-29) the 3 h binary, where the
  // mesh carries half the pull, drifted by 2.4e-4 in r and 6.2e-4 in KE: this test failed there.
  if (!root()) return;
  const double m = 1.0e9, h = 6.25;
  struct Case {
    double r_h, split_h;
  };
  for (const Case c : {Case{1.0, 2.5}, Case{1.5, 2.5}, Case{2.0, 2.5}, Case{3.0, 2.5}}) {
    const double r_h = c.r_h;
    const double r0 = r_h * h, period = 2 * kPi * std::sqrt(r0 * r0 * r0 / (2 * G * m));
    std::vector<std::string> split;
    if (c.split_h != 2.5) split.push_back("self_gravity.split=" + std::to_string(c.split_h * h));
    auto sim = two_bodies(r0, 0.7, period / 2000, split, 1.0);
    const double ke0 = kinetic(*sim);
    // orbit means (the mesh's error varies with the pair's angle to the grid, a wobble of
    // ~1 % of the force that averages out over an orbit: what must not happen is a drift)
    std::vector<double> r_mean(10, 0.0), ke_mean(10, 0.0);
    double wobble = 0;
    for (int s = 0; s < 20000; ++s) {
      sim->step();
      r_mean[s / 2000] += separation(*sim) / r0 / 2000;
      ke_mean[s / 2000] += kinetic(*sim) / ke0 / 2000;
      wobble = std::max(wobble, std::abs(separation(*sim) / r0 - 1));
    }
    double dr = 0, dke = 0;
    for (int o = 1; o < 10; ++o) {
      dr = std::max(dr, std::abs(r_mean[o] / r_mean[0] - 1));
      dke = std::max(dke, std::abs(ke_mean[o] / ke_mean[0] - 1));
    }
    std::printf("binary at %.1f h, split %.1f h: orbit means drift by |dr/r| = %.2e, |dKE/KE| = %.2e over 10 orbits (wobble %.2e)\n",
                r_h, c.split_h, dr, dke, wobble);
    // measured at 2.5 h: 1e-9 / 6e-8, 1.6e-7 / 1.8e-7, 1.9e-6 / 4.0e-6, 3.5e-5 / 9.6e-5 at 1, 1.5,
    // 2, 3 h. At 2 h: 7e-8 / 2e-6, 3e-6 / 2e-6, 5e-5 / 8e-5 at 1, 1.5, 2 h; 2.4e-4 / 6.2e-4 at 3 h (where
    // the mesh carries half the pull, and its ~1 % error is not a gradient: over 30 orbits the
    // mean r there wanders by 3 %). split = h: 0.5,
    // 0.036, 0.054, 0.011 in r.
    const double bound = 1e-4;
    EXPECT_LT(dr, bound) << r_h << " h, split " << c.split_h << " h";
    EXPECT_LT(dke, bound) << r_h << " h, split " << c.split_h << " h";
  }
}

TEST(SelfGravity, InfallGainsThePotentialEnergyNewtonLoses) {
  // Two particles fall from rest at 8 h = 50 m to 0.6 h = 3.75 m: the kinetic energy gained must
  // be the drop of Newton's potential energy summed over the square lattice of images,
  //   -Delta U = G m^2 sum_n (1/|d + n L| - 1/|d0 + n L|),
  // (the sum converges: the terms fall as |n|^-3). Goal 0.5 %. Measured 0.99984 at the default
  // split 2.5 h; at 2 h 0.99955 (0.9987 at 6.2 m,
  // 1.00007 at 2.1 m); split = h: 1.0091 (1.0072 at 6.2 m, 1.0057 at 2.1 m).
  if (!root()) return;
  const double m = 1.0e9, h = 6.25, angle = 0.45;
  auto sim = two_bodies(8 * h, angle, 0.25, {}, 0.0);
  while (separation(*sim) > 0.6 * h) sim->step();
  const double drop = newton_drop(*sim, 8 * h * Vec3(std::cos(angle), std::sin(angle), 0.0), m);
  const double gained = kinetic(*sim);
  std::printf("infall to %.2f m: KE gained / -Delta U (Newton with images) = %.5f\n", separation(*sim), gained / drop);
  EXPECT_NEAR(gained / drop, 1.0, 0.005);
}

namespace {
// Two touching 2 m particles of the gravity-wakes scene (t_c = 20 s, N_c = 10, the Bridges law,
// elastic below v_c = 77 um/s) for 40,000 s: the largest relative normal speed, and the loading
// oscillation's a_rel t_c / pi (their mutual pull a_rel = 2 G m / r^2 only loads the spring).
std::pair<double, double> resting_pair(const std::string& scene, const std::string& mesh_period) {
  const double a = 2.0, m = 400.0 * 4.0 / 3.0 * kPi * a * a * a;
  auto sim = make_sim(with_bridges(scene, 7.7e-5), {"species[0].radius=2.0", "species[0].t_c=20.0", "time.dt=2.0", mesh_period},
                      MPI_COMM_SELF);
  sim->particles.add(0, 0, a, m, Vec3(10.0, 20.0, 0.3), Vec3::Zero());
  sim->particles.add(1, 0, a, m, Vec3(10.0 + 2 * a * std::cos(0.3), 20.0 + 2 * a * std::sin(0.3), 0.3), Vec3::Zero());
  sim->setup();
  double worst = 0;
  for (int s = 0; s < 20000; ++s) {  // 1,000 mesh periods of 2 t_c
    sim->step();
    const auto& p = sim->particles;
    const Vec3 n = (p.x[local_index(*sim, 1)] - p.x[local_index(*sim, 0)]).normalized();
    worst = std::max(worst, std::abs((p.v[local_index(*sim, 1)] - p.v[local_index(*sim, 0)]).dot(n)));
  }
  return {worst, 2 * G * m / (4 * a * a) * 20.0 / kPi};
}
}  // namespace

TEST(SelfGravity, RestingPairIsNotPumpedByTheMeshImpulse) {
  // The mesh solved every 20 steps = 2 t_c: the period of the resting pair's contact
  // oscillation. Applied as an impulse every 2 t_c, the short range pumped it in resonance to
  // ~0.8 v_c; every step, the relative speed stays at the loading oscillation's.
  if (!root()) return;
  const auto [worst, loading] = resting_pair(kFree, "self_gravity.every=20");
  std::printf("resting pair: max relative normal speed %.3e m/s (loading oscillation %.3e, v_c 7.7e-05)\n", worst, loading);
  EXPECT_LT(worst, 2 * loading);
}

namespace {
// kPatch's Hill frame turned down 100x (Omega = 1.3e-6 / s: the tide and the shear offset are
// ~1e-5 of the pulls below over these runs), under the multi-rate integrator: two-body
// problems then have the closed forms of the free patch, and the free particles' path
// (kicks of Delta/2 at the long steps' ends, the exact epicycle between) and the contact
// steps' (the short range every step) are both taken.
std::string slow_hill_multirate() {
  std::string t = kPatch;
  const std::string mass = "saturn_mass = 5.68e26";
  t.replace(t.find(mass), mass.size(), "saturn_mass = 5.68e20");
  t.replace(t.find("end = 1.0e6"), 11, "end = 1.0e6\nintegrator = \"multirate\"");
  return t;
}
const std::string kSlowHill = slow_hill_multirate();

// The Jacobi energy's frame part: kinetic energy minus the tidal potential (Hill frame, linear form).
double jacobi_kinetic(const Simulation& sim) {
  const double w = sim.cfg.get<HillSettings>().omega0();
  double e = 0;
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i) {
    const Vec3& x = sim.particles.x[i];
    e += sim.particles.mass[i] * (0.5 * sim.particles.v[i].squaredNorm() - 1.5 * w * w * x[1] * x[1] + 0.5 * w * w * x[2] * x[2]);
  }
  return e;
}
}  // namespace

TEST(SelfGravity, MultiRateInfallGainsThePotentialEnergyNewtonLoses) {
  // Two ring particles (1 m, 400 kg/m^3: 1,676 kg) fall from rest at 4 h = 25 m until they
  // touch, under the multi-rate integrator with the ring's long step (48 s = 24 steps; their
  // mutual dynamical time is ~5,000 s at contact, ~1e5 s at the start, as in a ring). They fall
  // free (mesh and short range as kicks of Delta/2) until their straight-line paths close within a
  // long step, then on contact steps (the short range every step, the mesh still as kicks). The
  // Jacobi energy gained at contact must be Newton's -Delta U with the images. Goal 0.5 %.
  if (!root()) return;
  const double h = 6.25, angle = 0.45, m = 400.0 * 4.0 / 3.0 * kPi;
  auto sim = make_sim(kSlowHill, {"time.long_step=48.0"}, MPI_COMM_SELF);
  const Vec3 c(3.0, -7.0, 0.7), u(std::cos(angle), std::sin(angle), 0.0);
  sim->particles.add(0, 0, 1.0, m, c - 2 * h * u, Vec3::Zero());
  sim->particles.add(1, 0, 1.0, m, c + 2 * h * u, Vec3::Zero());
  sim->setup();
  const double e0 = jacobi_kinetic(*sim);
  // A free particle's stored state lags (it is that of the long step's start): on contact steps
  // it is the present one. They take them once a long step would close the gap (~2 cm here).
  const auto& mr = *sim->find<MultiRateHill>();
  while (separation(*sim) > 2.01 || mr.contact_particle_steps == 0) sim->step();
  EXPECT_GT(separation(*sim), 2.0) << "stopped before the contact";
  const double drop = newton_drop(*sim, 4 * h * u, m);
  std::printf("multi-rate infall to %.4f m at %.4g s: Jacobi KE gained / -Delta U = %.5f (%lld particle-steps free, %lld on contact steps)\n",
              separation(*sim), sim->time, (jacobi_kinetic(*sim) - e0) / drop, mr.free_particle_steps, mr.contact_particle_steps);
  EXPECT_NEAR((jacobi_kinetic(*sim) - e0) / drop, 1.0, 0.005);
}

TEST(SelfGravity, MultiRateCircularBinaryKeepsItsRadiusAndEnergy) {
  // The circular binaries at 1.5 h and 3 h under the multi-rate integrator: both particles free
  // (7-17 m of gap), their gravity as kicks of Delta/2 at the long steps' ends with the exact
  // epicycle between, 200 long steps an orbit. Orbit means of r and KE over 10 orbits must stay
  // put as under the plain scheme (goal 1e-4; 1e-3 at 3 h, the mesh's own limit there).
  if (!root()) return;
  const double m = 1.0e9, h = 6.25;
  for (const double r_h : {1.5, 3.0}) {
    const double r0 = r_h * h, period = 2 * kPi * std::sqrt(r0 * r0 * r0 / (2 * G * m));
    const double dt = period / 2000;
    auto sim = two_bodies(r0, 0.7, dt, {"time.long_step=" + std::to_string(10 * dt)}, 1.0, kSlowHill);
    const double ke0 = kinetic(*sim);
    std::vector<double> r_mean(10, 0.0), ke_mean(10, 0.0);
    long samples[10] = {};
    for (int s = 1; s <= 20000; ++s) {
      sim->step();
      if (s % 10 != 0) continue;  // long steps' ends: the free particles' stored state is the present one there
      r_mean[(s - 1) / 2000] += separation(*sim) / r0;
      ke_mean[(s - 1) / 2000] += kinetic(*sim) / ke0;
      ++samples[(s - 1) / 2000];
    }
    double dr = 0, dke = 0;
    for (int o = 1; o < 10; ++o) {
      dr = std::max(dr, std::abs(r_mean[o] / samples[o] / (r_mean[0] / samples[0]) - 1));
      dke = std::max(dke, std::abs(ke_mean[o] / samples[o] / (ke_mean[0] / samples[0]) - 1));
    }
    const auto& mr = *sim->find<MultiRateHill>();
    std::printf("multi-rate binary at %.1f h: orbit means drift by |dr/r| = %.2e, |dKE/KE| = %.2e over 10 orbits (%lld contact particle-steps)\n",
                r_h, dr, dke, mr.contact_particle_steps);
    EXPECT_EQ(mr.contact_particle_steps, 0) << "the binary's particles should stay free";
    const double bound = r_h <= 2 ? 1e-4 : 1e-3;
    EXPECT_LT(dr, bound) << r_h << " h";
    EXPECT_LT(dke, bound) << r_h << " h";
  }
}

TEST(SelfGravity, MultiRateRestingPairIsNotPumpedByTheMeshKicks) {
  // The same pair under the multi-rate integrator, long steps of 40 s = 2 t_c: touching, it is
  // on contact steps, where the short range comes every step and only the mesh's smooth part as
  // kicks at the long steps' ends.
  if (!root()) return;
  const auto [worst, loading] = resting_pair(kSlowHill, "time.long_step=40.0");
  std::printf("multi-rate resting pair: max relative normal speed %.3e m/s (loading oscillation %.3e, v_c 7.7e-05)\n", worst,
              loading);
  EXPECT_LT(worst, 2 * loading);
}

TEST(SelfGravity, ConservesMomentumAndHasNoSelfForce) {
  if (!root()) return;
  auto sim = make_sim(kPatch, {"self_gravity.split=1.0", "self_gravity.short_range=false"}, MPI_COMM_SELF);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-100.0, 100.0), z(-6.0, 6.0), mass(1e5, 1e7);
  for (int i = 0; i < 400; ++i) sim->particles.add(i, 0, 0.01, mass(rng), Vec3(u(rng), u(rng), z(rng)), Vec3::Zero());
  sim->setup();
  sim->domain.shear.offset = 1234.5;
  SelfGravity& g = gravity_of(*sim);
  g.solve(*sim);
  const auto& p = sim->particles;
  Vec3 total = Vec3::Zero();
  double scale = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Vec3 f = p.mass[i] * g.field(p.x[i]);
    total += f;
    scale += f.norm();
  }
  std::printf("momentum: |sum F| / sum |F| = %.2e\n", total.norm() / scale);
  EXPECT_LT(total.norm() / scale, 1e-10);

  // A lone particle feels nothing from itself, wherever it sits in its cell.
  auto lone = make_sim(kPatch, {"self_gravity.short_range=false"}, MPI_COMM_SELF);
  lone->particles.add(0, 0, 1.0, 1e9, Vec3(3.7, -41.2, 2.3), Vec3::Zero());
  lone->setup();
  gravity_of(*lone).solve(*lone);
  const Vec3 self = gravity_of(*lone).field(lone->particles.x[0]);
  const double near = G * 1e9 / (6.25 * 6.25);  // a neighbour one cell away would pull this hard
  EXPECT_LT(self.norm(), 1e-10 * near) << self.transpose();
}

TEST(SelfGravity, SameTrajectoriesOnOneAndTwoRanks) {
  // A self-gravitating 3D ring patch with contacts and the short range, 300 steps (a solve
  // every 2): bitwise, with slabs across the radial direction (each rank's mesh box a band of
  // rows) and across the azimuthal one (a band of columns, skewed by the shear, and every row).
  // Last, the same under modified Lees-Edwards boundaries (two copies, two meshes).
  // Then all three under the multi-rate integrator (long steps of 10 steps in place of `every`).
  struct Variant {
    const char* axis;
    bool fed, multirate;
  };
  for (const Variant v : {Variant{"y", false, false}, Variant{"x", false, false}, Variant{"x", true, false},
                          Variant{"y", false, true}, Variant{"x", false, true}, Variant{"x", true, true}}) {
    const std::string axis = std::string(v.axis) + (v.fed ? ", fed" : "") + (v.multirate ? ", multi-rate" : "");
    std::vector<std::string> over = {"particles.init=\"random\"", "particles.count=600", "particles.shear_flow=true",
                                     "particles.velocity_sigma=0.001", "self_gravity.split=3.0",
                                     std::string("domain.slab_axis=\"") + v.axis + "\""};
    if (v.fed) over.push_back("domain.modified_lees_edwards=true");
    if (v.multirate) {
      over.push_back("time.integrator=\"multirate\"");
      over.push_back("time.long_step=20.0");
    } else {
      over.push_back("self_gravity.every=2");
    }
    auto run = [&](MPI_Comm comm) {
      auto sim = make_sim(kPatch, over, comm);
      sim->setup();
      for (int s = 0; s < 300; ++s) sim->step();
      // forces too: a pull summed in another order differs in its last bits, which the
      // velocities (1e5 x larger than a step's kick) would round away
      return gather_state(*sim, true);
    };
    StateById one;
    if (root()) one = run(MPI_COMM_SELF);
    const StateById two = run(MPI_COMM_WORLD);
    if (!root()) continue;
    ASSERT_GT(one.size(), v.fed ? 1000u : 590u);  // a few leave through the open z faces
    EXPECT_EQ(differing(one, two), 0) << "slabs along " << axis;
  }
}

TEST(SelfGravity, EachRanksMeshBoxIsItsSlabAtAnyShear) {
  // Slabs across the azimuth on 2 ranks: each rank deposits into and reads from the nodes its
  // particles touch, a band of ~nx / 2 + 2 columns in every row of the sheared grid. The band
  // shifts along x from row to row, and the top row's particles reach the bottom row a shear
  // away: a bounding rectangle would span the whole grid once the shear nears Lx / 2 (and the
  // mesh memory per rank would no longer fall as 1 / P).
  auto sim = make_sim(kPatch, {"particles.init=\"random\"", "particles.count=600", "domain.slab_axis=\"x\""});
  sim->setup();
  SelfGravity& g = gravity_of(*sim);
  const long nx = 32, ny = 32;
  for (const double shear : {0.0, 50.0, 100.0, 130.0, 1234.5}) {
    sim->domain.shear.offset = shear;
    g.solve(*sim, false);
    EXPECT_LE(g.box_nodes(), (ny + 2) * (nx / 2 + 4)) << "shear offset " << shear << " m";
    EXPECT_GT(g.box_nodes(), 0) << "shear offset " << shear << " m";
  }
}

TEST(SelfGravity, EachCopyUnderModifiedLeesEdwardsFeelsItsOwnMass) {
  // Modified Lees-Edwards boundaries run two copies of the box in the same coordinates (LE1,
  // LE2): each copy's mass pulls its own particles only. A pair 10 m apart in one copy attracts
  // by Newton's law (with the images); the same pair split between the copies does not at all.
  if (!root()) return;
  const double m = 1.0e9, r = 10.0, newton = G * m * m / (r * r);
  const Vec3 a(7.0, 3.0, 0.5), b = a + Vec3(r * std::cos(0.7), r * std::sin(0.7), 0.0);
  auto pull = [&](int copy_of_b) {
    auto sim = make_sim(kPatch, {"domain.modified_lees_edwards=true"}, MPI_COMM_SELF);
    sim->particles.add(0, 0, 1.0, m, a, Vec3::Zero());
    sim->particles.add(1, 0, 1.0, m, b, Vec3::Zero());
    sim->particles.le_copy[1] = static_cast<std::uint8_t>(copy_of_b);
    sim->setup();
    std::vector<Vec3> F(sim->particles.nlocal, Vec3::Zero());
    gravity_of(*sim).add_body_forces(*sim, F);
    return F[local_index(*sim, 0)];
  };
  const Vec3 same = pull(0), apart = pull(1);
  const Vec3 ref = m * (image_sum({b}, {m}, a, 200.0, 0.0, 12000.0, 1e-9) + image_sum({a}, {m}, a, 200.0, 0.0, 12000.0, 1e-9, 0));
  std::printf("copies: same copy |F - Newton| / Newton = %.4f; other copy |F| / Newton = %.2e\n", (same - ref).norm() / ref.norm(),
              apart.norm() / newton);
  EXPECT_LT((same - ref).norm() / ref.norm(), 0.02);
  EXPECT_LT(apart.norm() / newton, 1e-6);  // only its own images, which cancel on the unsheared lattice
}

TEST(SelfGravity, RefusesWhatItCannotSolve) {
  auto fails = [](const std::vector<std::string>& over, const std::string& key) {
    try {
      config_from(kPatch, over);
    } catch (const ConfigError& e) {
      return std::string(e.what()).find(key) != std::string::npos;
    }
    return false;
  };
  EXPECT_TRUE(fails({"self_gravity.grid=[31, 32, 16]"}, "self_gravity.grid"));
  EXPECT_TRUE(fails({"self_gravity.grid=[32, 32]"}, "self_gravity.grid"));
  EXPECT_TRUE(fails({"domain.boundary=[\"periodic\", \"lees_edwards\", \"periodic\"]"}, "domain.boundary"));
  EXPECT_TRUE(fails({"self_gravity.every=0"}, "self_gravity.every"));
  EXPECT_TRUE(fails({"self_gravity.cutoff=1.5"}, "self_gravity.cutoff"));
  EXPECT_TRUE(fails({"self_gravity.every=2", "time.integrator=\"multirate\""}, "self_gravity.every"));  // the long step is the period
  EXPECT_TRUE(fails({"domain.planar=true", "domain.boundary=[\"periodic\", \"lees_edwards\", \"periodic\"]"}, "nz = 1"));
}

