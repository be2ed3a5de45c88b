#pragma once
// A short version of cases/clogging for tests: 6 D upstream, 3 D downstream, the inlet at
// -5 D. The flow cache goes to the build directory's tests/flow-cache.
#include <string>

namespace cassini::test {

inline std::string channel_case(const std::string& modules = R"(["contact", "channel", "drag", "inlet", "clog"])") {
  return "modules = " + modules + R"(
seed = 3
[domain]
lo = [-6.0e-4, -2.0e-4, 0.0]
hi = [3.0e-4, 2.0e-4, 1.0e-4]
boundary = ["open", "open", "wall"]
[channel]
neck_width = 1.0e-4
[[species]]
density = 1050.0
radius = 3.3333e-5
t_c = 1.0e-4
e = 0.1
mu_s = 0.5
[particles]
init = "none"
[flow]
mean_velocity = 1.47e-3
resolution = 6
solve_half_length = 3.0e-4
cache = "flow-cache"
[inlet]
x = -5.0e-4
[time]
end = 1.0
)";
}

}  // namespace cassini::test
