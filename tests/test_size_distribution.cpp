// Radii from a size distribution (species size_distribution: uniform, power_law, list): the
// drawn radii follow the law (moments and CDF against closed forms written out here), a scene
// placed at an optical depth reaches it, and with a_max / a_min = 10 the neighbour list is
// exactly the set of pairs within a_i + a_j + skin (against all pairs).
#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "core/Initializer.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

// A planar ring patch of 1-10 m particles, dN/da ~ a^-3 (REBOUND's shearing-sheet sizes are 1-4 m).
const char* kPolydisperseRing = R"(
seed = 11
modules = ["contact", "hill"]
[domain]
lo = [-500.0, -500.0, -10.0]
hi = [500.0, 500.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
planar = true
[[species]]
density = 500.0
radius_min = 1.0
radius_max = 10.0
size_distribution = "power_law"
size_exponent = 3.0
t_c = 4.0
e = 0.5
[particles]
init = "random"
optical_depth = 0.3
shear_flow = true
dispersion = 0.01
[time]
n_c = 10
end = 1000.0
)";

}  // namespace

TEST(SizeDistribution, PowerLawRadiiHaveTheLawsMomentsAndCdf) {
  // dN/da = C a^-3 on [1, 10]: C = 2 / (1 - 10^-2); <a> = C (1 - 1/10), <a^2> = C ln 10,
  // <a^3> = C 9, P(a < 2) = (1 - 2^-2) / (1 - 10^-2).
  SizeDistribution d;
  d.kind = SizeDistribution::PowerLaw;
  d.q = 3;
  const double C = 2 / (1 - 1e-2);
  const double m1 = C * 0.9, m2 = C * std::log(10.0), m3 = C * 9, below2 = 0.75 / 0.99;
  EXPECT_NEAR(d.mean_power(1, 10, 1), m1, 1e-12 * m1);
  EXPECT_NEAR(d.mean_power(1, 10, 2), m2, 1e-12 * m2);
  EXPECT_NEAR(d.mean_power(1, 10, 3), m3, 1e-12 * m3);
  Random rng(5);
  const int n = 1000000;
  double s1 = 0, s2 = 0, s3 = 0, lo = 1e30, hi = 0;
  long small = 0;
  for (int k = 0; k < n; ++k) {
    const double a = d.quantile(1, 10, rng.uniform());
    s1 += a; s2 += a * a; s3 += a * a * a;
    small += a < 2;
    lo = std::min(lo, a); hi = std::max(hi, a);
  }
  // Standard errors for 1e6 draws: 0.06 %, 0.19 %, 0.7 % (var <a^k> from <a^2k>); bounds ~5 sigma.
  EXPECT_NEAR(s1 / n / m1, 1, 0.003);
  EXPECT_NEAR(s2 / n / m2, 1, 0.01);
  EXPECT_NEAR(s3 / n / m3, 1, 0.035);
  EXPECT_NEAR(double(small) / n, below2, 0.003);
  EXPECT_GE(lo, 1.0);
  EXPECT_LE(hi, 10.0);
  // q = 1 (dN/da ~ 1/a): log-uniform, <a> = (10 - 1) / ln 10.
  d.q = 1;
  EXPECT_NEAR(d.mean_power(1, 10, 1), 9 / std::log(10.0), 1e-12);
  EXPECT_NEAR(d.quantile(1, 10, 0.5), std::sqrt(10.0), 1e-12);
}

TEST(SizeDistribution, ListDrawsItsFractions) {
  std::string text = kPolydisperseRing;
  const std::string sizes = "radius_min = 1.0\nradius_max = 10.0\nsize_distribution = \"power_law\"\nsize_exponent = 3.0\n";
  ASSERT_NE(text.find(sizes), std::string::npos);
  text.replace(text.find(sizes), sizes.size(), "radii = [4.0, 1.0, 2.0]\nradius_weights = [2.0, 5.0, 3.0]\n");
  const Config cfg = config_from(text);
  const Species& s = cfg.species[0];
  EXPECT_EQ(s.radius_min, 1.0);
  EXPECT_EQ(s.radius_max, 4.0);
  Random rng(9);
  const int n = 200000;
  double count[3] = {0, 0, 0};
  for (int k = 0; k < n; ++k) {
    const double a = s.sizes.quantile(s.radius_min, s.radius_max, rng.uniform());
    const int k3 = a == 1.0 ? 0 : a == 2.0 ? 1 : 2;
    ASSERT_TRUE(a == 1.0 || a == 2.0 || a == 4.0) << a;
    count[k3] += 1;
  }
  // Fractions 0.5, 0.3, 0.2 (the weights normalised, sorted with their radii): 5 sigma ~ 0.006.
  EXPECT_NEAR(count[0] / n, 0.5, 0.006);
  EXPECT_NEAR(count[1] / n, 0.3, 0.006);
  EXPECT_NEAR(count[2] / n, 0.2, 0.006);
  EXPECT_NEAR(s.sizes.mean_power(1, 4, 2), 0.5 + 0.3 * 4 + 0.2 * 16, 1e-12);
}

TEST(SizeDistribution, PowerLawPatchReachesItsOpticalDepthAndListsEveryPair) {
  auto sim = make_sim(kPolydisperseRing);
  sim->setup();
  const ParticleStore& p = sim->particles;
  double area = 0, amin = 1e30, amax = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    area += M_PI * p.radius[i] * p.radius[i];
    amin = std::min(amin, p.radius[i]);
    amax = std::max(amax, p.radius[i]);
  }
  // N = tau L^2 / (pi <a^2>) from the law's <a^2>; the realised tau scatters by the sample's
  // <a^2> (relative standard error sqrt(var a^2 / N) ~ 1.9 / sqrt(N)), here ~4 %.
  const double tau = area / (1000.0 * 1000.0);
  EXPECT_NEAR(tau, 0.3, 0.3 * 5 * 1.9 / std::sqrt(double(p.nlocal))) << p.nlocal << " particles";
  EXPECT_LT(amin, 1.05);
  EXPECT_GT(amax, 8.0);
  // The neighbour list against every pair (periodic in x, sheared in y: the minimum image at
  // t = 0, offset 0), within a_i + a_j + skin.
  std::set<std::pair<std::int64_t, std::int64_t>> listed, all;
  const NeighborList& nl = sim->neighbors;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::uint32_t k = nl.start[i]; k < nl.start[i + 1]; ++k) listed.insert({p.id[i], p.id[nl.partner[k]]});
  const double L = 1000.0, skin = sim->skin;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    for (std::size_t j = 0; j < p.nlocal; ++j) {
      if (i == j) continue;
      double dx = p.x[i][0] - p.x[j][0], dy = p.x[i][1] - p.x[j][1];
      dx -= L * std::round(dx / L);
      dy -= L * std::round(dy / L);
      const double cut = p.radius[i] + p.radius[j] + skin;
      if (dx * dx + dy * dy < cut * cut) all.insert({p.id[i], p.id[j]});
    }
  std::printf("%zu particles, %zu listed pairs, %lld candidates tested (%.1f per listed pair)\n", p.nlocal, nl.size(),
              nl.candidates, double(nl.candidates) / nl.size());
  EXPECT_GT(all.size(), 100u);
  EXPECT_EQ(listed, all);
}
