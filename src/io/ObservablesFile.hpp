#pragma once
// The run's observables as an H5MD 1.1 file (observables.h5md, beside observables.csv):
//   observables/<name>/{step[T], time[T], value[T] or value[T][width]}
// at the observables' own cadence (output.observe_every), e.g. with h5py
//   f["observables/kinetic_energy/value"][:] against f["observables/kinetic_energy/time"][:].
// Rank 0 appends one row per call and closes the file each time, so a killed run leaves every
// row written before it readable.
#include <string>
#include <utility>
#include <vector>

namespace cassini {

class ObservablesFile {
 public:
  using Row = std::vector<std::pair<std::string, std::vector<double>>>;  // name -> value(s)
  explicit ObservablesFile(std::string path) : path_(std::move(path)) {}
  void append(long step, double time, const Row& row);

 private:
  std::string path_;
  bool created_ = false;
};

}  // namespace cassini
