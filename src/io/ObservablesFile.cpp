#include "io/ObservablesFile.hpp"

#include <cstdint>
#include <string>

#include "io/Hdf5Handle.hpp"

namespace cassini {

namespace {

using h5::check;
using h5::Handle;

// An extendible [T] or [T][width] dataset, chunked along time.
void create_series(hid_t parent, const char* name, hid_t type, hsize_t width) {
  const int rank = width > 1 ? 2 : 1;
  const hsize_t dims[2] = {0, width}, maxdims[2] = {H5S_UNLIMITED, width}, chunk[2] = {256, width};
  Handle space(H5Screate_simple(rank, dims, maxdims), H5Sclose, "space");
  Handle plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "dcpl");
  check(H5Pset_chunk(plist, rank, chunk), "chunk");
  Handle d(H5Dcreate2(parent, name, type, space, H5P_DEFAULT, plist, H5P_DEFAULT), H5Dclose, name);
}

// The unit of each of observables.csv's own quantities (the modules' columns have none recorded).
std::string unit_of(const std::string& name) {
  if (name == "kinetic_energy" || name == "elastic_energy") return "kg m2 s-2";
  if (name == "momentum") return "kg m s-1";
  if (name == "velocity_variance" || name == "granular_temperature") return "m2 s-2";
  return "";  // counts and ratios
}

// Appends one row to an extendible series.
void append_row(hid_t parent, const char* name, hid_t type, const void* data) {
  Handle d(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose, name);
  hsize_t dims[2] = {0, 1};
  int rank = 1;
  {
    Handle s(H5Dget_space(d), H5Sclose, "space");
    rank = H5Sget_simple_extent_ndims(s);
    H5Sget_simple_extent_dims(s, dims, nullptr);
  }
  hsize_t grown[2] = {dims[0] + 1, dims[1]};
  check(H5Dset_extent(d, grown), "extend " + std::string(name));
  Handle fs(H5Dget_space(d), H5Sclose, "space");
  const hsize_t start[2] = {dims[0], 0}, count[2] = {1, rank == 2 ? dims[1] : 1};
  check(H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr), "hyperslab");
  Handle mem(H5Screate_simple(rank, count, nullptr), H5Sclose, "mem");
  check(H5Dwrite(d, type, mem, fs, H5P_DEFAULT, data), "append " + std::string(name));
}

}  // namespace

void ObservablesFile::append(long step, double time, const Row& row) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // a failure is reported once, by io_failure
  const h5::WriteScope writing(path_);
  if (injected_write_failure(path_, 0)) io_failure(path_, "No space left on device (injected by CASSINI_FAIL_WRITE)");
  if (!created_) {
    Handle file(H5Fcreate(path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, "create " + path_);
    h5::h5md_header(file);
    {
      // One clock for every observable (sampled together): the first element's step and
      // time, hard-linked into the others (H5MD 1.1 shared step/time).
      Handle obs = h5::group(file, "observables");
      const std::string clock = "/observables/" + row.front().first;
      for (const auto& [name, value] : row) {
        Handle g = h5::group(obs, name);
        if (name == row.front().first) {
          create_series(g, "step", H5T_NATIVE_INT64, 1);
          create_series(g, "time", H5T_NATIVE_DOUBLE, 1);
          h5::unit(g, "time", "s");
        } else {
          check(H5Lcreate_hard(g, (clock + "/step").c_str(), g, "step", H5P_DEFAULT, H5P_DEFAULT), "link step");
          check(H5Lcreate_hard(g, (clock + "/time").c_str(), g, "time", H5P_DEFAULT, H5P_DEFAULT), "link time");
        }
        create_series(g, "value", H5T_NATIVE_DOUBLE, value.size());
        h5::unit(g, "value", unit_of(name));
      }
    }
    file.close_checked("close " + path_);
    created_ = true;
  }
  Handle file(H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose, "open " + path_);
  const std::int64_t s = step;
  for (const auto& [name, value] : row) {
    Handle g(H5Gopen2(file, ("observables/" + name).c_str(), H5P_DEFAULT), H5Gclose, "observables/" + name);
    if (name == row.front().first) {
      append_row(g, "step", H5T_NATIVE_INT64, &s);
      append_row(g, "time", H5T_NATIVE_DOUBLE, &time);
    }
    append_row(g, "value", H5T_NATIVE_DOUBLE, value.data());
  }
  file.close_checked("close " + path_);
}

}  // namespace cassini
