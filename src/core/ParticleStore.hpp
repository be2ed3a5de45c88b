#pragma once
// All particle data of one rank as structure-of-arrays. Entries [0, nlocal) are the particles
// this rank owns; [nlocal, size()) are ghosts (read-only copies of other ranks' particles or
// periodic images), rebuilt at every neighbour-list rebuild. One owner, no hidden copies:
// modules read and write these arrays directly.
//
// Rotation arrays (omega, torque, inv_inertia) exist only when the scene has friction; a
// frictionless scene never allocates them.
#include <cstdint>
#include <vector>

#include "core/Vec3.hpp"

namespace cassini {

struct ParticleStore {
  bool rotation = false;  // fixed at start: true iff some species has friction
  int walls = 0;          // number of wall planes (one tangential history slot each)
  bool impacts = false;   // fixed at start: true iff some restitution is set per impact (Bridges)
  bool rolling = false;   // fixed at start: true iff some pair resists rolling (needs rotation)

  std::size_t nlocal = 0;

  // owned and ghost
  std::vector<std::int64_t> id;
  std::vector<std::int32_t> species;
  std::vector<double> radius, mass, inv_mass;
  std::vector<Vec3> x, v;
  std::vector<Vec3> omega;  // rotation only

  // owned only (ghost slots exist but are unused)
  std::vector<Vec3> f;
  std::vector<Vec3> torque;           // rotation only
  std::vector<double> inv_inertia;    // rotation only
  std::vector<Vec3> x_build;          // position at the last neighbour-list build
  std::vector<Vec3> wall_xi;          // rotation only: tangential spring per (particle, wall)
  std::vector<double> wall_impact;    // impacts only: impact normal speed per (particle, wall), 0: none
  std::vector<Vec3> wall_roll;        // rolling only: rolling-resistance torque spring per (particle, wall)
  // The integrator's mode of the particle, carried through migration (multi-rate: on the
  // free epicycle or on contact steps; see MultiRateHill). 0 for the plain integrator.
  std::vector<std::uint8_t> mode;

  std::size_t size() const { return id.size(); }
  std::size_t nghost() const { return size() - nlocal; }

  void resize(std::size_t n);  // keeps [0, min(n, size)) intact
  void add(std::int64_t pid, int sp, double a, double m, const Vec3& pos, const Vec3& vel);
  void copy(std::size_t from, std::size_t to);  // every field
  // Reorders owned particles: new slot k takes old slot order[k]. Ghosts are dropped.
  void permute_local(const std::vector<std::size_t>& order);

  // Number of doubles that describe one owned particle when it migrates (see pack/unpack).
  std::size_t packed_size() const;
  void pack(std::size_t i, std::vector<double>& buf) const;
  // Appends an owned particle from buf at offset; returns the new offset.
  std::size_t unpack(const std::vector<double>& buf, std::size_t offset);
};

}  // namespace cassini
