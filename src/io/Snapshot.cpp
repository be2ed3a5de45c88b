#include "io/Snapshot.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <hdf5.h>

#include "core/CaseFile.hpp"
#include "io/Hdf5Handle.hpp"
#include "io/IoFailure.hpp"
#include "io/ReadConfig.hpp"
#include "io/SnapshotSchema.hpp"
#include "core/Simulation.hpp"

namespace cassini {
namespace {

using h5::Handle;
using h5::check;
using h5::attr_string;
using h5::attr_array;
using h5::group;

// H5Literate callback: appends each link name to a std::vector<std::string>.
herr_t collect_name(hid_t, const char* name, const H5L_info_t*, void* names) {
  static_cast<std::vector<std::string>*>(names)->push_back(name);
  return 0;
}

// Small dataset written identically by every rank (collective metadata, rank-0-style data).
template <class T>
void small_dataset(hid_t parent, const std::string& name, hid_t type, const std::vector<hsize_t>& dims, const T* data,
                   hid_t dxpl) {
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose, "space");
  Handle d(H5Dcreate2(parent, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose, name);
  check(H5Dwrite(d, type, H5S_ALL, H5S_ALL, dxpl, data), "write " + name);
}

// Rows [offset, offset + rows) of a [1][total][width] (or [1][total]) dataset, collectively.
void rows_dataset(hid_t parent, const std::string& name, hid_t type, hsize_t total, hsize_t offset, hsize_t rows,
                  hsize_t width, const void* data, hid_t dxpl, bool frame_axis = true) {
  std::vector<hsize_t> dims, start, count;
  if (frame_axis) { dims.push_back(1); start.push_back(0); count.push_back(1); }
  dims.push_back(total); start.push_back(offset); count.push_back(rows);
  if (width > 1) { dims.push_back(width); start.push_back(0); count.push_back(width); }
  Handle file_space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose, "space");
  Handle d(H5Dcreate2(parent, name.c_str(), type, file_space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose, name);
  Handle mem(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose, "mem space");
  if (rows == 0) {
    check(H5Sselect_none(file_space), "select none");
    check(H5Sselect_none(mem), "select none");
  } else {
    check(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), "hyperslab");
  }
  if (total == 0) return;  // an empty dataset (e.g. no contacts): nothing to write
  static const double dummy[3] = {0, 0, 0};  // HDF5 refuses a null buffer even for an empty selection
  check(H5Dwrite(d, type, mem, file_space, dxpl, data ? data : dummy), "write " + name);
}

// The frame's clock: the first element's step and time, which every other element of the
// frame shares by hard links (H5MD 1.1 allows shared step/time datasets).
constexpr const char* kClock = "/particles/grains/id";

// An H5MD time-dependent element holding one frame: name/{step, time, value}; the value
// carries its unit (none for a count or a label).
// g/step and g/time: the frame's clock, created by the first element, linked by the others.
void frame_clock(hid_t g, long step, double time, hid_t dxpl) {
  const std::string clock(kClock);
  if (H5Oexists_by_name(g, (clock + "/time").c_str(), H5P_DEFAULT) > 0) {
    check(H5Lcreate_hard(g, (clock + "/step").c_str(), g, "step", H5P_DEFAULT, H5P_DEFAULT), "link step");
    check(H5Lcreate_hard(g, (clock + "/time").c_str(), g, "time", H5P_DEFAULT, H5P_DEFAULT), "link time");
    return;
  }
  const std::int64_t s = step;
  small_dataset(g, "step", H5T_NATIVE_INT64, {1}, &s, dxpl);
  small_dataset(g, "time", H5T_NATIVE_DOUBLE, {1}, &time, dxpl);
  h5::unit(g, "time", "s");
}

void element(hid_t parent, const std::string& name, hid_t type, hsize_t total, hsize_t offset, hsize_t rows,
             hsize_t width, const void* data, long step, double time, hid_t dxpl, const std::string& unit) {
  Handle g = group(parent, name);
  frame_clock(g, step, time, dxpl);
  rows_dataset(g, "value", type, total, offset, rows, width, data, dxpl);
  h5::unit(g, "value", unit);
}

// The unit of each particle column (a module's own columns: the one it declared). position has
// none: MDAnalysis (2.x) knows no length unit "m" and refuses the file; the box edges and
// parameters@units say metres.
std::string unit_of(const GrainColumn& column) {
  static const std::map<std::string, std::string> units = {
      {"radius", "m"},     {"mass", "kg"},     {"velocity", "m s-1"}, {"force", "N"},
      {"body_force", "N"}, {"omega", "s-1"},   {"torque", "N m"}};
  const auto it = units.find(column.name);
  return it == units.end() ? column.unit : it->second;
}

// This rank's rows [offset, offset + rows) of a table of `total` rows spread over the ranks.
struct Rows {
  hsize_t total, offset, rows;
};
Rows my_rows(std::size_t n, MPI_Comm comm) {
  long long mine = static_cast<long long>(n), offset = 0, total = 0;
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  MPI_Exscan(&mine, &offset, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (rank == 0) offset = 0;  // MPI_Exscan leaves rank 0's result undefined
  MPI_Allreduce(&mine, &total, 1, MPI_LONG_LONG, MPI_SUM, comm);
  return {hsize_t(total), hsize_t(offset), hsize_t(mine)};
}

// One member of every record as a column: [N] of ids or [N][3] of a vector.
template <class R>
void id_column(hid_t g, const std::string& name, const Rows& r, const std::vector<R>& recs, std::int64_t R::*member, hid_t dxpl) {
  std::vector<std::int64_t> col(recs.size());
  for (std::size_t k = 0; k < recs.size(); ++k) col[k] = recs[k].*member;
  rows_dataset(g, name, H5T_NATIVE_INT64, r.total, r.offset, r.rows, 1, col.data(), dxpl, false);
}
template <class R>
void vec3_column(hid_t g, const std::string& name, const Rows& r, const std::vector<R>& recs, Vec3 R::*member, hid_t dxpl) {
  std::vector<double> col(3 * recs.size());
  for (std::size_t k = 0; k < recs.size(); ++k)
    for (int c = 0; c < 3; ++c) col[3 * k + c] = (recs[k].*member)[c];
  rows_dataset(g, name, H5T_NATIVE_DOUBLE, r.total, r.offset, r.rows, 3, col.data(), dxpl, false);
}

}  // namespace

namespace {

// out[r] to rank r, for every r; returns what every rank sent here, ordered by source rank.
std::vector<double> send_to_ranks(const std::vector<std::vector<double>>& out, MPI_Comm comm) {
  const int P = int(out.size());
  std::vector<int> sc(P), rc(P), sd(P), rd(P);
  std::vector<double> sendbuf;
  for (int r = 0; r < P; ++r) {
    sc[r] = int(out[r].size());
    sd[r] = int(sendbuf.size());
    sendbuf.insert(sendbuf.end(), out[r].begin(), out[r].end());
  }
  MPI_Alltoall(sc.data(), 1, MPI_INT, rc.data(), 1, MPI_INT, comm);
  int total = 0;
  for (int r = 0; r < P; ++r) { rd[r] = total; total += rc[r]; }
  std::vector<double> in(total);
  MPI_Alltoallv(sendbuf.data(), sc.data(), sd.data(), MPI_DOUBLE, in.data(), rc.data(), rd.data(), MPI_DOUBLE, comm);
  return in;
}

// Every rank's particle rows, redistributed into blocks of ids and ordered by id within its
// block: the file's rows are in id order whatever the rank count. Returns this rank's rows,
// `width` doubles each, in the order of `columns`.
std::vector<double> rows_by_id(const Simulation& sim, const std::vector<GrainColumn>& columns, std::size_t width) {
  const ParticleStore& p = sim.particles;
  const Decomposition& dom = sim.domain;
  const int P = dom.nranks;
  std::vector<Vec3> body(p.nlocal, Vec3::Zero());
  for (const auto& m : sim.modules) m->add_body_forces(sim, body);
  std::int64_t max_local = -1, max_id = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) max_local = std::max(max_local, p.id[i]);
  MPI_Allreduce(&max_local, &max_id, 1, MPI_INT64_T, MPI_MAX, dom.comm);
  std::vector<std::vector<double>> out(P);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    auto& r = out[static_cast<int>(static_cast<long double>(p.id[i]) * P / (max_id + 1))];
    const std::size_t at = r.size();
    r.resize(at + width);
    double* row = &r[at];
    for (const auto& c : columns) {
      c.pack(p, body, i, row);
      row += c.width;
    }
  }
  const std::vector<double> in = send_to_ranks(out, dom.comm);
  const std::size_t n = in.size() / width;
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return bits_id(in[a * width]) < bits_id(in[b * width]); });
  std::vector<double> sorted(in.size());
  for (std::size_t k = 0; k < n; ++k) std::copy_n(&in[order[k] * width], width, &sorted[k * width]);
  return sorted;
}

// particles/grains/<column>: one H5MD element per column of the schema.
void write_grains(hid_t grains, const std::vector<GrainColumn>& columns, const std::vector<double>& rows,
                  std::size_t width, const std::string& file, const Simulation& sim, hid_t dxpl) {
  const std::size_t n = rows.size() / width;
  const Rows block = my_rows(n, sim.domain.comm);
  std::size_t first = 0;
  for (const auto& c : columns) {
    std::vector<double> real;
    std::vector<std::int64_t> i64;
    std::vector<std::int32_t> i32;
    const void* data = nullptr;
    for (std::size_t k = 0; k < n; ++k)
      for (int q = 0; q < c.width; ++q) {
        const double v = rows[k * width + first + q];
        if (c.type == GrainColumn::Int64) i64.push_back(bits_id(v));
        else if (c.type == GrainColumn::Int32) i32.push_back(static_cast<std::int32_t>(v));
        else real.push_back(v);
      }
    data = c.type == GrainColumn::Int64 ? static_cast<const void*>(i64.data())
           : c.type == GrainColumn::Int32 ? static_cast<const void*>(i32.data()) : static_cast<const void*>(real.data());
    element(grains, c.name, c.hdf5_type(), block.total, block.offset, block.rows, c.width, data, sim.step_count, sim.time, dxpl,
            unit_of(c));
    if (first == 0 && injected_write_failure(file, sim.domain.rank))
      io_failure(file, "No space left on device (injected by CASSINI_FAIL_WRITE)");
    first += c.width;
  }
}

// particles/grains/box (and lees_edwards/ in sheared runs).
void write_box(hid_t grains, const Simulation& sim, hid_t dxpl) {
  const Decomposition& dom = sim.domain;
  const std::int64_t step = sim.step_count;
  const double time = sim.time;
  {
    Handle box = group(grains, "box");
    h5::attr_int(box, "dimension", 3);
    std::vector<std::string> bounds;
    for (int d = 0; d < 3; ++d) bounds.push_back(dom.periodic(d) || (d == 1 && dom.shear.enabled) ? "periodic" : "none");
    h5::attr_strings(box, "boundary", bounds);
    // Edge vectors as rows; the Lees-Edwards offset is the xy tilt (wrapped to [-Lx/2, Lx/2)).
    double tilt = 0;
    if (dom.shear.enabled) {
      tilt = dom.shear.wrapped(dom.length[0]);
      if (tilt >= 0.5 * dom.length[0]) tilt -= dom.length[0];
    }
    const double edges[9] = {dom.length[0], 0, 0, tilt, dom.length[1], 0, 0, 0, dom.length[2]};
    Handle eg = group(box, "edges");
    frame_clock(eg, step, time, dxpl);
    small_dataset(eg, "value", H5T_NATIVE_DOUBLE, {1, 3, 3}, edges, dxpl);
    h5::unit(eg, "value", "m");
    const double lo[3] = {dom.lo[0], dom.lo[1], dom.lo[2]};
    small_dataset(box, "origin", H5T_NATIVE_DOUBLE, {3}, lo, dxpl);
    h5::unit(box, "origin", "m");
  }
  if (!dom.shear.enabled) return;
  Handle le = group(grains, "lees_edwards");
  const double offset_unwrapped = dom.shear.offset;
  const std::int32_t direction = 0, normal = 1;
  for (const char* nm : {"offset", "direction", "normal"}) {
    Handle g = group(le, nm);
    frame_clock(g, step, time, dxpl);
    if (std::string(nm) == "offset") {
      small_dataset(g, "value", H5T_NATIVE_DOUBLE, {1}, &offset_unwrapped, dxpl);
      h5::unit(g, "value", "m");
    }
    else
      small_dataset(g, "value", H5T_NATIVE_INT32, {1}, nm[0] == 'd' ? &direction : &normal, dxpl);
  }
}

// contacts/: the contact history a restart needs (each rank its own block), then the pair and
// wall forces for stress (each pair once; contacts and lubrication): ids, position of i,
// branch r_i - r_j, force on i; wall contacts: particle id, contact point, branch, force.
void write_contacts(hid_t file, const Simulation& sim, hid_t dxpl) {
  const MPI_Comm comm = sim.domain.comm;
  PairHistory history = sim.history.columns_only();
  for (const auto& mod : sim.modules) mod->contact_history(sim, history);
  Handle cg = group(file, "contacts");
  const Rows sr = my_rows(history.size(), comm);
  rows_dataset(cg, "owner", H5T_NATIVE_INT64, sr.total, sr.offset, sr.rows, 1, history.owner.data(), dxpl, false);
  rows_dataset(cg, "partner", H5T_NATIVE_INT64, sr.total, sr.offset, sr.rows, 1, history.partner.data(), dxpl, false);
  for (const PairHistory::Column& c : history.columns()) {
    std::vector<double> col(c.width * history.size());
    for (std::size_t k = 0; k < history.size(); ++k) std::copy_n(history.row(k) + c.offset, c.width, &col[k * c.width]);
    rows_dataset(cg, c.name, H5T_NATIVE_DOUBLE, sr.total, sr.offset, sr.rows, c.width, col.data(), dxpl, false);
  }
  std::vector<PairForce> pairs;
  std::vector<WallForce> walls;
  for (const auto& mod : sim.modules) {
    mod->pair_forces(sim, pairs);
    mod->wall_forces(sim, walls);
  }
  const Rows pr = my_rows(pairs.size(), comm);
  std::vector<std::int64_t> ids(2 * pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    ids[2 * k] = pairs[k].i;
    ids[2 * k + 1] = pairs[k].j;
  }
  rows_dataset(cg, "pair_ids", H5T_NATIVE_INT64, pr.total, pr.offset, pr.rows, 2, ids.data(), dxpl, false);
  vec3_column(cg, "position_i", pr, pairs, &PairForce::xi, dxpl);
  vec3_column(cg, "branch", pr, pairs, &PairForce::branch, dxpl);
  vec3_column(cg, "force", pr, pairs, &PairForce::force, dxpl);
  const Rows wr = my_rows(walls.size(), comm);
  id_column(cg, "wall_particle", wr, walls, &WallForce::i, dxpl);
  vec3_column(cg, "wall_point", wr, walls, &WallForce::point, dxpl);
  vec3_column(cg, "wall_branch", wr, walls, &WallForce::branch, dxpl);
  vec3_column(cg, "wall_force", wr, walls, &WallForce::force, dxpl);
}

// The run's results as rank 0 has them. Attributes are created collectively, so every rank
// must pass the same ones: a module's result may hold per-rank numbers (self-gravity's timings),
// and a string attribute of a different length on one rank left the ranks in different
// metadata states, which hung both inside H5Fclose (gravity-wakes, snapshot after 3 orbits).
std::vector<std::pair<std::string, std::string>> results_of_rank0(const Simulation& sim) {
  std::string packed;
  if (sim.domain.rank == 0)
    for (const auto& [key, json] : sim.record.results) packed += key + '\0' + json + '\0';
  long long size = static_cast<long long>(packed.size());
  MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, sim.domain.comm);
  packed.resize(static_cast<std::size_t>(size));
  MPI_Bcast(packed.data(), static_cast<int>(size), MPI_CHAR, 0, sim.domain.comm);
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t at = 0; at < packed.size();) {
    const std::size_t key_end = packed.find('\0', at), value_end = packed.find('\0', key_end + 1);
    out.emplace_back(packed.substr(at, key_end - at), packed.substr(key_end + 1, value_end - key_end - 1));
    at = value_end + 1;
  }
  return out;
}

// parameters/: run state a restart needs beyond the particles (module counters and timers, the
// outlet counts), the run's results so far (results/), and what describes the run. The
// attribute `complete` is the last thing written.
void write_parameters(hid_t file, const Simulation& sim, const std::string& case_text, const std::string& run_id,
                      hid_t dxpl) {
  const Decomposition& dom = sim.domain;
  std::vector<std::pair<std::string, double>> state;
  for (const auto& m : sim.modules) m->save_state(state);
  long long counts[2] = {sim.halo.removed, sim.halo.removed_upper}, total[2];
  MPI_Allreduce(counts, total, 2, MPI_LONG_LONG, MPI_SUM, dom.comm);
  state.push_back({"halo.removed", double(total[0])});
  state.push_back({"halo.removed_upper", double(total[1])});
  if (dom.fed_x) {  // the same on every rank
    const long long fed[5] = {sim.halo.fed, sim.halo.drained, sim.halo.stillborn, sim.halo.returned, sim.halo.cornered};
    long long fed_total[5];
    MPI_Allreduce(fed, fed_total, 5, MPI_LONG_LONG, MPI_SUM, dom.comm);
    state.push_back({"halo.next_id", double(sim.halo.next_id)});
    const char* names[5] = {"halo.fed", "halo.drained", "halo.stillborn", "halo.returned", "halo.cornered"};
    for (int k = 0; k < 5; ++k) state.push_back({names[k], double(fed_total[k])});
  }
  Handle params = group(file, "parameters");
  {
    Handle sg = group(params, "state");
    for (const auto& [key, value] : state) small_dataset(sg, key, H5T_NATIVE_DOUBLE, {1}, &value, dxpl);
    Handle rg = group(file, "results");
    for (const auto& [key, json] : results_of_rank0(sim)) {
      char* end = nullptr;
      const double v = std::strtod(json.c_str(), &end);
      if (!json.empty() && end == json.c_str() + json.size()) attr_array<double>(rg, key, H5T_NATIVE_DOUBLE, {v});
      else if (json == "true" || json == "false") attr_array<int>(rg, key, H5T_NATIVE_INT, {json == "true"});
      else attr_string(rg, key, json.size() >= 2 && json.front() == '"' ? json.substr(1, json.size() - 2) : json);
    }
  }
  attr_string(params, "case", case_text);
  if (!run_id.empty()) attr_string(params, "run_id", run_id);
  // Settings in force that the case may leave to a default which has changed (contact_scheme).
  for (const auto& [key, value] : sim.cfg.recorded_settings) attr_string(params, key, value);
  attr_string(params, "units", "SI: m, s, kg, m/s, N, 1/s");
  const double now[3] = {sim.time, dom.shear.offset, sim.dt};
  small_dataset(params, "time_offset_dt", H5T_NATIVE_DOUBLE, {3}, now, dxpl);
  const double rate = dom.shear.enabled ? dom.shear.rate : 0.0;
  small_dataset(params, "shear_rate", H5T_NATIVE_DOUBLE, {1}, &rate, dxpl);
  const std::int32_t planar = dom.dims == 2;
  small_dataset(params, "planar", H5T_NATIVE_INT32, {1}, &planar, dxpl);
  // Angular velocity of the frame (Omega0 in the Hill frame, else 0): cassini-cg's T0 unit.
  small_dataset(params, "frame_rotation", H5T_NATIVE_DOUBLE, {1}, &sim.cfg.frame_rotation, dxpl);
  const std::int64_t s = sim.step_count;
  small_dataset(params, "step", H5T_NATIVE_INT64, {1}, &s, dxpl);
  attr_string(params, "complete", "yes");  // last thing written
}

// XDMF sidecar (rank 0): ParaView opens the particles as points with their scalars.
void write_xdmf(const std::string& final_name, double time, hsize_t total) {
  const std::string side = final_name.substr(0, final_name.size() - 5) + ".xdmf";
  std::ofstream xm(side);
  const std::string h5 = std::filesystem::path(final_name).filename().string();
  xm << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"grains\" GridType=\"Uniform\">\n"
     << "   <Time Value=\"" << time << "\"/>\n"
     << "   <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << total << "\"/>\n"
     << "   <Geometry GeometryType=\"XYZ\">\n    <DataItem Dimensions=\"1 " << total
     << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5 << ":/particles/grains/position/value</DataItem>\n   </Geometry>\n";
  for (const char* s : {"radius", "mass"})
    xm << "   <Attribute Name=\"" << s << "\" Center=\"Node\">\n    <DataItem Dimensions=\"1 " << total
       << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5 << ":/particles/grains/" << s
       << "/value</DataItem>\n   </Attribute>\n";
  xm << "   <Attribute Name=\"velocity\" Center=\"Node\" AttributeType=\"Vector\">\n    <DataItem Dimensions=\"1 " << total
     << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5 << ":/particles/grains/velocity/value</DataItem>\n   </Attribute>\n";
  xm << "  </Grid>\n </Domain>\n</Xdmf>\n";
  xm.close();
  if (!xm) io_failure(side, os_write_reason(side));
}

}  // namespace

std::string write_snapshot(Simulation& sim, const std::string& dir, const std::string& case_text,
                           const std::string& run_id) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // a failure is reported once, by io_failure
  sim.restart_point = true;  // a restart starts with a rebuild (and module setup): do the same
  sim.rebuild();             // here, so that both continue alike
  sim.restart_point = false;
  const std::vector<GrainColumn> columns = grain_columns(sim.particles);
  std::size_t width = 0;
  for (const auto& c : columns) width += c.width;
  const std::vector<double> rows = rows_by_id(sim, columns, width);

  std::ostringstream name;
  name << dir << "/snap_" << std::setw(9) << std::setfill('0') << sim.step_count << ".h5md";
  const std::string final_name = name.str(), tmp = final_name + ".partial";
  {
    const h5::WriteScope writing(tmp);
    Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "fapl");
    check(H5Pset_fapl_mpio(fapl, sim.domain.comm, MPI_INFO_NULL), "mpio");
    Handle file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl), H5Fclose, "create " + tmp);
    Handle dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose, "dxpl");
    check(H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE), "collective");
    h5::h5md_header(file);
    Handle particles = group(file, "particles");
    Handle grains = group(particles, "grains");
    write_grains(grains, columns, rows, width, tmp, sim, dxpl);
    write_box(grains, sim, dxpl);
    write_contacts(file, sim, dxpl);
    write_parameters(file, sim, case_text, run_id, dxpl);
    grains.close_checked("close particles/grains");  // a file closes only once nothing in it is open
    particles.close_checked("close particles");
    file.close_checked("close " + tmp);  // the metadata reaches the disk here: check it
  }
  const long total = sim.total_particles();
  MPI_Barrier(sim.domain.comm);
  if (sim.domain.rank == 0) {
    std::filesystem::rename(tmp, final_name);
    write_xdmf(final_name, sim.time, hsize_t(total));
  }
  MPI_Barrier(sim.domain.comm);
  return final_name;
}

namespace {

// Contact history: each rank reads a block of rows and sends each row to the rank that read its
// owner particle (particle rows are in id order, so rank r's block starts at id first[r]);
// migration then carries it on with its particle. No rank holds more than its share. The
// columns are those `history` declares (a column the snapshot lacks reads as zeros: a contact
// then starts it afresh, e.g. an impact speed from the present approach).
void read_history(const SnapshotReader& in, const std::vector<double>& my_ids, const Decomposition& dom,
                  PairHistory& history) {
  const int P = dom.nranks;
  const hsize_t M = in.extent("contacts/owner", 0);
  const hsize_t lo = M * dom.rank / P, n = M * (dom.rank + 1) / P - lo;
  std::vector<std::int64_t> owner(n), partner(n);
  in.read("contacts/owner", H5T_NATIVE_INT64, lo, n, 1, owner.data(), false);
  in.read("contacts/partner", H5T_NATIVE_INT64, lo, n, 1, partner.data(), false);
  const std::size_t W = static_cast<std::size_t>(history.width());
  std::vector<double> rows(W * n, 0.0);
  for (const PairHistory::Column& c : history.columns()) {
    if (!in.has("contacts/" + c.name)) continue;
    std::vector<double> col(c.width * n);
    in.read("contacts/" + c.name, H5T_NATIVE_DOUBLE, lo, n, c.width, col.data(), false);
    for (hsize_t k = 0; k < n; ++k) std::copy_n(&col[k * c.width], c.width, &rows[k * W + c.offset]);
  }

  // The first id of each rank's particle block (an empty block takes the next one's).
  const std::int64_t none = std::numeric_limits<std::int64_t>::max();
  const std::int64_t mine = my_ids.empty() ? none : bits_id(my_ids.front());
  std::vector<std::int64_t> first(P);
  MPI_Allgather(&mine, 1, MPI_INT64_T, first.data(), 1, MPI_INT64_T, dom.comm);
  for (int r = P - 2; r >= 0; --r) first[r] = std::min(first[r], first[r + 1]);
  std::vector<std::vector<double>> out(P);  // per row: owner, partner (as bits), the columns
  for (hsize_t k = 0; k < n; ++k) {
    const int r = std::max<int>(0, int(std::upper_bound(first.begin(), first.end(), owner[k]) - first.begin()) - 1);
    out[r].push_back(id_bits(owner[k]));
    out[r].push_back(id_bits(partner[k]));
    out[r].insert(out[r].end(), &rows[k * W], &rows[k * W] + W);
  }
  const std::vector<double> got = send_to_ranks(out, dom.comm);
  std::vector<std::int64_t> held(my_ids.size());  // ascending: the rows are in id order
  for (std::size_t k = 0; k < my_ids.size(); ++k) held[k] = bits_id(my_ids[k]);
  history.clear();
  for (std::size_t o = 0; o < got.size(); o += 2 + W)
    if (std::binary_search(held.begin(), held.end(), bits_id(got[o])))  // a contact of a particle not in the file: dropped
      std::copy_n(&got[o + 2], W, history.add(bits_id(got[o]), bits_id(got[o + 1])));
}

}  // namespace

void read_snapshot(Simulation& sim, const std::string& path) {
  const Decomposition& dom = sim.domain;
  ParticleStore& p = sim.particles;
  try {
    const SnapshotReader in(path, dom.comm);
    const hsize_t N = in.particles();
    const hsize_t lo = N * dom.rank / dom.nranks, n = N * (dom.rank + 1) / dom.nranks - lo;
    // This scene's columns, as the run that wrote the snapshot had them.
    const std::vector<GrainColumn> columns = grain_columns(p);
    std::vector<std::vector<double>> values;
    for (const auto& c : columns) {
      values.emplace_back(n * c.width, 0.0);
      if (!in.has(kGrains + c.name) && !c.former.empty() && in.has(kGrains + c.former)) {
        // An older snapshot kept these values as a share of a column several modules filled.
        const hsize_t w = std::max<hsize_t>(1, in.extent(kGrains + c.former + "/value", 2));  // [1][N]: one
        if (c.former_offset + c.width > static_cast<int>(w))
          throw ConfigError(path + ": particles/grains/" + c.former + " is narrower than the case's wall modules need");
        const std::vector<double> whole = in.grain(c.former, lo, n, w);
        for (hsize_t k = 0; k < n; ++k)
          std::copy_n(&whole[k * w + c.former_offset], c.width, &values.back()[k * c.width]);
        continue;
      }
      if (!in.has(kGrains + c.name)) {
        if (c.optional) continue;  // older snapshots: zeros (e.g. contacts take their present speed)
        throw ConfigError(path + ": the case needs particles/grains/" + c.name +
                          " but the snapshot has none (it was written for a scene without it)");
      }
      // ids travel as their bits; everything else converts exactly to double
      if (c.type == GrainColumn::Int64) {
        std::vector<std::int64_t> raw(n * c.width);
        in.read(kGrains + c.name + "/value", H5T_NATIVE_INT64, lo, n, c.width, raw.data());
        for (std::size_t k = 0; k < raw.size(); ++k) values.back()[k] = id_bits(raw[k]);
      } else {
        in.read(kGrains + c.name + "/value", H5T_NATIVE_DOUBLE, lo, n, c.width, values.back().data());
      }
    }
    auto column = [&](const std::string& name) -> const std::vector<double>& {
      for (std::size_t k = 0; k < columns.size(); ++k)
        if (columns[k].name == name) return values[k];
      throw std::logic_error("no grain column " + name);
    };
    const auto &ids = column("id"), &species = column("species"), &radius = column("radius"), &mass = column("mass"),
               &x = column("position"), &v = column("velocity");
    p.resize(0);
    for (hsize_t k = 0; k < n; ++k) {
      p.add(bits_id(ids[k]), static_cast<int>(species[k]), radius[k], mass[k], Vec3(x[3 * k], x[3 * k + 1], x[3 * k + 2]),
            Vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2]));
      for (std::size_t c = 0; c < columns.size(); ++c)
        if (columns[c].unpack) columns[c].unpack(p, k, &values[c][k * columns[c].width]);
    }
    p.nlocal = p.size();

    const double state[3] = {in.number("parameters/time_offset_dt", 0), in.number("parameters/time_offset_dt", 1),
                             in.number("parameters/time_offset_dt", 2)};
    std::int64_t step = 0;
    in.read("parameters/step", H5T_NATIVE_INT64, 0, 1, 1, &step, false);
    read_history(in, ids, dom, sim.history);
    if (std::abs(state[2] - sim.dt) > 1e-12 * sim.dt)
      throw ConfigError(path + ": snapshot dt " + std::to_string(state[2]) + " differs from the case's dt " +
                        std::to_string(sim.dt) + " (a restart must keep the time step)");
    // Named run state (written by every rank alike; outlet counts go to rank 0 only).
    sim.restart_state.clear();
    if (in.has("parameters/state")) {
      Handle sg(H5Gopen2(in.file(), "parameters/state", H5P_DEFAULT), H5Gclose, "group parameters/state");
      std::vector<std::string> keys;
      H5Literate(sg, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect_name, &keys);
      for (const auto& key : keys) sim.restart_state.push_back({key, in.number("parameters/state/" + key)});
    }
    double count = 0;
    if (sim.domain.rank == 0 && sim.restart_value("halo.removed", count)) sim.halo.removed = static_cast<std::int64_t>(count);
    if (sim.domain.rank == 0 && sim.restart_value("halo.removed_upper", count))
      sim.halo.removed_upper = static_cast<std::int64_t>(count);
    if (sim.restart_value("halo.next_id", count)) sim.halo.next_id = static_cast<std::int64_t>(count);
    // Totals over the ranks: rank 0 carries them on (a snapshot before 2026-11-28 lacks the last two).
    for (auto [key, counter] : {std::pair{"halo.fed", &sim.halo.fed}, {"halo.drained", &sim.halo.drained},
                                {"halo.stillborn", &sim.halo.stillborn}, {"halo.returned", &sim.halo.returned},
                                {"halo.cornered", &sim.halo.cornered}})
      if (sim.domain.rank == 0 && sim.restart_value(key, count)) *counter = static_cast<std::int64_t>(count);
    sim.step_count = step;
    sim.time = state[0];
    sim.domain.shear.offset = state[1];
    sim.time_at_build_ = state[0];
    sim.restored = true;
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError(path + ": not a complete cassini snapshot (truncated, still being written, or not H5MD from "
                             "cassini): " + e.what());
  }
}

std::string snapshot_parameter(const std::string& path, const std::string& name) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);  // serial: every rank reads the attribute
  if (file < 0) throw ConfigError(path + ": not a readable HDF5 file (truncated, or not a cassini snapshot)");
  std::string text;
  if (H5Aexists_by_name(file, "parameters", name.c_str(), H5P_DEFAULT) > 0) {
    const hid_t a = H5Aopen_by_name(file, "parameters", name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    const hid_t type = H5Aget_type(a);
    text.resize(H5Tget_size(type));
    if (H5Aread(a, type, text.data()) < 0) text.clear();
    H5Tclose(type);
    H5Aclose(a);
    text = text.c_str();  // drop the terminating NUL
  }
  H5Fclose(file);
  return text;
}

double snapshot_time(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw ConfigError(path + ": not a readable HDF5 file (truncated, or not a cassini snapshot)");
  double now[3] = {0, 0, 0};
  const hid_t d = H5Dopen2(file, "parameters/time_offset_dt", H5P_DEFAULT);
  const bool ok = d >= 0 && H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, now) >= 0;
  if (d >= 0) H5Dclose(d);
  H5Fclose(file);
  if (!ok) throw ConfigError(path + ": not a complete cassini snapshot (no parameters/time_offset_dt)");
  return now[0];
}

std::string snapshot_case_text(const std::string& path) {
  std::string text = snapshot_parameter(path, "case");
  if (text.empty()) throw ConfigError(path + ": not a complete cassini snapshot (it stores no case)");
  return text;
}

void check_restart_case(const std::string& snapshot, const CaseFile& now) {
  if (!std::filesystem::exists(snapshot)) throw ConfigError("--restart '" + snapshot + "': no such file");
  if (std::filesystem::is_directory(snapshot))
    throw ConfigError("--restart '" + snapshot + "': is a directory, expected a snap_<step>.h5md file");
  CaseFile then = CaseFile::parse(snapshot_case_text(snapshot), snapshot + " (its stored case)");
  // Compare what each case resolves to (defaults filled in, dt however it was given), so that
  // writing a default out or giving dt for the equivalent n_c is no change. A stored case that
  // today's reader refuses (an older format) is compared as printed text instead.
  std::map<std::string, std::string> old, cur = now.resolved();
  try {
    read_config(then);
    old = then.resolved();
  } catch (const ConfigError&) {
    std::ostringstream printed;
    printed << now.table();
    const CaseFile now_printed = CaseFile::parse(printed.str(), now.source());
    for (const auto& [k, v] : then.leaf_values()) old[k] = v;
    cur.clear();
    for (const auto& [k, v] : now_printed.leaf_values()) cur[k] = v;
  }
  auto may_change = [](const std::string& key) {
    for (const char* prefix : {"output.", "guards."})
      if (key.rfind(prefix, 0) == 0) return true;
    for (const char* k : {"time.end", "time.force", "domain.slab_axis", "domain.decomposition", "domain.grid",
                        "domain.balance_every"})
      if (key == k) return true;
    return false;
  };
  auto same = [](const std::string& a, const std::string& b) {
    if (a == b) return true;
    char *ea = nullptr, *eb = nullptr;
    const double x = std::strtod(a.c_str(), &ea), y = std::strtod(b.c_str(), &eb);
    return ea == a.c_str() + a.size() && eb == b.c_str() + b.size() && !a.empty() && !b.empty() &&
           std::abs(x - y) <= 1e-12 * std::max(std::abs(x), std::abs(y));
  };
  std::set<std::string> keys;
  for (const auto& [k, v] : old) keys.insert(k);
  for (const auto& [k, v] : cur) keys.insert(k);
  // Name a key the case files write before one whose default follows from it (contact.skin
  // from the radius), and list the rest.
  std::set<std::string> written;
  for (const auto& [k, v] : then.leaf_values()) written.insert(k);
  for (const auto& [k, v] : now.leaf_values()) written.insert(k);
  std::vector<std::string> differ;
  for (const auto& k : keys) {
    if (may_change(k)) continue;
    const auto o = old.find(k), c = cur.find(k);
    if (!same(o == old.end() ? "(absent)" : o->second, c == cur.end() ? "(absent)" : c->second)) differ.push_back(k);
  }
  std::stable_partition(differ.begin(), differ.end(), [&](const std::string& k) { return written.count(k) > 0; });
  if (!differ.empty()) {
    const std::string& k = differ.front();
    const auto o = old.find(k), c = cur.find(k);
    const std::string was = o == old.end() ? "(absent)" : o->second, is = c == cur.end() ? "(absent)" : c->second;
    std::string also;
    for (std::size_t n = 1; n < differ.size() && n <= 5; ++n) also += (n > 1 ? ", " : "") + differ[n];
    throw ConfigError(now.source() + ": key '" + k + "' is " + is + " but the snapshot " + snapshot + " was made with " +
                      was + (also.empty() ? "" : " (also differs: " + also + ")") +
                      ": a restart continues the same system (only time.end, output.*, guards.*, time.force "
                      "and the parallel layout may change)");
  }
  // A continuation must have steps to run: an end at or before the snapshot's time would
  // "complete" with none.
  const double t_snap = snapshot_time(snapshot);
  const auto t_end = cur.find("time.end");
  if (t_end != cur.end() && !(std::strtod(t_end->second.c_str(), nullptr) > t_snap)) {
    std::ostringstream os;
    os << now.source() << ": key 'time.end' is " << t_end->second << " s, not after the snapshot's time " << t_snap
       << " s (" << snapshot << "): expected a later end for the run to continue to (--set time.end=...)";
    throw ConfigError(os.str());
  }
}

}  // namespace cassini
