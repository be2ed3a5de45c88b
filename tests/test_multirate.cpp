// The multi-rate Hill integrator (time.integrator = "multirate") against analytic solutions
// and against the plain scheme (every particle on velocity Verlet steps).
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "core/Initializer.hpp"
#include "physics/contact/ContactForces.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "physics/ring/MultiRateHill.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

const double kOmega = std::sqrt(kGravitationalConstant * 5.68e26 / std::pow(1.17e8, 3));
const double kMass = 500.0 * 4.0 / 3.0 * std::numbers::pi * 8.0;
const double kT0 = 2 * std::numbers::pi / kOmega;

// One particle in an empty 3D Hill-frame box.
const char* kEmpty = R"(
modules = ["contact", "hill"]
[domain]
lo = [-1000.0, -1000.0, -100.0]
hi = [1000.0, 1000.0, 100.0]
boundary = ["periodic", "lees_edwards", "periodic"]
[hill]
vertical_frequency = 2.0
[[species]]
density = 500.0
radius = 2.0
t_c = 100.0
e = 0.25
[particles]
init = "none"
[time]
dt = 10.0
end = 1.0
integrator = "multirate"
)";

// A ring gas at optical depth 0.1 (1,600 particles), no moonlet.
const char* kGas = R"(
seed = 11
modules = ["contact", "hill"]
[domain]
lo = [-400.0, -100.0, -10.0]
hi = [400.0, 100.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
planar = true
[[species]]
density = 500.0
radius = 2.0
t_c = 10.0
e = 0.5
[particles]
init = "random"
optical_depth = 0.1
shear_flow = true
dispersion = 0.02
[contact]
skin = 1.0
[time]
n_c = 10
end = 1.0e6
)";

// Radial velocity dispersion (relative to the shear) and mean, over all ranks.
double radial_dispersion(const Simulation& sim) {
  const auto& p = sim.particles;
  double s[2] = {0, 0}, g[2];
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    s[0] += p.v[i][1] * p.v[i][1];
    s[1] += 1;
  }
  MPI_Allreduce(s, g, 2, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  return std::sqrt(g[0] / g[1]);
}

struct GasRun {
  long collisions = 0;
  double dispersion = 0;
  MultiRateHill* multirate = nullptr;
  std::unique_ptr<Simulation> sim;
};

GasRun run_gas(const std::string& integrator, double orbits) {
  GasRun r;
  r.sim = make_sim(kGas, {"time.integrator=\"" + integrator + "\""});
  r.sim->setup();
  r.multirate = r.sim->find<MultiRateHill>();
  while (r.sim->time < orbits * kT0) r.sim->step();
  r.collisions = r.sim->find<ContactForces>()->take_collisions();
  r.dispersion = radial_dispersion(*r.sim);
  return r;
}

}  // namespace

TEST(MultiRate, FreeParticleIsOnTheExactEpicycleAtAnyStep) {
  // Analytic solution of Hill's linear equations in guiding-centre form (as test_hill_frame)
  // and the vertical oscillation at Omega_z = 2 Omega0; dt = 10 s, 25x the ring's step, where
  // velocity Verlet's phase error would be ~1e-4 of the amplitude after 10 orbits.
  auto sim = make_sim(kEmpty);
  const double x0 = 0, y0 = 100.0, z0 = 3.0, vx0 = 1.5 * kOmega * 60.0, vy0 = 0.004, vz0 = 0.001;
  sim->particles.add(0, 0, 2.0, kMass, Vec3(x0, y0, z0), Vec3(vx0, vy0, vz0));
  sim->setup();
  const double W = kOmega, Wz = 2 * kOmega, C = vx0 - 2 * W * y0, yg = -2 * C / W, B = y0 - yg, D = vy0 / W;
  const double amplitude = std::hypot(B, D);
  double worst = 0, worst_z = 0, x_unwrapped = x0, x_last = x0;
  while (sim->time < 10 * kT0) {
    sim->step();
    const auto& p = sim->particles;
    double dx = p.x[0][0] - x_last;
    dx -= sim->domain.length[0] * std::round(dx / sim->domain.length[0]);
    x_unwrapped += dx;
    x_last = p.x[0][0];
    const double s = sim->time;
    const double x = x0 - 3 * C * s + 2 * B * std::sin(W * s) - 2 * D * (std::cos(W * s) - 1);
    const double y = yg + B * std::cos(W * s) + D * std::sin(W * s);
    const double z = z0 * std::cos(Wz * s) + vz0 / Wz * std::sin(Wz * s);
    worst = std::max({worst, std::abs(x_unwrapped - x), std::abs(p.x[0][1] - y)});
    worst_z = std::max(worst_z, std::abs(p.x[0][2] - z));
  }
  std::printf("multi-rate free epicycle over 10 orbits at dt = 10 s: max deviation %.3e m (amplitude %.1f m), z %.3e m\n",
              worst, amplitude, worst_z);
  EXPECT_LT(worst, 1e-9 * amplitude);
  EXPECT_LT(worst_z, 1e-9 * z0);
}

TEST(MultiRate, RingGasCollidesAsThePlainScheme) {
  // Same initial state; the two schemes differ by rounding and by the free particles' exact
  // drift (Verlet's error is (Omega dt)^2 ~ 1e-6), so over the first 0.05 orbits (about a
  // collision per ten particles) the same collisions happen: a missed contact would show.
  {
    const GasRun plain = run_gas("verlet", 0.05), multi = run_gas("multirate", 0.05);
    std::printf("first 0.05 orbits: %ld collisions (plain), %ld (multi-rate); contact steps %.4f of particle-steps\n",
                plain.collisions, multi.collisions,
                double(multi.multirate->contact_particle_steps) /
                    double(multi.multirate->contact_particle_steps + multi.multirate->free_particle_steps));
    EXPECT_GT(plain.collisions, 50);
    EXPECT_LE(std::abs(plain.collisions - multi.collisions), 2);
    EXPECT_EQ(multi.multirate->missed, 0);
  }
  // Over half an orbit the gas cools (e = 0.5) by collisions: the dispersion after it is the
  // collisional physics, compared within 5 % (the seed-to-seed scatter at 1,600 particles is ~2 %).
  const GasRun plain = run_gas("verlet", 0.5), multi = run_gas("multirate", 0.5);
  std::printf("after 0.5 orbits: collisions %ld / %ld, radial dispersion %.4e / %.4e m/s (plain / multi-rate)\n",
              plain.collisions, multi.collisions, plain.dispersion, multi.dispersion);
  EXPECT_NEAR(double(multi.collisions) / double(plain.collisions), 1.0, 0.05);
  EXPECT_NEAR(multi.dispersion / plain.dispersion, 1.0, 0.05);
  const double frac = double(multi.multirate->contact_particle_steps) /
                      double(multi.multirate->contact_particle_steps + multi.multirate->free_particle_steps);
  EXPECT_LT(frac, 0.3) << "most particle-steps should be free ones";
}

TEST(MultiRate, MoonletEncountersEndAsWithThePlainScheme) {
  // One particle meets the moonlet (r_H = 228.5 m) on a horseshoe orbit (b = 200 m: it turns
  // back, to y_g = -142 m) and on a passing one (b = 600 m: it leaves with an epicycle). Far
  // from the moonlet its pull is a kick every long step (40.8 s, 102 steps); the plain scheme
  // at the same dt = 0.4 s is the reference. Compared after 2 orbits: guiding centre and
  // epicycle amplitude, which the encounter set.
  const std::string scene = R"(
modules = ["contact", "hill", "moonlet"]
[domain]
lo = [-10000.0, -1000.0, -10.0]
hi = [10000.0, 1000.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
planar = true
[moonlet]
mass = 1.27e10
radius = 150.0
[[species]]
density = 500.0
radius = 2.0
t_c = 4.0
e = 0.25
[particles]
init = "none"
[time]
n_c = 10
end = 1.0e6
)";
  for (const double b : {200.0, 600.0}) {
    double final_state[2][4];
    for (int k = 0; k < 2; ++k) {
      auto sim = make_sim(scene, {k ? "time.integrator=\"multirate\"" : "time.integrator=\"verlet\""});
      const double x0 = -(b < 400 ? 3000.0 : 4000.0);  // upstream (y > 0 flows towards +x)
      sim->particles.add(0, 0, 2.0, kMass, Vec3(x0, b, 0), Vec3(1.5 * kOmega * b, 0, 0));
      sim->setup();
      while (sim->time < 2 * kT0) sim->step();
      const Vec3 x = sim->particles.x[0], v = sim->particles.v[0];
      // guiding centre y_g = 4 y - 2 vx / W (test_hill_frame), radial amplitude
      const double yg = 4 * x[1] - 2 * v[0] / kOmega, amp = std::hypot(x[1] - yg, v[1] / kOmega);
      final_state[k][0] = yg;
      final_state[k][1] = amp;
      final_state[k][2] = x[1];
      final_state[k][3] = x[0];
    }
    std::printf("b = %.0f m: guiding centre %.3f / %.3f m, amplitude %.4f / %.4f m (plain / multi-rate)\n", b,
                final_state[0][0], final_state[1][0], final_state[0][1], final_state[1][1]);
    if (b < 400) EXPECT_LT(final_state[0][0], -100.0) << "a horseshoe: the particle turned back";
    else EXPECT_GT(final_state[0][1], 1.0) << "a passing particle keeps an epicycle";
    EXPECT_NEAR(final_state[1][0], final_state[0][0], 1e-3 * b);
    EXPECT_NEAR(final_state[1][1], final_state[0][1], 0.01 * final_state[0][1] + 0.01);
  }
}

TEST(MultiRate, PropellerGapsTrailDownstreamOfTheMoonlet) {
  // cases/propeller for one orbit. In the Hill frame the ring outside the
  // moonlet (y > 0) drifts to +x at 1.5 Omega0 y and the ring inside to -x, so material the
  // moonlet's gravity has scattered is missing downstream of it: the outer gap lies at +x, the
  // inner one at -x (Keplerian shear alone fixes the side; thesis fig. 6.4, Seiss et al. 2005).
  // Count particles in boxes 300-1500 m downstream and upstream, 100-350 m from the moonlet's
  // orbit (the Hill-radius scale, r_H = 228 m, where the gaps open). After one orbit ring at
  // y >= 100 m has drifted >= 9 km past the moonlet, so the downstream boxes hold only ring
  // that has met it. Measured: 101 / 203 outside, 99 / 191 inside (about half).
  // kPropellerPatch grown to cases/propeller's box, particles, t_c, step, skin and integrator.
  auto sim = make_sim(kPropellerPatch, {"seed=2019", "domain.lo=[-9000.0, -1000.0, -10.0]",
                                        "domain.hi=[9000.0, 1000.0, 10.0]", "particles.count=30000",
                                        "species.0.t_c=1.0", "time.n_c=10", "contact.skin=4.0",
                                        "time.integrator=\"multirate\"", "time.end=40840.0",
                                        "guards.max_overlap=0.1"});
  sim->setup();
  sim->run();
  auto count = [&](double x0, double x1, double y0, double y1) {
    long n = 0;
    for (std::size_t i = 0; i < sim->particles.nlocal; ++i) {
      const Vec3& x = sim->particles.x[i];
      n += x[0] >= x0 && x[0] < x1 && x[1] >= y0 && x[1] < y1;
    }
    return n;
  };
  const long outer_down = count(300, 1500, 100, 350), outer_up = count(-1500, -300, 100, 350);
  const long inner_down = count(-1500, -300, -350, -100), inner_up = count(300, 1500, -350, -100);
  const double expected = 30000.0 / (18000.0 * 2000.0) * 1200 * 250;  // ~250 unperturbed
  std::printf("particles per box (unperturbed ~%.0f): outer downstream %ld, upstream %ld; inner downstream %ld, upstream %ld\n",
              expected, outer_down, outer_up, inner_down, inner_up);
  // A gap: downstream below 70 % of upstream (Poisson scatter of ~250 counts is ~6 %).
  EXPECT_LT(outer_down, 0.7 * outer_up);
  EXPECT_LT(inner_down, 0.7 * inner_up);
  // Upstream the ring has not met the moonlet yet: near its unperturbed density.
  EXPECT_NEAR(outer_up / expected, 1, 0.3);
  EXPECT_NEAR(inner_up / expected, 1, 0.3);
}

// The neighbour list stays valid while free particles are lazy because the rebuild decision
// takes a bound on how far each can have drifted since the build. Every free particle's present
// displacement (relative to the imposed flow at its build position) must be within the drift
// the integrator reported for the step. In the propeller patch the moonlet flings particles
// onto fast epicycles, which carry bounds of their own (MultiRateHill::fast_bounds; a bound
// that left them out, or dropped its velocity term, fails here).
TEST(MultiRate, FreeParticlesStayWithinTheDriftBound) {
  auto sim = make_sim(kPropellerPatch, {"time.integrator=\"multirate\"", "contact.skin=4.0"});
  sim->setup();
  const MultiRateHill* mr = sim->find<MultiRateHill>();
  ASSERT_NE(mr, nullptr);
  const double rate = sim->domain.shear.rate;
  const std::size_t mode = sim->particles.find_column("multirate_mode");
  double t_build = sim->time, farthest = 0;
  long rebuilds = sim->rebuilds, checked = 0, violations = 0;
  while (sim->time < 0.1 * kT0) {
    sim->step();
    if (sim->rebuilds != rebuilds) {  // built this step: every displacement is zero
      rebuilds = sim->rebuilds;
      t_build = sim->time;
      continue;
    }
    const MultiRateHill::Present now = mr->present(*sim);
    const ParticleStore& p = sim->particles;
    const double stream = rate * (sim->time - t_build), bound = std::sqrt(sim->stepping.max_drift2);
    double largest = 0;
    for (std::size_t i = 0; i < p.nlocal; ++i) {
      if (*p.column(mode, i) != 0) continue;  // free ones only (contact steps: their drift is counted as they move)
      const Vec3 x = now(i), xb = p.x_build[i];
      largest = std::max(largest, Vec3(x[0] - xb[0] - stream * xb[1], x[1] - xb[1], x[2] - xb[2]).norm());
    }
    violations += largest > bound * (1 + 1e-9) + 1e-9;
    farthest = std::max(farthest, largest);
    ++checked;
  }
  std::printf("%ld steps checked, %ld rebuilds: free particles drifted up to %.3f m from their build positions; %ld violations\n",
              checked, sim->rebuilds, farthest, violations);
  EXPECT_EQ(violations, 0);
  EXPECT_GT(checked, 5000);
  // Free particles must drift far enough between rebuilds (half the skin triggers one) for a
  // bound that is too small to show.
  EXPECT_GT(farthest, 0.25 * sim->skin);
}

// On contact steps only the targets get new damping loads, so the damping limit moves loads
// for them and for last step's loaded particles only: its columns must stay those of a pass
// over every particle, through targets that change, particles that leave the contact steps
// and rebuilds (slots moved).
TEST(DampingLimit, ContactStepLoadsAreThoseOfAFullPass) {
  ParticleStore sparse, full;
  DampingLimit ls = DampingLimit::attach(sparse), lf = DampingLimit::attach(full);
  for (ParticleStore* p : {&sparse, &full}) {
    for (int k = 0; k < 200; ++k) p->add(k, 0, 1.0, 1.0, Vec3(k, 0, 0), Vec3::Zero());
    p->nlocal = p->size();
  }
  Random rng(3);
  long rebuilds = 0, compared = 0, loaded = 0;
  for (int step = 0; step < 400; ++step) {
    if (step % 97 == 50) ++rebuilds;  // slots may have moved: the next pass is a full one
    std::vector<std::uint32_t> targets;
    for (std::uint32_t i = 0; i < 200; ++i)
      if (rng.uniform() < 0.1) targets.push_back(i);
    for (const std::uint32_t i : targets)
      if (rng.uniform() < 0.5) {
        const double K = rng.uniform(), G = rng.uniform();
        ls.add(sparse, i, K, G, 1.0);
        lf.add(full, i, K, G, 1.0);
      }
    ls.finish_step(sparse, targets.data(), targets.size(), rebuilds);
    lf.finish_step(full, nullptr, full.nlocal, rebuilds);
    for (std::size_t i = 0; i < 200; ++i) {
      ++compared;
      loaded += ls.scale(sparse, i) != 1.0 || full.column(full.find_column("damping_load"), i)[0] != 0;
      ASSERT_EQ(sparse.column(sparse.find_column("damping_load"), i)[0], full.column(full.find_column("damping_load"), i)[0])
          << "step " << step << ", particle " << i;
      ASSERT_EQ(sparse.column(sparse.find_column("damping_load"), i)[1], full.column(full.find_column("damping_load"), i)[1]);
    }
  }
  EXPECT_GT(loaded, compared / 40) << "loads must occur, or the test shows nothing";
}

// Between long steps only the particles on contact steps move, so the
// step's ghost update refreshes their images and the sheared ones (whose x follows the shear
// offset) only. A ghost left stale would change what the contact particles meet: the ring gas
// (Lees-Edwards, many collisions across the sheared boundary) and the propeller patch (a pile
// on the moonlet) must come out bit for bit as with every ghost rewritten every step.
TEST(MultiRate, GhostUpdatesOfTheMovedOnlyChangeNoBit) {
  struct Scene { const char* text; std::vector<std::string> sets; double end; };
  const Scene scenes[] = {
      {kGas, {"time.integrator=\"multirate\"", "domain.lo=[-400.0,-40.0,-10.0]", "domain.hi=[400.0,40.0,10.0]", "particles.optical_depth=0.3"}, 0.2 * kT0},
      // Self-gravity's short range reads the free partners where they are now, sheared images too.
      {kSelfGravityPatch, {"time.integrator=\"multirate\"", "time.long_step=20.0", "particles.init=\"random\"",
                           "particles.count=3000", "particles.shear_flow=true", "particles.velocity_sigma=0.003",
                           "self_gravity.split=3.0"}, 1000.0},
      {kPropellerPatch, {"time.integrator=\"multirate\"", "time.long_step=20.0"}, 0.05 * kT0},
      {kPropellerPatch, {"time.integrator=\"multirate\"", "time.long_step=20.0", "domain.modified_lees_edwards=true"}, 0.05 * kT0}};
  for (const Scene& sc : scenes) {
    auto partial = make_sim(sc.text, sc.sets), full = make_sim(sc.text, sc.sets);
    full->halo.full_updates = true;
    partial->setup();
    full->setup();
    long moved_steps = 0, crossings = 0;
    while (partial->time < sc.end) {
      partial->step();
      full->step();
      moved_steps += partial->stepping.moved_known;
    }
    crossings = partial->halo.shear_crossings;
    const ParticleStore &a = partial->particles, &b = full->particles;
    ASSERT_EQ(a.nlocal, b.nlocal);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.nlocal; ++i)
      differ += a.id[i] != b.id[i] || a.x[i] != b.x[i] || a.v[i] != b.v[i];
    const long contacts = partial->find<ContactForces>()->take_collisions();
    std::printf("%zu particles, %ld steps with partial ghost updates of %ld, %ld contacts, %ld sheared crossings: %zu differ\n",
                a.nlocal, moved_steps, partial->step_count, contacts, crossings, differ);
    EXPECT_EQ(differ, 0u);
    EXPECT_GT(moved_steps, partial->step_count / 2) << "the partial update must be what ran";
    EXPECT_GT(contacts + crossings, 20) << "contacts or crossings must happen, or the test shows nothing";
  }
}
