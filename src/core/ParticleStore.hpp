#pragma once
// All particle data of one rank as structure-of-arrays. Entries [0, nlocal) are the particles
// this rank owns; [nlocal, size()) are ghosts (read-only copies of other ranks' particles or
// periodic images), rebuilt at every neighbour-list rebuild. One owner, no hidden copies:
// modules read and write these arrays directly.
//
// Rotation arrays (omega, torque, inv_inertia) exist only when the scene has friction; a
// frictionless scene never allocates them.
#include <cstdint>
#include <string>
#include <vector>

#include "core/Vec3.hpp"

namespace cassini {

// Where a snapshot from before a module's column existed kept its values: the column's width
// in doubles from `offset` in each row of particles/grains/<name> (no name: such a snapshot
// gives zeros).
struct FormerColumn {
  std::string name;
  int offset = 0;
};

struct ParticleStore {
  bool rotation = false;  // fixed at start: true iff some species has friction
  bool copies = false;    // fixed at start: true under modified Lees-Edwards boundaries

  std::size_t nlocal = 0;

  // owned and ghost
  std::vector<std::int64_t> id;
  std::vector<std::int32_t> species;
  std::vector<double> radius, mass, inv_mass;
  std::vector<Vec3> x, v;
  std::vector<Vec3> omega;  // rotation only

  // owned only: no ghost slots (resize_ghosts)
  std::vector<Vec3> f;
  std::vector<Vec3> torque;           // rotation only
  std::vector<double> inv_inertia;    // rotation only
  std::vector<Vec3> x_build;          // position at the last neighbour-list build
  // Modified Lees-Edwards boundaries only: the copy of the box the particle lives in, 0 = LE1
  // (the main box, with the moonlet), 1 = LE2 (the moonlet-free feed). Particles of different
  // copies never touch; ghosts carry it.
  std::vector<std::uint8_t> le_copy;

  // Per-particle values a module declares for itself (declare(), when the module is made):
  // `width` doubles per particle in `data`. They migrate with their particle, go into
  // snapshots as particles/grains/<name> and come back on a restart. Zero for a new particle.
  // Ghost slots hold the owner's values (`carry`, refreshed every step), zeros (`zero`), or do
  // not exist (`none`: values only an owned particle has, like its wall springs).
  enum class Ghosts { carry, zero, none };
  struct ModuleColumn {
    std::string name;
    int width;
    Ghosts ghosts;
    std::string unit;  // in snapshots ("": none recorded)
    FormerColumn former;
    std::vector<double> data;
    bool carried() const { return ghosts == Ghosts::carry; }
  };
  std::vector<ModuleColumn> module_columns;
  // Returns the column's index in module_columns. Declared before any particle exists.
  std::size_t declare(const std::string& name, int width, Ghosts ghosts, const std::string& unit = "",
                      const FormerColumn& former = {});
  // The index of a declared column, or kNoColumn (for columns several modules share).
  static constexpr std::size_t kNoColumn = static_cast<std::size_t>(-1);
  std::size_t find_column(const std::string& name) const {
    for (std::size_t c = 0; c < module_columns.size(); ++c)
      if (module_columns[c].name == name) return c;
    return kNoColumn;
  }
  double* column(std::size_t c, std::size_t i) { return &module_columns[c].data[i * module_columns[c].width]; }
  const double* column(std::size_t c, std::size_t i) const { return &module_columns[c].data[i * module_columns[c].width]; }
  int ghost_column_width() const;  // doubles per ghost of the carried columns

  std::size_t size() const { return id.size(); }
  std::size_t nghost() const { return size() - nlocal; }

  void resize(std::size_t n);  // keeps [0, min(n, size)) intact; new entries are zero
  // nlocal owned particles and n ghosts: the owned-only columns keep nlocal entries (a gas's
  // ghosts are a sixth of its particles on one rank, more on several: 80 B each with friction).
  void resize_ghosts(std::size_t n);
  void add(std::int64_t pid, int sp, double a, double m, const Vec3& pos, const Vec3& vel);
  void copy(std::size_t from, std::size_t to);  // every field
  // Reorders owned particles: new slot k takes old slot order[k]. Ghosts are dropped.
  void permute_local(const std::vector<std::size_t>& order);

  // Number of doubles that describe one owned particle when it migrates (see pack/unpack).
  std::size_t packed_size() const;
  void pack(std::size_t i, std::vector<double>& buf) const;
  // Appends an owned particle from buf at offset; returns the new offset.
  std::size_t unpack(const std::vector<double>& buf, std::size_t offset);

  // Every per-particle array once: visit(array, entries per particle, migrates, ghosts). resize,
  // copy, reordering and migration all walk this list, so a new column is one line here (ghosts
  // carry only what forces read: HaloExchange::build_ghosts; the others have no ghost slots).
  // Columns that do not migrate are derived from others (unpack recomputes them).
  template <class Visit>
  void for_each_column(Visit&& visit) { columns(*this, visit); }
  template <class Visit>
  void for_each_column(Visit&& visit) const { columns(*this, visit); }

 private:
  template <class Self, class Visit>
  static void columns(Self& p, Visit& visit) {
    visit(p.id, 1, true, true);
    visit(p.species, 1, true, true);
    visit(p.radius, 1, true, true);
    visit(p.mass, 1, true, true);
    visit(p.inv_mass, 1, false, true);
    visit(p.x, 1, true, true);
    visit(p.v, 1, true, true);
    visit(p.x_build, 1, true, false);
    visit(p.f, 1, true, false);  // after a rebuild at the end of a step the next kick needs F(t)
    if (p.rotation) {
      visit(p.omega, 1, true, true);
      visit(p.torque, 1, true, false);
      visit(p.inv_inertia, 1, false, false);
    }
    if (p.copies) visit(p.le_copy, 1, true, true);
    for (auto& c : p.module_columns) visit(c.data, c.width, true, c.ghosts != Ghosts::none);
  }
};

}  // namespace cassini
