#include "physics/channel/ChannelWalls.hpp"

#include <bit>
#include <sstream>
#include <stdexcept>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/contact/WallContact.hpp"

namespace cassini {

ModuleKind ChannelWalls::kind() {
  auto read = [](CaseFile& f, Config& c) {
    read_channel_config(f, c);
    if (c.get<ContactSettings>().velocity_dependent_restitution())
      f.fail("species", "restitution = \"constant\" with module \"channel\" (the Bridges law is for ice rings: "
                        "particle pairs, plane walls and the moonlet)");
  };
  auto make = [](Simulation& sim) {
    auto walls = std::make_unique<ChannelWalls>(sim.cfg, sim.dt);
    walls->history_ = WallHistory(sim.particles, "channel_wall", walls->geometry().features(), walls->law_);
    if (walls->law_.damping_limit()) walls->limit_ = DampingLimit::attach(sim.particles);
    return walls;
  };
  return {"channel", {}, read, make};
}

ChannelWalls::ChannelWalls(const Config& cfg, double dt) : law_(cfg, dt), geometry_(cfg.get<ChannelConfig>()) {
  geometry_.index(cfg.max_radius(), cfg.lo[0], cfg.hi[0]);
  if (geometry_.features() > 64) throw std::runtime_error("channel: more than 64 wall faces and edges");
}

void ChannelWalls::post_rebuild(Simulation& sim) {
  ParticleStore& p = sim.particles;
  const bool fric = law_.friction();
  const int nf = geometry_.features();
  candidates_.assign(p.nlocal, 0);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    // Between rebuilds a particle moves less than skin / 2.
    candidates_[i] = geometry_.near_features(p.x[i][0], p.x[i][1], p.radius[i] + sim.skin);
    // A spring of a feature out of reach is zero already (it was not touched at the last
    // step); clearing it here keeps that true without a per-step sweep over every feature.
    if (fric || law_.rolling())
      for (int k = 0; k < nf; ++k)
        if (!(candidates_[i] >> k & 1)) history_.relax(p, i, k);
  }
}

void ChannelWalls::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (candidates_.size() != p.nlocal) post_rebuild(sim);
  const bool fric = law_.friction(), exact = law_.exact();
  const double dt = law_.dt();
  DeepestOverlap deepest;
  shifts_.clear();
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const std::uint64_t cand = candidates_[i];
    if (!cand) continue;
    const double a = p.radius[i];
    // The exact scheme also looks at faces the particle left during the step (it moved at
    // most |v| dt), to correct their exit.
    const double reach = exact ? a + p.v[i].norm() * dt : a;
    touching_.clear();
    for (std::uint64_t m = cand; m; m &= m - 1)  // ascending feature order, as contacts() gives
      geometry_.feature_contact(std::countr_zero(m), p.x[i][0], p.x[i][1], reach, touching_);
    // Springs of features no longer touched relax to zero (a new contact starts unloaded).
    if (fric) {
      std::uint64_t touched = 0;
      for (const auto& c : touching_)
        if (c.distance < a) touched |= std::uint64_t{1} << c.feature;
      for (std::uint64_t m = cand & ~touched; m; m &= m - 1)
        history_.relax(p, i, std::countr_zero(m));
    }
    Vec3 move = Vec3::Zero();
    for (const auto& c : touching_) {
      if (c.distance <= 0) {
        std::ostringstream os;
        os << "particle " << p.id[i] << " passed through a channel side wall at (" << p.x[i][0] << ", " << p.x[i][1] << ")";
        sim.raise_guard(os.str());
        continue;
      }
      const Vec3 n(c.nx, c.ny, 0);
      const double delta = a - c.distance;
      if (wall_contact(law_, p, i, n, delta, history_, c.feature, move, 0, limit_, !sim.stepping.initial_forces))
        deepest.see(delta, a, p.id[i]);
    }
    if (!move.isZero(0)) shifts_.add(i, move);
  }
  max_overlap_ = deepest.fraction;
  worst_id_ = deepest.id;
}

template <class Visit>
void ChannelWalls::for_each_touching(const ParticleStore& p, Visit&& visit) const {
  std::vector<WallContact> touching;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    touching.clear();
    geometry_.contacts(p.x[i][0], p.x[i][1], p.radius[i], touching);
    for (const auto& c : touching)
      if (c.distance > 0) visit(i, c);
  }
}

void ChannelWalls::wall_forces(const Simulation& sim, std::vector<WallForce>& out) const {
  const ParticleStore& p = sim.particles;
  for_each_touching(p, [&](std::size_t i, const WallContact& c) {
    const Vec3 n(c.nx, c.ny, 0);
    const Vec3 f = wall_contact_force(law_, p, i, n, p.radius[i] - c.distance, history_, c.feature);
    out.push_back({p.id[i], p.x[i] - c.distance * n, c.distance * n, f});
  });
}

void ChannelWalls::final_integrate(Simulation& sim) {
  shifts_.apply(sim.particles);
  const Simulation::TargetList t = sim.target_list();
  limit_.finish_step(sim.particles, t.list, t.count, sim.rebuilds);
}

double ChannelWalls::elastic_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  double e = 0;
  for_each_touching(p, [&](std::size_t i, const WallContact& c) {
    e += wall_contact_energy(law_, p, i, Vec3(c.nx, c.ny, 0), p.radius[i] - c.distance, history_, c.feature);
  });
  return e;
}

}  // namespace cassini
