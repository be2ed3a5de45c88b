#pragma once
// One rank's share of a run: the particle store, its slab, the halo, the neighbour list and
// the active modules, and the step loop that calls the modules' stages in a fixed order.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <mpi.h>

#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/NeighborList.hpp"
#include "core/PairHistory.hpp"
#include "core/ParticleStore.hpp"
#include "core/StageTimers.hpp"
#include "parallel/Decomposition.hpp"
#include "parallel/HaloExchange.hpp"

namespace cassini {

class RunSink;

// A guard tripped: every rank throws it on the same step (the verdict is reduced first).
struct GuardError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Simulation {
 public:
  Simulation(const Config& cfg, MPI_Comm comm);
  ~Simulation();

  // Places the initial particles (unless some were added or restored), builds the first
  // halo and neighbour list and evaluates F(0) (unless restored from a snapshot).
  void setup();
  // Migration, ghosts and neighbour list from scratch. Also called before a snapshot, so that
  // a restart (which starts with a rebuild) continues bitwise like the uninterrupted run.
  void rebuild();
  bool restored = false;  // state (including F) came from a snapshot
  bool restart_point = false;  // true during the rebuild a snapshot makes (a restart from it starts alike)
  void step();
  // Steps to cfg.t_end; with `out`, prints progress and writes observables and dumps.
  void run(RunSink* out = nullptr);

  // Collective reductions over all ranks.
  double kinetic_energy() const;   // translational + rotational
  double elastic_energy() const;   // contact springs
  Vec3 momentum() const;
  long total_particles() const;

  // Records that a guard tripped on this rank; the step loop stops all ranks together.
  void raise_guard(const std::string& why);

  Config cfg;
  Decomposition domain;
  ParticleStore particles;
  NeighborList neighbors;
  HaloExchange halo;
  PairHistory history;  // contact history in transit during a rebuild (columns: the contact law's)

  // Particles to add at the next rebuild (an inlet): added after the pre_rebuild hooks have
  // saved the contact history, so that no spring is lost.
  struct NewParticle { std::int64_t id; int species; double radius, mass; Vec3 x, v; };
  std::vector<NewParticle> incoming;

  // What the integrator and the force modules tell each other within a step (set and read
  // during the step; nothing here is run state a restart keeps).
  struct StepState {
    // Set before the initial_integrate stage: the integrator measures, while it drifts, the
    // largest squared displacement since the last rebuild relative to the imposed flow
    // (x - x_build - stream * y_build e_x), into max_drift2 (fused: one pass over memory).
    double stream = 0, max_drift2 = 0;
    // An integrator may also give a bound on every owned particle's speed relative to the
    // imposed flow this step (-1: none); the tunnelling guard then needs no scan.
    double max_speed = -1;
    // An integrator that touched every owned particle's position, velocity and spin this step may
    // give the sum of all their components (state_summed): non-finite iff one of them is NaN or
    // infinite, the check Guards otherwise makes with a pass of its own over the particles.
    double state_sum = 0;
    bool state_summed = false;
    // The integrator zeroed every owned particle's force and torque as its first kick read them
    // (in the same pass, where a fill of its own went over them again): the force stage need not.
    // A rebuild clears it (particles arrive and move).
    bool forces_cleared = false;

    // The owned particles that get forces this step (ascending slots), or all of them. A
    // multi-rate integrator narrows it between its long steps (Module::pre_force). A force
    // module loops `const TargetList T = sim.target_list(); for (t < T.count) { i = T[t]; ... }`
    // (a plain loop, not a callback: accumulators then stay in registers).
    bool all_targets = true;
    std::vector<std::uint32_t> targets;
    // An integrator that knows which owned particles' state (position, velocity, spin, carried
    // columns) changed since the last ghost update lists them in `moved` and sets moved_known
    // (in initial_integrate); the step's ghost update then refreshes only their images and the
    // sheared ones (HaloExchange::update_ghosts_of), with the same result. Reset every step.
    bool moved_known = false;
    std::vector<std::uint32_t> moved;
    // A module column (ParticleStore::declare) in which 0 marks a particle whose stored state is
    // not the present one between a multi-rate integrator's long steps: force loops skip it as a
    // partner (it is woken before it can touch anything). -1: none.
    int lazy_column = -1;
    // True while setup() evaluates F(0): contact histories (springs) are read, not advanced, so
    // the first step does not add a step's stretch twice.
    bool initial_forces = false;
  };
  StepState stepping;
  // The targets as a list to loop over.
  struct TargetList {
    const std::uint32_t* list;  // null: every owned particle, in order
    std::size_t count;
    std::size_t operator[](std::size_t t) const { return list ? list[t] : t; }
  };
  TargetList target_list() const {
    return stepping.all_targets ? TargetList{nullptr, particles.nlocal}
                                 : TargetList{stepping.targets.data(), stepping.targets.size()};
  }
  // Steps after which output is written (observables, dumps, snapshots) and the last step:
  // an integrator with long steps ends one there, so that output sees a synchronised state.
  bool is_output_step(long step) const;

  double dt = 0, time = 0;
  long step_count = 0;
  double range = 0, skin = 0;
  double halo_range = 0;  // >= range: the ghosts' reach (Config::halo_range)
  long rebuilds = 0;
  static constexpr long kSortEvery = 10;  // rebuilds between spatial sorts of the owned particles

  // What the run records for its reports (run.log, summary.json, the ensemble table).
  struct RunRecord {
    StageTimers timers;  // this rank's wall time per stage of the step
    double imbalance = 1;  // max / mean rank cost at the last balancing (1 when never balanced)
    // Max / mean rank cost (particles + neighbour pairs) measured at every rebuild.
    double imbalance_sum = 0, imbalance_worst = 1;
    long imbalance_samples = 0;
    // Neighbour-list entries at the rebuilds, on this rank: all, and those with a ghost partner.
    // Owned pairs are listed on both rows and evaluated once; a pair across ranks is evaluated on
    // each side (summary.json: pair evaluations per distinct pair).
    double list_entries = 0, ghost_entries = 0;
    bool finished = false;
    std::string finish_reason;
    int interrupted = 0;  // the signal (SIGTERM, SIGINT) that stopped the run at a step boundary, 0 if none
    std::vector<std::pair<std::string, std::string>> results;
  };
  RunRecord record;

  std::vector<std::unique_ptr<Module>> modules;  // integrator first, guards last (ModuleRegistry.hpp)

  // Velocity of the imposed flow at x (the Lees-Edwards shear v_x = gamma_dot y; zero otherwise).
  Vec3 imposed_flow(const Vec3& x) const {
    return Vec3(domain.shear.enabled ? domain.shear.rate * x[1] : 0.0, 0, 0);
  }

  std::vector<std::string> module_names() const;
  // The active module of type M, or null when the scene does not use it.
  template <class M>
  M* find() const {
    for (const auto& m : modules)
      if (auto* p = dynamic_cast<M*>(m.get())) return p;
    return nullptr;
  }

  // A module may end the run early (collectively: every rank calls it on the same step), and
  // publish results for summary.json (values are JSON text).
  void finish(const std::string& why) {
    record.finished = true;
    record.finish_reason = why;
  }
  void set_result(const std::string& key, const std::string& json_value);
  // Module state read from a snapshot (see Module::save_state); empty for a fresh run.
  std::vector<std::pair<std::string, double>> restart_state;
  bool restart_value(const std::string& key, double& value) const {
    for (const auto& [k, v] : restart_state)
      if (k == key) { value = v; return true; }
    return false;
  }

 private:
  void compute_forces();
  // Modified Lees-Edwards boundaries: removes this rebuild's clones that overlap LE1 material
  // (see HaloExchange::born). Collective; true if any rank removed one.
  bool remove_stillborn();
  void check_guards();
  void check_initial_overlaps();
  bool global_guard_pending();
  std::vector<Module*> stage_[6];
  std::string guard_message_;
  bool guard_dumped_ = false;
  RunSink* output_ = nullptr;  // during run(): where a tripped guard dumps its state
  double time_at_build_ = 0;
  double stillborn_potential_ = 0;
  friend void read_snapshot(Simulation&, const std::string&);
};

}  // namespace cassini
