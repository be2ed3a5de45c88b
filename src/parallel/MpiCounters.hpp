#pragma once
// Counts of the MPI calls this process makes, by kind: collectives (calls and bytes sent into
// them) and point-to-point sends (messages and bytes). Measured, not estimated: MpiCounters.cpp
// defines MPI's own entry points (the standard profiling interface, PMPI) around the real
// ones, so every call is counted, whichever file makes it (HDF5's included). A few additions
// per call: cheap enough to be always on.
#include <array>
#include <cstdint>

namespace cassini::mpi_counters {

enum Kind { Allreduce, Reduce, Bcast, Barrier, Allgather, Alltoall, Gather, Scan, Send, kKinds };
inline constexpr const char* kNames[kKinds] = {"allreduce", "reduce", "bcast", "barrier", "allgather",
                                               "alltoall", "gather", "scan", "send"};

struct Counts {
  std::array<std::int64_t, kKinds> calls{}, bytes{};
  std::int64_t collectives() const { return calls[Allreduce] + calls[Reduce] + calls[Bcast] + calls[Barrier] +
                                            calls[Allgather] + calls[Alltoall] + calls[Gather] + calls[Scan]; }
};

Counts now();  // since the process started (v- and non-blocking variants counted with their plain kind)
inline std::int64_t collective_calls = 0;  // all collective kinds, for StageTimers' per-stage counts

}  // namespace cassini::mpi_counters
