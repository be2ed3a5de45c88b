#include "io/RunOutput.hpp"

#include <filesystem>
#include <iomanip>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <iostream>
#include <sstream>

#include <unistd.h>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "core/Version.hpp"
#include "io/IoFailure.hpp"
#include "io/Snapshot.hpp"

namespace fs = std::filesystem;

namespace cassini {

namespace {
// observables.csv's own columns; the modules' (Module::observables) follow.
const char* const kObservablesHeader =
    "step,time,particles,kinetic_energy,elastic_energy,px,py,pz,T_xx,T_yy,T_zz";
}  // namespace

namespace {

// errno is often gone by the time a stream reports failure (a later flush): ask the file system.
std::string write_reason(const std::string& file) {
  const std::string os = os_write_reason(file);
  return os.empty() ? std::string("the write failed (the file system reports no error)") : os;
}

const char* kMarker = ".cassini-run";

std::string utc_now() {  // ISO 8601, seconds
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string host_name() {
  char buf[256] = {0};
  return gethostname(buf, sizeof buf - 1) == 0 ? std::string(buf) : std::string("unknown");
}  // written into every run directory cassini creates

bool inside(const fs::path& p, const fs::path& dir) {  // p is dir or below it (both canonical)
  auto d = dir.begin(), q = p.begin();
  for (; d != dir.end(); ++d, ++q)
    if (q == p.end() || *d != *q) return false;
  return true;
}

// Why `dir` may not be (re)used as the output directory, or "" when it may. Nothing is touched.
std::string refuse_output(const std::string& dir, bool force, const std::vector<RunInput>& keep) {
  std::error_code ec;
  const fs::path out = fs::weakly_canonical(fs::absolute(dir), ec);
  if (fs::exists(out) && !fs::is_directory(out))
    return "--out '" + dir + "' is a file, not a directory: cassini never replaces a file; choose another --out";
  const fs::path cwd = fs::weakly_canonical(fs::current_path(), ec);
  if (inside(cwd, out))
    return "--out '" + dir + "' is the working directory or one of its parents: refused, nothing was touched";
  for (const auto& [path, what] : keep) {
    if (path.empty()) continue;
    if (inside(fs::weakly_canonical(fs::absolute(path), ec), out))
      return "--out '" + dir + "' holds '" + path + "', which this run reads (" + what + "): nothing was touched; " +
             "write to another --out" + (what == "--restart" ? " (continuing a run in place would overwrite its frames)" : "");
  }
  if (!fs::exists(out) || fs::is_empty(out)) return "";
  if (!force) return "output directory '" + dir + "' exists and is not empty: choose another --out or pass --force";
  if (!fs::exists(out / kMarker))
    return "--force replaces only a run directory cassini made (it holds " + std::string(kMarker) + "); '" + dir +
           "' is not one: nothing was deleted";
  return "";
}

}  // namespace

RunOutput::RunOutput(const std::string& dir, bool force, MPI_Comm comm, const std::vector<RunInput>& keep)
    : started_(utc_now()), dir_(dir), comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  std::string error;
  if (rank_ == 0) {
    std::error_code ec;
    error = refuse_output(dir, force, keep);
    if (error.empty() && fs::exists(dir) && !fs::is_empty(dir)) {  // a cassini run directory, --force given
      fs::remove_all(dir, ec);
      if (ec) error = "cannot replace output directory '" + dir + "': " + ec.message();
    }
    if (error.empty()) {
      fs::create_directories(dir + "/dump", ec);
      if (ec) error = "cannot create output directory '" + dir + "': " + ec.message();
    }
    if (error.empty()) {
      std::ofstream(dir + "/" + kMarker) << "A cassini run directory: `cassini ... --out " << dir
                                        << " --force` may replace it.\n";
      if (!fs::exists(dir + "/" + kMarker)) error = "cannot write into output directory '" + dir + "'";
    }
  }
  int len = static_cast<int>(error.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, comm);
  error.resize(len);
  MPI_Bcast(error.data(), len, MPI_CHAR, 0, comm);
  if (!error.empty()) throw ConfigError(error);
  // A write that fails on any rank ends the job: that rank says so in summary.json first.
  set_io_failure_summary([this](const std::string& why) { error_summary(why, true); });
  if (rank_ == 0) {
    set_io_failure_log(dir + "/run.log");
    log_.open(dir + "/run.log");
    obs_.open(dir + "/observables.csv");
    h5obs_ = std::make_unique<ObservablesFile>(dir + "/observables.h5md");
  }
}

void RunOutput::checked_flush(std::ofstream& out, const std::string& name) {
  out.flush();
  if (!out || injected_write_failure(name, rank_)) {
    const std::string why = out ? "No space left on device (injected by CASSINI_FAIL_WRITE)" : write_reason(dir_ + "/" + name);
    set_io_failure_log("");  // run.log may be the file that failed
    io_failure(dir_ + "/" + name, why);
  }
}

void RunOutput::log(const std::string& line) {
  if (rank_ != 0) return;
  std::cout << line << std::endl;
  log_ << line << "\n";
  checked_flush(log_, "run.log");
}

void RunOutput::log_only(const std::string& line) {
  if (rank_ != 0) return;
  log_ << line << "\n";
  log_.flush();  // best effort: this reports an error already
}

void RunOutput::write_text(const std::string& name, const std::string& text) {
  if (rank_ != 0) return;
  // Under a temporary name, then renamed: a full disk never leaves a complete-looking file.
  const std::string path = dir_ + "/" + name, tmp = path + ".partial";
  std::ofstream out(tmp);
  out << text;
  out.close();
  if (!out || injected_write_failure(name, rank_))
    io_failure(path, out ? "No space left on device (injected by CASSINI_FAIL_WRITE)" : write_reason(path));
  fs::rename(tmp, path);
}

void RunOutput::observe(Simulation& sim) {
  // Granular temperature per component: mass-weighted variance of the velocity relative to
  // the imposed flow (the Lees-Edwards shear) or, without one, to the mean velocity.
  const ParticleStore& p = sim.particles;
  const double ke = sim.kinetic_energy(), pe = sim.elastic_energy();
  const Vec3 mom = sim.momentum();
  const long n = sim.total_particles();
  double local[7] = {0};  // mass, m dv^2 per axis, LE1 population, fed, drained
  for (std::size_t i = 0; i < p.nlocal; ++i) local[0] += p.mass[i];
  double mass = 0;
  MPI_Allreduce(&local[0], &mass, 1, MPI_DOUBLE, MPI_SUM, comm_);
  const Vec3 mean = sim.domain.shear.enabled ? Vec3::Zero() : Vec3(mom / mass);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Vec3 dv = p.v[i] - mean - sim.imposed_flow(p.x[i]);
    for (int d = 0; d < 3; ++d) local[1 + d] += p.mass[i] * dv[d] * dv[d];
  }
  if (p.copies) {  // modified Lees-Edwards boundaries: LE1's population and the feed's counts
    for (std::size_t i = 0; i < p.nlocal; ++i) local[4] += p.le_copy[i] == 0;
    local[5] = double(sim.halo.fed);
    local[6] = double(sim.halo.drained);
  }
  double sums[std::size(local)];
  MPI_Allreduce(local, sums, int(std::size(local)), MPI_DOUBLE, MPI_SUM, comm_);
  std::vector<std::pair<std::string, double>> own;  // the modules' own columns (collective)
  for (const auto& m : sim.modules) m->observables(sim, own);
  if (rank_ != 0) return;
  if (!header_written_) write_header(own);
  obs_ << std::setprecision(12) << sim.step_count << "," << sim.time << "," << n << "," << ke << "," << pe << ","
       << mom[0] << "," << mom[1] << "," << mom[2] << "," << sums[1] / mass << "," << sums[2] / mass << ","
       << sums[3] / mass;
  for (const auto& [name, value] : own) obs_ << "," << value;
  obs_ << "\n";
  checked_flush(obs_, "observables.csv");
  // Granular temperature: the mean velocity variance over the axes that move.
  const int dims = sim.cfg.planar ? 2 : 3;
  const std::vector<double> variance = {sums[1] / mass, sums[2] / mass, sums[3] / mass};
  ObservablesFile::Row row = {{"particles", {double(n)}},
                  {"kinetic_energy", {ke}},
                  {"elastic_energy", {pe}},
                  {"momentum", {mom[0], mom[1], mom[2]}},
                  {"velocity_variance", variance},
                  {"granular_temperature", {(variance[0] + variance[1] + (dims == 3 ? variance[2] : 0.0)) / dims}}};
  for (const auto& [name, value] : own) row.push_back({name, {value}});
  if (p.copies)
    row.insert(row.end(), {{"le1_particles", {sums[4]}}, {"fed_into_le1", {sums[5]}}, {"drained_from_le1", {sums[6]}}});
  h5obs_->append(sim.step_count, sim.time, row);
}

void RunOutput::snapshot(Simulation& sim) {
  const double start = MPI_Wtime();
  const std::string file = write_snapshot(sim, dir_, case_text, run_id);
  const double seconds = MPI_Wtime() - start;
  const long particles = sim.total_particles();  // collective
  if (rank_ != 0) return;  // run.log only: a line per frame would crowd the progress output
  std::error_code ec;
  const double mb = double(std::filesystem::file_size(file, ec)) / 1e6;
  log_ << "snapshot " << std::filesystem::path(file).filename().string() << ": " << particles << " particles, "
       << mb << " MB in " << seconds << " s (" << (seconds > 0 ? mb / seconds : 0.0) << " MB/s)\n";
  log_.flush();
}

void RunOutput::dump(const Simulation& sim, const std::string& tag) {
  const ParticleStore& p = sim.particles;
  std::ostringstream name;
  name << dir_ << "/dump/" << tag << "_" << std::setw(9) << std::setfill('0') << sim.step_count << ".rank" << rank_
       << ".txt";
  // Written under a temporary name and renamed: a crash never leaves a complete-looking dump.
  const std::string tmp = name.str() + ".partial";
  {
    std::ofstream out(tmp);
    out << "# step " << sim.step_count << " time " << std::setprecision(17) << sim.time << "\n";
    out << "# id species radius x y z vx vy vz\n";
    for (std::size_t i = 0; i < p.nlocal; ++i)
      out << p.id[i] << " " << p.species[i] << " " << p.radius[i] << " " << p.x[i][0] << " " << p.x[i][1] << " "
          << p.x[i][2] << " " << p.v[i][0] << " " << p.v[i][1] << " " << p.v[i][2] << "\n";
    out.close();
    if (!out) io_failure(tmp, write_reason(tmp));
  }
  fs::rename(tmp, name.str());
}

std::string json_number(double v) {  // JSON has no inf or NaN
  if (!std::isfinite(v)) return "null";
  std::ostringstream os;
  os << std::setprecision(10) << v;
  return os.str();
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += std::string("\\") + c;
    else if (c == '\n') out += "\\n";
    else if (static_cast<unsigned char>(c) < 0x20) out += ' ';
    else out += c;
  }
  return out + "\"";
}

void RunOutput::summary(Simulation& sim, double wall, long steps, const std::string& status, const std::string& reason) {
  // MPI calls of the step loop, read before this function makes its own.
  namespace mc = mpi_counters;
  const mc::Counts mpi = sim.record.timers.mpi();
  const auto stage_calls = sim.record.timers.collectives();
  std::array<double, 2 * mc::kKinds + StageTimers::kStages> mine_mpi{}, sum_mpi{};
  for (int k = 0; k < mc::kKinds; ++k) {
    mine_mpi[k] = double(mpi.calls[k]);
    mine_mpi[mc::kKinds + k] = double(mpi.bytes[k]);
  }
  for (int k = 0; k < StageTimers::kStages; ++k) mine_mpi[2 * mc::kKinds + k] = double(stage_calls[k]);
  MPI_Reduce(mine_mpi.data(), sum_mpi.data(), int(mine_mpi.size()), MPI_DOUBLE, MPI_SUM, 0, comm_);
  // Pair evaluations per distinct pair: owned pairs once (listed twice), pairs across ranks
  // (and periodic self-images) on each side.
  const double entries[2] = {sim.record.list_entries, sim.record.ghost_entries};
  double entries_sum[2] = {0, 0};
  MPI_Reduce(entries, entries_sum, 2, MPI_DOUBLE, MPI_SUM, 0, comm_);
  const double owned_pairs = 0.5 * (entries_sum[0] - entries_sum[1]);
  const double evaluations_per_pair = entries_sum[0] > 0 ? (owned_pairs + entries_sum[1]) / (owned_pairs + 0.5 * entries_sum[1]) : 1.0;
  const double ke = sim.kinetic_energy();
  const long n = sim.total_particles();
  const double mine = wall > 0 ? double(sim.particles.nlocal) * steps / wall : 0.0;
  std::vector<double> rates(sim.domain.nranks);
  MPI_Gather(&mine, 1, MPI_DOUBLE, rates.data(), 1, MPI_DOUBLE, 0, comm_);
  // Stage times: min, mean and max over ranks (the spread is the load imbalance per stage);
  // "other" is the rest of rank 0's wall time (the one summary.json reports) on each rank.
  double wall0 = wall;
  MPI_Bcast(&wall0, 1, MPI_DOUBLE, 0, comm_);
  constexpr int ns = StageTimers::kStages + 1;
  std::array<double, ns> t{};
  const auto stage_seconds = sim.record.timers.seconds();
  for (int k = 0; k < StageTimers::kStages; ++k) t[k] = stage_seconds[k];
  double staged = 0;
  for (int k = 0; k < StageTimers::kStages; ++k) staged += t[k];
  t[ns - 1] = std::max(0.0, wall0 - staged);
  std::array<double, ns> tmin{}, tmax{}, tsum{};
  MPI_Reduce(t.data(), tmin.data(), ns, MPI_DOUBLE, MPI_MIN, 0, comm_);
  MPI_Reduce(t.data(), tmax.data(), ns, MPI_DOUBLE, MPI_MAX, 0, comm_);
  MPI_Reduce(t.data(), tsum.data(), ns, MPI_DOUBLE, MPI_SUM, 0, comm_);
  // Halo traffic over all ranks (bytes and messages to other ranks), per step.
  std::int64_t traffic[2] = {sim.halo.bytes_sent, sim.halo.messages_sent}, traffic_sum[2] = {0, 0};
  MPI_Reduce(traffic, traffic_sum, 2, MPI_INT64_T, MPI_SUM, 0, comm_);
  if (rank_ != 0) return;
  auto stage_name = [](int k) { return k < StageTimers::kStages ? StageTimers::names[k] : "other"; };
  std::ostringstream table;
  table.setf(std::ios::fixed);
  table.precision(3);
  table << "time per stage (s over the run; min / mean / max over ranks; % of the wall time " << wall << " s):";
  for (int k = 0; k < ns; ++k) {
    const double mean = tsum[k] / sim.domain.nranks;
    table << "\n  " << std::left << std::setw(10) << stage_name(k) << std::right << std::setw(10) << tmin[k]
          << std::setw(10) << mean << std::setw(10) << tmax[k] << std::setw(8) << std::setprecision(1)
          << (wall > 0 ? 100 * mean / wall : 0.0) << " %  "
          << (k < StageTimers::kStages ? StageTimers::meaning[k] : "set-up of the step loop, guards, the rest")
          << std::setprecision(3);
  }
  // Per step and rank (means over ranks).
  const double per = steps > 0 ? 1.0 / (double(steps) * sim.domain.nranks) : 0.0;
  double collectives = 0, collective_bytes = 0;
  for (int k = 0; k < mc::kKinds; ++k)
    if (k != mc::Send) {
      collectives += sum_mpi[k] * per;
      collective_bytes += sum_mpi[mc::kKinds + k] * per;
    }
  table << "\nMPI per step and rank: " << std::setprecision(2) << collectives << " collectives (" << collective_bytes
        << " B in), " << sum_mpi[mc::Send] * per << " sends (" << std::setprecision(0)
        << sum_mpi[mc::kKinds + mc::Send] * per << " B); collectives by stage:";
  table << std::setprecision(2);
  for (int k = 0; k < StageTimers::kStages; ++k) table << " " << StageTimers::names[k] << " " << sum_mpi[2 * mc::kKinds + k] * per;
  timing_ = table.str();
  auto num = json_number;
  std::ostringstream js;
  js << "{\n"
     << "  \"status\": " << json_string(status) << ",\n"
     << "  \"stop_reason\": " << json_string(reason) << ",\n"
     << "  \"case\": " << json_string(sim.cfg.source) << ",\n"
     << "  \"run_id\": " << json_string(run_id) << ",\n"
     << provenance_json()
     << "  \"steps\": " << steps << ",\n"
     << "  \"final_step\": " << sim.step_count << ",\n"
     << "  \"simulated_time\": " << num(sim.time) << ",\n"
     << "  \"dt\": " << num(sim.dt) << ",\n"
     << "  \"particles\": " << n << ",\n"
     << "  \"wall_seconds\": " << num(wall) << ",\n"
     << "  \"particle_steps_per_second\": " << num(wall > 0 ? double(n) * steps / wall : 0.0) << ",\n"
     << "  \"particle_steps_per_second_per_rank\": [";
  for (int r = 0; r < sim.domain.nranks; ++r) js << (r ? ", " : "") << num(rates[r]);
  js << "]";
  js << ",\n  \"mpi_per_step_per_rank\": {\"collectives\": " << num(collectives)
     << ", \"collective_bytes\": " << num(collective_bytes) << ", \"collectives_by_stage\": {";
  for (int k = 0; k < StageTimers::kStages; ++k)
    js << (k ? ", " : "") << json_string(StageTimers::names[k]) << ": " << num(sum_mpi[2 * mc::kKinds + k] * per);
  js << "}";
  for (int k = 0; k < mc::kKinds; ++k)
    js << ", " << json_string(mc::kNames[k]) << ": {\"calls\": " << num(sum_mpi[k] * per)
       << ", \"bytes\": " << num(sum_mpi[mc::kKinds + k] * per) << "}";
  js << "}";
  js << ",\n  \"halo_bytes_per_step\": " << num(steps > 0 ? double(traffic_sum[0]) / steps : 0.0)
     << ",\n  \"halo_messages_per_step\": " << num(steps > 0 ? double(traffic_sum[1]) / steps : 0.0);
  js << ",\n  \"neighbour_rebuilds\": " << sim.rebuilds << ",\n  \"slab_cuts\": [";
  const std::vector<double>& slab_cuts = sim.domain.cuts[sim.domain.axis];
  for (std::size_t r = 0; r < slab_cuts.size(); ++r) js << (r ? ", " : "") << num(slab_cuts[r]);
  js << "],\n  \"decomposition\": " << json_string(sim.cfg.decomposition);
  if (sim.cfg.decomposition == "grid") {
    const Decomposition& dom = sim.domain;
    js << ",\n  \"grid\": [" << dom.grid[0] << ", " << dom.grid[1] << ", " << dom.grid[2] << "],\n  \"grid_cuts\": [";
    for (int d = 0; d < 3; ++d) {
      js << (d ? ", [" : "[");
      for (std::size_t r = 0; r < dom.cuts[d].size(); ++r) js << (r ? ", " : "") << num(dom.cuts[d][r]);
      js << "]";
    }
    js << "]";
  }
  js << ",\n  \"imbalance_at_last_balancing\": " << num(sim.record.imbalance);
  js << ",\n  \"pair_evaluations_per_pair\": " << num(evaluations_per_pair);
  js << ",\n  \"imbalance_mean\": " << num(sim.record.imbalance_samples ? sim.record.imbalance_sum / sim.record.imbalance_samples : 1.0);
  js << ",\n  \"imbalance_worst\": " << num(sim.record.imbalance_worst) << ",\n  \"active_modules\": [";
  const auto names = sim.module_names();
  for (std::size_t k = 0; k < names.size(); ++k) js << (k ? ", " : "") << json_string(names[k]);
  js << "],\n  \"final_kinetic_energy\": " << num(ke) << ",\n  \"stage_seconds\": {";
  for (int k = 0; k < ns; ++k)
    js << (k ? ", " : "") << "\n    " << json_string(stage_name(k)) << ": {\"min\": " << num(tmin[k])
       << ", \"mean\": " << num(tsum[k] / sim.domain.nranks) << ", \"max\": " << num(tmax[k]) << "}";
  js << "\n  }";
  if (sim.record.finished) js << ",\n  \"ended\": " << json_string(sim.record.finish_reason);
  for (const auto& [k, v] : sim.record.results) js << ",\n  " << json_string(k) << ": " << v;
  js << "\n}\n";
  write_text("summary.json", js.str());
}

void RunOutput::write_header(const std::vector<std::pair<std::string, double>>& own) {
  obs_ << kObservablesHeader;
  for (const auto& [name, value] : own) obs_ << "," << name;
  obs_ << "\n";
  checked_flush(obs_, "observables.csv");
  header_written_ = true;
}

RunOutput::~RunOutput() {
  set_io_failure_summary(nullptr);
  if (rank_ != 0 || header_written_ || !obs_.is_open()) return;
  obs_ << kObservablesHeader << "\n";  // best effort: no throwing here
}

void RunOutput::error_summary(const std::string& reason, bool any_rank) {
  if (rank_ != 0 && !any_rank) return;
  const std::string text = "{\n  \"status\": \"error\",\n  \"stop_reason\": " + json_string(reason) + ",\n" +
                           provenance_json() + "  \"run_id\": " + json_string(run_id) + "\n}\n";
  if (!any_rank) return write_text("summary.json", text);
  // The rank that failed, just before it aborts the job: quietly, under a name of its own, and
  // renamed only when whole (the disk may be what failed).
  const std::string path = dir_ + "/summary.json";
  std::string tmp = path + ".partial";
  tmp.append(".").append(std::to_string(rank_));
  std::ofstream out(tmp);
  out << text;
  out.close();
  std::error_code ec;
  if (out) fs::rename(tmp, path, ec);
  if (!out || ec) fs::remove(tmp, ec);
}

std::string RunOutput::provenance_json() const {
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  std::ostringstream js;
  js << "  \"version\": " << json_string(version()) << ",\n"
     << "  \"commit\": " << json_string(commit()) << ",\n"
     << "  \"started\": " << json_string(started_) << ",\n"
     << "  \"ended_at\": " << json_string(utc_now()) << ",\n"
     << "  \"host\": " << json_string(host_name()) << ",\n"
     << "  \"ranks\": " << ranks << ",\n"
     << "  \"command\": " << json_string(command) << ",\n"
     << "  \"restarted_from\": " << (restarted_from.empty() ? "null" : json_string(restarted_from)) << ",\n";
  return js.str();
}

std::string RunOutput::provenance_line() const {
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  return std::string("cassini ") + version() + " (commit " + commit() + "), " + host_name() + ", " +
         std::to_string(ranks) + " rank(s), started " + started_ + "\ncommand: " + command;
}

void RunOutput::ensemble_summary(const std::string& status, const std::string& reason, int runs, int finished,
                                 double wall) {
  if (rank_ != 0) return;
  std::ostringstream js;
  js << "{\n  \"status\": " << json_string(status) << ",\n  \"stop_reason\": " << json_string(reason) << ",\n"
     << "  \"run_id\": " << json_string(run_id) << ",\n" << provenance_json()
     << "  \"ensemble_runs\": " << runs << ",\n  \"runs_finished\": " << finished << ",\n"
     << "  \"wall_seconds\": " << json_number(wall) << ",\n"
     << "  \"table\": \"ensemble.csv\"\n}\n";
  write_text("summary.json", js.str());
}

}  // namespace cassini
