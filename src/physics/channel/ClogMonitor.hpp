#pragma once
// Counts the particles that escaped through the neck and ends the run at a permanent clog
// (spec section 3). Escapees: particles whose centre is beyond clog.pass_x, plus those that
// left through the outlet. The neck's state is the number of particles with centres between
// 2 radii upstream of the neck and pass_x. The run ends as clogged when neither the neck's
// state nor the escapee count has changed for clog.window seconds while particles sit in
// the neck (an empty, not yet reached neck is not a clog). Checked every window/1000.
// Results go to summary.json (escapees s, clog time, clogged) and to the snapshots.
//
// Stationary statistics. The channel starts empty and the first beads reach the neck as a
// dilute front that cannot arch. The front has passed once the approach zone, the channel
// between 3 D and D upstream of the neck, holds clog.front_fraction (default 0.5) of the
// inlet's volume fraction; summary.json gives that time and the escapees counted after it.
// Continuous mode (clog.mode = "continuous"): a clog is recorded, then the arch is removed (the
// beads within a diameter of the most downstream bead that has not escaped: at a clog in the
// neck, the neck's beads) and the flow goes on, until clog.avalanches clogs. A pile can then
// jam again just upstream of the neck zone: after the first clog, beads anywhere in the
// approach zone with no passage for clog.window also count as a clog. With clog.backflush > 0
// the clog is cleared as in the experiments instead: the beads past clog.pass_x (escaped,
// already counted) leave through the outlet, the flow runs backwards for clog.backflush
// seconds (re-suspending the pile), then forwards again; the next avalanche counts from there.
// Each clog's avalanche size (escapees since the flow last resumed), start time and clog time (its
// standstill's start) go to summary.json; avalanches that start after the front has passed are the stationary ones.
// Removing only the arch leaves the beads that were pressed against it at the neck, denser than
// the flowing suspension, and the next avalanche is short (docs/clogging.md). clog.clear_length
// also removes every bead up to that far upstream of the neck (the pile), and clog.recover
// counts the next avalanche only from that long after a clearing, once the flowing suspension
// has refilled the emptied stretch: a clog whose standstill began before counting resumed is
// then a recovery clog (recovery_clogs in summary.json), cleared like any other but not an
// avalanche. open_avalanche: the escapees of an avalanche still counting when the run ended
// (a censored avalanche), null otherwise. A pile can grow longer than any fixed stretch while a
// clog is confirmed: clog.clear_stalled also removes every bead upstream of the escape line moving
// slower than a tenth of the fluid at its centre (the jammed pile; flowing beads move with the
// fluid). phi_beyond_clear: the largest volume fraction found, at a clearing, in the diameter of
// channel just upstream of the beads cleared (~0.5-0.6: a pile remains; the suspension's is ~0.2).
//
// Early end at rest: once a clog holds, the pile behind it grows until it reaches the inlet
// and then stops dead (kinetic energy ~1e-35 J). A pile at rest under steady drag, with an
// inlet that is full, is a fixed point: nothing can change at the neck for the rest of the
// window. When every particle has been slower than clog.rest_speed for 1 % of the window
// (many relaxation and contact times) the run ends as clogged with the same clog time the
// full window would give. Typically a third of the window is skipped. Under the pressure drive
// the pile never comes to rest (the flow through a clog falls but keeps bringing beads), and
// clog.rest_region = "neck" (its default there) asks only the neck's beads, the arch, to be
// slower than clog.rest_speed (then 1e-4 of the mean velocity: the arch still creeps as the
// pile's load grows). Not a fixed point: checked against the full window on paired seeds
// (docs/clogging.md).
//
// The window's cost: every clog is confirmed by clog.window seconds of a packed pile, most of a
// run's contacts. longest_pause (summary.json, the ensemble CSV) is the longest standstill at
// the neck that ended in a passage. Any window longer than every such pause in an ensemble gives
// the same s and clog time, run by run, to the checks' interval (a standstill that no passage
// ends is the clog); scripts/clog_physics.py reports it per ensemble.
#include <algorithm>

#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"

namespace cassini {

struct Config;
class ChannelGeometry;

class ClogMonitor : public Module {
 public:
  static ModuleKind kind();
  explicit ClogMonitor(const Config& cfg) : cfg_(cfg) {}
  std::string name() const override { return "clog monitor"; }
  unsigned stages() const override { return kEndOfStep; }
  void setup(Simulation& sim) override;
  void end_of_step(Simulation& sim) override;
  std::string ends_run_at() const override;
  long escapees() const { return escaped_; }
  // escapees (since the start), in_neck and the approach's volume fraction (3 D to D upstream
  // of the neck: is the suspension arriving at the neck stationary?), as last counted.
  void observables(Simulation&, std::vector<std::pair<std::string, double>>& out) override {
    out.emplace_back("escapees", double(std::max(escaped_, 0L)));
    out.emplace_back("in_neck", double(std::max(in_neck_, 0L)));
    out.emplace_back("approach_phi", approach_phi_);
  }
  bool clogged() const { return clogged_; }
  double clog_time() const { return last_change_; }
  const std::vector<long>& avalanches() const { return sizes_; }
  const std::vector<double>& avalanche_starts() const { return starts_; }
  const std::vector<double>& avalanche_clogs() const { return clogs_; }
  long recovery_clogs() const { return recovery_clogs_; }
  double front_time() const { return front_time_; }
  double longest_pause() const { return longest_pause_; }
  long removed() const { return removed_; }
  void save_state(std::vector<std::pair<std::string, double>>& out) const override;

 private:
  void check(Simulation& sim);
  bool at_rest(Simulation& sim, double neck_lo) const;
  void clog_found(Simulation& sim, const std::string& why);
  void publish(Simulation& sim) const;
  const Config& cfg_;
  long every_ = 1;
  long escaped_ = 0, in_neck_ = -1;
  long in_approach_ = -1;  // beads between the approach's start and the neck zone when watched (continuous mode,
                          // empty neck), else -1
  double approach_phi_ = 0;  // solid volume fraction of the approach zone at the last count
  double rest_since_ = -1;  // time since which everything has been at rest (-1: moving)
  const class Inlet* inlet_ = nullptr;
  double last_change_ = 0;
  double longest_pause_ = 0;  // the longest standstill at an occupied neck that ended in a change
  bool clogged_ = false;
  double zone_lo_ = 0, zone_hi_ = 0, zone_volume_ = 0;  // the approach zone
  double front_time_ = -1;
  long escaped_at_front_ = 0;
  double count_time_ = -1;    // clog.count_from: when counting from it began (-1: not yet)
  long escaped_at_count_ = 0;
  long avalanche_start_ = 0;  // escapees when the flow last resumed
  double resumed_at_ = 0;
  double backflush_until_ = -1;  // the flow runs backwards until then (-1: it does not)
  long removed_ = 0;          // particles removed from the neck (continuous mode)
  double count_at_ = -1;      // clog.recover: the next avalanche counts from then (-1: counting)
  long recovery_clogs_ = 0;   // clogs before counting resumed (clog.recover)
  // The largest volume fraction, at a clearing, of the stretch one D long just upstream of the
  // beads cleared: a pile reaching beyond what was cleared shows up as ~0.5-0.6.
  double phi_beyond_clear_ = 0;
  // clog.clear_stalled: slower than this fraction of the fluid at its centre = stopped in a pile
  // (the flowing suspension moves with the fluid; a jammed pile is at rest to ~1e-6 of it).
  static constexpr double kStalled = 0.1;
  double stretch_volume(const ChannelGeometry& geo, double lo, double hi) const;
  std::vector<long> sizes_;
  std::vector<double> starts_;
  std::vector<double> clogs_;  // when each avalanche's clog began (its standstill's start)
};

}  // namespace cassini
