#pragma once
// One particle against one point of a wall: what every wall module (plane walls, the channel's
// faces and edges, the moonlet's surface) does once its geometry has found the point. Written
// once here, so the walls share the contact's life cycle: springs that relax when the particle
// lets go, the exact scheme's exit step, the Bridges impact speed, torque and overlap.
// The law is the particle's own species law against an immovable wall
// (LinearSpringDashpot::wall_force).
#include <cstdint>

#include "core/ParticleStore.hpp"
#include "physics/contact/DampingLimit.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"

namespace cassini {

// A particle's history with one wall, in the wall-spring columns (ParticleStore::walls slots):
// the tangential spring (friction), the impact speed (Bridges), the torque spring (rolling).
struct WallSprings {
  Vec3* xi = nullptr;
  double* impact = nullptr;
  Vec3* roll = nullptr;
  // Apart from the wall: a new contact starts unloaded (the impact speed stays until the exact
  // scheme's exit step is past: wall_contact).
  void relax() const {
    if (xi) xi->setZero();
    if (roll) roll->setZero();
  }
};

inline WallSprings wall_springs(ParticleStore& p, bool friction, std::size_t i, int slot) {
  const std::size_t k = i * p.walls + slot;
  return {friction ? &p.wall_xi[k] : nullptr, p.impacts ? &p.wall_impact[k] : nullptr,
          p.rolling ? &p.wall_roll[k] : nullptr};
}

// Adds the wall's force (and torque) on particle i to p.f (p.torque) for a point of the wall at
// overlap delta along n (unit, from the wall to the centre); the exact scheme's end-of-step move
// goes into `move`. A particle that neither touches now nor touched a step ago gets nothing,
// and its springs and impact speed are forgotten. Returns true when it touches now.
// wall_radius: the surface's radius of curvature (the moonlet); 0 for a flat wall. limit: the
// scene's DampingLimit (off in most scenes): the contact's load and its dashpots' scale.
// advance: false for the forces of t = 0 (Simulation::initial_forces), which move no spring.
inline bool wall_contact(const LinearSpringDashpot& law, ParticleStore& p, std::size_t i, const Vec3& n, double delta,
                         const WallSprings& s, Vec3& move, double wall_radius, const DampingLimit& limit,
                         bool advance = true) {
  if (delta <= 0) {  // apart now: a new contact starts unloaded
    s.relax();
    // The exact scheme's exit step: touching a step ago (delta + v_n dt > 0), parted now.
    if (!law.exact() || delta + p.v[i].dot(n) * law.dt() <= 0) {
      if (s.impact) *s.impact = 0;
      return false;
    }
  }
  Vec3 torque;
  double shift = 0;
  const bool touching = delta > 0;
  LinearSpringDashpot::Stability load;
  const bool limit_it = limit.on() && touching;
  p.f[i] += law.wall_force(p, i, n, delta, touching ? s.xi : nullptr, torque, advance, &shift, s.impact,
                           touching ? s.roll : nullptr, wall_radius, limit_it ? limit.scale(p, i) : 1.0,
                           limit_it ? &load : nullptr);
  if (limit_it) limit.add(p, i, load.K, load.G, DampingLimit::weight(p.mass[i], 0));
  move += shift * n;
  if (touching && law.friction()) p.torque[i] += torque;
  return touching;
}

// The force of a touching wall point as the contact stands, for stress output (snapshots,
// cassini-cg): the step already advanced the springs, so they are read, not moved.
inline Vec3 wall_contact_force(const LinearSpringDashpot& law, const ParticleStore& p, std::size_t i, const Vec3& n,
                               double delta, int slot, double wall_radius = 0) {
  const std::size_t k = i * p.walls + slot;
  Vec3 spring = law.friction() ? p.wall_xi[k] : Vec3::Zero(), torque;
  double impact = p.impacts ? p.wall_impact[k] : 0.0;
  Vec3 roll = p.rolling ? p.wall_roll[k] : Vec3::Zero();
  return law.wall_force(p, i, n, delta, law.friction() ? &spring : nullptr, torque, false, nullptr, &impact, &roll,
                        wall_radius);
}

// The elastic energy of a touching wall point (observables): its normal, tangential and
// rolling springs (LinearSpringDashpot::spring_energy).
inline double wall_contact_energy(const LinearSpringDashpot& law, const ParticleStore& p, std::size_t i, const Vec3& n,
                                  double delta, int slot, double wall_radius = 0) {
  const std::size_t k = i * p.walls + slot;
  return law.wall_spring_energy(p, i, n, delta, law.friction() ? &p.wall_xi[k] : nullptr,
                                p.impacts ? &p.wall_impact[k] : nullptr, p.rolling ? &p.wall_roll[k] : nullptr,
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
