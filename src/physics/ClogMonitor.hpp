#pragma once
// Counts the particles that escaped through the neck and ends the run at a permanent clog
// (spec section 3). Escapees: particles whose centre is beyond clog.pass_x, plus those that
// left through the outlet. The neck's state is the number of particles with centres between
// 2 radii upstream of the neck and pass_x. The run ends as clogged when neither the neck's
// state nor the escapee count has changed for clog.window seconds while particles sit in
// the neck (an empty, not yet reached neck is not a clog). Checked every window/1000.
// Results go to summary.json (escapees s, clog time, clogged) and to the snapshots.
//
// Early end at rest: once a clog holds, the pile behind it grows until it reaches the inlet
// and then stops dead (kinetic energy ~1e-35 J). A pile at rest under steady drag, with an
// inlet that is full, is a fixed point: nothing can change at the neck for the rest of the
// window. When every particle has been slower than clog.rest_speed for 1 % of the window
// (many relaxation and contact times) the run ends as clogged with the same clog time the
// full window would give. Typically a third of the window is skipped.
#include "core/Module.hpp"

namespace cassini {

struct Config;

class ClogMonitor : public Module {
 public:
  explicit ClogMonitor(const Config& cfg) : cfg_(cfg) {}
  std::string name() const override { return "clog monitor"; }
  unsigned stages() const override { return kEndOfStep; }
  void setup(Simulation& sim) override;
  void end_of_step(Simulation& sim) override;
  long escapees() const { return escaped_; }
  bool clogged() const { return clogged_; }
  double clog_time() const { return last_change_; }
  void save_state(std::vector<std::pair<std::string, double>>& out) const override {
    out.insert(out.end(), {{"clog.last_change", last_change_}, {"clog.rest_since", rest_since_}});
  }

 private:
  void check(Simulation& sim);
  bool at_rest(Simulation& sim) const;
  void publish(Simulation& sim) const;
  const Config& cfg_;
  long every_ = 1;
  long escaped_ = 0, in_neck_ = -1;
  double rest_since_ = -1;  // time since which everything has been at rest (-1: moving)
  const class Inlet* inlet_ = nullptr;
  double last_change_ = 0;
  bool clogged_ = false;
};

}  // namespace cassini
