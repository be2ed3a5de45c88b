#include "core/Simulation.hpp"
#include "core/Interrupt.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

#include "core/Initializer.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/RunSink.hpp"

namespace cassini {

Simulation::Simulation(const Config& c, MPI_Comm comm)
    : cfg(c), domain(c, comm), halo(domain, c.halo_range()) {
  dt = cfg.dt;
  skin = cfg.skin;
  range = cfg.pair_range();  // largest a_i + a_j (+ lubrication reach) + skin
  halo_range = cfg.halo_range();
  particles.rotation = cfg.rotation;
  particles.copies = cfg.modified_lees_edwards;
  if (particles.copies) {  // the boundaries' own state per particle (HaloExchange)
    particles.declare(HaloExchange::kEnteredColumn, 1, ParticleStore::Ghosts::zero);
    particles.declare(HaloExchange::kInflowColumn, 1, ParticleStore::Ghosts::zero);
  }
  if (cfg.decomposition == "metis") domain.use_cells(range);
  // The modules, in registry order between the integrator and the guards. Made here, not in
  // setup(): they declare their per-particle columns (wall springs), which a restart reads.
  const auto& ik = integrator_kinds();
  for (const auto& k : ik)
    if (k.name == cfg.integrator) modules.push_back(k.make(*this));
  if (modules.empty()) throw std::logic_error("unknown integrator '" + cfg.integrator + "'");
  for (const auto& k : module_kinds())
    if (cfg.has_module(k.name)) modules.push_back(k.make(*this));
  modules.push_back(make_guards(*this));  // last: they see every module's energy
}

Simulation::~Simulation() = default;

void Simulation::set_result(const std::string& key, const std::string& json_value) {
  for (auto& [k, v] : record.results)
    if (k == key) { v = json_value; return; }
  record.results.emplace_back(key, json_value);
}

std::vector<std::string> Simulation::module_names() const {
  std::vector<std::string> names;
  for (const auto& m : modules) names.push_back(m->name());
  return names;
}

void Simulation::setup() {
  for (auto& m : modules) {
    const unsigned s = m->stages();
    for (int k = 0; k < 6; ++k)
      if (s & (1u << k)) stage_[k].push_back(m.get());
  }
  if (particles.size() == 0 && !restored) place_particles(cfg, domain, particles);
  particles.nlocal = particles.size();
  // "The position at the last build" before the first: where they are (a restart's frame was
  // written right after a build, so its first build sees what the run it continues saw).
  for (std::size_t i = 0; i < particles.nlocal; ++i) particles.x_build[i] = particles.x[i];
  rebuild();
  for (auto& m : modules) m->setup(*this);  // modules may need the placed particles (and set up data F needs)
  if (!restored) {
    stepping.initial_forces = true;
    compute_forces();
    stepping.initial_forces = false;
    check_initial_overlaps();
  }
}

void Simulation::check_initial_overlaps() {
  // Overlapping initial particles would start with a violent, unphysical push: refuse them,
  // naming the worst particle (collective: every rank throws the same message).
  // Particle pairs only: a particle placed against a wall is the scene's choice.
  const Module* pairs = nullptr;
  for (const auto& m : modules)
    if (m->pair_loop()) pairs = m.get();
  const double worst = pairs ? pairs->max_overlap_fraction() : 0.0;
  struct { double value; int rank; } local{worst, domain.rank}, global{};
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE_INT, MPI_MAXLOC, domain.comm);
  if (global.value <= cfg.max_overlap_fraction) return;
  std::int64_t id = pairs && domain.rank == global.rank ? pairs->worst_id() : 0;
  MPI_Bcast(&id, 1, MPI_INT64_T, global.rank, domain.comm);
  std::ostringstream os;
  os << cfg.source << ": key 'particles': initial particles overlap by " << global.value
     << " radii at particle " << id << ", expected at most guards.max_overlap = " << cfg.max_overlap_fraction;
  throw ConfigError(os.str());
}

void Simulation::rebuild() {
  stepping.forces_cleared = false;  // arrivals and new particles bring forces of their own
  {
    auto t = record.timers.scope(StageTimers::Neighbour);  // the modules' lists and histories are part of it
    for (Module* m : stage_[4]) m->pre_rebuild(*this);
  }
  if (cfg.balance_every > 0 && domain.nranks > 1 && rebuilds % cfg.balance_every == 0) {
    // Cost of a particle: 1 + its neighbour-list entries (integration plus pair work).
    std::vector<Vec3> where(particles.x.begin(), particles.x.begin() + particles.nlocal);
    std::vector<double> cost(particles.nlocal, 1.0);
    const bool listed = neighbors.start.size() == particles.nlocal + 1;
    for (std::size_t i = 0; i < particles.nlocal; ++i)
      if (listed) cost[i] += neighbors.start[i + 1] - neighbors.start[i];
    for (auto& m : modules) m->weigh(*this, cost);
    record.imbalance = domain.balance(where, cost);
  }
  if (!incoming.empty()) {
    particles.resize(particles.nlocal);  // drop ghosts: owned particles come first
    for (const auto& q : incoming) particles.add(q.id, q.species, q.radius, q.mass, q.x, q.v);
    particles.nlocal = particles.size();
    incoming.clear();
  }
  // Wrapping a particle across a Lees-Edwards boundary changes its potential energy in the
  // frame (the tide at y and y -+ L_y differ once it overshot the boundary): part of the
  // shear's work for the energy bookkeeping (HaloExchange counts the velocity jumps), as are
  // the particles the modified boundaries add and remove.
  auto potential = [&] {
    double u = 0;
    for (const auto& m : modules)
      if (!m->image_invariant_potential()) u += m->potential_energy(*this);
    return u;
  };
  {
    auto t = record.timers.scope(StageTimers::Comm);
    const double before = domain.shear.enabled ? potential() : 0.0;
    halo.migrate(particles, history);
    if (domain.shear.enabled) halo.shear_energy += potential() - before;
    if (domain.fed_x) stillborn_potential_ = potential();  // clones removed below take theirs away
  }
  {
    auto t = record.timers.scope(StageTimers::Neighbour);
    // Particles drift at most half a skin between rebuilds, so the order by cell decays slowly:
    // re-sorting at every rebuild cost ~5 % of a gas's run for no faster pair loop than every
    // tenth (LAMMPS sorts every 1,000 steps). Results do not depend on the order (each particle
    // sums its contacts in partner-id order), so this changes no bit.
    if (rebuilds % kSortEvery == 0) particles.permute_local(NeighborList::spatial_order(particles, domain, range));
  }
  {
    auto t = record.timers.scope(StageTimers::Comm);
    halo.build_ghosts(particles);
  }
  {
    // Pairs listed up to a_i + a_j + reach + skin: lubrication acts across gaps.
    auto t = record.timers.scope(StageTimers::Neighbour);
    neighbors.build(particles, domain, range, skin + cfg.pair_reach);
  }
  if (domain.fed_x && remove_stillborn()) {  // rare: ghosts and list again without them
    halo.shear_energy += potential() - stillborn_potential_;
    particles.permute_local(NeighborList::spatial_order(particles, domain, range));
    halo.build_ghosts(particles);
    neighbors.build(particles, domain, range, skin + cfg.pair_reach);
  }
  record.list_entries += double(neighbors.size());
  for (const std::uint32_t j : neighbors.partner) record.ghost_entries += j >= particles.nlocal;
  if (domain.nranks > 1) {  // the cost balance the ranks actually ran with (summary.json)
    const double now = domain.imbalance(static_cast<double>(particles.nlocal + neighbors.size()));
    record.imbalance_sum += now;
    record.imbalance_worst = std::max(record.imbalance_worst, now);
    ++record.imbalance_samples;
  }
  {
    auto t = record.timers.scope(StageTimers::Neighbour);
    for (Module* m : stage_[4]) m->post_rebuild(*this);
  }
  for (std::size_t i = 0; i < particles.nlocal; ++i) particles.x_build[i] = particles.x[i];
  time_at_build_ = time;
  ++rebuilds;
}

bool Simulation::remove_stillborn() {
  ParticleStore& p = particles;
  const std::size_t entered = p.find_column(HaloExchange::kEnteredColumn);
  bool any_entered = false;  // here, at this rebuild's migration
  for (std::size_t i = 0; i < p.nlocal && !any_entered; ++i) any_entered = *p.column(entered, i) != 0;
  std::vector<std::size_t> doomed;
  if (any_entered) {
    // A clone or a returned particle overlaps nothing that saw it coming; one that wrapped
    // through y saw all but what HaloExchange::unseen_after_wrap names.
    neighbors.for_each_overlap(p, false, [&](const NeighborList::Overlap& c) {
      const double how = *p.column(entered, c.i);
      if (how == 0 || (how == 3 && !halo.unseen_after_wrap(p, c.i, c.j))) return;
      if (doomed.empty() || doomed.back() != c.i) doomed.push_back(c.i);
    });
    for (const std::size_t i : doomed) {  // a clone is not inserted; a returned or cornered one is drained
      const double how = *p.column(entered, i);
      if (how == 1) --halo.fed, ++halo.stillborn;
      if (how == 2) --halo.returned, ++halo.drained;
      if (how == 3) ++halo.cornered, ++halo.drained;
    }
    for (std::size_t i = 0; i < p.nlocal; ++i) *p.column(entered, i) = 0;
  }
  int mine = doomed.empty() ? 0 : 1, any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, domain.comm);
  if (!any) return false;
  p.resize(p.nlocal);  // drop ghosts; then remove from the back so that slots stay valid
  for (auto it = doomed.rbegin(); it != doomed.rend(); ++it) {
    halo.shear_energy -= 0.5 * p.mass[*it] * p.v[*it].squaredNorm();  // its potential: Simulation::rebuild
    const std::size_t last = p.nlocal - 1;
    if (*it != last) p.copy(last, *it);
    p.nlocal = last;
    p.resize(last);
  }
  return true;
}

void Simulation::compute_forces() {
  ParticleStore& p = particles;
  if (stepping.all_targets) {
    if (!stepping.forces_cleared) {
      std::fill(p.f.begin(), p.f.begin() + p.nlocal, Vec3::Zero());
      if (p.rotation) std::fill(p.torque.begin(), p.torque.begin() + p.nlocal, Vec3::Zero());
    }
  } else {
    for (const std::uint32_t i : stepping.targets) {
      p.f[i].setZero();
      if (p.rotation) p.torque[i].setZero();
    }
  }
  for (Module* m : stage_[1]) {
    auto t = record.timers.scope(m->pair_loop() ? StageTimers::Pair : StageTimers::Modules);
    m->force(*this);
  }
}

void Simulation::raise_guard(const std::string& why) {
  if (!guard_message_.empty()) return;
  std::ostringstream os;
  os << "guard tripped at step " << step_count << ", t = " << time << " s, rank " << domain.rank << ": " << why;
  guard_message_ = os.str();
  // The verdict reaches the other ranks at the next step's reduction; this rank dumps now, so
  // the diagnostic dump is the state of the step the message names.
  if (output_) output_->dump(*this, "diagnostic");
  guard_dumped_ = true;
}

void Simulation::step() {
  const double next_time = (step_count + 1) * dt;  // from the step count: no accumulated round-off
  stepping.stream = domain.shear.enabled ? domain.shear.rate * (next_time - time_at_build_) : 0.0;
  stepping.max_drift2 = 0;
  stepping.max_speed = -1;
  stepping.state_summed = stepping.forces_cleared = stepping.moved_known = false;
  ++step_count;  // first: the drift moves the state to this step (a guard in it names this step)
  time = next_time;
  {
    auto t = record.timers.scope(StageTimers::Integrate);
    for (Module* m : stage_[0]) m->initial_integrate(*this);
  }
  if (domain.shear.enabled) domain.shear.offset = domain.shear.rate * domain.length[1] * time;

  // One reduction per step decides both "rebuild?" and "did a guard trip last step?".
  // Under shear, displacements are measured relative to the imposed flow gamma_dot y: two
  // particles (or a particle and a sheared image) that can meet are at most `range` apart in
  // y at the build, so the flow moves them together by at most gamma_dot range dt_build.
  // Streaming particles then do not force rebuilds (a dilute ring rebuilds ~40x less often).
  // The reduction runs while the ghosts are updated, as if no rebuild were due (most steps):
  // its latency hides behind the neighbour messages' instead of adding to it. A rebuild makes
  // the ghosts anew, so on a rebuild step that update was only wasted, never wrong.
  double local[2] = {stepping.max_drift2, guard_message_.empty() ? 0.0 : 1.0};
  if (!std::isfinite(local[0])) local[1] = 1;
  double global[2];
  {
    auto t = record.timers.scope(StageTimers::Comm);
    MPI_Request decided;
    MPI_Iallreduce(local, global, 2, MPI_DOUBLE, MPI_MAX, domain.comm, &decided);
    if (stepping.moved_known) halo.update_ghosts_of(particles, stepping.moved, true);
    else halo.update_ghosts(particles);
    MPI_Wait(&decided, MPI_STATUS_IGNORE);
  }
  if (global[1] > 0) check_guards();
  // The halo may reach further than the pair range (self-gravity's pairs): its ghosts must stay valid too.
  const double approach = 2 * std::sqrt(global[0]) + std::abs(stepping.stream) * halo_range;
  if (approach > skin) rebuild();

  if (!stage_[5].empty()) {
    auto t = record.timers.scope(StageTimers::Integrate);
    for (Module* m : stage_[5]) m->pre_force(*this);
  }
  compute_forces();
  {
    auto t = record.timers.scope(StageTimers::Integrate);
    for (Module* m : stage_[2]) m->final_integrate(*this);
  }
  {
    auto t = record.timers.scope(StageTimers::Modules);
    for (Module* m : stage_[3]) m->end_of_step(*this);
  }
}

void Simulation::check_guards() {
  // Called collectively once some rank has a message: everyone stops with the messages.
  int len = static_cast<int>(guard_message_.size());
  std::vector<int> lens(domain.nranks);
  MPI_Allgather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, domain.comm);
  std::vector<int> displ(domain.nranks, 0);
  int total = 0;
  for (int r = 0; r < domain.nranks; ++r) { displ[r] = total; total += lens[r]; }
  std::string all(total, ' ');
  MPI_Allgatherv(guard_message_.data(), len, MPI_CHAR, all.data(), lens.data(), displ.data(), MPI_CHAR, domain.comm);
  std::string msg;
  for (int r = 0; r < domain.nranks; ++r)
    if (lens[r] > 0) {
      if (!msg.empty()) msg += '\n';
      msg.append(all, displ[r], lens[r]);
    }
  throw GuardError(msg);
}

namespace {
struct Cadence {
  long nsteps, observe, dump, snap;  // dump, snap: 0 for none
};
Cadence cadence(const Config& cfg, double dt) {
  return {std::lround(cfg.t_end / dt), std::max(1L, std::lround(cfg.observe_every / dt)),
          cfg.dump_every > 0 ? std::max(1L, std::lround(cfg.dump_every / dt)) : 0,
          cfg.snapshot_every > 0 ? std::max(1L, std::lround(cfg.snapshot_every / dt)) : 0};
}
}  // namespace

bool Simulation::is_output_step(long step) const {
  const Cadence c = cadence(cfg, dt);
  return step >= c.nsteps || step % c.observe == 0 || (c.dump && step % c.dump == 0) || (c.snap && step % c.snap == 0);
}

void Simulation::run(RunSink* out) {
  const Cadence c = cadence(cfg, dt);
  const long nsteps = c.nsteps, observe_every = c.observe, dump_every = c.dump, snap_every = c.snap;
  long n_total = total_particles();
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  auto last_print = t0;
  long last_step = step_count;
  const long first_step = step_count;
  std::string event;  // what may end the run before time.end
  for (const auto& m : modules)
    if (const std::string e = m->ends_run_at(); !e.empty()) event += (event.empty() ? "" : " or ") + e;
  output_ = out;
  record.timers.reset();  // the stages of the step loop only (not set-up, not a previous run)
  if (out) {
    out->observe(*this);
    if (dump_every) out->dump(*this, "step");
    if (snap_every && !restored && time >= cfg.snapshot_from) out->snapshot(*this);
  }
  while (step_count < nsteps && !record.finished) {
    try {
      step();
    } catch (const GuardError&) {
      if (out && !guard_dumped_) out->dump(*this, "diagnostic");
      output_ = nullptr;
      throw;
    }
    // Every 64 steps, one collective: rank 0's clock decides the progress line, and a
    // signal received by any rank stops every rank at this same step.
    if ((step_count & 63) == 0) {
      const auto now = clock::now();
      const double since = std::chrono::duration<double>(now - last_print).count();
      int flags[2] = {out && domain.rank == 0 && since >= cfg.progress_every, interrupt_signal()}, agreed[2];
      MPI_Allreduce(flags, agreed, 2, MPI_INT, MPI_MAX, domain.comm);
      if (agreed[1]) {
        record.interrupted = agreed[1];
        finish(std::string("interrupted by ") + signal_name(record.interrupted));
      }
      if (agreed[0]) {
        n_total = total_particles();  // changes in scenes with an inlet and an outlet
        const double rate = double(step_count - last_step) * n_total / since;
        const double elapsed = std::chrono::duration<double>(now - t0).count();
        // From this run's own steps: a continuation's earlier steps took no time here.
        const double eta = elapsed / double(step_count - first_step) * double(nsteps - step_count);
        std::ostringstream os;
        os.precision(4);
        os << "step " << step_count << "/" << nsteps << "  t = " << time << " s  " << rate << " particle-steps/s  ETA "
           << (event.empty() ? "" : "<= ") << std::lround(eta) << " s" << (event.empty() ? "" : " (or at " + event + ")");
        out->log(os.str());
        last_print = now;
        last_step = step_count;
      }
    }
    if (!out) continue;
    auto t_out = record.timers.scope(StageTimers::Output);
    if (step_count % observe_every == 0) out->observe(*this);
    if (dump_every && step_count % dump_every == 0) out->dump(*this, "step");
    if (snap_every && step_count % snap_every == 0 && time >= cfg.snapshot_from - 0.5 * dt) out->snapshot(*this);
  }
  output_ = nullptr;
  if (global_guard_pending()) check_guards();
  if (domain.fed_x) {  // the modified boundaries' bookkeeping, for summary.json
    long long local[6] = {halo.fed, halo.drained, halo.stillborn, 0, halo.returned, halo.cornered}, g[6];
    for (std::size_t i = 0; i < particles.nlocal; ++i) local[3] += particles.le_copy[i] == 0;
    MPI_Allreduce(local, g, 6, MPI_LONG_LONG, MPI_SUM, domain.comm);
    std::ostringstream os;
    os << "{\"fed_into_le1\": " << g[0] << ", \"drained_from_le1\": " << g[1] << ", \"clones_not_inserted\": " << g[2]
       << ", \"returned_against_flow\": " << g[4] << ", \"taken_out_at_corners\": " << g[5]
       << ", \"le1_particles\": " << g[3]
       << ", \"le2_particles\": " << total_particles() - g[3] << "}";
    set_result("modified_lees_edwards", os.str());
  }
  // A run that reached time.end or that a module ended (a clog) gets a last frame with its final
  // state and results, also when snapshot_every does not divide its length (so that a study can
  // continue it from its end); an interrupted one only when the case asks
  // (output.snapshot_on_signal: a frame to continue from).
  if (out && (record.finished || step_count >= nsteps)) {
    const bool wanted = record.interrupted ? cfg.snapshot_on_signal : snap_every > 0;
    const bool written = snap_every && step_count % snap_every == 0 && time >= cfg.snapshot_from - 0.5 * dt;
    if (wanted && !written) out->snapshot(*this);
  }
}

bool Simulation::global_guard_pending() {
  int local = guard_message_.empty() ? 0 : 1, any = 0;
  MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_MAX, domain.comm);
  return any != 0;
}

double Simulation::kinetic_energy() const {
  const ParticleStore& p = particles;
  double e = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    e += 0.5 * p.mass[i] * p.v[i].squaredNorm();
    if (p.rotation) e += 0.5 / p.inv_inertia[i] * p.omega[i].squaredNorm();
  }
  double g = 0;
  MPI_Allreduce(&e, &g, 1, MPI_DOUBLE, MPI_SUM, domain.comm);
  return g;
}

double Simulation::elastic_energy() const {
  double e = 0, g = 0;
  for (const auto& m : modules) e += m->elastic_energy(*this);
  MPI_Allreduce(&e, &g, 1, MPI_DOUBLE, MPI_SUM, domain.comm);
  return g;
}

Vec3 Simulation::momentum() const {
  Vec3 m = Vec3::Zero(), g;
  for (std::size_t i = 0; i < particles.nlocal; ++i) m += particles.mass[i] * particles.v[i];
  MPI_Allreduce(m.data(), g.data(), 3, MPI_DOUBLE, MPI_SUM, domain.comm);
  return g;
}

long Simulation::total_particles() const {
  long n = static_cast<long>(particles.nlocal), g = 0;
  MPI_Allreduce(&n, &g, 1, MPI_LONG, MPI_SUM, domain.comm);
  return g;
}

}  // namespace cassini
