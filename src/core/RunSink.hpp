#pragma once
// Where a running simulation sends what it produces: progress lines, observables rows,
// dumps and snapshots. The step loop (core) only knows this interface; io/RunOutput.hpp
// implements it with files, so core never depends on the output formats.
#include <string>

namespace cassini {

class Simulation;

class RunSink {
 public:
  virtual ~RunSink() = default;
  virtual void log(const std::string& line) = 0;                       // rank 0: a progress line
  virtual void observe(Simulation& sim) = 0;                           // collective: one observables row
  virtual void dump(const Simulation& sim, const std::string& tag) = 0;  // every rank: its own state
  virtual void snapshot(Simulation& sim) = 0;                          // collective: the whole state
};

}  // namespace cassini
