#include "app/Ensemble.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <sstream>

#include <mpi.h>

#include "core/Interrupt.hpp"
#include "core/ModuleRegistry.hpp"
#include "core/Simulation.hpp"
#include "io/RunOutput.hpp"

namespace cassini {

namespace {
std::string result(const Simulation& sim, const std::string& key) {
  for (const auto& [k, v] : sim.record.results)
    if (k == key) return v;
  return "";
}
}  // namespace

int run_ensemble(const Config& base, int runs, RunOutput& out) {
  int rank = 0, nranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &nranks);
  // What the runs share (the drag's flow solve, cached), once for everybody before the runs.
  for (const ModuleKind& kind : module_kinds())
    if (kind.prepare && base.has_module(kind.name)) kind.prepare(base, MPI_COMM_WORLD);

  const std::string header =
      "run,seed,D_over_d,clogged,escapees,clog_time,simulated_time,inserted,max_overlap_over_radius,wall_seconds,"
      "front_time,escapees_after_front,avalanches,avalanche_starts,longest_pause,ended,count_time,escapees_after_count,"
      "recovery_clogs,open_avalanche,open_avalanche_start,phi_beyond_clear,avalanche_clogs";
  const std::string part = out.dir() + "/ensemble.rank" + std::to_string(rank) + ".csv";
  std::ofstream rows(part);
  rows << header << "\n";
  const auto t0 = std::chrono::steady_clock::now();
  int done = 0, interrupted = 0;
  for (int k = rank; k < runs && !interrupted; k += nranks) {
    Config cfg = base;
    cfg.seed = base.seed + static_cast<std::uint64_t>(k);
    const auto r0 = std::chrono::steady_clock::now();
    Simulation sim(cfg, MPI_COMM_SELF);
    sim.setup();
    std::string ended = sim.record.finish_reason;
    double worst = 0;
    try {
      sim.run();
      if (!sim.record.finished) ended = "time limit";
      else ended = sim.record.finish_reason;
      interrupted = sim.record.interrupted;
      if (interrupted) break;  // an unfinished run is no sample: not in the table
    } catch (const GuardError& e) {
      ended = std::string("guard: ") + e.what();
      std::replace(ended.begin(), ended.end(), ',', ';');
      std::replace(ended.begin(), ended.end(), '\n', ' ');
    }
    for (const auto& m : sim.modules) worst = std::max(worst, m->max_overlap_fraction());
    const std::string ins = result(sim, "inserted");
    const long inserted = ins.empty() ? 0 : std::stol(ins);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - r0).count();
    std::string ct = result(sim, "clog_time");
    auto field = [&](const std::string& key) {  // JSON null -> empty; a list -> space-separated
      std::string v = result(sim, key);
      if (v == "null") return std::string();
      v.erase(std::remove_if(v.begin(), v.end(), [](char c) { return c == '[' || c == ']' || c == ','; }), v.end());
      return v;
    };
    rows << k << "," << cfg.seed << "," << result(sim, "D_over_d")  // empty without a clog monitor
         << "," << (result(sim, "clogged") == "true" ? 1 : 0)
         << "," << result(sim, "escapees") << "," << (ct == "null" ? "" : ct) << "," << sim.time << "," << inserted << ","
         << worst << "," << wall << "," << field("front_time") << "," << field("escapees_after_front") << ","
         << field("avalanches") << "," << field("avalanche_starts") << "," << field("longest_pause") << "," << ended << ","
         << field("count_time") << "," << field("escapees_after_count") << "," << field("recovery_clogs") << ","
         << field("open_avalanche") << "," << field("open_avalanche_start") << "," << field("phi_beyond_clear") << ","
         << field("avalanche_clogs") << "\n";
    rows.flush();
    ++done;
    if (rank == 0) {
      const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const int mine = (runs - rank + nranks - 1) / nranks;
      std::ostringstream os;
      os.precision(3);
      os << "run " << k << " (seed " << cfg.seed << "): " << ended << ", s = " << result(sim, "escapees") << ", "
         << wall << " s;  rank 0 " << done << "/" << mine << ", ETA " << el / done * (mine - done) << " s";
      out.log(os.str());
    }
  }
  rows.close();
  int signal = 0;  // any rank's
  MPI_Allreduce(&interrupted, &signal, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  int finished = done, all_finished = 0;
  MPI_Reduce(&finished, &all_finished, 1, MPI_INT, MPI_SUM, 0, MPI_COMM_WORLD);
  if (rank == 0) {
    std::map<int, std::string> byrun;
    for (int r = 0; r < nranks; ++r) {
      std::ifstream in(out.dir() + "/ensemble.rank" + std::to_string(r) + ".csv");
      std::string line;
      std::getline(in, line);
      while (std::getline(in, line))
        if (!line.empty()) byrun[std::stoi(line.substr(0, line.find(',')))] = line;
    }
    std::ofstream all(out.dir() + "/ensemble.csv");
    all << header << "\n";
    for (const auto& [k, line] : byrun) all << line << "\n";
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::ostringstream os;
    os << "ensemble: " << byrun.size() << " runs on " << nranks << " rank(s) in " << el << " s = " << 3600.0 * byrun.size() / el
       << " runs per hour -> " << out.dir() << "/ensemble.csv";
    out.log(os.str());
    std::string status = "completed", reason = "all runs ended";
    if (signal) {
      status = "interrupted";
      reason = std::string("interrupted by ") + signal_name(signal) + " after " + std::to_string(all_finished) + " of " +
               std::to_string(runs) + " runs; ensemble.csv holds the finished ones";
      out.log("INTERRUPTED: " + reason);
    }
    out.ensemble_summary(status, reason, runs, all_finished, el);
  }
  return signal ? 128 + signal : 0;
}

}  // namespace cassini
