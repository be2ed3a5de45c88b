#include "io/IoFailure.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <utility>

#include <fcntl.h>
#include <hdf5.h>
#include <sys/statvfs.h>
#include <unistd.h>

namespace cassini {
namespace {

std::string& log_path() {
  static std::string path;
  return path;
}

std::function<void(const std::string&)>& summary_record() {
  static std::function<void(const std::string&)> record;
  return record;
}

herr_t collect(unsigned, const H5E_error2_t* err, void* out) {
  // The walk goes from the innermost (the file driver: errno and strerror) outwards.
  if (err->desc) *static_cast<std::string*>(out) += std::string(err->desc) + "\n";
  return 0;
}

}  // namespace

void set_io_failure_log(const std::string& path) { log_path() = path; }
void set_io_failure_summary(std::function<void(const std::string&)> record) { summary_record() = std::move(record); }

void io_failure(const std::string& file, const std::string& reason) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const std::string msg = "error: cannot write " + file + ": " + reason +
                          " (rank " + std::to_string(rank) + "; the run stops; earlier complete files are intact)";
  std::cerr << msg << std::endl;
  if (!log_path().empty()) std::ofstream(log_path(), std::ios::app) << msg << "\n";
  if (auto record = std::exchange(summary_record(), nullptr)) {  // once: a failure while recording ends here
    try {
      record(msg.substr(7));  // without "error: "
    } catch (...) {
    }
  }
  MPI_Abort(MPI_COMM_WORLD, 4);
  std::abort();  // not reached
}

std::string os_write_reason(const std::string& file) {
  // The MPI-IO driver reports a short write without errno: ask the file system, as a write
  // of the same kind would. A probe file is created beside the failed one and removed again.
  const std::string dir = std::filesystem::path(file).parent_path().string();
  struct statvfs fs {};
  if (statvfs(dir.empty() ? "." : dir.c_str(), &fs) == 0 && double(fs.f_bavail) * fs.f_frsize < 65536.0)
    return std::strerror(ENOSPC);
  const std::string probe = (dir.empty() ? std::string(".") : dir) + "/.cassini-write-probe";
  const int fd = ::open(probe.c_str(), O_CREAT | O_EXCL | O_WRONLY, 0600);  // never an existing file
  if (fd < 0) return errno == EEXIST ? "" : std::strerror(errno);
  static const char block[65536] = {};
  const ssize_t n = ::write(fd, block, sizeof block);
  const int err = n == ssize_t(sizeof block) ? 0 : (n < 0 ? errno : ENOSPC);
  ::close(fd);
  ::unlink(probe.c_str());
  return err ? std::strerror(err) : "";
}

std::string hdf5_failure_reason(const std::string& file) {
  std::string desc;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, collect, &desc);
  // The sec2 driver puts the OS's words in the description ("errno = 28, error message =
  // 'No space left on device'"); the MPI-IO driver does not.
  std::smatch m;
  if (std::regex_search(desc, m, std::regex("error message = '([^']*)'"))) return m[1];
  const std::string first = desc.substr(0, desc.find('\n'));
  const std::string os = os_write_reason(file);
  if (!os.empty()) return os;
  return first.empty() ? "HDF5 reported a write error" : "HDF5: " + first + " (the file system reports no error)";
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
