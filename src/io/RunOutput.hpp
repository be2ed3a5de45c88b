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

#include "core/RunSink.hpp"
#include "io/ObservablesFile.hpp"

namespace cassini {

class Simulation;

std::string json_number(double v);         // "null" for inf and NaN
std::string json_string(const std::string& text);

// A file or directory the run reads, and what names it ("the case file", "particles.file").
struct RunInput {
  std::string path, what;
};

class RunOutput : public RunSink {
 public:
  // Creates `dir` (marked as a run directory). Refuses, before touching anything: a file,
  // the working directory or a parent, a directory holding any of `keep` (every input the run
  // reads: the case file, the restart snapshot, particles.file, the flow cache), a non-empty
  // directory without --force, and with --force one that cassini did not make.
  RunOutput(const std::string& dir, bool force, MPI_Comm comm, const std::vector<RunInput>& keep = {});
  // A run that wrote no observables row (an ensemble, an early error) still leaves
  // observables.csv with its column names.
  ~RunOutput();
  void log(const std::string& line) override;        // rank 0: stdout and run.log
  void log_only(const std::string& line);            // rank 0: run.log (already on stderr)
  void write_text(const std::string& name, const std::string& text);  // rank 0
  void observe(Simulation& sim) override;            // collective: one observables row
  void dump(const Simulation& sim, const std::string& tag) override;  // every rank its own file
  // Collective. status: "completed", "stopped by a guard" or "error"; reason: why it ended.
  void summary(Simulation& sim, double wall_seconds, long steps_run, const std::string& status,
               const std::string& reason);
  // An error before or outside the step loop: rank 0 writes it, or (any_rank) the rank that
  // failed alone, just before it aborts the job (the other ranks cannot be waited for; best
  // effort, never a half-written summary.json).
  void error_summary(const std::string& reason, bool any_rank = false);
  // Rank 0, after summary(): the table of time per stage of the step (Simulation::record.timers).
  const std::string& timing() const { return timing_; }
  void snapshot(Simulation& sim) override;           // collective: dir/snap_<step>.h5md
  const std::string& dir() const { return dir_; }
  std::string case_text;                             // resolved case, stored in snapshots
  std::string run_id;                                // names the run in snapshots (kept on restart)
  // Provenance (summary.json, run.log): which code, when, where, how and from what.
  std::string command;                               // the command line as given (--set overrides included)
  std::string restarted_from;                        // the snapshot a continuation starts from, "" if none
  std::string provenance_line() const;               // one line for run.log
  // Collective. A whole ensemble ends here: status, runs asked for and finished, where the table is.
  void ensemble_summary(const std::string& status, const std::string& reason, int runs, int finished, double wall);

 private:
  std::string provenance_json() const;                // the provenance members of summary.json
  std::string started_;                              // ISO 8601 UTC, when the output directory was made
  std::string timing_;
  bool header_written_ = false;  // observables.csv: its header names the modules' columns too
  void write_header(const std::vector<std::pair<std::string, double>>& module_columns);  // rank 0
  void checked_flush(std::ofstream& out, const std::string& name);  // a failed write ends the job
  std::string dir_;
  int rank_ = 0;
  MPI_Comm comm_;
  std::ofstream log_, obs_;
  std::unique_ptr<ObservablesFile> h5obs_;
};

}  // namespace cassini
