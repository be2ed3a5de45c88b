#include "io/SnapshotSchema.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/ParticleStore.hpp"

namespace cassini {

double id_bits(std::int64_t id) {
  double d;
  std::memcpy(&d, &id, 8);
  return d;
}

std::int64_t bits_id(double d) {
  std::int64_t i;
  std::memcpy(&i, &d, 8);
  return i;
}

hid_t GrainColumn::hdf5_type() const {
  return type == Int64 ? H5T_NATIVE_INT64 : type == Int32 ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE;
}

namespace {

using P = ParticleStore;
using Body = std::vector<Vec3>;

// A Vec3 member array.
GrainColumn vectors(const std::string& name, std::vector<Vec3> P::*member) {
  return {name, GrainColumn::Real, 3,
          [member](const P& p, const Body&, std::size_t i, double* out) {
            for (int c = 0; c < 3; ++c) out[c] = (p.*member)[i][c];
          },
          [member](P& p, std::size_t i, const double* in) { (p.*member)[i] = Vec3(in[0], in[1], in[2]); }};
}

// Restored by ParticleStore::add, which also derives the inverse mass and inertia.
GrainColumn identity(const std::string& name, GrainColumn::Type type, int width,
                     std::function<void(const P&, std::size_t, double*)> get) {
  return {name, type, width, [get](const P& p, const Body&, std::size_t i, double* out) { get(p, i, out); }, nullptr};
}

}  // namespace

std::vector<GrainColumn> grain_columns(const ParticleStore& p) {
  auto vec = [](const Vec3& v, double* out) { out[0] = v[0]; out[1] = v[1]; out[2] = v[2]; };
  std::vector<GrainColumn> c = {
      identity("id", GrainColumn::Int64, 1, [](const P& q, std::size_t i, double* o) { o[0] = id_bits(q.id[i]); }),
      identity("species", GrainColumn::Int32, 1, [](const P& q, std::size_t i, double* o) { o[0] = q.species[i]; }),
      identity("radius", GrainColumn::Real, 1, [](const P& q, std::size_t i, double* o) { o[0] = q.radius[i]; }),
      identity("mass", GrainColumn::Real, 1, [](const P& q, std::size_t i, double* o) { o[0] = q.mass[i]; }),
      identity("position", GrainColumn::Real, 3, [vec](const P& q, std::size_t i, double* o) { vec(q.x[i], o); }),
      identity("velocity", GrainColumn::Real, 3, [vec](const P& q, std::size_t i, double* o) { vec(q.v[i], o); }),
      vectors("force", &P::f),
      // The non-contact forces (gravity, drag, frame forces), for cassini-cg's stress (3.34).
      {"body_force", GrainColumn::Real, 3, [vec](const P&, const Body& b, std::size_t i, double* o) { vec(b[i], o); },
       nullptr},
  };
  if (p.rotation) {
    c.push_back(vectors("omega", &P::omega));
    c.push_back(vectors("torque", &P::torque));
  }
  // Modified Lees-Edwards boundaries: 0 = LE1 (the main box), 1 = LE2 (the moonlet-free feed).
  if (p.copies)
    c.push_back({"le_copy", GrainColumn::Int32, 1,
                 [](const P& q, const Body&, std::size_t i, double* o) { o[0] = q.le_copy[i]; },
                 [](P& q, std::size_t i, const double* in) { q.le_copy[i] = static_cast<std::uint8_t>(in[0]); }});
  // The modules' own columns (ParticleStore::declare).
  for (std::size_t k = 0; k < p.module_columns.size(); ++k) {
    const int w = p.module_columns[k].width;
    for (const auto& taken : c)
      if (taken.name == p.module_columns[k].name)
        throw std::logic_error("particle column '" + taken.name + "' would replace the snapshot's own");
    const ParticleStore::ModuleColumn& m = p.module_columns[k];
    c.push_back({m.name, GrainColumn::Real, w,
                 [k](const P& q, const Body&, std::size_t i, double* o) { std::copy_n(q.column(k, i), q.module_columns[k].width, o); },
                 [k, w](P& q, std::size_t i, const double* in) { std::copy_n(in, w, q.column(k, i)); },
                 true,  // a snapshot from before the column existed: zeros, or its former share
                 m.unit, m.former.name, m.former.offset});
  }
  return c;
}

namespace {

hid_t open_file(const std::string& path, MPI_Comm comm) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  h5::Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "fapl");
  if (comm != MPI_COMM_NULL) h5::check(H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL), "mpio");
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl);
  if (f < 0) throw std::runtime_error(path + ": not a readable HDF5 file (truncated or still being written?)");
  return f;
}

hid_t transfer(MPI_Comm comm) {
  const hid_t dxpl = H5Pcreate(H5P_DATASET_XFER);
  if (comm != MPI_COMM_NULL) h5::check(H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE), "collective");
  return dxpl;
}

}  // namespace

SnapshotReader::SnapshotReader(const std::string& path, MPI_Comm comm)
    : path_(path), file_(open_file(path, comm), H5Fclose, "open " + path), dxpl_(transfer(comm), H5Pclose, "dxpl") {
  // The attribute is written last: a file without it was cut short.
  if (H5Aexists_by_name(file_, "parameters", "complete", H5P_DEFAULT) <= 0)
    throw std::runtime_error(path + ": snapshot is incomplete (no parameters@complete)");
}

bool SnapshotReader::has(const std::string& object) const {
  // Each level must exist before the next is asked for (HDF5 fails on a missing parent).
  std::size_t at = 0;
  while ((at = object.find('/', at + 1)) != std::string::npos)
    if (H5Lexists(file_, object.substr(0, at).c_str(), H5P_DEFAULT) <= 0) return false;
  return H5Lexists(file_, object.c_str(), H5P_DEFAULT) > 0;
}

hsize_t SnapshotReader::extent(const std::string& dataset, int axis) const {
  h5::Handle d(H5Dopen2(file_, dataset.c_str(), H5P_DEFAULT), H5Dclose, "missing dataset " + dataset);
  h5::Handle fs(H5Dget_space(d), H5Sclose, "space");
  hsize_t dims[4] = {0, 0, 0, 0};
  H5Sget_simple_extent_dims(fs, dims, nullptr);
  return dims[axis];
}

hsize_t SnapshotReader::particles() const { return extent(kGrains + "position/value", 1); }

void SnapshotReader::read(const std::string& dataset, hid_t type, hsize_t lo, hsize_t n, hsize_t w, void* out,
                          bool framed) const {
  h5::Handle d(H5Dopen2(file_, dataset.c_str(), H5P_DEFAULT), H5Dclose, "missing dataset " + dataset);
  h5::Handle fs(H5Dget_space(d), H5Sclose, "space");
  std::vector<hsize_t> start, count;
  if (framed) { start.push_back(0); count.push_back(1); }
  start.push_back(lo); count.push_back(n);
  if (w > 1) { start.push_back(0); count.push_back(w); }
  h5::Handle mem(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose, "mem");
  if (n == 0) {
    h5::check(H5Sselect_none(fs), "none");
    h5::check(H5Sselect_none(mem), "none");
  } else {
    h5::check(H5Sselect_hyperslab(fs, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), "hyperslab " + dataset);
  }
  hsize_t dims[4] = {0, 0, 0, 0};
  H5Sget_simple_extent_dims(fs, dims, nullptr);
  if (dims[framed ? 1 : 0] == 0) return;  // an empty dataset (no contacts)
  static double dummy[3];  // HDF5 refuses a null buffer even for an empty selection
  h5::check(H5Dread(d, type, mem, fs, dxpl_, n ? out : dummy), "read " + dataset);
}

std::vector<double> SnapshotReader::grain(const std::string& name, hsize_t lo, hsize_t n, hsize_t w) const {
  std::vector<double> out(n * w);
  read(kGrains + name + "/value", H5T_NATIVE_DOUBLE, lo, n, w, out.data());
  return out;
}

double SnapshotReader::number(const std::string& dataset, int index) const {
  const hsize_t n = extent(dataset, 0);
  std::vector<double> all(n);
  read(dataset, H5T_NATIVE_DOUBLE, 0, n, 1, all.data(), false);
  if (index >= static_cast<int>(n)) throw std::runtime_error(path_ + ": " + dataset + " has no entry " + std::to_string(index));
  return all[index];
}

std::string SnapshotReader::attribute(const std::string& object, const std::string& name) const {
  if (H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) <= 0) return "";
  h5::Handle a(H5Aopen_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, "attr " + name);
  h5::Handle type(H5Aget_type(a), H5Tclose, "type");
  h5::Handle space(H5Aget_space(a), H5Sclose, "space");
  // A string or an array of fixed-length strings (box@boundary): the entries comma-joined.
  const std::size_t width = H5Tget_size(type), n = std::max<hssize_t>(1, H5Sget_simple_extent_npoints(space));
  std::string raw(width * n, '\0');
  if (H5Aread(a, type, raw.data()) < 0) return "";
  std::string text;
  for (std::size_t k = 0; k < n; ++k) text += (k ? "," : "") + std::string(raw.c_str() + k * width);
  return text;
}

}  // namespace cassini
