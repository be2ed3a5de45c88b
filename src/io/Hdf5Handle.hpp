#pragma once
// Thin RAII over HDF5 handles, and the few attribute helpers every HDF5 writer here needs.
#include <stdexcept>
#include <string>
#include <vector>

#include <hdf5.h>

namespace cassini::h5 {

struct Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) throw std::runtime_error("HDF5: " + what);
  }
  Handle(const Handle&) = delete;
  ~Handle() {
    if (id >= 0) close(id);
  }
  operator hid_t() const { return id; }
};

inline void check(herr_t r, const std::string& what) {
  if (r < 0) throw std::runtime_error("HDF5: " + what);
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

}  // namespace cassini::h5
