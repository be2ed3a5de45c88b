#pragma once
// Moving particles between ranks, and the ghost halo.
//
// Ghosts are made in one pass over the owned particles: for each periodic (or sheared) image
// of a particle near the box faces, every rank whose region (slab or cells), widened by the
// interaction range, holds the image receives a copy. This one rule covers the plain neighbour slab, periodic
// wrap-around, edges and corners, slabs thinner than the range, and the Lees-Edwards case in
// which the ranks facing a slab across the sheared boundary change as the offset grows.
// What was sent is remembered as (particle, image) pairs, so each step only positions and
// velocities are re-sent, with the image shift recomputed from the current shear offset.
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/PairHistory.hpp"
#include "core/ParticleStore.hpp"
#include "parallel/Decomposition.hpp"

namespace cassini {

class HaloExchange {
 public:
  HaloExchange(Decomposition& dom, double range) : dom_(dom), range_(range) {}

  // Wraps owned particles into the box (periodic and sheared axes) and sends every particle
  // to the rank owning its slab, with its contact history. Particles past an open boundary are
  // removed and counted in `removed`.
  void migrate(ParticleStore& p, PairHistory& history);
  // Rebuilds the ghost region from scratch (owned particles must be inside their slab).
  void build_ghosts(ParticleStore& p);
  // Refreshes ghost positions, velocities, spins and integrator modes from their owners.
  void update_ghosts(ParticleStore& p);
  // The same for the ghosts of `changed` owned particles only (indices below nlocal), in one
  // round of messages with the ranks this one exchanges ghosts with: each says which of its
  // particles changed, often none, so no collective is needed to agree whether any did. With
  // `sheared`, also every sheared image's position (its x shift follows the shear offset, which
  // moves every step): then, if no other owned particle changed since the last update, the
  // ghosts hold the same bits as update_ghosts() writes. The cost is that of the changed
  // particles' images and the sheared ones, where update_ghosts() rewrites every ghost: between
  // a multi-rate integrator's long steps a few dozen particles move, and the full rewrite was
  // a quarter of a ring's contact steps.
  void update_ghosts_of(ParticleStore& p, const std::vector<std::uint32_t>& changed, bool sheared = false);
  // For tests: every update_ghosts_of(..., sheared = true) rewrites every ghost instead.
  bool full_updates = false;

  std::int64_t removed = 0;
  std::int64_t removed_upper = 0;  // of those, through an upper face (an outlet downstream)
  double shear_momentum = 0;  // sum of m dv_x applied by Lees-Edwards crossings on this rank
  double shear_energy = 0;    // kinetic energy those velocity jumps added (the shear's work)
  std::int64_t shear_crossings = 0;  // particles wrapped through the sheared boundary here
  // Modified Lees-Edwards boundaries (Decomposition::fed_x), counts on this rank:
  //  - fed: LE2 particles that crossed x with the shear flow and were copied into LE1 (at its
  //    inflow face);
  //  - drained: LE1 particles that left through x with the flow (its outflow face), removed;
  //  - returned: LE1 particles that left against the flow (through the inflow face, possible
  //    near y = 0 where a particle's own velocity beats the flow), kept in LE1: they re-enter
  //    through the opposite (outflow) face, as in a periodic box. LE2 crossings against the flow
  //    make no clone. So against-flow traffic is LE1's own, as LE2's is LE2's, and LE1 without a
  //    moonlet is statistically LE2 at any velocity dispersion.
  std::int64_t fed = 0, drained = 0, returned = 0;
  std::int64_t next_id = -1;  // the next free particle id (the same on every rank; a snapshot keeps it)
  // Particles that enter LE1 (clones, returned ones) and would overlap LE1 material are taken
  // out again, as an inlet refuses an overlapping bead (Simulation::remove_stillborn, once the
  // new neighbour list shows the overlap): nothing there saw them coming. A clone taken out
  // counts here; a returned one counts as drained.
  std::int64_t stillborn = 0;
  // LE1 particles that wrapped through the sheared y boundary and landed on material they
  // could not see before (unseen_after_wrap), taken out as a returned one is
  // (Simulation::remove_stillborn): counted here and as drained.
  std::int64_t cornered = 0;
  // Whether ghost j was out of sight of owned LE1 particle i before i wrapped through y at this
  // rebuild. Across y, LE1's images repeat along x (each copy is a sheared box); across x LE1
  // has none (beyond its inflow face lie LE2's inflow images, beyond its outflow face nothing).
  // The two meet where an x face meets a y face. Out of sight were:
  //  - LE2's inflow images (j beyond an x face, not a sheared image): from across y, LE1's own
  //    images stood in their place;
  //  - images of LE1 particles near the opposite x face: taken back across y, i and j's owner
  //    are a box length apart (i was near one x face, the owner near the other), while across
  //    y they are neighbours. E.g. i leaves through the bottom face at its outflow corner
  //    while a clone enters at the inflow corner of the same face.
  // Valid at the ghost build.
  bool unseen_after_wrap(const ParticleStore& p, std::size_t i, std::size_t j) const {
    if (j < p.nlocal || !p.copies || p.le_copy[j] != 0) return false;
    const double lo = dom_.lo[0], L = dom_.length[0];
    const int k = sheared_image(p, j);
    if (k == 0) return p.x[j][0] < lo || p.x[j][0] >= dom_.hi[0];
    auto back = [&](double x) {  // across y, into the box
      x -= k * (dom_.shear.offset - shear_base_);
      return x - L * std::floor((x - lo) / L);
    };
    return std::abs(back(p.x[i][0]) - back(p.x[j][0])) > 0.5 * L;
  }
  // Per-particle columns of these boundaries (ParticleStore::declare, in snapshots):
  //  - kEnteredColumn: 1 for a clone made at this rebuild's migration, 2 for a returned particle,
  //    3 for an LE1 particle that wrapped through y (`cornered`), else 0 (read by
  //    Simulation::remove_stillborn, cleared after it);
  //  - kInflowColumn: 1 while an LE2 particle is shown to LE1 beyond LE1's inflow face.
  static constexpr const char* kEnteredColumn = "le_entered";
  static constexpr const char* kInflowColumn = "le_inflow_image";
  // How many sheared y images ghost j is of its particle (k_y: its y is the owner's + k_y L_y,
  // its v_x the owner's + k_y gamma L_y); 0 for owned particles and images across x or z only.
  int sheared_image(const ParticleStore& p, std::size_t j) const {
    return j < p.nlocal ? 0 : ghost_sheared_[j - p.nlocal];
  }
  // Traffic to other ranks since the run started (ghost updates, ghost builds, migration):
  // bytes and non-empty messages, for docs/scaling.md's model.
  std::int64_t bytes_sent = 0, messages_sent = 0;

 private:
  struct Image {
    std::uint32_t index;  // owned particle
    std::int8_t k[3];     // image shift in box lengths per axis
    std::uint8_t copy;    // the copy the ghost belongs to (modified Lees-Edwards; else unused)
  };
  // Modified Lees-Edwards boundaries: the clones of the LE2 particles that crossed x, with new
  // ids agreed by every rank (ordered by the crossing particle's id).
  void feed(ParticleStore& p);
  Vec3 shift(const Image& im) const;
  double shift_x(const Image& im) const;  // shift()[0]: the box length and the shear's offset
  // A ghost's position and velocity from its owner's, written component by component.
  void image_state(const ParticleStore& p, const Image& im, double* x, double* v) const;
  std::vector<std::vector<double>>& empty_buffers();
  double shear_velocity(const Image& im) const;
  // A ghost's row (x, v, spin, ghost columns; `width` doubles) from its owner, and back.
  std::size_t ghost_width(const ParticleStore& p) const;
  void pack_ghost(const ParticleStore& p, const Image& im, double* q) const;
  void unpack_ghost(ParticleStore& p, const double* b, std::size_t j) const;
  // This rank's own image `im`, written straight into ghost slot j (pack_ghost's values).
  void write_own_image(ParticleStore& p, const Image& im, std::size_t j) const;
  // Sends out[r] to rank r and gathers what every rank sent here into `in`, ordered by source
  // rank. With `rcount` given, the receive sizes are known and the count exchange is skipped
  // (the per-step ghost update).
  void exchange(std::vector<std::vector<double>>& out, std::vector<double>& in,
                const std::vector<int>* rcount = nullptr);

  Decomposition& dom_;
  double range_;
  std::vector<std::vector<Image>> send_;  // per destination rank
  std::vector<int> recv_ghosts_;          // ghosts received per source rank
  // Each owned particle's images, as (destination rank, place in send_[rank]), particle i's
  // from images_start_[i]; and per destination the places of the sheared images (k_y != 0).
  struct ImageRef { std::int32_t rank; std::uint32_t slot; };
  std::vector<std::uint32_t> images_start_;
  std::vector<ImageRef> images_;
  std::vector<std::vector<std::uint32_t>> sheared_;
  std::vector<std::size_t> first_ghost_;  // each source rank's first ghost slot
  std::vector<char> changed_;             // update_ghosts_of: marks, all 0 between calls
  std::vector<int> recv_doubles_;         // per-step update message sizes
  std::vector<std::int8_t> ghost_sheared_;  // per ghost slot: its k_y (sheared_image)
  std::vector<int> recv_others_;          // the same without this rank's own images
  std::vector<double> scratch_;           // one own image, written straight to its ghost slot
  double shear_base_ = 0;                 // offset - wrapped offset at the last build
  std::vector<std::vector<double>> out_;
  std::vector<double> in_;
  std::vector<int> near_;  // scratch: ranks near one image
};

}  // namespace cassini
