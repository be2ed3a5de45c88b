#include "physics/Guards.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/Simulation.hpp"

namespace cassini {

void Guards::setup(Simulation& sim) {
  start_ = energy(sim);
  next_energy_check_ = (sim.step_count / kEnergyPeriod + 1) * kEnergyPeriod;
  double r = sim.cfg.min_radius(), smallest = 0;
  for (std::size_t i = 0; i < sim.particles.nlocal; ++i) r = std::min(r, sim.particles.radius[i]);
  MPI_Allreduce(&r, &smallest, 1, MPI_DOUBLE, MPI_MIN, sim.domain.comm);
  step_limit2_ = max_step_ * smallest * max_step_ * smallest;
}

void Guards::initial_integrate(Simulation& sim) {
  // Free bound first: the integrator measured each particle's drift d since the last rebuild
  // (relative to the flow); this step moved it by d_now - d_before, at most sqrt(this step's
  // max d^2) + sqrt(the last step's) (a rebuild in between only shrinks d_before). In a normal
  // run the skin keeps that far below the limit, and the per-particle scan never runs.
  const double bound = std::sqrt(sim.stepping.max_drift2) + std::sqrt(last_drift2_);
  last_drift2_ = sim.stepping.max_drift2;
  if (bound * bound <= 0.98 * step_limit2_) return;  // 2 %: the flow's change across y is in d too
  if (sim.stepping.max_speed >= 0 && (sim.dt * sim.stepping.max_speed) * (sim.dt * sim.stepping.max_speed) <= step_limit2_) return;
  // Scan: the velocity now is the half-step velocity the drift just used.
  const ParticleStore& p = sim.particles;
  std::size_t worst = 0;
  double w = -1;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    if (!p.x[i].allFinite() || !p.v[i].allFinite()) { worst = i; w = INFINITY; break; }
    const double s = (p.v[i] - sim.imposed_flow(p.x[i])).stableNorm();  // no overflow of the square
    if (s > w) { w = s; worst = i; }
  }
  if (std::isfinite(w) && (sim.dt * w) * (sim.dt * w) <= step_limit2_) return;
  std::ostringstream os;
  if (!std::isfinite(w)) {
    os << "non-finite position or velocity of particle " << p.id[worst] << " (x = " << p.x[worst].transpose()
       << ", v = " << p.v[worst].transpose() << ")";
  } else {
    os << "particle " << p.id[worst] << " moved " << sim.dt * w / std::sqrt(step_limit2_) * max_step_
       << " smallest radii in one step (relative to the imposed flow), more than guards.max_step = " << max_step_
       << ": it can pass through other particles unseen (tunnelling); |v - u| = " << w << " m/s, dt = " << sim.dt
       << " s";
  }
  sim.raise_guard(os.str());
}

std::string Guards::diagnose(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  std::ostringstream why;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const bool finite = p.x[i].allFinite() && p.v[i].allFinite() && (!p.rotation || p.omega[i].allFinite());
    if (!finite) {
      why << "non-finite position or velocity of particle " << p.id[i];
      break;
    }
  }
  for (int d = 0; d < sim.domain.dims && why.tellp() == 0; ++d) {
    if (sim.domain.boundary[d] != Boundary::Wall) continue;
    for (std::size_t i = 0; i < p.nlocal; ++i)
      if (p.x[i][d] < sim.domain.lo[d] - p.radius[i] || p.x[i][d] > sim.domain.hi[d] + p.radius[i]) {
        // Past a wall by more than a radius: it tunnelled through.
        why << "particle " << p.id[i] << " left the domain through the wall on axis " << "xyz"[d];
        break;
      }
  }
  for (const auto& m : sim.modules)
    if (why.tellp() == 0 && m->max_overlap_fraction() > max_overlap_)
      why << m->overlap_label() << " of " << m->max_overlap_fraction() << " radii at particle " << m->worst_id()
          << " exceeds guards.max_overlap = " << max_overlap_ << " (time step too large or impact too fast for t_c)";
  return why.str();
}

void Guards::end_of_step(Simulation& sim) {
  const ParticleStore& p = sim.particles;
  // Fast scan first: the message is only built when something is wrong (this runs every step).
  // One sum per array: a NaN or an infinity anywhere makes it non-finite (finite values that
  // could overflow a sum are far beyond any guard anyway).
  // Eight independent partial sums over the flat arrays (a Vec3 is three packed doubles):
  // a loop the compiler vectorises, where one serial chain of adds was the cost of this scan.
  double s[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  auto add = [&s](const std::vector<Vec3>& a, std::size_t n) {
    static_assert(sizeof(Vec3) == 3 * sizeof(double));
    const double* q = a.data()->data();
    const std::size_t m = 3 * n;
    std::size_t j = 0;
    for (; j + 8 <= m; j += 8)
      for (int k = 0; k < 8; ++k) s[k] += q[j + k];
    for (; j < m; ++j) s[0] += q[j];
  };
  // The integrator's sum, when it took one as it wrote the state (Simulation::state_sum), spares
  // the pass: a position moved after its drift (an exact-scheme onset or exit) comes with a
  // force in this step's velocities, and shows in the next step's drift.
  if (sim.stepping.all_targets && sim.stepping.state_summed) {
    s[0] = sim.stepping.state_sum;
  } else if (sim.stepping.all_targets) {
    add(p.x, p.nlocal);
    add(p.v, p.nlocal);
    if (p.rotation) add(p.omega, p.nlocal);
  } else {  // between a multi-rate integrator's long steps only its targets took forces; all are scanned at its end
    for (const std::uint32_t i : sim.stepping.targets) {
      s[0] += p.x[i].sum();
      s[1] += p.v[i].sum();
      if (p.rotation) s[2] += p.omega[i].sum();
    }
  }
  bool bad = !std::isfinite(s[0] + s[1] + s[2] + s[3] + s[4] + s[5] + s[6] + s[7]);
  for (int d = 0; d < sim.domain.dims && !bad; ++d) {
    if (sim.domain.boundary[d] != Boundary::Wall) continue;
    for (std::size_t i = 0; i < p.nlocal && !bad; ++i)
      bad = p.x[i][d] < sim.domain.lo[d] - p.radius[i] || p.x[i][d] > sim.domain.hi[d] + p.radius[i];
  }
  for (const auto& m : sim.modules) bad = bad || m->max_overlap_fraction() > max_overlap_;
  if (bad) sim.raise_guard(diagnose(sim));

  // Kinetic energy growth, every kEnergyPeriod steps, at a step that moved every particle
  // (collective: every rank takes this branch on the same steps). Under the multi-rate
  // integrator that is a long step's end: the free particles' stored states are then the
  // present ones, and a check costs one pass over all particles (two with the potentials),
  // which every 100 contact steps was ~8 % of a ring's orbit.
  if (sim.stepping.all_targets && sim.step_count >= next_energy_check_) {
    next_energy_check_ = sim.step_count + kEnergyPeriod;
    const Energy now = energy(sim);
    // Energy conservation bounds the kinetic energy by what it started with, what the
    // potentials released and what the sources fed in (contacts only dissipate):
    // KE <= KE0 + (U0 - U) + W. Beyond growth x that bound the integration is unstable.
    const double available = std::max(start_.kinetic + (start_.potential - now.potential) + (now.input - start_.input),
                                       start_.kinetic);
    if (available > 0 && now.kinetic > energy_growth_ * available) {
      // Name the particle with the most kinetic energy on this rank: where the growth shows.
      const ParticleStore& p = sim.particles;
      std::size_t fast = 0;
      for (std::size_t i = 1; i < p.nlocal; ++i)
        if (p.mass[i] * p.v[i].squaredNorm() > p.mass[fast] * p.v[fast].squaredNorm()) fast = i;
      std::ostringstream os;
      os << "kinetic energy " << now.kinetic << " J exceeds guards.energy_growth = " << energy_growth_
         << " times what energy conservation allows, " << available
         << " J (initial kinetic energy + potential energy released + work of the sources)";
      if (p.nlocal > 0) os << "; the most energetic particle here is " << p.id[fast] << " at |v| = " << p.v[fast].norm() << " m/s";
      sim.raise_guard(os.str());
    }
  }
}

Guards::Energy Guards::energy(const Simulation& sim) const {
  double local[2] = {0, sim.halo.shear_energy}, global[2];
  for (const auto& m : sim.modules) {
    local[0] += m->potential_energy(sim);
    local[1] += m->energy_input();
  }
  MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  return {sim.kinetic_energy(), global[0], global[1]};
}

}  // namespace cassini
