#include "physics/channel/Inlet.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/Initializer.hpp"
#include "core/Simulation.hpp"
#include "physics/channel/ChannelWalls.hpp"
#include "physics/channel/StokesDrag.hpp"

namespace cassini {

ModuleKind Inlet::kind() {
  auto make = [](Simulation& sim) { return std::make_unique<Inlet>(sim.cfg, sim.find<ChannelWalls>()->geometry()); };
  return {"inlet", {"channel"}, nullptr, make};
}

namespace {
struct Nearby {
  std::int64_t id;
  double x, y, z, a;
};
}  // namespace

void Inlet::setup(Simulation& sim) {
  every_ = std::max(1L, std::lround(cfg_.get<ChannelConfig>().inlet_every / sim.dt));
  std::int64_t local = -1;
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i) local = std::max(local, sim.particles.id[i]);
  MPI_Allreduce(&local, &next_id_, 1, MPI_INT64_T, MPI_MAX, sim.domain.comm);
  ++next_id_;
  // After a restart the counters go on; ids are never reused even if the newest bead has left.
  double v;
  if (sim.restart_value("inlet.next_id", v)) next_id_ = static_cast<std::int64_t>(v);
  if (sim.restart_value("inlet.inserted", v)) inserted_ = static_cast<long>(v);
  if (sim.restart_value("inlet.failed_top_ups", v)) short_ = static_cast<long>(v);
  sim.set_result("inserted", std::to_string(inserted_));
  if (sim.restored) return;
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  // A channel that starts full: beads are at the neck from the first step instead of arriving
  // as a front. (A random fill is not the flowing suspension's state either: docs/clogging.md.)
  if (ch.prefill) fill(sim, ch.inlet_x - 0.5 * ch.inlet_length, ch.neck_x1 - (ch.inlet_x - 0.5 * ch.inlet_length), 0, true);
  top_up(sim);
}

void Inlet::end_of_step(Simulation& sim) {
  if (sim.step_count % every_ == 0) top_up(sim);
}

void Inlet::top_up(Simulation& sim) {
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  full_ = fill(sim, ch.inlet_x - 0.5 * ch.inlet_length, ch.inlet_length, static_cast<std::uint64_t>(sim.step_count) + 1, false);
}

bool Inlet::fill(Simulation& sim, double x0, double length, std::uint64_t stream, bool patient) {
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  ParticleStore& p = sim.particles;
  const Species& sp = cfg_.species[cfg_.init_species];
  const double amax = sp.radius_max, x1 = x0 + length;
  const double z0 = cfg_.lo[2], z1 = cfg_.hi[2];

  // Particles that a candidate could touch, from every rank, in id order.
  std::vector<double> mine;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (p.x[i][0] > x0 - 2 * amax && p.x[i][0] < x1 + 2 * amax)
      mine.insert(mine.end(), {double(p.id[i]), p.x[i][0], p.x[i][1], p.x[i][2], p.radius[i]});
  int n = static_cast<int>(mine.size());
  std::vector<int> counts(sim.domain.nranks), displ(sim.domain.nranks, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, sim.domain.comm);
  for (int r = 1; r < sim.domain.nranks; ++r) displ[r] = displ[r - 1] + counts[r - 1];
  std::vector<double> all(displ.back() + counts.back());
  MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displ.data(), MPI_DOUBLE, sim.domain.comm);
  std::vector<Nearby> near;
  for (std::size_t k = 0; k < all.size(); k += 5)
    near.push_back({static_cast<std::int64_t>(all[k]), all[k + 1], all[k + 2], all[k + 3], all[k + 4]});
  std::sort(near.begin(), near.end(), [](const Nearby& a, const Nearby& b) { return a.id < b.id; });

  auto volume = [](double a) { return 4.0 / 3.0 * std::numbers::pi * a * a * a; };
  double present = 0;
  for (const auto& q : near)
    if (q.x >= x0 && q.x < x1) present += volume(q.a);
  // Zone volume: the channel's cross-section integrated over the zone (midpoint rule, 64
  // intervals per insertion-zone length).
  const int parts = std::max(1, static_cast<int>(std::ceil(length / ch.inlet_length - 1e-9)));
  double zone = 0;
  for (int k = 0; k < 64 * parts; ++k) {
    const double x = x0 + (k + 0.5) * length / (64 * parts);
    zone += (geo_.upper_y(x) - geo_.lower_y(x)) * length / (64 * parts);
  }
  zone *= z1 - z0;
  const double target = ch.inlet_fraction * zone;

  Random rng = Random::stream(cfg_.seed, stream);
  std::vector<Nearby> added;
  int attempts = 0;
  const bool full = present + 0.5 * volume(sp.radius_min) > target;
  while (attempts < ch.inlet_attempts) {
    const double a = sp.radius_min == sp.radius_max ? sp.radius_min
                                                    : sp.sizes.quantile(sp.radius_min, sp.radius_max, rng.uniform(0.0, 1.0));
    if (present + 0.5 * volume(a) > target) break;  // closest to the target
    ++attempts;
    const double x = rng.uniform(x0, x1);
    const double y = rng.uniform(geo_.lower_y(x) + a, geo_.upper_y(x) - a), z = rng.uniform(z0 + a, z1 - a);
    if (geo_.clearance(x, y) < a) continue;
    auto clear = [&](const Nearby& q) {
      const double dx = q.x - x, dy = q.y - y, dz = q.z - z;
      return dx * dx + dy * dy + dz * dz >= (q.a + a) * (q.a + a);
    };
    if (!std::all_of(near.begin(), near.end(), clear) || !std::all_of(added.begin(), added.end(), clear)) continue;
    added.push_back({next_id_++, x, y, z, a});
    present += volume(a);
    if (patient) attempts = 0;  // the prefill gives up only after inlet.attempts failures in a row
  }
  if (attempts >= ch.inlet_attempts) ++short_;
  if (added.empty()) return full;

  // The owner of each new particle adds it; then every rank rebuilds (collective).
  const StokesDrag* drag = sim.find<StokesDrag>();
  for (const auto& q : added) {
    const Vec3 x(q.x, q.y, q.z);
    if (sim.domain.owner(x) != sim.domain.rank) continue;
    const Vec3 v = drag ? drag->flow().velocity(x) : Vec3::Zero();
    sim.incoming.push_back({q.id, cfg_.init_species, q.a, sp.density * volume(q.a), x, v});
    added_energy_ += 0.5 * sp.density * volume(q.a) * v.squaredNorm();
  }
  inserted_ += static_cast<long>(added.size());
  sim.set_result("inserted", std::to_string(inserted_));
  sim.rebuild();
  return full;
}

}  // namespace cassini
