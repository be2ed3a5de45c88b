#pragma once
// A write that failed (disk full, I/O error, permission) ends the whole job at once.
//
// Why abort rather than throw: the snapshot is written collectively, and a failure is often
// seen by one rank only (the one whose MPI-IO aggregator hit the full disk). A rank that
// throws and closes the file while another still writes deadlocks both. MPI_Abort ends every
// rank within about a second; the frame being written stays under its `.partial` name, so
// every file that looks complete is complete.
#include <functional>
#include <string>

#include <mpi.h>

namespace cassini {

// Prints "error: cannot write FILE: REASON" once (to stderr and, when it can, to run.log)
// and aborts all ranks with exit code 4.
[[noreturn]] void io_failure(const std::string& file, const std::string& reason);

// Where io_failure also appends its message (rank 0's run.log); empty: stderr only.
void set_io_failure_log(const std::string& path);
// What io_failure calls with its message before it aborts, on the rank that failed: the run's
// summary.json says "error" and why (RunOutput; best effort, it must not fail itself). Empty: none.
void set_io_failure_summary(std::function<void(const std::string&)> record);

// The operating system's reason why a write to `file` failed ("No space left on device"):
// from HDF5's error stack when it has one, else by asking the file system.
std::string hdf5_failure_reason(const std::string& file);
std::string os_write_reason(const std::string& file);

// Tests only: CASSINI_FAIL_WRITE=<file name part>[@rank] makes the first matching write
// on that rank fail as if the disk were full (for machines where a test cannot mount a tmpfs).
bool injected_write_failure(const std::string& file, int rank);

}  // namespace cassini
