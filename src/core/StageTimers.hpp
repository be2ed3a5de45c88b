#pragma once
// Wall time per stage of the step on this rank, as LAMMPS's "MPI task timing breakdown": where
// a run's time goes, in run.log and summary.json. A scope reads the CPU's time-stamp counter
// twice (~10 ns each on x86-64; the system clock costs ~40 ns a read, which was 7 % of a
// clogging run's few-microsecond steps). Ticks become seconds through the steady clock over
// the same interval, so a counter that does not tick at the nominal rate is still right.
#include <array>
#include <chrono>
#include <cstdint>

#include "parallel/MpiCounters.hpp"

namespace cassini {

struct StageTimers {
  enum Stage { Integrate, Pair, Neighbour, Comm, Modules, Output, kStages };
  static constexpr std::array<const char*, kStages> names = {"integrate", "pair", "neighbour", "comm", "modules",
                                                             "output"};
  // What each stage holds (run.log prints this under the table).
  static constexpr std::array<const char*, kStages> meaning = {
      "drift and kicks (initial and final integrate)", "particle-particle contacts",
      "neighbour-list builds, spatial sort, modules' rebuild work (contact history)", "ghost updates, migration, ghost builds, the per-step reduction",
      "every other module's forces and end-of-step work", "observables, dumps, snapshots, progress"};

  StageTimers() { reset(); }
  // Starts counting afresh (the step loop only: not set-up, not a previous run).
  void reset() {
    ticks_.fill(0);
    collectives_.fill(0);
    mpi0_ = mpi_counters::now();
    tick0_ = now();
    clock0_ = std::chrono::steady_clock::now();
  }
  // Seconds per stage since reset().
  std::array<double, kStages> seconds() const {
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock0_).count();
    const std::uint64_t elapsed = now() - tick0_;
    const double per_tick = elapsed > 0 ? wall / double(elapsed) : 0.0;
    std::array<double, kStages> s{};
    for (int k = 0; k < kStages; ++k) s[k] = double(ticks_[k]) * per_tick;
    return s;
  }

  // MPI collectives per stage since reset() (which stage synchronises the ranks, and how often).
  const std::array<std::int64_t, kStages>& collectives() const { return collectives_; }
  // MPI calls and bytes by kind since reset().
  mpi_counters::Counts mpi() const {
    mpi_counters::Counts c = mpi_counters::now();
    for (int k = 0; k < mpi_counters::kKinds; ++k) {
      c.calls[k] -= mpi0_.calls[k];
      c.bytes[k] -= mpi0_.bytes[k];
    }
    return c;
  }

  // Scopes may nest (a snapshot rebuilds the neighbour list inside "output"): the inner
  // stage's time is taken out of the outer one, so the stages add up to the step loop.
  class Scope {
   public:
    Scope(StageTimers& t, Stage s)
        : t_(t), s_(s), parent_(t.current_), start_(now()), calls_(mpi_counters::collective_calls) {
      t.current_ = this;
    }
    ~Scope() {
      const std::uint64_t spent = now() - start_;
      t_.ticks_[s_] += spent - inner_;
      const std::int64_t calls = mpi_counters::collective_calls - calls_;
      t_.collectives_[s_] += calls - inner_calls_;
      if (parent_) {
        parent_->inner_ += spent;
        parent_->inner_calls_ += calls;
      }
      t_.current_ = parent_;
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimers& t_;
    Stage s_;
    Scope* parent_;
    std::uint64_t inner_ = 0;
    std::uint64_t start_;
    std::int64_t calls_, inner_calls_ = 0;
  };
  Scope scope(Stage s) { return Scope(*this, s); }

 private:
  static std::uint64_t now() {
#if defined(__x86_64__) || defined(__i386__)
    return __builtin_ia32_rdtsc();
#else
    return static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
#endif
  }
  std::array<std::uint64_t, kStages> ticks_{};
  std::array<std::int64_t, kStages> collectives_{};
  mpi_counters::Counts mpi0_;
  std::uint64_t tick0_ = 0;
  std::chrono::steady_clock::time_point clock0_;
  Scope* current_ = nullptr;
};

}  // namespace cassini
