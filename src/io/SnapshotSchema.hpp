#pragma once
// The layout of a snapshot, in one place: the per-particle datasets as one list of columns
// (the solver writes them and a restart reads them back by walking it), and the reader both
// the solver and cassini-cg open snapshots with. A new per-particle quantity is one entry in
// grain_columns(); Snapshot.hpp describes the whole file.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <hdf5.h>
#include <mpi.h>

#include "core/Vec3.hpp"
#include "io/Hdf5Handle.hpp"

namespace cassini {

struct ParticleStore;

inline const std::string kGrains = "particles/grains/";  // H5MD particle group

// One per-particle dataset, particles/grains/<name>/value[1][N][width] (width 1: [1][N]).
// Values travel as doubles between ranks (int64 ids bit for bit, see id_bits).
struct GrainColumn {
  enum Type { Real, Int64, Int32 };
  std::string name;
  Type type;
  int width;
  // Particle i's values into out[0, width). `body` holds the non-contact forces (3.34).
  std::function<void(const ParticleStore&, const std::vector<Vec3>& body, std::size_t i, double* out)> pack;
  // Restores them on a restart (null: the column is output only, or restored by
  // ParticleStore::add from the identity columns id, species, radius, mass, position, velocity).
  std::function<void(ParticleStore&, std::size_t i, const double* in)> unpack;
  bool optional = false;  // older snapshots may lack it: restored as zeros
  std::string unit;       // "" : none recorded
  // Where an older snapshot without this dataset kept these values: `width` doubles from
  // `former_offset` in each row of particles/grains/<former> (FormerColumn).
  std::string former;
  int former_offset = 0;
  hid_t hdf5_type() const;
};

// The columns of this scene's particles (rotation, copies, modules' columns only where they exist),
// id first: rows are ordered by it.
std::vector<GrainColumn> grain_columns(const ParticleStore& p);

double id_bits(std::int64_t id);  // an id carried in a double's bits (exact for every id)
std::int64_t bits_id(double d);

// A complete snapshot opened for reading: collectively (MPI-IO) when given a communicator,
// else by this process alone (cassini-cg). Throws std::runtime_error naming what is wrong.
class SnapshotReader {
 public:
  explicit SnapshotReader(const std::string& path, MPI_Comm comm = MPI_COMM_NULL);
  const std::string& path() const { return path_; }
  bool has(const std::string& object) const;
  hsize_t particles() const;                          // rows of particles/grains/position
  hsize_t extent(const std::string& dataset, int axis) const;
  // Rows [lo, lo + n) of `dataset` ([1][N][w] when framed, else [N][w]; w = 1: no last axis),
  // converted to `type` (H5T_NATIVE_DOUBLE, ...).
  void read(const std::string& dataset, hid_t type, hsize_t lo, hsize_t n, hsize_t w, void* out,
            bool framed = true) const;
  // particles/grains/<name>/value rows [lo, lo + n), as doubles.
  std::vector<double> grain(const std::string& name, hsize_t lo, hsize_t n, hsize_t w) const;
  double number(const std::string& dataset, int index = 0) const;  // an entry of a small dataset
  std::string attribute(const std::string& object, const std::string& name) const;  // "" when absent
  hid_t file() const { return file_; }

 private:
  std::string path_;
  h5::Handle file_;
  h5::Handle dxpl_;
};

}  // namespace cassini
