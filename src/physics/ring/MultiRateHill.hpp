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
// Free particles are not touched between long steps: their stored state stays that of the time
// t_ref (the long step's start, or the last neighbour-list rebuild), and the exact solution of
// the linear Hill equations (the epicycle: tide plus Coriolis, so the ring's shear and epicycles
// carry no step error at all) brings them forward when needed: at a rebuild (migration and the
// new list need positions) and at the long step's end. Particles on contact steps take velocity
// Verlet steps with every force, as the plain scheme. At the long step's end free particles get
// the other half kick, Delta/2 a(x(t + Delta)): kick-drift-kick with an exact drift, the
// symplectic epicycle integrator of ring codes. A step's cost is then that of the few particles
// on contact steps, plus a bound: the neighbour list's skin test takes, for the free particles,
// the largest displacement their epicycles can have made since t_ref (speed bounds from each
// epicycle's invariant |(2 u_x, u_y)|; the fast ones, flung by the moonlet, each their own),
// so the list stays valid without moving them.
//
// Nothing is missed by the classification: before each step's forces every free particle with a
// partner on contact steps (owned or ghost; ghosts carry the mode) computes its present position
// and its gap to that partner, and joins the contact steps ("is woken") when the gap is below
// 4 |v_rel| dt, i.e. a few steps before the contact begins, at the latest when the plain scheme
// would see the overlap. Its state then is exact, and its moonlet impulse is corrected to the
// time it spent free. Two free particles cannot meet within a long step of K >= 8 steps: the
// classification's margin exceeds the wake distance (smaller K: every free particle with a
// partner is checked). Decisions are made from each particle's own side with the modes as of
// the step's start (wake-ups are sent to the ghosts before the forces), so results are the
// same on any rank count. Lees-Edwards crossings, ghosts, migration and snapshots (at long-step
// ends) work as with the plain scheme.
//
// Self-gravity (SelfGravity.hpp says how it splits): its mesh is a slow force for every particle
// and its short range one for the free particles, kicked Delta/2 at both ends of the long step
// with the moonlet's; particles on contact steps get the short range every step. The
// classification's bend bound adds twice the largest gravitational acceleration in the box (a
// maximum over all ranks: the same on any rank count), so that two free particles still cannot
// meet within the long step.
#include <cstdint>
#include <vector>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/ParticleStore.hpp"
#include "parallel/HaloExchange.hpp"

namespace cassini {

class Moonlet;
class SelfGravity;

class MultiRateHill : public Module {
 public:
  struct Settings {  // time.long_step, time.max_tidal_phase
    double long_step = 0;          // seconds (a whole number of steps; default ~T0/1000)
    double max_tidal_phase = 0.1;  // sqrt(G M_moonlet / r^3) x long step above this: contact steps
  };
  static ModuleKind kind();  // time.integrator = "multirate"
  MultiRateHill(const Config& cfg, double dt);
  std::string name() const override;
  unsigned stages() const override { return kInitialIntegrate | kPreForce | kFinalIntegrate | kRebuild; }
  void pre_rebuild(Simulation& sim) override;
  void setup(Simulation& sim) override;
  void initial_integrate(Simulation& sim) override;
  void post_rebuild(Simulation& sim) override;
  void pre_force(Simulation& sim) override;
  void final_integrate(Simulation& sim) override;
  // Coriolis as a body force (stress bookkeeping), as the plain integrator reports it.
  void add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const override;
  // A particle costs a plain step's work at each long step's start (classification) and at each
  // of its contact steps, nothing in between: the cost is scaled by that count (the moonlet's
  // neighbourhood, where the contacts are, gets narrower regions).
  void weigh(Simulation& sim, std::vector<double>& cost) override;

  // The exact linear-Hill (epicycle) map over time t, in place. Public for the tests.
  struct Epicycle {
    Epicycle(double omega, double omega_z, double t, bool planar);
    void advance(Vec3& x, Vec3& v) const;
    double omega, omega_z, t;
    bool planar;
    double s1, c1, cz, sz;  // sin(W t)/W, (1 - cos W t)/W, cos(W_z t), sin(W_z t)
  };

  // Where a particle (owned or ghost, by index) is now: a free particle's stored state is that
  // of t_ref, brought forward on its epicycle; a ghost that is a sheared image (HaloExchange::
  // sheared_image) moves as its owner, in its owner's y. The same bits for a particle and for
  // its unsheared ghosts, so forces from it are the same on any rank count. Valid for this step.
  struct Present {
    const ParticleStore& p;
    const HaloExchange& halo;
    const MultiRateHill& integrator;
    Epicycle map;
    double Ly, rate;
    bool lagging;  // free particles' stored states lag (within a long step, after its first step)
    Vec3 operator()(std::size_t j) const;
  };
  Present present(const Simulation& sim) const;

  // Counts on this rank since the run started.
  long long contact_particle_steps = 0;  // particle-steps on contact steps
  long long free_particle_steps = 0;
  long long stepped_particle_steps = 0;  // particles stepped, drifted or watched at contact steps
  long wakes = 0;          // free particles that joined the contact steps mid long step
  long wakes_touching = 0; // ... of those, already overlapping (woken as the plain scheme sees it)
  long missed = 0;         // free particles found touching the moonlet at a long step's end (0 expected)

 private:
  // kFree: stored state of time t_ref (3 was "drifting", moved every step: no longer made).
  enum Mode : std::uint8_t { kFree = 0, kContact = 1, kWoken = 2 };
  static bool on_contact_steps(std::uint8_t m) { return m == kContact || m == kWoken; }
  // A particle's mode: a column this module declares (ParticleStore::declare), so it migrates,
  // reaches the ghosts every step and goes into snapshots with no code elsewhere.
  std::size_t mode_column_ = 0;
  std::size_t work_column_ = 0;  // long steps begun + contact steps taken since the last balancing
  std::uint8_t mode_of(const ParticleStore& p, std::size_t i) const {
    return static_cast<std::uint8_t>(p.column(mode_column_, i)[0]);
  }
  void set_mode(ParticleStore& p, std::size_t i, Mode m) const { p.column(mode_column_, i)[0] = m; }
  void begin_long_step(Simulation& sim);
  // Moves the free particles from t_ref to now (exact epicycle) and records, for the drift
  // bound, their displacement since the last build and their epicycle speeds.
  void materialize(Simulation& sim);
  void find_watched(const Simulation& sim);
  void make_lists(const ParticleStore& p);
  bool needs_contact_steps(const Simulation& sim, std::size_t i) const;
  Vec3 moonlet_acceleration(const ParticleStore& p, std::size_t i) const;  // zero where there is no moonlet
  void publish(Simulation& sim) const;

  double dt_, omega_, omega_z_, long_step_, max_tidal_phase_;
  long substeps_;  // K
  bool planar_;
  double gm_ = 0, moonlet_radius_ = 0;
  const Moonlet* moonlet_ = nullptr;
  SelfGravity* gravity_ = nullptr;
  double gravity_bound_ = 0;  // twice the largest gravitational acceleration at the long step's start
  // Kicks of a long step's ends: the moonlet's and (free particles) gravity's, or (on contact steps) the mesh's.
  Vec3 slow_acceleration(const ParticleStore& p, std::size_t i, bool free) const;
  double rot_c_, rot_s_;  // Coriolis rotation over dt/2 for the contact steps

  bool in_long_step_ = false;
  long last_step_ = 0;  // the current long step ends after this step
  double t0_ = 0, delta_ = 0;
  std::vector<std::uint32_t> contact_;  // owned slots on contact steps (ascending)
  std::vector<std::uint32_t> watch_;    // free owned slots with a partner on contact steps (ascending)
  std::vector<std::uint32_t> woken_;    // scratch
  // Free particles on fast epicycles (flung by the moonlet): a bound of their own, so that they
  // do not widen the shared one. Particle k's displacement since the list was built is at most
  // A + B tau + C tau^2 at tau = time - t_ref (see fast_bound). Entries of particles woken since
  // stay (a bound that holds no longer matters: their drift is counted as they move).
  std::vector<double> fast_a_, fast_b_, fast_c_;
  double fast_u2_ = 0;  // their largest |v - flow|^2 bound
  // The bounds of the free particles faster than the shared bound's free_speed_, from their
  // present (synchronised) state: at a long step's start (stream: the flow's offset since
  // the build) or right after a rebuild (rebuilt: D0 = 0).
  void fast_bounds(const Simulation& sim, double stream, bool rebuilt);
  double skin_;
  double t_ref_ = 0;                    // time of the free particles' stored state
  // Drift bound of the free particles since t_ref: displacement from the build position then,
  // |y - y_build| then, largest in-plane epicycle speed |(2 u_x, u_y)| and vertical one.
  double free_drift_ = 0, free_dy_ = 0, free_speed_ = 0, free_vz_ = 0;
  std::size_t ghosts_awake_ = 0;        // ghosts on contact steps at the last check
  bool watch_dirty_ = true;
  std::vector<std::uint32_t> rebuild_woken_;  // woken by post_rebuild: their ghosts were built free
};

}  // namespace cassini
