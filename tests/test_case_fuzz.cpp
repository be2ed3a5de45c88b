// Fuzzed input: the case-file reader survives a generated corpus of broken files and --set
// strings (truncations, wrong types, huge numbers, unknown modules, byte flips): every input
// is either accepted or refused with a ConfigError that names the file; nothing else escapes.
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "TestScene.hpp"
#include "core/Initializer.hpp"

using namespace cassini;
using namespace cassini::test;

namespace {

const std::string kBase = R"(seed = 3
modules = ["contact", "gravity"]
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.02, 0.02, 0.02]
boundary = ["periodic", "periodic", "wall"]
slab_axis = "x"
[[species]]
name = "glass"
density = 2500.0
radius = 0.0005
t_c = 1.0e-5
e = 0.9
mu_s = 0.3
[particles]
init = "random"
count = 500
velocity_sigma = 0.1
[gravity]
g = [0.0, 0.0, -9.81]
[time]
n_c = 50
end = 1.0e-4
[output]
observe_every = 1.0e-5
)";

struct Outcome {
  long accepted = 0, refused = 0, escaped = 0;
  std::string first_escape, last_refusal;
};

void check(const std::string& text, const std::vector<std::string>& overrides, Outcome& o) {
  try {
    config_from(text, overrides);
    ++o.accepted;
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    o.last_refusal = msg;
    if (msg.find("test.toml") == std::string::npos && msg.find("--set") == std::string::npos) {
      ++o.escaped;
      if (o.first_escape.empty()) o.first_escape = "error without file name: " + msg;
    } else {
      ++o.refused;
    }
  } catch (const std::exception& e) {
    ++o.escaped;
    if (o.first_escape.empty()) o.first_escape = std::string("unexpected exception: ") + e.what() + "\n" + text;
  }
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

}  // namespace

TEST(CaseFuzz, TruncatedFiles) {
  Outcome o;
  for (std::size_t n = 0; n < kBase.size(); n += 3) check(kBase.substr(0, n), {}, o);
  std::printf("truncations: %ld accepted, %ld refused\n", o.accepted, o.refused);
  EXPECT_EQ(o.escaped, 0) << o.first_escape;
  EXPECT_GT(o.refused, 100);
}

TEST(CaseFuzz, EveryValueReplacedByWrongTypesAndExtremes) {
  const std::vector<std::string> values = {"\"text\"", "1e308", "-1e308", "0", "-1", "[]", "[1, 2]", "{}", "true",
                                           "9223372036854775807", "-9223372036854775808", "nan", "inf", "1979-05-27"};
  Outcome o;
  const auto lines = lines_of(kBase);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto eq = lines[i].find(" = ");
    if (eq == std::string::npos) continue;
    for (const auto& v : values) {
      auto copy = lines;
      copy[i] = lines[i].substr(0, eq) + " = " + v;
      check(join(copy), {}, o);
    }
  }
  std::printf("wrong values: %ld accepted, %ld refused\n", o.accepted, o.refused);
  EXPECT_EQ(o.escaped, 0) << o.first_escape;
  EXPECT_GT(o.refused, 200);
}

TEST(CaseFuzz, RandomByteFlipsAndInsertions) {
  Random rng(12345);
  const std::string alphabet = "[]{}=\".,#\n 0123456789eE+-abcxyz_";
  Outcome o;
  for (int k = 0; k < 3000; ++k) {
    std::string t = kBase;
    const int edits = 1 + static_cast<int>(rng.uniform() * 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t pos = static_cast<std::size_t>(rng.uniform() * t.size());
      const char c = alphabet[static_cast<std::size_t>(rng.uniform() * alphabet.size())];
      if (rng.uniform() < 0.5) t[pos] = c;
      else t.insert(pos, 1, c);
    }
    check(t, {}, o);
  }
  std::printf("byte flips: %ld accepted, %ld refused\n", o.accepted, o.refused);
  EXPECT_EQ(o.escaped, 0) << o.first_escape;
}

TEST(CaseFuzz, BrokenOverridesAndUnknownModules) {
  const std::vector<std::string> sets = {"a", "=", "=1", "time.end", "time.end=", "species.99.e=0.5", "species.0.e.x=1",
                                         "species.x.e=1", "domain.lo.0=1", "modules=[\"contact\", \"warp-drive\"]",
                                         "modules=\"contact\"", "modules=[1, 2]", "time=3", "particles.count=1e99",
                                         "particles.count=99999999999999999999", "species.0.radius=1e-300",
                                         "domain.hi=[1e308, 1e308, 1e308]", "time.n_c=0", "time.n_c=-5",
                                         "species.0.t_c=1e-300", "seed=-1", "gravity.g=[nan, 0, 0]"};
  Outcome o;
  for (const auto& s : sets) check(kBase, {s}, o);
  std::printf("overrides: %ld accepted, %ld refused\n", o.accepted, o.refused);
  EXPECT_EQ(o.escaped, 0) << o.first_escape;
  EXPECT_GT(o.refused, 15);
}

TEST(CaseFuzz, TheUnbrokenBaseIsAccepted) {
  Outcome o;
  check(kBase, {}, o);
  EXPECT_EQ(o.accepted, 1) << o.first_escape << o.last_refusal;
  check(kBase, {"species.0.radius=1e-6"}, o);
  EXPECT_EQ(o.accepted, 2);
}
