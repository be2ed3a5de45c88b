#pragma once
// Small helpers to build a scene from an inline case text in tests.
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "io/ReadConfig.hpp"
#include "core/Simulation.hpp"

namespace cassini::test {

// Two 1 mm glass spheres in an empty periodic 10 cm box, no initial particles (tests add them):
// the scene of the binary-collision and single-contact tests.
inline const char* kPair = R"(
modules = ["contact"]
[domain]
lo = [-0.05, -0.05, -0.05]
hi = [0.05, 0.05, 0.05]
[[species]]
density = 2500.0
radius = 0.001
t_c = 1.0e-4
e = 0.5
[particles]
init = "none"
[time]
end = 1.0
)";

// A small propeller patch: Hill frame, moonlet, planar, Lees-Edwards (1,500 particles in 1 km^2).
inline const char* kPropellerPatch = R"(
seed = 3
modules = ["contact", "hill", "moonlet"]
[domain]
lo = [-500.0, -500.0, -10.0]
hi = [500.0, 500.0, 10.0]
boundary = ["periodic", "lees_edwards", "periodic"]
planar = true
[moonlet]
mass = 1.27e10
radius = 150.0
[[species]]
density = 500.0
radius = 2.0
t_c = 20.0
e = 0.25
[particles]
init = "random"
count = 1500
shear_flow = true
dispersion = 0.01
[time]
n_c = 50
end = 1.0e6
)";

// A self-gravitating 3D ring patch (200 m, 32 x 32 x 16 mesh), no particles placed: the
// self-gravity tests' scene.
inline const char* kSelfGravityPatch = R"(
seed = 11
modules = ["contact", "hill", "self-gravity"]
[domain]
lo = [-100.0, -100.0, -16.0]
hi = [100.0, 100.0, 16.0]
boundary = ["periodic", "lees_edwards", "open"]
[hill]
form = "linear"
saturn_mass = 5.68e26
orbit_radius = 1.3e8
[self_gravity]
grid = [32, 32, 16]
[[species]]
density = 400.0
radius = 1.0
t_c = 50.0
e = 0.5
[particles]
init = "none"
[time]
dt = 2.0
end = 1.0e6
)";

// The scene with the first species' constant e replaced by the Bridges law at v_c (m/s).
inline std::string with_bridges(std::string text, double v_c) {
  const auto at = text.find("\ne = ");
  if (at == std::string::npos) throw std::logic_error("with_bridges: the scene has no 'e = ' line");
  const auto end = text.find('\n', at + 1);
  char law[96];
  std::snprintf(law, sizeof law, "\nrestitution = \"bridges\"\nv_c = %.17g", v_c);
  return text.replace(at, end - at, law);
}

inline Config config_from(const std::string& text, const std::vector<std::string>& overrides = {}) {
  CaseFile cf = CaseFile::parse(text, "test.toml", overrides);
  return read_config(cf);
}

inline std::unique_ptr<Simulation> make_sim(const std::string& text, const std::vector<std::string>& overrides = {},
                                            MPI_Comm comm = MPI_COMM_WORLD) {
  return std::make_unique<Simulation>(config_from(text, overrides), comm);
}

// Particle 0 rolling along +x without slip under a limit torque decelerates uniformly until it
// stops at t_stop. Steps to 1.5 t_stop; returns the deceleration of v_x between 0.25 and 0.75
// t_stop (NaN if the run never got there) and records v_x - roll_speed() at 0.75 t_stop.
struct RollingToRest {
  double deceleration = std::numeric_limits<double>::quiet_NaN();
  double slip = std::numeric_limits<double>::quiet_NaN();  // v_x - the speed the spin gives
};
template <class RollSpeed>
RollingToRest roll_to_rest(Simulation& sim, double t_stop, RollSpeed roll_speed) {
  RollingToRest out;
  double v_a = 0, t_a = 0;
  while (sim.time < 1.5 * t_stop) {
    sim.step();
    if (t_a == 0 && sim.time > 0.25 * t_stop) { v_a = sim.particles.v[0][0]; t_a = sim.time; }
    if (t_a > 0 && sim.time > 0.75 * t_stop && sim.time - sim.dt <= 0.75 * t_stop) {
      out.deceleration = (v_a - sim.particles.v[0][0]) / (sim.time - t_a);
      out.slip = sim.particles.v[0][0] - roll_speed();
    }
  }
  return out;
}

// Particle i's vectors in a wall module's column (WallHistory: e.g. plane_wall_xi,
// plane_wall_roll), one per wall point; none where the scene does not declare it.
inline std::vector<Vec3> wall_vectors(const ParticleStore& p, const std::string& column, std::size_t i = 0) {
  const std::size_t c = p.find_column(column);
  std::vector<Vec3> out;
  if (c == ParticleStore::kNoColumn) return out;
  for (int k = 0; k < p.module_columns[c].width; k += 3) out.emplace_back(p.column(c, i) + k);
  return out;
}

// Every owned particle's state (x, v, omega; with `full` also f, torque, wall springs), keyed
// by id, gathered on rank 0 of the simulation's communicator (empty on other ranks).
using StateById = std::map<std::int64_t, std::vector<double>>;
inline StateById gather_state(const Simulation& sim, bool full = false) {
  const auto& p = sim.particles;
  // The wall modules' tangential springs (WallHistory's <module>_xi columns).
  std::vector<std::size_t> springs;
  for (std::size_t c = 0; c < p.module_columns.size() && full; ++c)
    if (p.module_columns[c].name.ends_with("_xi")) springs.push_back(c);
  int width = 1 + 9 + (full ? 6 : 0);
  for (const std::size_t c : springs) width += p.module_columns[c].width;
  std::vector<double> mine;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    mine.push_back(double(p.id[i]));
    const Vec3 w = p.rotation ? p.omega[i] : Vec3::Zero(), t = p.rotation ? p.torque[i] : Vec3::Zero();
    for (const Vec3* q : {&p.x[i], &p.v[i], &w}) mine.insert(mine.end(), q->data(), q->data() + 3);
    if (!full) continue;
    for (const Vec3* q : {&p.f[i], &t}) mine.insert(mine.end(), q->data(), q->data() + 3);
    for (const std::size_t c : springs) mine.insert(mine.end(), p.column(c, i), p.column(c, i) + p.module_columns[c].width);
  }
  int n = static_cast<int>(mine.size()), size = 0, rank = 0;
  MPI_Comm_size(sim.domain.comm, &size);
  MPI_Comm_rank(sim.domain.comm, &rank);
  std::vector<int> counts(size), displ(size);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, sim.domain.comm);
  int total = 0;
  for (int r = 0; r < size; ++r) { displ[r] = total; total += counts[r]; }
  std::vector<double> all(rank == 0 ? total : 0);
  MPI_Gatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displ.data(), MPI_DOUBLE, 0, sim.domain.comm);
  StateById out;
  for (std::size_t k = 0; k + width <= all.size(); k += width)
    out[std::int64_t(all[k])] = std::vector<double>(all.begin() + k + 1, all.begin() + k + width);
  return out;
}

// Number of particles whose state differs bitwise (-1 when the particle sets differ).
inline long differing(const StateById& a, const StateById& b) {
  if (a.size() != b.size()) return -1;
  long d = 0;
  for (const auto& [id, s] : a)
    if (!b.count(id) || b.at(id) != s) ++d;
  return d;
}

// Finds an owned particle by id on this rank (nullptr-like -1 when not here).
inline long local_index(const Simulation& sim, std::int64_t id) {
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i)
    if (sim.particles.id[i] == id) return static_cast<long>(i);
  return -1;
}

}  // namespace cassini::test
