#include "physics/channel/ClogMonitor.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/channel/ChannelConfig.hpp"
#include "physics/channel/ChannelGeometry.hpp"
#include "physics/channel/Inlet.hpp"
#include "physics/channel/StokesDrag.hpp"

namespace cassini {

ModuleKind ClogMonitor::kind() {
  return {"clog", {"channel"}, nullptr, [](Simulation& sim) { return std::make_unique<ClogMonitor>(sim.cfg); }};
}

void ClogMonitor::setup(Simulation& sim) {
  every_ = std::max(1L, std::lround(cfg_.get<ChannelConfig>().clog_window / 1000 / sim.dt));
  last_change_ = sim.time;
  inlet_ = sim.find<Inlet>();
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  if (ch.backflush > 0 && !sim.find<StokesDrag>())
    throw ConfigError(cfg_.source + ": key 'clog.backflush': a back-flush reverses the drag's flow; add the \"drag\" module");
  if (ch.clear_stalled && !sim.find<StokesDrag>())
    throw ConfigError(cfg_.source + ": key 'clog.clear_stalled': stalled beads are told by the drag's flow; add the \"drag\" module");
  const ChannelGeometry geo(ch);
  zone_lo_ = ch.neck_x0 - 3 * ch.neck_width;
  zone_hi_ = ch.neck_x0 - ch.neck_width;
  zone_volume_ = stretch_volume(geo, zone_lo_, zone_hi_);
  double v;  // a restart continues where it was
  if (sim.restart_value("clog.front_time", v)) front_time_ = v;
  if (sim.restart_value("clog.escaped_at_front", v)) escaped_at_front_ = std::lround(v);
  if (sim.restart_value("clog.count_time", v)) count_time_ = v;
  if (sim.restart_value("clog.escaped_at_count", v)) escaped_at_count_ = std::lround(v);
  if (sim.restart_value("clog.avalanche_start", v)) avalanche_start_ = std::lround(v);
  if (sim.restart_value("clog.resumed_at", v)) resumed_at_ = v;
  if (sim.restart_value("clog.removed", v)) removed_ = std::lround(v);
  if (sim.restart_value("clog.longest_pause", v)) longest_pause_ = v;
  if (sim.restart_value("clog.count_at", v)) count_at_ = v;
  if (sim.restart_value("clog.recovery_clogs", v)) recovery_clogs_ = std::lround(v);
  if (sim.restart_value("clog.phi_beyond_clear", v)) phi_beyond_clear_ = v;
  if (sim.restart_value("clog.backflush_until", v) && v >= 0) {
    backflush_until_ = v;
    sim.find<StokesDrag>()->set_flow_sign(-1);
  }
  if (sim.restart_value("clog.avalanches", v))
    for (long k = 0; k < std::lround(v); ++k) {
      double s = 0, t = 0, c = 0;
      sim.restart_value("clog.avalanche." + std::to_string(k), s);
      sim.restart_value("clog.avalanche_start." + std::to_string(k), t);
      sim.restart_value("clog.avalanche_clog." + std::to_string(k), c);
      sizes_.push_back(std::lround(s));
      starts_.push_back(t);
      clogs_.push_back(c);
    }
  check(sim);
  if (sim.restart_value("clog.last_change", v)) last_change_ = v;
  if (sim.restart_value("clog.rest_since", v)) rest_since_ = v;
  publish(sim);
}

double ClogMonitor::stretch_volume(const ChannelGeometry& geo, double lo, double hi) const {
  const int n = 200;  // midpoint rule over the channel's width (walls are straight pieces)
  double v = 0;
  for (int k = 0; k < n; ++k) {
    const double x = lo + (k + 0.5) * (hi - lo) / n;
    v += (geo.upper_y(x) - geo.lower_y(x)) * (hi - lo) / n;
  }
  return v * (cfg_.hi[2] - cfg_.lo[2]);
}

void ClogMonitor::save_state(std::vector<std::pair<std::string, double>>& out) const {
  out.insert(out.end(), {{"clog.last_change", last_change_}, {"clog.rest_since", rest_since_},
                         {"clog.front_time", front_time_}, {"clog.escaped_at_front", double(escaped_at_front_)},
                         {"clog.count_time", count_time_}, {"clog.escaped_at_count", double(escaped_at_count_)},
                         {"clog.avalanche_start", double(avalanche_start_)}, {"clog.resumed_at", resumed_at_},
                         {"clog.removed", double(removed_)}, {"clog.avalanches", double(sizes_.size())},
                         {"clog.backflush_until", backflush_until_}, {"clog.longest_pause", longest_pause_},
                         {"clog.count_at", count_at_}, {"clog.recovery_clogs", double(recovery_clogs_)},
                         {"clog.phi_beyond_clear", phi_beyond_clear_}});
  for (std::size_t k = 0; k < sizes_.size(); ++k) {
    out.emplace_back("clog.avalanche." + std::to_string(k), double(sizes_[k]));
    out.emplace_back("clog.avalanche_start." + std::to_string(k), starts_[k]);
    out.emplace_back("clog.avalanche_clog." + std::to_string(k), clogs_[k]);
  }
}

void ClogMonitor::end_of_step(Simulation& sim) {
  if (sim.step_count % every_ == 0) check(sim);
}

void ClogMonitor::check(Simulation& sim) {
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  if (backflush_until_ >= 0) {
    if (sim.time < backflush_until_) return;
    backflush_until_ = -1;  // forwards again: a fresh avalanche from the next count
    sim.find<StokesDrag>()->set_flow_sign(1);
    in_neck_ = -1;
    escaped_ = -1;
  }
  const bool resuming = escaped_ < 0;
  const ParticleStore& p = sim.particles;
  const double neck_lo = ch.neck_x0 - 2 * cfg_.max_radius();
  long local[3] = {static_cast<long>(sim.halo.removed_upper), 0, 0}, global[3];
  double zone = 0;  // solid volume in the approach zone
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double x = p.x[i][0];
    if (x > ch.pass_x) ++local[0];
    else if (x > neck_lo) ++local[1];
    else if (x >= zone_lo_) ++local[2];
    if (x >= zone_lo_ && x < zone_hi_) zone += 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius[i], 3);
  }
  MPI_Allreduce(local, global, 3, MPI_LONG, MPI_SUM, sim.domain.comm);
  MPI_Allreduce(MPI_IN_PLACE, &zone, 1, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  approach_phi_ = zone / zone_volume_;
  if (front_time_ < 0 && zone >= ch.front_fraction * ch.inlet_fraction * zone_volume_) {
    front_time_ = sim.time;
    escaped_at_front_ = global[0];
  }
  if (count_time_ < 0 && ch.count_from >= 0 && sim.time >= ch.count_from - 0.5 * sim.dt) {  // t sums steps: round
    count_time_ = sim.time;
    escaped_at_count_ = global[0];
  }
  if (resuming || (count_at_ >= 0 && sim.time >= count_at_ - 0.5 * sim.dt)) {  // t sums steps: round
    avalanche_start_ = global[0];
    resumed_at_ = sim.time;
    count_at_ = -1;
  }
  // Continuous mode: once an arch has been cleared, the pile behind it can jam again just
  // upstream of the neck zone; beads anywhere in the approach then count as a standing clog,
  // and while the neck is empty, beads entering or leaving the approach as a change (else the
  // first beads to reach an emptied approach would look like a standstill that began at the
  // clearing). While beads sit in the neck only the neck is watched, as for the first clog: a
  // pile growing behind an arch does not end its standstill.
  const bool approach_watched = ch.continuous && !sizes_.empty();
  const long approach = approach_watched && global[1] == 0 ? global[2] : -1;
  if (global[0] != escaped_ || global[1] != in_neck_ || approach != in_approach_) {
    // A standstill at an occupied neck that ends: how close it came to counting as a clog.
    if (!resuming && in_neck_ > 0) longest_pause_ = std::max(longest_pause_, sim.time - last_change_);
    escaped_ = global[0];
    in_neck_ = global[1];
    in_approach_ = approach;
    last_change_ = sim.time;
  }
  const bool occupied = in_neck_ > 0 || (approach_watched && global[2] > 0);
  const bool holding = occupied && sim.time > last_change_;
  // clog.rest_region = "neck" ends early only at an arch in the neck (a clog standing in the
  // approach of an emptied neck, continuous mode, waits out the window).
  const bool watched = ch.rest_speed > 0 && (!ch.rest_neck_only || in_neck_ > 0);
  if (holding && watched && at_rest(sim, neck_lo)) {
    if (rest_since_ < 0) rest_since_ = sim.time;
  } else {
    rest_since_ = -1;
  }
  if (occupied && sim.time - last_change_ >= ch.clog_window)
    clog_found(sim, "clogged: no change at the neck for " + std::to_string(ch.clog_window) + " s");
  else if (rest_since_ >= 0 && sim.time - rest_since_ >= 0.01 * ch.clog_window)
    clog_found(sim, "clogged: at rest behind the clog since t = " + std::to_string(rest_since_) + " s (a fixed point)");
  publish(sim);
}

std::string ClogMonitor::ends_run_at() const {
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  return ch.continuous ? "clog " + std::to_string(ch.avalanches) : "a clog";
}

void ClogMonitor::clog_found(Simulation& sim, const std::string& why) {
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  clogged_ = true;
  // A clog whose standstill began before counting resumed (clog.recover) is not an avalanche.
  if (count_at_ >= 0 || last_change_ < resumed_at_) {
    ++recovery_clogs_;
  } else {
    sizes_.push_back(escaped_ - avalanche_start_);
    starts_.push_back(resumed_at_);
    clogs_.push_back(last_change_);
  }
  if (!ch.continuous || static_cast<int>(sizes_.size()) >= ch.avalanches) {
    sim.finish(why + (ch.continuous ? " (clog " + std::to_string(sizes_.size()) + ")" : ""));
    return;
  }
  ParticleStore& p = sim.particles;
  if (ch.backflush > 0) {
    for (std::size_t i = 0; i < p.nlocal; ++i)
      if (p.x[i][0] > ch.pass_x) p.x[i][0] = cfg_.hi[0] + 1.0;  // out through the outlet
    sim.find<StokesDrag>()->set_flow_sign(-1);
    backflush_until_ = sim.time + ch.backflush;
    clogged_ = false;
    rest_since_ = -1;
    return;
  }
  // Clear the arch: the beads within a diameter of the most downstream bead that has not
  // escaped (at the neck: the neck zone). They leave the domain upstream (removed at the next
  // rebuild, which their displacement forces; not escapees). The clock and counts restart.
  double lead = -1e300;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (p.x[i][0] <= ch.pass_x) lead = std::max(lead, p.x[i][0]);
  MPI_Allreduce(MPI_IN_PLACE, &lead, 1, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  // With clog.clear_length, everything from that far upstream of the neck on (the pile) goes too;
  // with clog.clear_stalled, every bead upstream of the escape line that has (nearly) stopped in
  // the flow: the jammed pile, however long it grew while the clog was being confirmed.
  const double arch_lo = std::min(lead - 2 * cfg_.max_radius(), ch.clear_length > 0 ? ch.neck_x0 - ch.clear_length : 1e300);
  const StokesDrag* drag = ch.clear_stalled ? sim.find<StokesDrag>() : nullptr;
  auto cleared = [&](std::size_t i) {
    const double x = p.x[i][0];
    if (x > ch.pass_x) return false;
    return x > arch_lo || (drag && p.v[i].norm() < kStalled * drag->flow().velocity(p.x[i]).norm());
  };
  std::vector<char> goes(p.nlocal);
  double tail = arch_lo;  // the most upstream bead that goes
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if ((goes[i] = cleared(i))) tail = std::min(tail, p.x[i][0]);
  MPI_Allreduce(MPI_IN_PLACE, &tail, 1, MPI_DOUBLE, MPI_MIN, sim.domain.comm);
  // How dense the channel is just upstream of what goes (a diameter's stretch): the flowing
  // suspension's ~0.2, or ~0.5-0.6 where a pile reaches beyond it.
  double beyond = 0;
  const double beyond_lo = tail - ch.neck_width;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (!goes[i] && p.x[i][0] >= beyond_lo && p.x[i][0] < tail) beyond += 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius[i], 3);
  MPI_Allreduce(MPI_IN_PLACE, &beyond, 1, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  phi_beyond_clear_ = std::max(phi_beyond_clear_, beyond / stretch_volume(ChannelGeometry(ch), beyond_lo, tail));
  long gone = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (goes[i]) {
      p.x[i][0] = cfg_.lo[0] - 1.0;
      p.v[i] = Vec3::Zero();
      ++gone;
    }
  MPI_Allreduce(MPI_IN_PLACE, &gone, 1, MPI_LONG, MPI_SUM, sim.domain.comm);
  removed_ += gone;
  clogged_ = false;
  rest_since_ = -1;
  in_neck_ = -1;
  last_change_ = sim.time;
  if (ch.recover > 0) {
    count_at_ = sim.time + ch.recover;  // check() starts the count then
  } else {
    resumed_at_ = sim.time;
    avalanche_start_ = escaped_;
  }
}

bool ClogMonitor::at_rest(Simulation& sim, double neck_lo) const {
  // Collective: every rank reaches this with the same `holding`.
  const ChannelConfig& ch = cfg_.get<ChannelConfig>();
  double v2 = inlet_ && !inlet_->full() && !ch.rest_neck_only ? 1e300 : 0;
  // "neck": the beads the neck's state counts (from neck_lo to pass_x).
  const double lo = ch.rest_neck_only ? neck_lo : -1e300;
  const double hi = ch.rest_neck_only ? ch.pass_x : 1e300;
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (p.x[i][0] > lo && p.x[i][0] <= hi) v2 = std::max(v2, p.v[i].squaredNorm());
  MPI_Allreduce(MPI_IN_PLACE, &v2, 1, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  return v2 < ch.rest_speed * ch.rest_speed;
}

void ClogMonitor::publish(Simulation& sim) const {
  auto list = [](const auto& v) {
    std::ostringstream os;
    os.precision(10);
    os << "[";
    for (std::size_t k = 0; k < v.size(); ++k) os << (k ? ", " : "") << v[k];
    return os.str() + "]";
  };
  sim.set_result("front_time", front_time_ >= 0 ? std::to_string(front_time_) : "null");
  // A clog whose standstill began before a count started (its pile can fill the approach and
  // pass the front for it) is not the counted regime's: null, as when the count never started.
  auto counted = [&](double since) { return since >= 0 && !(clogged_ && last_change_ < since); };
  sim.set_result("escapees_after_front", counted(front_time_) ? std::to_string(escaped_ - escaped_at_front_) : "null");
  if (cfg_.get<ChannelConfig>().count_from >= 0) {
    sim.set_result("count_time", count_time_ >= 0 ? std::to_string(count_time_) : "null");
    sim.set_result("escapees_after_count", counted(count_time_) ? std::to_string(escaped_ - escaped_at_count_) : "null");
  }
  if (cfg_.get<ChannelConfig>().continuous) {
    sim.set_result("avalanches", list(sizes_));
    sim.set_result("avalanche_starts", list(starts_));
    sim.set_result("avalanche_clogs", list(clogs_));
    sim.set_result("removed_from_neck", std::to_string(removed_));
    sim.set_result("recovery_clogs", std::to_string(recovery_clogs_));
    if (!sizes_.empty() && cfg_.get<ChannelConfig>().backflush == 0) sim.set_result("phi_beyond_clear", std::to_string(phi_beyond_clear_));
    const bool open = !clogged_ && count_at_ < 0 && backflush_until_ < 0 && escaped_ >= 0;
    sim.set_result("open_avalanche", open ? std::to_string(escaped_ - avalanche_start_) : "null");
    sim.set_result("open_avalanche_start", open ? std::to_string(resumed_at_) : "null");
  }
  std::ostringstream ratio;  // the neck over the inserted species' largest diameter
  ratio << cfg_.get<ChannelConfig>().neck_width / (2 * cfg_.species[cfg_.init_species].radius_max);
  sim.set_result("D_over_d", ratio.str());
  sim.set_result("clogged", clogged_ ? "true" : "false");
  sim.set_result("escapees", std::to_string(escaped_));
  sim.set_result("clog_time", clogged_ ? std::to_string(last_change_) : "null");
  sim.set_result("particles_in_neck", std::to_string(in_neck_));
  sim.set_result("longest_pause", std::to_string(longest_pause_));
}

}  // namespace cassini
