// An elastic, frictionless gas: total energy (kinetic + contact springs) and momentum.
#include <cmath>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "physics/contact/ContactForces.hpp"

using namespace cassini;
using namespace cassini::test;

TEST(ElasticGas, ConservesEnergyAndMomentum) {
  const char* text = R"(
seed = 11
modules = ["contact"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.012, 0.012, 0.012]
[[species]]
density = 2500.0
radius = 0.0005
t_c = 1.0e-5
e = 1.0
[particles]
init = "random"
volume_fraction = 0.3
velocity_sigma = 1.0
[time]
n_c = 50
end = 1.0
)";
  auto sim = make_sim(text);
  sim->setup();
  const double e0 = sim->kinetic_energy() + sim->elastic_energy();
  const Vec3 p0 = sim->momentum();
  double scale = 0;  // sum |m v|: the size of momentum round-off
  for (std::size_t i = 0; i < sim->particles.nlocal; ++i) scale += sim->particles.mass[i] * sim->particles.v[i].norm();
  double worst = 0;
  long collisions_seen = 0;
  for (int s = 1; s <= 10000; ++s) {
    sim->step();
    if (s % 50 == 0) {
      const double e = sim->kinetic_energy() + sim->elastic_energy();
      worst = std::max(worst, std::abs(e / e0 - 1));
      collisions_seen += sim->find<ContactForces>()->contacts();
    }
  }
  const double drift = std::abs((sim->kinetic_energy() + sim->elastic_energy()) / e0 - 1);
  std::printf("energy: max |E/E0 - 1| = %.3e, final %.3e; contacts sampled %ld\n", worst, drift, collisions_seen);
  ASSERT_GT(collisions_seen, 1000) << "the gas must actually collide for this test to mean anything";
  // Velocity Verlet is symplectic on the smooth part of the spring; the kink at contact onset
  // costs O((dt/t_c)^2) of a collision's energy at random, so the error stays at
  // ~ (pi/N_c)^2 ~ 4e-3 of the energy in contact at any time, a small part of E: 1e-3 bound.
  EXPECT_LT(worst, 1e-3);
  const Vec3 p = sim->momentum();
  EXPECT_LT((p - p0).norm(), 1e-13 * scale) << "momentum changes only by round-off (pair forces are exactly antisymmetric)";
}
