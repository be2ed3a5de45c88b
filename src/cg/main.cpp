// cassini-cg: coarse-grained fields from cassini snapshots, in the spirit of MercuryCG.
//   mpirun -n 2 cassini-cg run/snap_*.h5md --grid 200x50 --width 100 --kernel gauss --out fields.h5
//   cassini-cg run/dump --frames 0.9T0: --grid 200x50 --width 100 --background shear --out fields.h5
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <hdf5.h>
#include <mpi.h>
#include <unistd.h>

#include "cg/CoarseGrainer.hpp"
#include "core/Version.hpp"
#include "io/Hdf5Handle.hpp"
#include "io/IoFailure.hpp"
#include "io/Snapshot.hpp"
#include "io/SnapshotSchema.hpp"

using namespace cassini::cg;
namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& msg) { throw std::runtime_error(msg); }

// Time of a snapshot and its frame's angular velocity (0 when the frame does not rotate).
void frame_time(const std::string& path, double& time, double& rotation) {
  try {
    const cassini::SnapshotReader in(path);
    time = in.number("parameters/time_offset_dt", 0);
    rotation = in.has("parameters/frame_rotation") ? in.number("parameters/frame_rotation") : 0.0;
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": not a cassini snapshot (" + e.what() + ")");
  }
}

// One end of a --frames window: seconds ("120", "120s") or orbital periods ("0.9T0").
double window_end(const std::string& text, double T0) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (...) {
    fail("--frames: expected START:END with times like 4000, 4000s or 0.9T0, got '" + text + "'");
  }
  const std::string unit = text.substr(used);
  if (unit.empty() || unit == "s") return v;
  if (unit == "T0") {
    if (!(T0 > 0)) fail("--frames: T0 (the orbital period) needs snapshots of a rotating (hill) frame");
    return v * T0;
  }
  fail("--frames: unknown unit '" + unit + "' in '" + text + "' (use s or T0)");
}

// The snapshot files named on the command line (directories: their snap_*.h5md, by step),
// keeping those whose time lies in the --frames window [start, end].
std::vector<std::string> select_frames(const std::vector<std::string>& args, const std::string& window) {
  std::vector<std::string> files;
  for (const auto& a : args) {
    if (!fs::is_directory(a)) {
      files.push_back(a);
      continue;
    }
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(a)) {
      const std::string name = e.path().filename().string();
      if (name.rfind("snap_", 0) == 0 && e.path().extension() == ".h5md") found.push_back(e.path().string());
    }
    if (found.empty()) fail(a + ": directory holds no snap_*.h5md snapshots");
    std::sort(found.begin(), found.end());  // snap_<step> is zero-padded: name order is step order
    files.insert(files.end(), found.begin(), found.end());
  }
  if (window.empty()) return files;
  const auto colon = window.find(':');
  if (colon == std::string::npos) fail("--frames: expected START:END (either may be empty), got '" + window + "'");
  std::vector<std::string> kept;
  for (const auto& f : files) {
    if (!fs::exists(f)) fail(f + ": no such snapshot");
    double t = 0, rotation = 0;
    frame_time(f, t, rotation);
    const double T0 = rotation > 0 ? 2 * 3.141592653589793 / rotation : 0;
    const std::string a = window.substr(0, colon), b = window.substr(colon + 1);
    const double lo = a.empty() ? -1e300 : window_end(a, T0), hi = b.empty() ? 1e300 : window_end(b, T0);
    // Half a part in 1e9 of slack: frames are written at step multiples, not exact times.
    if (t >= lo - 1e-9 * std::abs(lo) && t <= hi + 1e-9 * std::abs(hi)) kept.push_back(f);
  }
  if (kept.empty()) fail("--frames " + window + ": none of the " + std::to_string(files.size()) + " snapshots is in the window");
  return kept;
}

struct Loaded {
  Frame frame;
  double shear_rate = 0, time = 0;
  bool planar = false;
};

// Each rank reads its block of rows of the snapshot.
// Modified Lees-Edwards runs hold two copies of the box in one snapshot (particles/grains/
// le_copy): only particles of copy `copy` (0 = LE1, the main box; 1 = LE2, the feed) and their
// contacts are kept. -1 keeps everything.
template <class Keep>
void keep_rows(std::vector<double>& a, int width, const Keep& keep) {
  std::size_t out = 0;
  for (std::size_t r = 0; r < a.size() / width; ++r)
    if (keep(r)) {
      for (int c = 0; c < width; ++c) a[out * width + c] = a[r * width + c];
      ++out;
    }
  a.resize(out * width);
}

Loaded load(const std::string& path, int rank, int size, int copy) {
  if (!fs::exists(path)) fail(path + ": no such snapshot");
  const cassini::SnapshotReader in(path);  // the solver's reader: the same layout, the same checks
  Loaded L;
  const hsize_t N = in.particles();
  const hsize_t lo = N * rank / size, n = N * (rank + 1) / size - lo;
  Frame& f = L.frame;
  f.x = in.grain("position", lo, n, 3);
  f.v = in.grain("velocity", lo, n, 3);
  f.m = in.grain("mass", lo, n, 1);
  if (in.has(cassini::kGrains + "body_force")) f.body = in.grain("body_force", lo, n, 3);
  // Pair and wall contacts (each once), a block of rows per rank; the three arrays of a kind
  // (3 values per row) share their row count. Snapshots from before wall forces have none.
  auto rows_block = [&](const std::vector<std::string>& names, std::vector<std::vector<double>*> into) {
    if (!in.has(names[0])) return;
    const hsize_t M = in.extent(names[0], 0), clo = M * rank / size, cn = M * (rank + 1) / size - clo;
    for (std::size_t k = 0; k < names.size(); ++k) {
      into[k]->resize(3 * cn);
      in.read(names[k], H5T_NATIVE_DOUBLE, clo, cn, 3, into[k]->data(), false);
    }
  };
  if (!in.has("contacts")) fail(path + ": no contacts group");
  rows_block({"contacts/force", "contacts/position_i", "contacts/branch"}, {&f.contact_force, &f.contact_x, &f.contact_branch});
  rows_block({"contacts/wall_force", "contacts/wall_point", "contacts/wall_branch"}, {&f.wall_force, &f.wall_point, &f.wall_branch});
  if (copy >= 0 && in.has(cassini::kGrains + "le_copy")) {
    const std::vector<double> ids = in.grain("id", 0, N, 1), copies = in.grain("le_copy", 0, N, 1);
    std::vector<double> members;  // ids of the kept copy, sorted
    for (hsize_t k = 0; k < N; ++k)
      if (copies[k] == copy) members.push_back(ids[k]);
    std::sort(members.begin(), members.end());
    auto member = [&](double id) { return std::binary_search(members.begin(), members.end(), id); };
    auto mine = [&](hsize_t r) { return copies[lo + r] == copy; };
    keep_rows(f.x, 3, mine);
    keep_rows(f.v, 3, mine);
    keep_rows(f.m, 1, mine);
    if (!f.body.empty()) keep_rows(f.body, 3, mine);
    // The same blocks of contact rows as rows_block read; a pair belongs to the copy of its first particle.
    auto filter_contacts = [&](const std::string& ids_path, int per_row, std::vector<std::vector<double>*> arrays) {
      if (arrays[0]->empty() && !in.has(ids_path)) return;
      const hsize_t M = in.extent(ids_path, 0), clo = M * rank / size, cn = M * (rank + 1) / size - clo;
      std::vector<double> pid(per_row * cn);
      in.read(ids_path, H5T_NATIVE_DOUBLE, clo, cn, per_row, pid.data(), false);
      for (auto* a : arrays) keep_rows(*a, 3, [&](std::size_t r) { return member(pid[r * per_row]); });
    };
    filter_contacts("contacts/pair_ids", 2, {&f.contact_force, &f.contact_x, &f.contact_branch});
    filter_contacts("contacts/wall_particle", 1, {&f.wall_force, &f.wall_point, &f.wall_branch});
  }
  double edges[9], origin[3];
  in.read(cassini::kGrains + "box/edges/value", H5T_NATIVE_DOUBLE, 0, 3, 3, edges);
  in.read(cassini::kGrains + "box/origin", H5T_NATIVE_DOUBLE, 0, 3, 1, origin, false);
  const double rate = in.number("parameters/shear_rate");
  const std::string bounds = in.attribute(cassini::kGrains + "box", "boundary");
  std::istringstream bs(bounds);
  std::string item;
  for (int d = 0; d < 3 && std::getline(bs, item, ','); ++d) f.periodic[d] = item.rfind("periodic", 0) == 0;
  for (int d = 0; d < 3; ++d) {
    f.lo[d] = origin[d];
    f.length[d] = edges[4 * d];
  }
  f.sheared = rate != 0;
  f.le_offset = edges[3];  // xy tilt = wrapped offset
  f.le_rate = rate;
  L.shear_rate = rate;
  L.time = in.number("parameters/time_offset_dt", 0);
  L.planar = in.number("parameters/planar") != 0;
  return L;
}

// Every HDF5 call of the output is checked: a full disk or an I/O error ends the job naming the
// file and the reason (exit 4), and the file stays under its .partial name.
hid_t checked(hid_t id, const std::string& file) {
  if (id < 0) cassini::io_failure(file, cassini::hdf5_failure_reason(file));
  return id;
}

void write_attr(hid_t obj, const std::string& name, const std::string& value, const std::string& path) {
  const hid_t t = checked(H5Tcopy(H5T_C_S1), path);
  checked(H5Tset_size(t, value.size() + 1), path);
  const hid_t s = checked(H5Screate(H5S_SCALAR), path);
  const hid_t a = checked(H5Acreate2(obj, name.c_str(), t, s, H5P_DEFAULT, H5P_DEFAULT), path);
  checked(H5Awrite(a, t, value.c_str()), path);
  checked(H5Aclose(a), path);
  checked(H5Sclose(s), path);
  checked(H5Tclose(t), path);
}

void write_dataset(hid_t file, const std::string& name, const std::vector<hsize_t>& dims, const double* data,
                   const std::string& unit, const std::string& path) {
  const hid_t s = checked(H5Screate_simple(int(dims.size()), dims.data(), nullptr), path);
  const hid_t d = checked(H5Dcreate2(file, name.c_str(), H5T_NATIVE_DOUBLE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path);
  checked(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path);
  if (!unit.empty()) {
    const cassini::h5::WriteScope writing(path);  // a failure here also ends the job naming the file
    cassini::h5::attr_utf8(d, "unit", {unit}, true);  // as H5MD's units: a variable-length string
  }
  checked(H5Dclose(d), path);
  checked(H5Sclose(s), path);
}

// ParaView reads the fields through this sidecar: a co-rectilinear mesh of the grid points.
void write_xdmf(const std::string& out, const Grid& g, std::size_t frames) {
  const std::string h5 = fs::path(out).filename().string();
  // Always a 3D mesh, z y x (slowest first, as stored): ParaView puts a 2DCoRectMesh in the
  // y-z plane, where the default view of an x-y field is empty. A 2D grid is one layer thick
  // at z = the box's mid-plane.
  std::string dims, mesh_dims, origin, spacing;
  for (int d = 2; d >= 0; --d) {
    std::ostringstream o, h;
    o.precision(17);
    h.precision(17);
    if (d < g.dims) {
      o << g.centre(d, 0);
      h << g.h(d);
      dims += std::to_string(g.n[d]) + (d ? " " : "");
    } else {
      o << 0.5 * (g.lo[d] + g.hi[d]);
      h << 1.0;
    }
    mesh_dims += std::to_string(d < g.dims ? g.n[d] : 1) + (d ? " " : "");
    origin += o.str() + (d ? " " : "");
    spacing += h.str() + (d ? " " : "");
  }
  const std::string mesh = "3DCoRectMesh", geo = "ORIGIN_DXDYDZ";
  const std::string side = fs::path(out).replace_extension(".xdmf").string(), tmp = side + ".partial";
  std::ofstream x(tmp);
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"cg\" GridType=\"Uniform\">\n"
    << "   <Information Name=\"frames\" Value=\"" << frames << "\"/>\n"
    << "   <Topology TopologyType=\"" << mesh << "\" Dimensions=\"" << mesh_dims << "\"/>\n"
    << "   <Geometry GeometryType=\"" << geo << "\">\n"
    << "    <DataItem Dimensions=\"3\" Format=\"XML\">" << origin << "</DataItem>\n"
    << "    <DataItem Dimensions=\"3\" Format=\"XML\">" << spacing << "</DataItem>\n   </Geometry>\n";
  const std::pair<const char*, int> fields[] = {{"density", 1}, {"velocity", 3}, {"momentum", 3}, {"velocity_fluctuation", 1},
                                                {"background_fluctuation", 1}, {"stress", 9}, {"wall_traction", 3},
                                                {"body_force_density", 3}};
  for (const auto& [name, c] : fields) {
    const char* type = c == 1 ? "Scalar" : c == 3 ? "Vector" : "Tensor";
    x << "   <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\"Node\">\n    <DataItem Dimensions=\""
      << dims << (c > 1 ? " " + std::to_string(c) : "") << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5 << ":/"
      << name << "</DataItem>\n   </Attribute>\n";
  }
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  x.close();
  if (!x) cassini::io_failure(tmp, cassini::os_write_reason(tmp));
  fs::rename(tmp, side);
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  CLI::App app{"cassini-cg: coarse-grained fields (density, momentum, velocity, velocity fluctuations; kinetic, contact\n"
               "and wall stress; wall traction and body-force densities) on a regular grid from cassini H5MD snapshots,\n"
               "averaged over the given frames. Writes HDF5 plus an XDMF sidecar for ParaView (2D and 3D grids)."};
  std::vector<std::string> files;
  std::string frames;
  std::string grid_spec, kernel = "gauss", background = "auto", out = "fields.h5";
  double width = 0, margin = 0;
  bool force = false;
  app.add_option("snapshots", files, "snapshot files (snap_<step>.h5md) or run directories (all their snapshots);\n"
                                     "fields are averaged over the selected frames")->required();
  app.add_option("--frames", frames, "time window START:END of the frames to average (either end may be empty), in\n"
                                     "seconds or in orbital periods T0 = 2 pi/Omega0 of a Hill-frame run: 0.9T0: is\n"
                                     "the last tenth of the first orbit onwards, :4000 everything up to t = 4000 s");
  app.add_option("--grid", grid_spec, "grid points per axis: NX (1D along x), NXxNY (2D, x-y; the default for planar\n"
                                      "scenes, giving surface densities) or NXxNYxNZ (3D). Default 100x100 or 50x50x50");
  app.add_option("--width", width, "kernel width w in metres (default: two grid spacings along the finest axis)");
  app.add_option("--kernel", kernel, "gauss (cut off at 3w), lucy (c = 2w) or heaviside (c = w); default gauss");
  app.add_option("--background", background, "flow the 'background' fluctuations are measured against: shear (v_x =\n"
                                              "rate y, the snapshot's Lees-Edwards rate), shear:RATE, none, or auto (shear\n"
                                              "when the run was sheared)");
  app.add_option("--margin", margin, "extend the grid by this many metres beyond the box on each side of every\n"
                                      "non-periodic axis (default 0). A particle's kernel is renormalised to the grid\n"
                                      "so that mass is conserved; with a margin of at least the kernel's cutoff nothing\n"
                                      "is cut at a wall, and div(stress) = wall_traction + body_force_density holds\n"
                                      "up to the wall (for a system at rest)")->check(CLI::NonNegativeNumber);
  app.add_option("--out", out, "output HDF5 file (default fields.h5)");
  app.add_flag("--force", force, "overwrite an existing output file");
  int copy = 0;
  app.add_option("--copy", copy, "modified Lees-Edwards runs: the copy of the box to average, 0 = LE1 (the main box,\n"
                                 "the default), 1 = LE2 (the moonlet-free feed), -1 = both (ignored for other runs)")
      ->check(CLI::Range(-1, 1));
  bool mix_runs = false;
  app.add_flag("--mix-runs", mix_runs, "average frames of different runs (e.g. several seeds); refused without it");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int shown = rank == 0 ? app.exit(e) : e.get_exit_code();
    MPI_Finalize();
    return shown == 0 ? 0 : 2;  // --help succeeds; every command-line error exits 2
  }
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  int code = 0;
  try {
    if (app.count("--width") && !(width > 0 && std::isfinite(width)))
      fail("--width: expected a positive, finite kernel width in metres, got " + std::to_string(width));
    if (!std::isfinite(margin)) fail("--margin: expected a finite length in metres >= 0, got " + std::to_string(margin));
    double shear_given = 0;
    if (background.rfind("shear:", 0) == 0) {
      const std::string rate = background.substr(6);
      char* end = nullptr;
      shear_given = std::strtod(rate.c_str(), &end);
      if (rate.empty() || end != rate.c_str() + rate.size() || !std::isfinite(shear_given))
        fail("--background shear:RATE: expected a finite shear rate in 1/s, got '" + rate + "'");
    } else if (background != "auto" && background != "shear" && background != "none") {
      fail("--background: expected shear, shear:RATE, none or auto, got '" + background + "'");
    }
    if (fs::exists(out) && fs::is_directory(out)) fail("--out " + out + " is a directory, expected an HDF5 file name");
    if (fs::exists(out) && !force) fail(out + " exists: pass --force to overwrite");
    files = select_frames(files, frames);
    // Frames of different runs (another seed, another case) average into nothing meaningful.
    if (!mix_runs) {
      auto identity = [](const std::string& f) {
        if (!fs::exists(f)) fail(f + ": no such snapshot");
        const std::string id = cassini::snapshot_parameter(f, "run_id");
        return id.empty() ? cassini::snapshot_parameter(f, "case") : id;  // older snapshots: their case
      };
      const std::string first = identity(files.front());
      for (const auto& f : files)
        if (identity(f) != first)
          fail(f + " is from another run than " + files.front() + ": pass --mix-runs to average frames of different runs");
    }
    Fields sum;
    Grid g;
    std::string dims_note;
    for (std::size_t k = 0; k < files.size(); ++k) {
      Loaded L = load(files[k], rank, size, copy);
      if (k == 0) {
        std::vector<int> n;
        if (!grid_spec.empty()) {
          std::stringstream ss(grid_spec);
          std::string part;
          while (std::getline(ss, part, 'x')) {
            char* end = nullptr;
            const long v = std::strtol(part.c_str(), &end, 10);
            if (part.empty() || end != part.c_str() + part.size() || v < 1 || v > 100000)
              fail("--grid: expected NX, NXxNY or NXxNYxNZ with positive counts, got '" + grid_spec + "'");
            n.push_back(int(v));
          }
          if (n.empty() || n.size() > 3) fail("--grid: expected NX, NXxNY or NXxNYxNZ, got '" + grid_spec + "'");
          double points = 1;
          for (int v : n) points *= v;
          // 1 + 3 + 6 + 6 + 9 + 9 + 3 + 3 doubles per point, summed and written: refuse what cannot fit.
          const double bytes = points * 40 * 8 * 2;
          const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
          if (bytes > 0.8 * ram)
            fail("--grid " + grid_spec + ": the fields would need " + std::to_string(bytes / 1e9) + " GB per rank, more than this machine's " +
                 std::to_string(ram / 1e9) + " GB");
        } else {
          n = L.planar ? std::vector<int>{100, 100} : std::vector<int>{50, 50, 50};
        }
        g.dims = int(n.size());
        for (int d = 0; d < 3; ++d) {
          g.n[d] = d < g.dims ? n[d] : 1;
          const double pad = d < g.dims && !L.frame.periodic[d] ? margin : 0.0;
          g.lo[d] = L.frame.lo[d] - pad;
          g.hi[d] = L.frame.lo[d] + L.frame.length[d] + pad;
        }
        if (width <= 0) {  // two grid spacings along the finest axis
          width = 1e300;
          for (int d = 0; d < g.dims; ++d) width = std::min(width, 2 * g.h(d));
        }
        for (int d = 0; d < g.dims; ++d)  // a kernel as wide as the box smears every field flat
          if (width >= g.hi[d] - g.lo[d])
            fail("--width " + std::to_string(width) + ": as wide as the grid along " + std::string(1, "xyz"[d]) + " (" +
                 std::to_string(g.hi[d] - g.lo[d]) + " m): expected a kernel narrower than the box");
        sum.resize(g.size());
      }
      Background bg;
      if (background == "auto") bg.shear = L.shear_rate;
      else if (background == "shear") bg.shear = L.shear_rate;
      else if (background.rfind("shear:", 0) == 0) bg.shear = shear_given;
      Kernel kern(kernel, width, g.dims);
      Fields f;
      f.resize(g.size());
      accumulate(L.frame, 0, L.frame.m.size(), g, kern, bg, f);
      accumulate_contacts(L.frame, 0, L.frame.contact_force.size() / 3, g, kern, f);
      accumulate_walls(L.frame, 0, L.frame.wall_force.size() / 3, g, kern, f);
      sum.add(f, 1.0 / files.size());
    }
    // Sum the ranks' partial grids on rank 0.
    for (auto* v : sum.all())
      MPI_Reduce(rank == 0 ? MPI_IN_PLACE : v->data(), v->data(), int(v->size()), MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    if (rank == 0) {
      finish(sum, g.size());
      const std::size_t P = g.size();
      std::vector<double> velocity(3 * P, 0), fluct(P, 0), bfluct(P, 0), stress(6 * P), total(9 * P);
      const int sym[9] = {0, 3, 4, 3, 1, 5, 4, 5, 2};  // (a, b) -> index in (xx yy zz xy xz yz)
      for (std::size_t i = 0; i < P; ++i) {
        const double rho = sum.density[i];
        if (rho > 0) {
          for (int d = 0; d < 3; ++d) velocity[3 * i + d] = sum.momentum[3 * i + d] / rho;
          fluct[i] = std::sqrt(std::max(0.0, (sum.kinetic[6 * i] + sum.kinetic[6 * i + 1] + sum.kinetic[6 * i + 2]) / rho));
          bfluct[i] = std::sqrt(std::max(0.0, (sum.background[6 * i] + sum.background[6 * i + 1] + sum.background[6 * i + 2]) / rho));
        }
        for (int q = 0; q < 6; ++q) stress[6 * i + q] = sum.kinetic[6 * i + q];
        for (int q = 0; q < 9; ++q) total[9 * i + q] = sum.kinetic[6 * i + sym[q]] + sum.contact[9 * i + q] + sum.wall[9 * i + q];
      }
      std::vector<hsize_t> shape;
      for (int d = g.dims - 1; d >= 0; --d) shape.push_back(hsize_t(g.n[d]));  // C order: [z][y][x]
      auto with = [&](hsize_t c) { auto s = shape; if (c > 1) s.push_back(c); return s; };
      const std::string tmp = out + ".partial";
      const hid_t file = checked(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), tmp);
      // Units per quantity: "volume" is m^D on a D-dimensional grid (2D: surface densities).
      const std::string per = " m-" + std::to_string(g.dims);
      const std::string per_m1 = g.dims == 1 ? "" : g.dims == 2 ? " m-1" : " m-2";  // m^(1-D)
      const std::string stress_unit = g.dims == 1 ? "kg m s-2" : g.dims == 2 ? "kg s-2" : "kg m-1 s-2";  // m^(2-D)
      for (int d = 0; d < g.dims; ++d) {
        std::vector<double> c(g.n[d]);
        for (int k = 0; k < g.n[d]; ++k) c[k] = g.centre(d, k);
        write_dataset(file, std::string("grid_") + "xyz"[d], {hsize_t(g.n[d])}, c.data(), "m", tmp);
      }
      write_dataset(file, "density", with(1), sum.density.data(), "kg" + per, tmp);
      write_dataset(file, "momentum", with(3), sum.momentum.data(), "kg" + per_m1 + " s-1", tmp);
      write_dataset(file, "velocity", with(3), velocity.data(), "m s-1", tmp);
      write_dataset(file, "kinetic_stress", with(6), stress.data(), stress_unit, tmp);
      write_dataset(file, "contact_stress", with(9), sum.contact.data(), stress_unit, tmp);
      write_dataset(file, "wall_stress", with(9), sum.wall.data(), stress_unit, tmp);
      write_dataset(file, "stress", with(9), total.data(), stress_unit, tmp);
      write_dataset(file, "wall_traction", with(3), sum.traction.data(), "kg" + per_m1 + " s-2", tmp);
      write_dataset(file, "body_force_density", with(3), sum.body.data(), "kg" + per_m1 + " s-2", tmp);
      write_dataset(file, "velocity_fluctuation", with(1), fluct.data(), "m s-1", tmp);
      write_dataset(file, "background_fluctuation", with(1), bfluct.data(), "m s-1", tmp);
      const hid_t root = checked(H5Gopen2(file, "/", H5P_DEFAULT), tmp);
      std::ostringstream desc;
      desc << "kernel " << kernel << ", width " << width << " m, " << files.size() << " frame(s), " << g.dims
           << "D grid; density is mass per " << (g.dims == 3 ? "volume" : g.dims == 2 ? "area (surface density)" : "length")
           << "; stresses compression-positive: kinetic_stress = sum m v'v' psi (xx yy zz xy xz yz), contact_stress = "
              "sum_pairs f r int psi ds (3x3, row a = force component, also lubrication pairs), wall_stress = sum_walls f b "
              "int psi ds (b = centre - contact point), stress = kinetic + contact + wall; wall_traction = sum_walls f psi(r - c), "
              "body_force_density = sum F psi (gravity, drag, frame forces); at rest div(stress) = wall_traction + "
              "body_force_density; fluctuations are rms speeds about the local mean velocity and about the background flow";
      write_attr(root, "description", desc.str(), tmp);
      write_attr(root, "kernel", kernel, tmp);
      write_attr(root, "width", std::to_string(width), tmp);
      write_attr(root, "creator", std::string("cassini-cg ") + cassini::version() + " (commit " + cassini::commit() + ")", tmp);
      checked(H5Gclose(root), tmp);
      checked(H5Fclose(file), tmp);  // the data reach the disk here: a full disk shows now
      if (cassini::injected_write_failure("fields", rank))
        cassini::io_failure(tmp, "No space left on device (injected by CASSINI_FAIL_WRITE)");
      if (g.dims >= 2) write_xdmf(out, g, files.size());
      fs::rename(tmp, out);  // last: a complete fields file only once its sidecar is written
      std::cout << "cassini-cg: " << files.size() << " frame(s) -> " << out << " (" << desc.str() << ")\n";
    }
  } catch (const std::exception& e) {
    if (rank == 0) std::cerr << "cassini-cg: error: " << e.what() << std::endl;
    code = 2;
  }
  MPI_Finalize();
  return code;
}
