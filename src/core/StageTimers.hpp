#pragma once
// Wall time per stage of the step on this rank, as LAMMPS's "MPI task timing breakdown": where
// a run's time goes, in run.log and summary.json. A scope costs two clock reads (~40 ns); a
// step has about ten, against microseconds of work even for a few particles.
#include <array>
#include <chrono>

namespace cassini {

struct StageTimers {
  enum Stage { Integrate, Pair, Neighbour, Comm, Modules, Output, kStages };
  static constexpr std::array<const char*, kStages> names = {"integrate", "pair", "neighbour", "comm", "modules",
                                                             "output"};
  // What each stage holds (run.log prints this under the table).
  static constexpr std::array<const char*, kStages> meaning = {
      "drift and kicks (initial and final integrate)", "particle-particle contacts",
      "neighbour-list builds, spatial sort", "ghost updates, migration, ghost builds, the per-step reduction",
      "every other module's forces and end-of-step work", "observables, dumps, snapshots, progress"};
  std::array<double, kStages> seconds{};

  // Scopes may nest (a snapshot rebuilds the neighbour list inside "output"): the inner
  // stage's time is taken out of the outer one, so the stages add up to the step loop.
  class Scope {
   public:
    Scope(StageTimers& t, Stage s) : t_(t), s_(s), parent_(t.current_), start_(std::chrono::steady_clock::now()) {
      t.current_ = this;
    }
    ~Scope() {
      const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
      t_.seconds[s_] += spent - inner_;
      if (parent_) parent_->inner_ += spent;
      t_.current_ = parent_;
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimers& t_;
    Stage s_;
    Scope* parent_;
    double inner_ = 0;
    std::chrono::steady_clock::time_point start_;
  };
  Scope scope(Stage s) { return Scope(*this, s); }

 private:
  Scope* current_ = nullptr;
};

}  // namespace cassini
