// Modified Lees-Edwards boundaries (domain.modified_lees_edwards; thesis fig. 9.1): a
// moonlet-free copy LE2 of the ring patch feeds the main box LE1 through its x faces.
//  - LE2 is the unperturbed ring: particle for particle the same as a plain Lees-Edwards run
//    without the moonlet from the same start (the independent calculation), while LE1 is not.
//  - Without a moonlet LE1 is statistically LE2: the same population, no drift, the same
//    density profile along x (the feed and drain faces included) and the same dispersion.
#include <cmath>
#include <numeric>
#include <set>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "physics/contact/ContactForces.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

// The propeller patch (1 km^2, 1,500 particles) under the multi-rate integrator, fed.
const std::vector<std::string> kMultiRate = {"species.0.t_c=4.0", "time.n_c=10", "time.integrator=\"multirate\"",
                                             "time.long_step=20.0"};
constexpr double kT0 = 40840.0;  // s, one orbit at 1.17e8 m from Saturn

std::vector<std::string> with(std::vector<std::string> base, const std::vector<std::string>& more) {
  base.insert(base.end(), more.begin(), more.end());
  return base;
}
const std::vector<std::string> kFed = with(kMultiRate, {"domain.modified_lees_edwards=true"});

// The patch without its moonlet.
std::string ring_patch() {
  std::string text = kPropellerPatch;
  const std::string table = "[moonlet]\nmass = 1.27e10\nradius = 150.0\n", modules = "\"hill\", \"moonlet\"]";
  const auto t = text.find(table), m = text.find(modules);
  if (t == std::string::npos || m == std::string::npos) throw std::logic_error("kPropellerPatch changed: update ring_patch()");
  text.erase(t, table.size());
  return text.replace(text.find(modules), modules.size(), "\"hill\"]");
}

struct Sample {
  long n1 = 0, n2 = 0;
  std::vector<double> hist1, hist2;  // particles per x bin
  double var1 = 0, var2 = 0;         // radial velocity variance
};

Sample sample(const Simulation& sim, int bins) {
  const ParticleStore& p = sim.particles;
  Sample s;
  s.hist1.assign(bins, 0);
  s.hist2.assign(bins, 0);
  const double lo = sim.domain.lo[0], L = sim.domain.length[0];
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const int b = std::clamp(int((p.x[i][0] - lo) / L * bins), 0, bins - 1);
    if (p.le_copy[i] == 0) { ++s.n1; s.hist1[b] += 1; s.var1 += p.v[i][1] * p.v[i][1]; }
    else { ++s.n2; s.hist2[b] += 1; s.var2 += p.v[i][1] * p.v[i][1]; }
  }
  s.var1 /= std::max(1L, s.n1);
  s.var2 /= std::max(1L, s.n2);
  return s;
}

}  // namespace

TEST(ModifiedLeesEdwards, LE2IsTheUnperturbedRingAndTheMoonletActsOnLE1Only) {
  // A: the propeller patch fed by LE2. B: the same patch, no moonlet, plain boundaries. Their
  // random starts are the same draw (LE2 is placed whole; ids of LE2 are N + k for B's k).
  auto a = make_sim(kPropellerPatch, kFed);
  auto b = make_sim(ring_patch(), kMultiRate);
  a->setup();
  b->setup();
  const long N = b->total_particles();
  // A quarter orbit, LE2 particles near the x faces cross; whole long steps (50 steps), where
  // the multi-rate integrator has every particle at the present time.
  const int steps = int(kT0 / 4 / a->dt) / 50 * 50;
  for (int s = 0; s < steps; ++s) a->step();
  for (int s = 0; s < steps; ++s) b->step();
  const StateById sa = gather_state(*a), sb = gather_state(*b);
  long le2 = 0, le2_apart = 0, le1 = 0, le1_apart = 0;
  for (const auto& [id, st] : sa) {
    const std::int64_t twin = id >= N && id < 2 * N ? id - N : id < N ? id : -1;
    if (twin < 0 || !sb.count(twin)) continue;  // a clone made during the run
    const auto& tb = sb.at(twin);
    const double d = std::hypot(st[0] - tb[0], st[1] - tb[1]);
    if (id >= N) { ++le2; le2_apart += d > 0.01; }
    else { ++le1; le1_apart += d > 0.01; }
  }
  const long fed = a->halo.fed;
  std::printf("LE2: %ld of %ld particles > 1 cm from the moonlet-free run; LE1: %ld of %ld; clones made: %ld\n", le2_apart,
              le2, le1_apart, le1, fed);
  EXPECT_EQ(le2, N) << "every LE2 particle stays in LE2";
  EXPECT_GT(fed, 50) << "LE2 particles must cross x within the run";
  // Collisions amplify the last-bit differences of the two runs' schedules (rebuild times,
  // LE2 particles near the feed faces on contact steps): a few particles part, no more. The
  // moonlet's pull (G M / r^2 ~ 3e-6 m/s^2 at 500 m) would move every one by metres.
  EXPECT_LT(double(le2_apart), 0.05 * N) << le2_apart << " of " << N << " LE2 particles differ from the moonlet-free run by > 1 cm";
  EXPECT_GT(double(le1_apart), 0.5 * le1) << "LE1 feels the moonlet: " << le1_apart << " of " << le1 << " differ";
}

TEST(ModifiedLeesEdwards, WithoutMoonletLE1IsStatisticallyLE2) {
  auto sim = make_sim(ring_patch(), with(kFed, {"particles.count=2000"}));
  sim->setup();
  const int bins = 10;
  const Sample first = sample(*sim, bins);
  const long N = first.n2;
  ASSERT_EQ(first.n1, N);
  // One orbit; the first quarter is the start (the patch's edges at 0.12 m/s cross the box in
  // 0.2 orbit), then a sample every 400 s.
  const long every = std::lround(400.0 / sim->dt), steps = std::lround(kT0 / sim->dt), skip = steps / 4;
  std::vector<double> t, n1;
  std::vector<double> h1(bins, 0), h2(bins, 0);
  double var1 = 0, var2 = 0;
  for (long s = 1; s <= steps; ++s) {
    sim->step();
    if (s % every || s < skip) continue;
    const Sample x = sample(*sim, bins);
    ASSERT_EQ(x.n2, N) << "LE2 keeps every particle";
    EXPECT_EQ(x.n1 - N, sim->halo.fed - sim->halo.drained) << "LE1 changes only by what was fed and drained";
    t.push_back(sim->time);
    n1.push_back(double(x.n1));
    for (int k = 0; k < bins; ++k) { h1[k] += x.hist1[k]; h2[k] += x.hist2[k]; }
    var1 += x.var1;
    var2 += x.var2;
  }
  EXPECT_GT(sim->halo.fed, N / 2) << "most of the box should have been replaced through the feed";
  std::set<std::int64_t> ids(sim->particles.id.begin(), sim->particles.id.begin() + sim->particles.nlocal);
  EXPECT_EQ(ids.size(), sim->particles.nlocal) << "ids stay unique";
  // Population: the mean within 2 % of LE2's and no drift (least-squares slope times the
  // window below 2 % of N; the count's own scatter is ~sqrt of the ~200 in transit).
  const double tm = std::accumulate(t.begin(), t.end(), 0.0) / t.size(), nm = std::accumulate(n1.begin(), n1.end(), 0.0) / n1.size();
  double sxy = 0, sxx = 0;
  for (std::size_t k = 0; k < t.size(); ++k) { sxy += (t[k] - tm) * (n1[k] - nm); sxx += (t[k] - tm) * (t[k] - tm); }
  const double drift = sxy / sxx * (t.back() - t.front());
  std::printf("LE1 population %.4f of LE2's, drift %.1f over the window; fed %ld; sigma_y LE1/LE2 %.4f; x bins LE1/LE2:",
              nm / N, drift, long(sim->halo.fed), std::sqrt(var1 / var2));
  for (int k = 0; k < bins; ++k) std::printf(" %.3f", h1[k] / h2[k]);
  std::printf("\n");
  EXPECT_NEAR(nm / N, 1.0, 0.02) << "LE1's mean population";
  EXPECT_LT(std::abs(drift), 0.02 * N) << "LE1's population drifts by " << drift << " over the window";
  // Density along x, the fed and drained faces included: each tenth of the box within 10 %
  // (each bin sums ~200 particles x ~75 samples, correlated over a crossing time).
  for (int k = 0; k < bins; ++k) EXPECT_NEAR(h1[k] / h2[k], 1.0, 0.10) << "x bin " << k;
  EXPECT_NEAR(std::sqrt(var1 / var2), 1.0, 0.05) << "radial velocity dispersion LE1 / LE2";
}

TEST(ModifiedLeesEdwards, HotRingWithoutMoonletLE1IsStatisticallyLE2) {
  // A hot ring (sigma 40 mm/s per component, e = 0.9: the dispersion a constant-e ring reaches
  // near e = 0.85) moves against the shear flow wherever |1.5 Omega0 y| < ~sigma: within ~170 m of
  // y = 0 here, a third of the box. LE1 and LE2 start as twins and stay twins there (no moonlet).
  // Before the fix, an LE2 particle that crossed x against the flow re-entered LE2 within range
  // of the opposite face and was shown at once to LE1 beyond its inflow face: on top of its own
  // LE1 twin, which had not crossed yet (overlaps of ~2 radii, the overlap guard's stop at
  // e >= 0.9 in docs/propeller.md), and a clone entered LE1 through its outflow face.
  auto sim = make_sim(ring_patch(), with(kFed, {"particles.count=2000", "species.0.e=0.9", "particles.dispersion=0",
                                                "particles.velocity_sigma=0.04"}));
  sim->setup();
  const int bins = 10;
  const long N = sample(*sim, bins).n2;
  const long every = std::lround(200.0 / sim->dt), steps = std::lround(0.5 * kT0 / sim->dt);
  std::vector<double> h1(bins, 0), h2(bins, 0);
  double n1 = 0, var1 = 0, var2 = 0, worst = 0;
  int samples = 0;
  for (long s = 1; s <= steps; ++s) {
    ASSERT_NO_THROW(sim->step()) << "step " << s;
    ASSERT_FALSE(sim->record.finished) << "stopped at step " << s << " (a guard)";
    if (auto* c = sim->find<ContactForces>()) worst = std::max(worst, c->max_overlap_fraction());
    if (s % every) continue;
    const Sample x = sample(*sim, bins);
    ASSERT_EQ(x.n2, N) << "LE2 keeps every particle";
    EXPECT_EQ(x.n1 - N, sim->halo.fed - sim->halo.drained) << "LE1 changes by fed minus drained only";
    n1 += double(x.n1);
    for (int k = 0; k < bins; ++k) { h1[k] += x.hist1[k]; h2[k] += x.hist2[k]; }
    var1 += x.var1;
    var2 += x.var2;
    ++samples;
  }
  std::printf("hot ring: LE1 population %.4f of LE2's; returned against the flow %ld, fed %ld, drained %ld, not "
              "inserted %ld; sigma_y LE1/LE2 %.4f; worst overlap %.4f radii; x bins LE1/LE2:",
              n1 / samples / N, long(sim->halo.returned), long(sim->halo.fed), long(sim->halo.drained),
              long(sim->halo.stillborn), std::sqrt(var1 / var2), worst);
  for (int k = 0; k < bins; ++k) std::printf(" %.3f", h1[k] / h2[k]);
  std::printf("\n");
  EXPECT_GT(sim->halo.returned, 40) << "the scene must exercise crossings against the flow";
  // The hottest impacts of this ring (~0.25 m/s, the Gaussian tail of a 40 mm/s dispersion over
  // a few thousand collisions) overlap by v t_c / pi = 0.32 m = 0.16 radii at t_c = 4 s; a
  // particle placed on its twin or on unseen material overlaps by up to 2.
  EXPECT_LT(worst, 0.4) << "an LE1 particle overlapped something by " << worst << " radii";
  EXPECT_NEAR(n1 / samples / N, 1.0, 0.02) << "LE1's mean population";
  for (int k = 0; k < bins; ++k) EXPECT_NEAR(h1[k] / h2[k], 1.0, 0.05) << "x bin " << k;
  EXPECT_NEAR(std::sqrt(var1 / var2), 1.0, 0.03) << "radial velocity dispersion LE1 / LE2";
}

TEST(ModifiedLeesEdwards, InflowIntoLE1CarriesLE2sStatisticsWithTheMoonlet) {
  // With the moonlet, what enters LE1 through its inflow faces must be the unperturbed ring:
  // within 100 m inside each inflow face (x = lo where y > 0, x = hi where y < 0; |y| in 50-250 m:
  // beyond 50 m the flow beats the particles' own velocities, within 250 m the sheared y faces'
  // traffic does not reach), LE1 holds as many particles as LE2 at the same place, with the same
  // radial velocity dispersion. The outflow strips, downstream of the moonlet, are the control:
  // there LE1 is depleted (the gaps) and stirred. The outer band |y| > 250 m is printed, not
  // tested: stirred LE1 material that crossed a y face enters there (1.5x LE2's dispersion).
  // A moonlet of 1/8 the mass (r_H = 114 m) in a 2 x 1 km patch: the inflow faces 8.8 r_H up
  // the stream, the sheared y faces 4.4 r_H out (stirred material that crosses them re-enters
  // LE1 anywhere, the inflow strips included: the radial width docs/propeller.md discusses).
  auto sim = make_sim(kPropellerPatch, with(kFed, {"particles.count=2000", "moonlet.mass=1.5875e9", "moonlet.radius=75.0",
                                                   "domain.lo=[-1000.0, -500.0, -10.0]", "domain.hi=[1000.0, 500.0, 10.0]"}));
  sim->setup();
  const ParticleStore& p = sim->particles;
  const double lo = sim->domain.lo[0], hi = sim->domain.hi[0], strip = 100.0;
  const long every = std::lround(200.0 / sim->dt), steps = std::lround(0.75 * kT0 / sim->dt), skip = steps / 3;
  double n[3][2] = {}, var[3][2] = {};  // [inflow, outflow, inflow beyond 250 m][LE1, LE2]
  for (long s = 1; s <= steps; ++s) {
    sim->step();
    if (s % every || s < skip) continue;
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      const Vec3& x = p.x[i];
      if (std::abs(x[1]) < 50.0) continue;
      const bool near_lo = x[0] < lo + strip, near_hi = x[0] >= hi - strip;
      if (!near_lo && !near_hi) continue;
      const bool inflow = near_lo == (x[1] > 0);
      const int side = std::abs(x[1]) > 250.0 ? (inflow ? 2 : -1) : (inflow ? 0 : 1);
      if (side < 0) continue;
      n[side][p.le_copy[i]] += 1;
      var[side][p.le_copy[i]] += p.v[i][1] * p.v[i][1];
    }
  }
  const double ratio_in = n[0][0] / n[0][1], ratio_out = n[1][0] / n[1][1];
  const double disp_in = std::sqrt(var[0][0] / n[0][0] / (var[0][1] / n[0][1]));
  const double disp_out = std::sqrt(var[1][0] / n[1][0] / (var[1][1] / n[1][1]));
  std::printf("inflow strips: LE1/LE2 particles %.4f (of %.0f), sigma_y %.4f; outflow strips: %.4f, %.4f; inflow "
              "beyond 250 m: %.4f, %.4f\n", ratio_in, n[0][1], disp_in, ratio_out, disp_out, n[2][0] / n[2][1],
              std::sqrt(var[2][0] / n[2][0] / (var[2][1] / n[2][1])));
  // ~4,000 LE2 particle-samples in the inflow strips, correlated over the ~1,000 s a particle
  // takes to cross one: ~3 % noise on the count and the dispersion.
  EXPECT_NEAR(ratio_in, 1.0, 0.05) << "LE1's density entering through the inflow faces";
  EXPECT_NEAR(disp_in, 1.0, 0.05) << "LE1's radial dispersion entering through the inflow faces";
  EXPECT_GT(std::abs(ratio_out - 1.0) + std::abs(disp_out - 1.0), 0.1) << "the moonlet must show downstream (the control)";
}

namespace {

// Two particles in a sheared 1 km box under the modified boundaries, no Hill frame (the shear
// alone: gamma = 1e-4 /s, a velocity jump of 0.1 m/s across y), at t = 5,000 s, when the shear
// offset is half the box: LE1 particle P (id 0) leaves through the bottom y face at ~100 s
// and lands next to LE1's inflow face at the top (x = lo, where the flow gamma y is positive);
// LE2 particle F (id 1) moves towards its outflow face near the top, so that its inflow image
// beyond LE1's inflow face (at x - Lx) is shown (it came into range from inside LE2) and lies
// where P lands when feed_x = 495 m (1.1 radii deep); elsewhere with feed_x = 0.
std::unique_ptr<Simulation> inflow_corner(double feed_x, bool outflow_corner = false) {
  auto sim = make_sim(R"(
modules = ["contact"]
[domain]
lo = [-500.0, -500.0, -10.0]
hi = [500.0, 500.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
shear_rate = 1.0e-4
planar = true
modified_lees_edwards = true
[[species]]
density = 500.0
radius = 2.0
t_c = 1.0
e = 0.5
[particles]
init = "none"
[contact]
skin = 0.5
[time]
n_c = 20
end = 1.0e6
)");
  const double a = 2.0, m = 500.0 * 4.0 / 3.0 * M_PI * a * a * a, tau_c = 102.5;  // P's crossing, +- a rebuild
  sim->step_count = std::lround(5000.0 / sim->dt);
  sim->time = 5000.0;
  sim->domain.shear.offset = 1.0e-4 * 1000.0 * sim->time;
  if (sim->domain.rank == 0 && outflow_corner) {
    // P leaves through the corner of the bottom face and LE1's outflow face there (x = lo:
    // the flow gamma y is negative), crossing both within one rebuild interval (~10 s).
    sim->particles.add(0, 0, a, m, Vec3(-499.9, -499.9, 0.0), Vec3(-0.01, -0.01, 0.0));
  } else if (sim->domain.rank == 0) {
    // P lands at x + offset(5000 + tau_c) - Lx = -499.5 (0.5 m inside the inflow face), y ~ 499.9.
    sim->particles.add(0, 0, a, m, Vec3(0.5 - 0.1 * tau_c, -499.0, 0.0), Vec3(0.0, -0.01, 0.0));
    sim->particles.add(1, 0, a, m, Vec3(feed_x, 499.0, 0.0), Vec3(0.04, 0.0, 0.0));
    sim->particles.le_copy.back() = 1;
  }
  sim->setup();
  return sim;
}

}  // namespace

// LE1 is a sheared box across y (its y images repeat along x) but has no x images (beyond its
// inflow face lie LE2's inflow images). The two meet at the corners: a particle that wraps
// through y next to the inflow face cannot have seen the inflow images there. One that lands
// on one is taken out (counted as drained and `cornered`), as a returned particle that lands on
// LE1 material is; one that lands clear stays. Before, the run went on with the overlap (1.1
// radii here) until the overlap guard stopped it (once in six hot propeller runs at e = 0.9).
TEST(ModifiedLeesEdwards, WrappingIntoAnInflowCornerOntoAFeedImageDrainsTheParticle) {
  for (const double feed_x : {495.0, 0.0}) {
    auto sim = inflow_corner(feed_x);
    bool wrapped = false;
    try {
      for (int s = 0; s < int(120.0 / sim->dt); ++s) {
        sim->step();
        const long here = local_index(*sim, 0);
        if (here >= 0 && sim->particles.x[here][1] > 0) wrapped = true;
      }
    } catch (const GuardError& e) {
      FAIL() << "feed_x = " << feed_x << ": " << e.what();
    }
    long wrapped_any = wrapped, cornered = sim->halo.cornered, drained = sim->halo.drained, in_le1 = 0;
    for (std::size_t i = 0; i < sim->particles.nlocal; ++i) in_le1 += sim->particles.le_copy[i] == 0;
    long g[4], l[4] = {wrapped_any, cornered, drained, in_le1};
    MPI_Allreduce(l, g, 4, MPI_LONG, MPI_SUM, sim->domain.comm);
    if (feed_x > 0) {
      EXPECT_EQ(g[1], 1) << "P landed on F's inflow image: taken out";
      EXPECT_EQ(g[2], 1) << "and counted as drained";
      EXPECT_EQ(g[3], 0);
    } else {
      EXPECT_EQ(g[0], 1) << "P must wrap through y within the run";
      EXPECT_EQ(g[1], 0) << "P landed clear of every inflow image: it stays";
      EXPECT_EQ(g[3], 1);
    }
  }
}

// A particle that leaves LE1 through a corner of its outflow face and a y face crossed the
// outflow face: it is drained, as through the face alone. Before, only a particle that crossed
// x alone was drained; one that crossed both was wrapped through y to the other side, where
// the x wrap put it next to material from LE1's opposite x face (in a 4.6 km propeller box at
// e = 0.9: 0.45 radii onto a clone's image, the overlap guard stopped the run).
TEST(ModifiedLeesEdwards, LeavingThroughAnOutflowCornerDrains) {
  auto sim = inflow_corner(0.0, true);
  for (int s = 0; s < int(40.0 / sim->dt); ++s) sim->step();
  long l[2] = {static_cast<long>(sim->halo.drained), 0}, g[2];
  for (std::size_t i = 0; i < sim->particles.nlocal; ++i) l[1] += sim->particles.le_copy[i] == 0;
  MPI_Allreduce(l, g, 2, MPI_LONG, MPI_SUM, sim->domain.comm);
  EXPECT_EQ(g[0], 1) << "P left with the flow through the outflow face: drained";
  EXPECT_EQ(g[1], 0) << "no LE1 particle remains";
}

TEST(ModifiedLeesEdwards, NeedsShearedBoundaries) {
  try {
    config_from(kPair, {"domain.modified_lees_edwards=true"});
    FAIL() << "accepted without a lees_edwards y boundary";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("domain.modified_lees_edwards"), std::string::npos) << e.what();
  }
}
