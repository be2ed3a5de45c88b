#pragma once
// Many small independent runs of one case with different seeds (clogging statistics): each
// MPI rank runs its own whole simulation on MPI_COMM_SELF, which for a few hundred particles
// is far more efficient than splitting one run over ranks. Run k uses seed base_seed + k and
// goes to rank k mod nranks. Each rank appends a row per finished run to
// <out>/ensemble.rank<r>.csv (nothing is lost if the job is killed); at the end rank 0 merges
// them into <out>/ensemble.csv ordered by run.
#include <string>

#include "core/Config.hpp"

namespace cassini {

class RunOutput;

// Returns the exit code: 0, or 128 + the signal that interrupted it (summary.json says which).
int run_ensemble(const Config& cfg, int runs, RunOutput& out);

}  // namespace cassini
