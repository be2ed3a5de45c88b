#pragma once
// One particle against one point of a wall: what every wall module (plane walls, the channel's
// faces and edges, the moonlet's surface) does once its geometry has found the point. Written
// once here, so the walls share the contact's life cycle: springs that relax when the particle
// lets go, the exact scheme's exit step, the Bridges impact speed, torque and overlap.
// The law is the particle's own species law against an immovable wall
// (LinearSpringDashpot::wall_force).
#include <algorithm>
#include <cstdint>
#include <string>

#include "core/ParticleStore.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"

namespace cassini {

// A wall module's history with its particles, as the module's own per-particle columns
// (owned particles only; they migrate, and snapshots and restarts carry them): for each of its
// `points` wall points (planes, channel faces and edges, the moonlet's surface) the tangential
// spring (`<name>_xi`, scenes with friction), the Bridges impact speed (`<name>_impact`) and the
// rolling-resistance torque spring (`<name>_roll`). Snapshots written before the wall modules
// owned their columns kept every module's springs side by side in wall_xi, wall_impact and
// wall_roll, in the order the modules were made: each column names its share there
// (FormerColumn), which a restart from such a snapshot reads.
class WallHistory {
 public:
  struct Springs {
    Vec3 xi = Vec3::Zero(), roll = Vec3::Zero();
    double impact = 0;
  };

  WallHistory() = default;
  WallHistory(ParticleStore& p, const std::string& name, int points, const LinearSpringDashpot& law) {
    auto declare = [&](const std::string& part, bool needed, int per, const char* unit) {
      if (!needed || points == 0) return ParticleStore::kNoColumn;
      // This module's share of the former shared column: after the wall modules made before it.
      const std::string former = "wall_" + part;
      int offset = 0;
      for (const auto& c : p.module_columns)
        if (c.former.name == former) offset += c.width;
      return p.declare(name + "_" + part, per * points, ParticleStore::Ghosts::none, unit, {former, offset});
    };
    xi_ = declare("xi", law.friction(), 3, "m");
    impact_ = declare("impact", law.velocity_dependent(), 1, "m s-1");
    roll_ = declare("roll", law.rolling(), 3, "m");
  }
  Springs get(const ParticleStore& p, std::size_t i, int point) const {
    Springs s;
    if (xi_ != ParticleStore::kNoColumn) s.xi = Vec3(p.column(xi_, i) + 3 * point);
    if (impact_ != ParticleStore::kNoColumn) s.impact = p.column(impact_, i)[point];
    if (roll_ != ParticleStore::kNoColumn) s.roll = Vec3(p.column(roll_, i) + 3 * point);
    return s;
  }
  void set(ParticleStore& p, std::size_t i, int point, const Springs& s) const {
    if (xi_ != ParticleStore::kNoColumn) std::copy_n(s.xi.data(), 3, p.column(xi_, i) + 3 * point);
    if (impact_ != ParticleStore::kNoColumn) p.column(impact_, i)[point] = s.impact;
    if (roll_ != ParticleStore::kNoColumn) std::copy_n(s.roll.data(), 3, p.column(roll_, i) + 3 * point);
  }
  // Apart from the wall: a new contact starts unloaded (the impact speed stays until the exact
  // scheme's exit step is past: wall_contact).
  void relax(ParticleStore& p, std::size_t i, int point) const {
    if (xi_ != ParticleStore::kNoColumn) std::fill_n(p.column(xi_, i) + 3 * point, 3, 0.0);
    if (roll_ != ParticleStore::kNoColumn) std::fill_n(p.column(roll_, i) + 3 * point, 3, 0.0);
  }
  // Far from the wall: nothing of the contact is left.
  void forget(ParticleStore& p, std::size_t i, int point) const {
    relax(p, i, point);
    if (impact_ != ParticleStore::kNoColumn) p.column(impact_, i)[point] = 0;
  }
  bool impacts() const { return impact_ != ParticleStore::kNoColumn; }
  bool rolling() const { return roll_ != ParticleStore::kNoColumn; }

 private:
  std::size_t xi_ = ParticleStore::kNoColumn, impact_ = ParticleStore::kNoColumn, roll_ = ParticleStore::kNoColumn;
};

// Adds the wall's force (and torque) on particle i to p.f (p.torque) for a point of the wall at
// overlap delta along n (unit, from the wall to the centre); the exact scheme's end-of-step move
// goes into `move`. A particle that neither touches now nor touched a step ago gets nothing,
// and its springs and impact speed are forgotten. Returns true when it touches now.
// wall_radius: the surface's radius of curvature (the moonlet); 0 for a flat wall. limit: the
// scene's DampingLimit (off in most scenes): the contact's load and its dashpots' scale.
// advance: false for the forces of t = 0 (Simulation::initial_forces), which move no spring.
inline bool wall_contact(const LinearSpringDashpot& law, ParticleStore& p, std::size_t i, const Vec3& n, double delta,
                         const WallHistory& history, int point, Vec3& move, double wall_radius,
                         const DampingLimit& limit, bool advance = true) {
  if (delta <= 0) {  // apart now: a new contact starts unloaded
    // The exact scheme's exit step: touching a step ago (delta + v_n dt > 0), parted now.
    if (!law.exact() || delta + p.v[i].dot(n) * law.dt() <= 0) {
      history.forget(p, i, point);
      return false;
    }
    history.relax(p, i, point);
  }
  WallHistory::Springs s = history.get(p, i, point);
  Vec3 torque;
  double shift = 0;
  const bool touching = delta > 0;
  LinearSpringDashpot::Stability load;
  const bool limit_it = limit.on() && touching;
  p.f[i] += law.wall_force(p, i, n, delta, touching && law.friction() ? &s.xi : nullptr, torque, advance, &shift,
                           history.impacts() ? &s.impact : nullptr, touching && history.rolling() ? &s.roll : nullptr,
                           wall_radius, limit_it ? limit.scale(p, i) : 1.0, limit_it ? &load : nullptr);
  history.set(p, i, point, s);
  if (limit_it) limit.add(p, i, load.K, load.G, DampingLimit::weight(p.mass[i], 0));
  move += shift * n;
  if (touching && law.friction()) p.torque[i] += torque;
  return touching;
}

// The force of a touching wall point as the contact stands, for stress output (snapshots,
// cassini-cg): the step already advanced the springs, so they are read, not moved.
inline Vec3 wall_contact_force(const LinearSpringDashpot& law, const ParticleStore& p, std::size_t i, const Vec3& n,
                               double delta, const WallHistory& history, int point, double wall_radius = 0) {
  WallHistory::Springs s = history.get(p, i, point);
  Vec3 torque;
  return law.wall_force(p, i, n, delta, law.friction() ? &s.xi : nullptr, torque, false, nullptr, &s.impact, &s.roll,
                        wall_radius);
}

// The elastic energy of a touching wall point (observables): its normal, tangential and
// rolling springs (LinearSpringDashpot::spring_energy).
inline double wall_contact_energy(const LinearSpringDashpot& law, const ParticleStore& p, std::size_t i, const Vec3& n,
                                  double delta, const WallHistory& history, int point, double wall_radius = 0) {
  const WallHistory::Springs s = history.get(p, i, point);
  return law.wall_spring_energy(p, i, n, delta, law.friction() ? &s.xi : nullptr,
                                history.impacts() ? &s.impact : nullptr, history.rolling() ? &s.roll : nullptr,
                                wall_radius);
}

// The deepest overlap a wall module saw in its last force evaluation (Module::max_overlap_fraction).
struct DeepestOverlap {
  double fraction = 0;
  std::int64_t id = -1;
  void see(double delta, double radius, std::int64_t particle) {
    if (delta / radius > fraction) {
      fraction = delta / radius;
      id = particle;
    }
  }
};

}  // namespace cassini
