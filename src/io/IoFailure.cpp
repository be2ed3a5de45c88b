#include "io/IoFailure.hpp"

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <regex>

#include <hdf5.h>

namespace cassini {
namespace {

std::string& log_path() {
  static std::string path;
  return path;
}

herr_t innermost(unsigned n, const H5E_error2_t* err, void* out) {
  // The walk goes from the innermost (the file driver: errno and strerror) outwards.
  if (n == 0 && err->desc) *static_cast<std::string*>(out) = err->desc;
  return 0;
}

}  // namespace

void set_io_failure_log(const std::string& path) { log_path() = path; }

void io_failure(const std::string& file, const std::string& reason) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const std::string msg = "error: cannot write " + file + ": " + reason +
                          " (rank " + std::to_string(rank) + "; the run stops; earlier complete files are intact)";
  std::cerr << msg << std::endl;
  if (!log_path().empty()) std::ofstream(log_path(), std::ios::app) << msg << "\n";
  MPI_Abort(MPI_COMM_WORLD, 4);
  std::abort();  // not reached
}

std::string hdf5_failure_reason() {
  std::string desc;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost, &desc);
  // The sec2 and MPI-IO drivers put the OS's words in the description:
  // "... errno = 28, error message = 'No space left on device', ..." or "MPI_File_...: <MPI error string>".
  std::smatch m;
  if (std::regex_search(desc, m, std::regex("error message = '([^']*)'"))) return m[1];
  if (std::regex_search(desc, m, std::regex("MPI_File[A-Za-z_]* failed[^:]*:? *(.*)"))) return m[1].str().empty() ? desc : m[1].str();
  return desc.empty() ? "HDF5 reported a write error" : desc;
}

bool injected_write_failure(const std::string& file, int rank) {
  const char* spec = std::getenv("CASSINI_FAIL_WRITE");
  if (!spec) return false;
  std::string s(spec);
  int on_rank = -1;
  if (const auto at = s.find('@'); at != std::string::npos) {
    on_rank = std::atoi(s.c_str() + at + 1);
    s = s.substr(0, at);
  }
  return file.find(s) != std::string::npos && (on_rank < 0 || on_rank == rank);
}

}  // namespace cassini
