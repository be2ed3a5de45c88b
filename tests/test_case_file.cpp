// Bad input must stop with an error naming the file, the key and what was expected.
#include <string>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "parallel/Decomposition.hpp"
#include "physics/contact/ContactSettings.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

const char* kGood = R"(
seed = 3
modules = ["contact"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.02, 0.02, 0.02]
[[species]]
name = "glass"
density = 2500.0
radius = 0.0005
t_c = 1.0e-5
e = 0.9
[particles]
init = "random"
count = 500
[time]
end = 1.0e-4
)";

// Returns the error message of reading kGood with the overrides ("" when it was accepted).
std::string error_of(const std::vector<std::string>& overrides, const std::string& text = kGood) {
  try {
    Config c = config_from(text, overrides);
    Simulation sim(c, MPI_COMM_SELF);
    sim.setup();  // placement errors (N that cannot fit) surface here
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

void expect_error(const std::vector<std::string>& overrides, const std::string& key, const std::string& expected) {
  const std::string msg = error_of(overrides);
  EXPECT_NE(msg.find("test.toml"), std::string::npos) << "no file name in: " << msg;
  EXPECT_NE(msg.find(key), std::string::npos) << "no key '" << key << "' in: " << msg;
  EXPECT_NE(msg.find(expected), std::string::npos) << "no '" << expected << "' in: " << msg;
}

}  // namespace

TEST(CaseFile, GoodCaseIsAccepted) { EXPECT_EQ(error_of({}), ""); }

TEST(CaseFile, ImpossibleValuesAreRefused) {
  expect_error({"species.0.radius=-1.0"}, "species[0].radius", "expected a positive number, got -1");
  expect_error({"species.0.e=1.5"}, "species[0].e", "(0, 1]");
  expect_error({"species.0.e=0.0"}, "species[0].e", "(0, 1]");
  expect_error({"species.0.density=0"}, "species[0].density", "positive");
  expect_error({"species.0.mu_s=0.2", "species.0.mu_d=0.5"}, "species[0].mu_d", "<= mu_s");
  expect_error({"domain.hi=[0.02, -1.0, 0.02]"}, "domain.hi", "larger than domain.lo");
  expect_error({"domain.boundary=[\"periodic\", \"sticky\", \"wall\"]"}, "domain.boundary", "\"periodic\", \"wall\" or \"open\"");
  expect_error({"domain.decomposition=\"cubes\""}, "domain.decomposition", "\"grid\"");
  expect_error({"domain.grid=[2, 1, 1]"}, "domain.grid", "unless domain.decomposition = \"grid\"");
  expect_error({"domain.decomposition=\"grid\"", "domain.grid=[2, 1]"}, "domain.grid", "three region counts");
  expect_error({"domain.decomposition=\"grid\"", "domain.grid=[0, 1, 1]"}, "domain.grid", "whole numbers >= 1");
}

TEST(CaseFile, GridShapeMustMatchTheRankCount) {
  // The rank count is known only when the decomposition is made: refused there, naming the key.
  auto config = config_from(kPair, {"domain.decomposition=\"grid\"", "domain.grid=[2, 2, 1]"});
  try {
    Decomposition dom(config, MPI_COMM_SELF);
    FAIL() << "a 2 x 2 grid accepted on one rank";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'domain.grid': 2 x 2 x 1 regions for 1 ranks"), std::string::npos) << e.what();
  }
}

TEST(CaseFile, LongTimeStepsNeedForceAndUnstableOnesAreRefused) {
  // Verlet: the restitution is badly wrong beyond t_c / 10; the exact scheme allows t_c / 5
  // (dense packings). kGood's t_c is 1e-5 s.
  const std::string verlet = "contact.scheme=\"verlet\"";
  expect_error({"time.dt=2.0e-6", verlet}, "time.dt", "t_c/10");
  expect_error({"time.n_c=5", verlet}, "time.n_c", "time.force = true");
  EXPECT_EQ(error_of({"time.dt=2.0e-6", "time.force=true", verlet}), "");
  EXPECT_EQ(error_of({"time.dt=2.0e-6"}), "");
  expect_error({"time.dt=3.0e-6"}, "time.dt", "t_c/5");
  expect_error({"time.n_c=4"}, "time.n_c", "time.force = true");
  EXPECT_EQ(error_of({"time.dt=3.0e-6", "time.force=true"}), "");
  // Beyond the stability bound of the scheme even force does not help.
  expect_error({"time.dt=7.0e-6", "time.force=true", verlet}, "time.dt", "unstable");
  expect_error({"time.dt=6.0e-6", "time.force=true"}, "time.dt", "unstable");
  expect_error({"contact.scheme=\"leapfrog\""}, "contact.scheme", "\"exact\" or \"verlet\"");
  expect_error({"contact.scheme=\"exact\"", "contact.clip_normal=true"}, "contact.scheme", "clip_normal");
}

TEST(CaseFile, WrongTypesAreRefused) {
  expect_error({"species.0.t_c=\"fast\""}, "species[0].t_c", "expected a number, got the string \"fast\"");
  expect_error({"particles.count=12.5"}, "particles.count", "an integer");
  expect_error({"domain.lo=[0.0, 0.0]"}, "domain.lo", "3 numbers");
  expect_error({"domain.planar=1"}, "domain.planar", "true or false");
}

TEST(CaseFile, UnknownKeysAndModulesAreRefused) {
  expect_error({"domain.bondary=1"}, "domain.bondary", "unknown key");
  expect_error({"modules=[\"contact\", \"magnetism\"]"}, "modules", "unknown module 'magnetism'");
  // The known names come from the registry: all of them, and in its (force) order.
  expect_error({"modules=[\"magnetism\"]"}, "modules",
               "{contact, lubrication, walls, channel, drag, inlet, clog, moonlet, hill, gravity, self-gravity}");
  expect_error({"modules=[\"contact\", \"drag\"]"}, "modules", "\"channel\" with \"drag\"");
  // A module reads only its own table, and only when listed.
  expect_error({"moonlet.mass=1.0"}, "moonlet.mass", "unknown key");
  expect_error({"time.long_step=1.0"}, "time.long_step", "multirate");
  expect_error({"time.integrator=\"leapfrog\""}, "time.integrator", "\"verlet\" or \"multirate\"");
  expect_error({"particles.init=\"poured\""}, "particles.init", "\"random\", \"lattice\"");
}

TEST(CaseFile, TheHillFrameNeedsTheKeplerianShear) {
  // Hill's equations carry the shear 1.5 Omega0; a Lees-Edwards boundary at another rate would
  // inject an inconsistent flow at every crossing, whatever the integrator.
  EXPECT_EQ(error_of({}, kPropellerPatch), "");
  const std::string msg = error_of({"domain.shear_rate=1.0e-4"}, kPropellerPatch);
  EXPECT_NE(msg.find("domain.shear_rate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1.5 Omega0"), std::string::npos) << msg;
  EXPECT_NE(msg.find("hill"), std::string::npos) << msg;
}

TEST(CaseFile, MultiRateNeedsTheKeplerianShear) {
  // Its free particles follow Hill's equations (shear 1.5 Omega0) and their drift bounds are
  // taken against the imposed flow: another shear rate would break the neighbour list's bound.
  const std::string multirate = "time.integrator=\"multirate\"";
  EXPECT_EQ(error_of({multirate}, kPropellerPatch), "");
  const std::string msg = error_of({multirate, "domain.shear_rate=1.0e-4"}, kPropellerPatch);
  EXPECT_NE(msg.find("domain.shear_rate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1.5 Omega0"), std::string::npos) << msg;
  // Nor without a sheared boundary: a particle riding the shear would drift unbounded.
  const std::string open = error_of({multirate, "domain.boundary=[\"periodic\", \"open\", \"periodic\"]",
                                     "particles.shear_flow=false"}, kPropellerPatch);
  EXPECT_NE(open.find("domain.boundary"), std::string::npos) << open;
  EXPECT_NE(open.find("lees_edwards"), std::string::npos) << open;
}

TEST(CaseFile, ParticlesThatCannotFitAreRefused) {
  // 40,000 spheres of radius 0.5 mm in 8 cm^3: volume fraction 2.6.
  expect_error({"particles.count=40000"}, "particles.count", "fraction");
  expect_error({"particles.init=\"lattice\"", "particles.count=40000"}, "particles.count", "lattice");
  EXPECT_EQ(error_of({"particles.init=\"lattice\"", "particles.count=8000"}), "");
}

TEST(CaseFile, BrokenTomlNamesFileAndLine) {
  const std::string msg = error_of({}, "[domain\nlo = [0,0,0]\n");
  EXPECT_NE(msg.find("test.toml:1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not valid TOML"), std::string::npos) << msg;
}

TEST(CaseFile, SetOverridesAnyKey) {
  const Config c = config_from(kGood, {"time.end=2.5", "species.0.e=0.25", "particles.velocity_sigma=3"});
  EXPECT_EQ(c.t_end, 2.5);
  EXPECT_EQ(c.get<ContactSettings>().species[0].e, 0.25);
  EXPECT_EQ(c.velocity_sigma, 3.0);
}
