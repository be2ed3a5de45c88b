#pragma once
// Thin RAII over HDF5 handles, and the few attribute helpers every HDF5 writer here needs.
#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <hdf5.h>

#include "core/Version.hpp"
#include "io/IoFailure.hpp"

namespace cassini::h5 {

// While a WriteScope is alive, any HDF5 failure ends the job at once through io_failure,
// naming the file being written: unwinding would close a collectively opened file on one
// rank while another still writes, which deadlocks. Outside one (reading), failures throw.
inline thread_local const std::string* writing = nullptr;
struct WriteScope {
  explicit WriteScope(const std::string& file) { writing = &file; }
  ~WriteScope() { writing = nullptr; }
  WriteScope(const WriteScope&) = delete;
};

inline void fail(const std::string& what) {
  if (writing) io_failure(*writing, hdf5_failure_reason(*writing));
  throw std::runtime_error("HDF5: " + what);
}

struct Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) fail(what);
  }
  Handle(const Handle&) = delete;
  ~Handle() {
    if (id >= 0) close(id);
  }
  // Closes now and checks: for a file, this is where cached data reaches the disk.
  void close_checked(const std::string& what) {
    const herr_t r = close(id);
    id = -1;
    if (r < 0) fail(what);
  }
  operator hid_t() const { return id; }
};

inline void check(herr_t r, const std::string& what) {
  if (r < 0) fail(what);
}

inline void attr_string(hid_t obj, const std::string& name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "type");
  check(H5Tset_size(type, value.size() + 1), "size");
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "space");
  Handle a(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, "attr " + name);
  check(H5Awrite(a, type, value.c_str()), "write attr " + name);
}

template <class T>
void attr_array(hid_t obj, const std::string& name, hid_t type, const std::vector<T>& v) {
  const hsize_t n = v.size();
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose, "space");
  Handle a(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, "attr " + name);
  check(H5Awrite(a, type, v.data()), "write attr " + name);
}

inline Handle group(hid_t parent, const std::string& name) {
  return Handle(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, "group " + name);
}

// Attributes of variable-length UTF-8 strings, as h5py and MDAnalysis write and read them (str,
// not bytes): a string array (H5MD's box@boundary, one per dimension) or, scalar, one string.
inline void attr_utf8(hid_t obj, const std::string& name, const std::vector<std::string>& values, bool scalar) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "type");
  check(H5Tset_size(type, H5T_VARIABLE), "size");
  check(H5Tset_cset(type, H5T_CSET_UTF8), "cset");
  std::vector<const char*> ptrs;
  for (const auto& v : values) ptrs.push_back(v.c_str());
  const hsize_t n = values.size();
  Handle space(scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), H5Sclose, "space");
  Handle a(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, "attr " + name);
  check(H5Awrite(a, type, ptrs.data()), "write attr " + name);
}
inline void attr_strings(hid_t obj, const std::string& name, const std::vector<std::string>& values) {
  attr_utf8(obj, name, values, false);
}

// A scalar integer attribute (H5MD's box@dimension).
inline void attr_int(hid_t obj, const std::string& name, int value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "space");
  Handle a(H5Acreate2(obj, name.c_str(), H5T_NATIVE_INT, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, "attr " + name);
  check(H5Awrite(a, H5T_NATIVE_INT, &value), "write attr " + name);
}

// The unit of a dataset (H5MD units module: "m", "m s-1", "kg m2 s-2"); none for a number.
inline void unit(hid_t parent, const std::string& dataset, const std::string& u) {
  if (u.empty()) return;
  Handle d(H5Dopen2(parent, dataset.c_str(), H5P_DEFAULT), H5Dclose, "open " + dataset);
  attr_utf8(d, "unit", {u}, true);
}

// The h5md/ metadata group every H5MD 1.1 file starts with: version, author, creator (with
// cassini's version and commit), and the units module (SI: every dataset with a dimension
// carries a `unit` attribute).
inline void h5md_header(hid_t file) {
  Handle h5md = group(file, "h5md");
  attr_array<int>(h5md, "version", H5T_NATIVE_INT, {1, 1});
  Handle author = group(h5md, "author");
  const char* user = std::getenv("USER");
  attr_string(author, "name", user && *user ? user : "cassini user");
  Handle creator = group(h5md, "creator");
  attr_string(creator, "name", "cassini");
  attr_string(creator, "version", std::string(version()) + " (commit " + commit() + ")");
  Handle modules = group(h5md, "modules");
  Handle units = group(modules, "units");
  attr_array<int>(units, "version", H5T_NATIVE_INT, {1, 0});
  attr_string(units, "system", "SI");
}

}  // namespace cassini::h5
