#include "physics/ClogMonitor.hpp"

#include <cmath>

#include "core/Simulation.hpp"
#include "physics/Inlet.hpp"

namespace cassini {

void ClogMonitor::setup(Simulation& sim) {
  every_ = std::max(1L, std::lround(cfg_.channel.clog_window / 1000 / sim.dt));
  last_change_ = sim.time;
  inlet_ = sim.find<Inlet>();
  check(sim);
  double v;  // a restart continues the window where it was
  if (sim.restart_value("clog.last_change", v)) last_change_ = v;
  if (sim.restart_value("clog.rest_since", v)) rest_since_ = v;
  publish(sim);
}

void ClogMonitor::end_of_step(Simulation& sim) {
  if (sim.step_count % every_ == 0) check(sim);
}

void ClogMonitor::check(Simulation& sim) {
  const ChannelConfig& ch = cfg_.channel;
  const ParticleStore& p = sim.particles;
  const double neck_lo = ch.neck_x0 - 2 * cfg_.max_radius();
  long local[2] = {static_cast<long>(sim.halo.removed_upper), 0}, global[2];
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double x = p.x[i][0];
    if (x > ch.pass_x) ++local[0];
    else if (x > neck_lo) ++local[1];
  }
  MPI_Allreduce(local, global, 2, MPI_LONG, MPI_SUM, sim.domain.comm);
  if (global[0] != escaped_ || global[1] != in_neck_) {
    escaped_ = global[0];
    in_neck_ = global[1];
    last_change_ = sim.time;
  }
  const bool holding = in_neck_ > 0 && sim.time > last_change_;
  if (holding && ch.rest_speed > 0 && at_rest(sim)) {
    if (rest_since_ < 0) rest_since_ = sim.time;
  } else {
    rest_since_ = -1;
  }
  clogged_ = in_neck_ > 0 && sim.time - last_change_ >= ch.clog_window;
  if (clogged_) {
    sim.finish("clogged: no change at the neck for " + std::to_string(ch.clog_window) + " s");
  } else if (rest_since_ >= 0 && sim.time - rest_since_ >= 0.01 * ch.clog_window) {
    clogged_ = true;
    sim.finish("clogged: at rest behind the clog since t = " + std::to_string(rest_since_) + " s (a fixed point)");
  }
  publish(sim);
}

bool ClogMonitor::at_rest(Simulation& sim) const {
  // Collective: every rank reaches this with the same `holding`.
  double v2 = inlet_ && !inlet_->full() ? 1e300 : 0;
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) v2 = std::max(v2, p.v[i].squaredNorm());
  MPI_Allreduce(MPI_IN_PLACE, &v2, 1, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  const double vr = cfg_.channel.rest_speed;
  return v2 < vr * vr;
}

void ClogMonitor::publish(Simulation& sim) const {
  sim.set_result("clogged", clogged_ ? "true" : "false");
  sim.set_result("escapees", std::to_string(escaped_));
  sim.set_result("clog_time", clogged_ ? std::to_string(last_change_) : "null");
  sim.set_result("particles_in_neck", std::to_string(in_neck_));
}

}  // namespace cassini
