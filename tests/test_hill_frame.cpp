// Hill-frame dynamics of a free particle against the analytic solution of Hill's equations
//   x'' = 2 W y',  y'' = -2 W x' + 3 W^2 y      (W = Omega0; linear form)
// With C = vx0 - 2 W y0 the solution is
//   y(t) = y_g + B cos Wt + D sin Wt,        y_g = -2C/W, B = y0 - y_g, D = vy0/W
//   x(t) = x0 - 3C t + 2B sin Wt - 2D (cos Wt - 1)
// an epicycle of period 2 pi/W with azimuthal:radial amplitudes 2:1 whose guiding centre
// drifts at -3C = 1.5 W y_g.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "physics/ring/HillFrame.hpp"
#include "physics/ring/Moonlet.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

const char* kRing = R"(
modules = ["contact", "hill"]
[domain]
lo = [-1000.0, -1000.0, -10.0]
hi = [1000.0, 1000.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
planar = true
[hill]
form = "linear"
[[species]]
density = 500.0
radius = 2.0
t_c = 100.0
e = 0.25
[particles]
init = "none"
[contact]
skin = 20.0
[time]
dt = 1.0
end = 1.0
)";

const double kOmega = std::sqrt(kGravitationalConstant * 5.68e26 / std::pow(1.17e8, 3));
const double kMass = 500.0 * 4.0 / 3.0 * std::numbers::pi * 8.0;

// Follows one particle, undoing periodic wraps of x so its track is continuous.
struct Track {
  Simulation& sim;
  double x_unwrapped, x_last;
  explicit Track(Simulation& s) : sim(s) {
    x_last = x_unwrapped = sim.particles.x[0][0];
  }
  void step() {
    sim.step();
    const double x = sim.particles.x[0][0], L = sim.domain.length[0];
    double dx = x - x_last;
    dx -= L * std::round(dx / L);
    x_unwrapped += dx;
    x_last = x;
  }
};

}  // namespace

TEST(HillFrame, ParticleOnTheShearFlowStaysOnIt) {
  auto sim = make_sim(kRing);
  const double y0 = 300.0, v0 = 1.5 * kOmega * y0;
  sim->particles.add(0, 0, 2.0, kMass, Vec3(0, y0, 0), Vec3(v0, 0, 0));
  sim->setup();
  Track t(*sim);
  const double T0 = 2 * std::numbers::pi / kOmega;
  while (sim->time < 10 * T0) t.step();
  const auto& p = sim->particles;
  EXPECT_NEAR(p.x[0][1], y0, 1e-6 * y0);
  EXPECT_NEAR(p.v[0][1], 0.0, 1e-6 * v0);
  EXPECT_NEAR(p.v[0][0], v0, 1e-6 * v0);
  EXPECT_NEAR(t.x_unwrapped, v0 * sim->time, 1e-6 * v0 * sim->time);
}

TEST(HillFrame, FreeParticlePerformsTheEpicycle) {
  // dt = 0.25 s (the ring case uses 0.02 s): the splitting's O((W dt)^2) phase error then
  // keeps the track within 1e-6 of the epicycle amplitude over 10 orbits.
  auto sim = make_sim(kRing, {"time.dt=0.25"});
  const double x0 = 0, y0 = 100.0, vx0 = 1.5 * kOmega * 60.0, vy0 = 0.004;
  sim->particles.add(0, 0, 2.0, kMass, Vec3(x0, y0, 0), Vec3(vx0, vy0, 0));
  sim->setup();
  Track t(*sim);
  const double W = kOmega, C = vx0 - 2 * W * y0, yg = -2 * C / W, B = y0 - yg, D = vy0 / W;
  const double amplitude = std::hypot(B, D);  // radial amplitude; azimuthal is twice this
  const double T0 = 2 * std::numbers::pi / W;
  double worst = 0;
  while (sim->time < 10 * T0) {
    t.step();
    const double s = sim->time;
    const double x = x0 - 3 * C * s + 2 * B * std::sin(W * s) - 2 * D * (std::cos(W * s) - 1);
    const double y = yg + B * std::cos(W * s) + D * std::sin(W * s);
    worst = std::max({worst, std::abs(t.x_unwrapped - x), std::abs(sim->particles.x[0][1] - y)});
  }
  std::printf("epicycle: radial amplitude %.3f m, guiding centre y_g = %.3f m, max deviation %.3e m\n", amplitude, yg,
              worst);
  EXPECT_LT(worst, 1e-6 * amplitude);
}

TEST(HillFrame, JacobiConstantIsConserved) {
  // E_J = (vx^2 + vy^2)/2 - 3/2 W^2 y^2 is the conserved energy of Hill's linear equations.
  auto sim = make_sim(kRing);
  // Guiding centre y_g = -276 m, radial amplitude 32 m: the orbit stays inside the box.
  const double y0 = -250.0;
  sim->particles.add(0, 0, 2.0, kMass, Vec3(0, y0, 0), Vec3(1.5 * kOmega * y0 + 0.002, 0.003, 0));
  sim->setup();
  auto jacobi = [&] {
    const auto& p = sim->particles;
    return 0.5 * p.v[0].squaredNorm() - 1.5 * kOmega * kOmega * p.x[0][1] * p.x[0][1];
  };
  const double j0 = jacobi();
  double worst = 0;
  const double T0 = 2 * std::numbers::pi / kOmega;
  while (sim->time < 10 * T0) {
    sim->step();
    worst = std::max(worst, std::abs(jacobi() / j0 - 1));
  }
  std::printf("Jacobi constant: max relative change %.3e over 10 orbits\n", worst);
  EXPECT_LT(worst, 1e-6);
}

TEST(HillFrame, FreeVerticalOscillationKeepsItsFrequencyAndAmplitude) {
  // 3D: z'' = -Omega_z^2 z, decoupled from the in-plane epicycle. Both forms, Omega_z = Omega0
  // (Saturn's tide) and 3 Omega0 (a ring mimicking self-gravity), over 50 orbits at dt = 0.5 s
  // (25x the ring case's): z(t) = z0 cos(Omega_z t) + (vz0 / Omega_z) sin(Omega_z t). Velocity
  // Verlet is symplectic: no amplitude drift, and a phase lag growing as t Omega_z^3 dt^2 / 24
  // (2e-6 rad after 50 orbits at 3 Omega0). The track must stay within 10 % above that
  // prediction, and the last orbit's peak at the amplitude (sampling: (W dt)^2 / 8 ~ 1e-8 low).
  for (const char* form : {"linear", "exact"})
    for (double ratio : {1.0, 3.0}) {
      auto sim = make_sim(kRing, {"domain.planar=false", "domain.lo=[-1000.0, -1000.0, -100.0]", "domain.hi=[1000.0, 1000.0, 100.0]", std::string("hill.form=\"") + form + "\"",
                                  "hill.vertical_frequency=" + std::to_string(ratio), "time.dt=0.5"});
      const double z0 = 3.0, vz0 = 1e-3;  // on the shear flow at y = 0: no in-plane motion
      sim->particles.add(0, 0, 2.0, kMass, Vec3(0, 0, z0), Vec3(0, 0, vz0));
      sim->setup();
      const double W = ratio * kOmega, amplitude = std::hypot(z0, vz0 / W);
      const double T0 = 2 * std::numbers::pi / kOmega;
      double worst = 0, zmax = 0;
      while (sim->time < 50 * T0) {
        sim->step();
        const double t = sim->time, z = sim->particles.x[0][2];
        worst = std::max(worst, std::abs(z - (z0 * std::cos(W * t) + vz0 / W * std::sin(W * t))));
        if (sim->time > 49 * T0) zmax = std::max(zmax, std::abs(z));
      }
      std::printf("vertical %s, Omega_z = %.0f Omega0: amplitude %.4f m, max deviation %.2e m, last-orbit peak %.6f m\n",
                  form, ratio, amplitude, worst, zmax);
      const double dt = sim->dt, lag = sim->time * W * W * W * dt * dt / 24;
      EXPECT_LT(worst, (1.1 * lag + 1e-9) * amplitude) << form << " " << ratio;
      EXPECT_NEAR(zmax, amplitude, 1e-7 * amplitude) << form << " " << ratio;
    }
}

// The energy guard stays on in driven scenes by counting what the frame, the moonlet and the
// shear put in. Its pieces against independent expectations, then the guard itself.
// kRing without its [hill] table: for scenes without the frame.
std::string without_frame() {
  std::string t = kRing;
  const std::string hill = "[hill]\nform = \"linear\"\n";
  t.erase(t.find(hill), hill.size());
  return t;
}

double total_potential(const Simulation& sim) {
  double u = 0;
  for (const auto& m : sim.modules) u += m->potential_energy(sim);
  return u;
}

TEST(EnergyBookkeeping, FramePotentialsAndShearWorkBalanceTheKineticEnergy) {
  // A free epicycle (3D, vertical tide at 2 Omega0) conserves KE + U_hill (the Jacobi energy).
  {
    auto sim = make_sim(kRing, {"domain.planar=false", "domain.lo=[-1000.0, -1000.0, -100.0]",
                                "domain.hi=[1000.0, 1000.0, 100.0]", "hill.vertical_frequency=2.0"});
    sim->particles.add(0, 0, 2.0, kMass, Vec3(0, -250.0, 7.0), Vec3(1.5 * kOmega * -250.0 + 0.002, 0.003, 0.001));
    sim->setup();
    const double e0 = sim->kinetic_energy() + total_potential(*sim);
    double worst = 0;
    for (int s = 0; s < 50000; ++s) {
      sim->step();
      worst = std::max(worst, std::abs(sim->kinetic_energy() + total_potential(*sim) - e0));
    }
    EXPECT_LT(worst, 1e-6 * std::abs(e0)) << "Jacobi energy";
  }
  // Falling from rest onto the moonlet (no frame): KE + U_moonlet is conserved until contact.
  {
    auto sim = make_sim(without_frame(), {"modules=[\"contact\", \"moonlet\"]", "moonlet.mass=1.27e10",
                                          "moonlet.radius=150.0", "domain.boundary=[\"periodic\", \"periodic\", \"periodic\"]"});
    sim->particles.add(0, 0, 2.0, kMass, Vec3(400.0, 300.0, 0), Vec3::Zero());
    sim->setup();
    const double e0 = sim->kinetic_energy() + total_potential(*sim);
    while (sim->particles.x[0].norm() > 200.0) sim->step();
    EXPECT_GT(sim->kinetic_energy(), 1e-3 * std::abs(e0));  // it really fell
    EXPECT_NEAR(sim->kinetic_energy() + total_potential(*sim), e0, 1e-6 * std::abs(e0)) << "moonlet potential";
  }
  // Crossing the sheared boundary: the velocity jump changes KE by exactly the shear's work.
  {
    auto sim = make_sim(without_frame(), {"modules=[\"contact\"]", "domain.shear_rate=0.0001"});
    sim->particles.add(0, 0, 2.0, kMass, Vec3(0, 990.0, 0), Vec3(0.01, 0.3, 0));
    sim->particles.add(1, 0, 2.0, kMass, Vec3(100, -990.0, 0), Vec3(-0.02, -0.4, 0));
    sim->setup();
    const double ke0 = sim->kinetic_energy();
    for (int s = 0; s < 100; ++s) sim->step();
    sim->rebuild();  // migration applies the jumps
    EXPECT_GE(sim->halo.shear_crossings, 2);
    EXPECT_NEAR(sim->kinetic_energy() - ke0, sim->halo.shear_energy, 1e-12 * ke0);
    EXPECT_GT(std::abs(sim->halo.shear_energy), 1e-3 * ke0);
  }
}

TEST(EnergyBookkeeping, GuardStopsEnergyFromNowhereInADrivenRing) {
  // A ring patch with frame, moonlet and shear, where the guard used to be off: a particle
  // suddenly 1,000x faster (what an unstable contact looks like) must stop the run within 100
  // steps, while the undisturbed run goes on.
  for (bool kick : {false, true}) {
    auto sim = make_sim(kRing, {"modules=[\"contact\", \"hill\", \"moonlet\"]", "moonlet.mass=1.27e10",
                                "moonlet.radius=150.0", "particles.init=\"random\"", "particles.count=400",
                                "particles.shear_flow=true", "particles.dispersion=0.01", "guards.max_step=1e6"});
    sim->setup();
    bool stopped = false;
    try {
      for (int s = 0; s < 400; ++s) {
        if (kick && s == 150) sim->particles.v[0] *= 1000.0;
        sim->step();
      }
    } catch (const GuardError& e) {
      stopped = std::string(e.what()).find("energy conservation allows") != std::string::npos;
      EXPECT_GE(sim->step_count, 150);
      EXPECT_LE(sim->step_count, 252);
    }
    EXPECT_EQ(stopped, kick) << (kick ? "kicked" : "undisturbed");
  }
}

TEST(HillFrame, ForcesCancelAtTheLagrangePoints) {
  // At rest at (0, +-r_H), r_H = (G M_M / (3 W^2))^(1/3), the tidal pull 3 W^2 r_H balances
  // the moonlet's gravity G M_M / r_H^2 (and the Coriolis force vanishes).
  const double gm = kGravitationalConstant * 1.27e10;
  const double rh = std::cbrt(gm / (3 * kOmega * kOmega));
  EXPECT_NEAR(rh, 1.17e8 * std::cbrt(1.27e10 / (3 * 5.68e26)), 1e-9 * rh);  // spec: 228.5 m
  EXPECT_NEAR(rh, 228.5, 0.1);
  for (const char* form : {"linear", "exact"}) {
    auto sim = make_sim(kRing, {"modules=[\"contact\", \"hill\", \"moonlet\"]", "moonlet.mass=1.27e10", "moonlet.radius=150.0",
                                std::string("hill.form=\"") + form + "\""});
    sim->particles.add(0, 0, 2.0, kMass, Vec3(0, rh, 0), Vec3(0, 0, 0));
    sim->particles.add(1, 0, 2.0, kMass, Vec3(0, -rh, 0), Vec3(0, 0, 0));
    sim->setup();  // evaluates F(0)
    const double scale = kMass * 3 * kOmega * kOmega * rh;  // size of each cancelling term
    for (int i = 0; i < 2; ++i) {
      const double residual = sim->particles.f[i].norm() / scale;
      std::printf("%s form: residual force at L%d = %.3e of the tidal term\n", form, i + 1, residual);
      // linear: exact cancellation up to round-off; exact: the Hill approximation itself is
      // off by O(r_H / r0) = 2e-6 (the octupole term of Saturn's tide).
      EXPECT_LT(residual, std::string(form) == "linear" ? 1e-12 : 1e-5);
    }
  }
}

TEST(HillFrame, ExactMinusLinearIsTheSecondOrderTide) {
  // Expanding G M_S / r^3 (r from Saturn, G M_S = W^2 r0^3) to second order in (x, y, z) / r0:
  //   exact - linear = W^2 / r0 (3 x y,  1.5 x^2 - 3 y^2 + 1.5 z^2,  3 y z)  + O(W^2 d^3 / r0^2),
  // an independent check of both forms. The remainder is ~d / r0 ~ 1e-5 of that term; round-off
  // in the exact form is ~1e-16 of W^2 r0 = 2.8 m/s^2, far below the ~1e-10 m/s^2 terms here.
  HillFrame linear(config_from(kRing, {"domain.planar=false", "domain.lo=[-1000.0, -1000.0, -100.0]",
                                       "domain.hi=[1000.0, 1000.0, 100.0]"})),
      exact(config_from(kRing, {"hill.form=\"exact\"", "domain.planar=false", "domain.lo=[-1000.0, -1000.0, -100.0]",
                                "domain.hi=[1000.0, 1000.0, 100.0]"}));
  const double r0 = 1.17e8, W2 = kOmega * kOmega;
  for (const Vec3& x : {Vec3(250.0, -900.0, 0.0), Vec3(-700.0, 100.0, 30.0), Vec3(600.0, 500.0, -80.0), Vec3(900.0, 10.0, 5.0)}) {
    const Vec3 d = exact.acceleration(x) - linear.acceleration(x);
    const Vec3 second = W2 / r0 *
                        Vec3(3 * x[0] * x[1], 1.5 * x[0] * x[0] - 3 * x[1] * x[1] + 1.5 * x[2] * x[2], 3 * x[1] * x[2]);
    const double scale = W2 * x.squaredNorm() / r0;
    EXPECT_LT((d - second).norm(), 1e-4 * scale + 1e-14) << "at " << x.transpose();
    EXPECT_GT(second.norm(), 0.3 * scale);  // the term is really there
  }
}

TEST(Moonlet, GravityIsFiniteInsideAndExactOutside) {
  Moonlet m(config_from(kRing, {"modules=[\"contact\", \"hill\", \"moonlet\"]", "moonlet.mass=1.27e10",
                                "moonlet.radius=150.0"}),
            1.0);
  const double gm = kGravitationalConstant * 1.27e10;
  EXPECT_NEAR(m.gravity(Vec3(300, 0, 0))[0], -gm / (300.0 * 300.0), 1e-15);
  EXPECT_EQ(m.gravity(Vec3(0, 0, 0)).norm(), 0.0);
  EXPECT_NEAR(m.gravity(Vec3(75, 0, 0))[0], -gm * 75 / std::pow(150.0, 3), 1e-15);
}
