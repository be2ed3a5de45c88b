#pragma once
// Multi-rate integrator of the Hill frame (time.integrator = "multirate"): a ring particle is
// touching another only a tiny fraction of the time, so only then does it need steps of t_c/N_c.
//
// Long steps of Delta = time.long_step (a whole number K of contact steps dt, ending early at
// output steps so output sees a synchronised state). At the start of each:
//   - every owned particle is classified, from its own side (the same on any rank count):
//     on CONTACT STEPS if, moving on straight lines from now, it comes within reach of a
//     neighbour-list partner or of the moonlet during Delta (margins below), or if the
//     moonlet's tide sqrt(G M / r^3) Delta exceeds time.max_tidal_phase; FREE otherwise.
//   - free particles get half of the long step's kick from the moonlet's gravity, Delta/2 a(x).
// Every step dt, free particles move on the exact solution of the linear Hill equations (the
// epicycle: tide plus Coriolis, so the ring's shear and epicycles carry no step error at all);
// particles on contact steps take velocity Verlet steps with every force, as the plain scheme.
// At the long step's end free particles get the other half kick, Delta/2 a(x(t + Delta)):
// kick-drift-kick with an exact drift, the symplectic epicycle integrator of ring codes.
//
// Nothing is missed by the classification: before each step's forces every free particle with a
// neighbour-list partner checks its gap to each partner, and joins the contact steps (is
// "woken") when the gap is below 4 |v_rel| dt, i.e. a few steps before the contact begins, at
// the latest when the plain scheme would see the overlap. Its state then is exact, and its
// moonlet impulse is corrected to the time it spent free. The neighbour list is kept valid for
// everyone by the usual skin test (free particles are moved every step, so their drift counts),
// and the ghosts, Lees-Edwards images, migration and snapshots work as with the plain scheme.
//
// The margins of the classification only decide how much work is done, not what is computed:
// a pair's straight-line approach is padded by (3 Omega^2 |dy| + Omega_z^2 |dz| + 2 Omega |dv|
// + |a_m,i| + |a_m,j|) Delta^2 (the relative acceleration the straight line ignores), and
// the moonlet's surface by (|v| + (G M / R^2 + 3 Omega^2 |y| + 2 Omega |v|) Delta) Delta.
#include <cstdint>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"

namespace cassini {

class Moonlet;

class MultiRateHill : public Module {
 public:
  MultiRateHill(const Config& cfg, double dt);
  std::string name() const override;
  unsigned stages() const override { return kInitialIntegrate | kPreForce | kFinalIntegrate | kRebuild; }
  void setup(Simulation& sim) override;
  void initial_integrate(Simulation& sim) override;
  void post_rebuild(Simulation& sim) override;
  void pre_force(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;
  // Coriolis as a body force (stress bookkeeping), as the plain integrator reports it.
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;

  // The exact linear-Hill (epicycle) map over time t, in place. Public for the tests.
  struct Epicycle {
    Epicycle(double omega, double omega_z, double t, bool planar);
    void advance(Vec3& x, Vec3& v) const;
    double omega, omega_z, t;
    bool planar;
    double s1, c1, cz, sz;  // sin(W t)/W, (1 - cos W t)/W, cos(W_z t), sin(W_z t)
  };

  // Counts on this rank since the run started.
  long long contact_particle_steps = 0;  // particle-steps on contact steps
  long long free_particle_steps = 0;
  long wakes = 0;          // free particles that joined the contact steps mid long step
  long wakes_touching = 0; // ... of those, already overlapping (woken as the plain scheme sees it)
  long missed = 0;         // free particles found touching the moonlet at a long step's end (0 expected)

 private:
  enum Mode : std::uint8_t { kFree = 0, kContact = 1, kWoken = 2 };
  void begin_long_step(Simulation& sim);
  bool needs_contact_steps(const Simulation& sim, std::size_t i) const;
  Vec3 moonlet_acceleration(const Vec3& x) const;
  void publish(Simulation& sim) const;

  double dt_, omega_, omega_z_, long_step_, max_tidal_phase_;
  long substeps_;  // K
  bool planar_;
  double gm_ = 0, moonlet_radius_ = 0;
  const Moonlet* moonlet_ = nullptr;
  Epicycle step_map_;
  double rot_c_, rot_s_;  // Coriolis rotation over dt/2 for the contact steps

  bool in_long_step_ = false;
  long first_step_ = 0, last_step_ = 0;  // steps of the current long step (first advances from t0)
  double t0_ = 0, delta_ = 0;
  std::vector<std::uint32_t> contact_;  // owned slots on contact steps (ascending)
  std::vector<std::uint32_t> watch_;    // free owned slots with neighbour-list partners (ascending)
  struct State { Vec3 x, v; };
  std::vector<State> saved_;            // scratch: contact-step particles before the free pass
};

}  // namespace cassini
