#pragma once
// A piece of physics (or bookkeeping) that plugs into the per-rank step loop. A module says
// which stages it uses; the loop calls only those, so a scene pays only for what it names.
//
// One step (velocity Verlet, kick-drift-kick):
//   initial_integrate   v += dt/2 F/m; x += dt v          (VelocityVerlet)
//   -- ghosts refreshed, or neighbour list rebuilt (pre_rebuild / post_rebuild)
//   pre_force           the integrator picks which owned particles get forces this step
//   force               forces from x(t+dt) and the half-step velocity v(t+dt/2)
//   final_integrate     v += dt/2 F/m
//   end_of_step         guards, observables, output
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/Vec3.hpp"

namespace cassini {

class Simulation;
class PairHistory;

// Forces for stress output (snapshots, cassini-cg), evaluated at the current state (full-step
// velocities) without changing any contact history.
struct PairForce {  // one interacting pair, once, from the side with the lower id
  std::int64_t i, j;
  Vec3 xi, branch, force;  // position of i, r_i - r_j (to the interacting image), force on i
};
struct WallForce {  // one particle-wall contact
  std::int64_t i;
  Vec3 point, branch, force;  // the wall point nearest the centre of i (the contact point),
                              // r_i - point, force on i
};

enum Stage : unsigned {
  kInitialIntegrate = 1u << 0,
  kForce = 1u << 1,
  kFinalIntegrate = 1u << 2,
  kEndOfStep = 1u << 3,
  kRebuild = 1u << 4,  // pre_rebuild / post_rebuild around migration and list rebuild
  kPreForce = 1u << 5,
};

class Module {
 public:
  virtual ~Module() = default;
  virtual std::string name() const = 0;
  virtual unsigned stages() const = 0;

  virtual void setup(Simulation&) {}
  virtual void initial_integrate(Simulation&) {}
  // Before any force: a multi-rate integrator sets Simulation::stepping.targets here.
  virtual void pre_force(Simulation&) {}
  // Forces on the owned particles Simulation::for_each_target names (all, but under a
  // multi-rate integrator between its long steps).
  virtual void force(Simulation&) {}
  virtual void final_integrate(Simulation&) {}
  virtual void end_of_step(Simulation&) {}
  virtual void pre_rebuild(Simulation&) {}
  virtual void post_rebuild(Simulation&) {}
  // Run state beyond the particles that a restart must restore (counters, timers), as named
  // numbers with the same value on every rank. Written into every snapshot; a restarted
  // run finds them in Simulation::restart_state when setup() is called.
  virtual void save_state(std::vector<std::pair<std::string, double>>&) const {}
  // Load balancing (domain.balance_every), at a balancing rebuild: scales each owned particle's
  // cost (1 + its neighbour-list entries, a plain step's work on it) by how often this module
  // worked on it since the last balancing (a multi-rate integrator: mostly on contact steps).
  virtual void weigh(Simulation&, std::vector<double>& /*cost*/) {}
  // Contact history of this rank's owned contacts, as rows of the columns the module declared in
  // Simulation::history (PairHistory.hpp); appended to `out`. Snapshots write it, restarts bring
  // it back into Simulation::history before the first rebuild.
  virtual void contact_history(const Simulation&, PairHistory&) const {}
  // What the module has to say in run.log once the run is set up (how it got its inputs, e.g.
  // the flow field's solve or cache); empty for nothing.
  virtual std::string setup_report() const { return ""; }

  // Stress bookkeeping (thesis 3.27, 3.32, 3.34): a module that puts pair forces, wall forces
  // or body forces (anything that is neither) on particles reports them here. Each appends;
  // add_body_forces adds into one entry per owned particle.
  virtual void pair_forces(const Simulation&, std::vector<PairForce>&) const {}
  virtual void wall_forces(const Simulation&, std::vector<WallForce>&) const {}
  virtual void add_body_forces(const Simulation&, std::vector<Vec3>&) const {}

  // Energy bookkeeping for the energy-growth guard (every scene keeps it on): a module with a
  // conservative force gives the potential energy of this rank's owned particles; one that
  // feeds energy otherwise (drag, an inlet) the work it has done on them since the run started.
  virtual double potential_energy(const Simulation&) const { return 0.0; }
  // True when that potential energy is the same for every periodic or sheared image of the
  // particles (the ring's self-gravity, unlike the tide): wrapping a particle across the box's
  // faces then moves no energy, and the rebuild need not evaluate it before and after.
  virtual bool image_invariant_potential() const { return false; }
  virtual double energy_input() const { return 0.0; }
  // Elastic energy stored in this rank's owned contacts (observables, energy bookkeeping).
  virtual double elastic_energy(const Simulation&) const { return 0.0; }

  // A module that keeps particles apart (contacts, walls, the moonlet) reports the deepest
  // overlap of its last force evaluation, as a fraction of the smaller radius, and the
  // particle it is at; the guards stop the run beyond guards.max_overlap, naming it by
  // overlap_label() ("wall overlap").
  virtual double max_overlap_fraction() const { return 0.0; }
  virtual std::int64_t worst_id() const { return -1; }
  virtual std::string overlap_label() const { return "overlap"; }

  // The module's own observables, as named global values (the module reduces over ranks
  // itself: called collectively, the same values on every rank). They become columns of
  // observables.csv and datasets of observables.h5md, at output.observe_every.
  virtual void observables(Simulation&, std::vector<std::pair<std::string, double>>&) {}

  // An event that may end the run before time.end ("a clog"), "" if none: the progress line's
  // time left is then an upper bound.
  virtual std::string ends_run_at() const { return ""; }

  // True for the particle-pair loop: its force stage is timed as "pair", the rest as "modules".
  virtual bool pair_loop() const { return false; }
};

}  // namespace cassini
