#pragma once
// What a run leaves in its output directory: run.log (everything rank 0 printed),
// observables.csv and the same as H5MD (observables.h5md), per-rank text dumps (until the HDF5 snapshots land), the resolved case
// file, and summary.json at the end. Refuses to write into an existing, non-empty directory
// unless forced.
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <mpi.h>

#include "io/ObservablesFile.hpp"

namespace cassini {

class Simulation;

class RunOutput {
 public:
  RunOutput(const std::string& dir, bool force, MPI_Comm comm);
  void log(const std::string& line);                 // rank 0: stdout and run.log
  void write_text(const std::string& name, const std::string& text);  // rank 0
  void observe(Simulation& sim);                     // collective: one observables row
  void dump(const Simulation& sim, const std::string& tag);  // every rank its own file
  void summary(Simulation& sim, double wall_seconds, long steps_run);  // collective
  void snapshot(Simulation& sim);                    // collective: dir/snap_<step>.h5md
  const std::string& dir() const { return dir_; }
  std::string case_text;                             // resolved case, stored in snapshots

 private:
  std::string dir_;
  int rank_ = 0;
  MPI_Comm comm_;
  std::ofstream log_, obs_;
  std::unique_ptr<ObservablesFile> h5obs_;
};

}  // namespace cassini
