// cassini: MPI-parallel discrete element solver.  mpirun -n N cassini cases/<scene> [options]
#include <malloc.h>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <hdf5.h>
#include <mpi.h>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "core/Interrupt.hpp"
#include "io/ReadConfig.hpp"
#include "core/Simulation.hpp"
#include "app/Ensemble.hpp"
#include "io/RunOutput.hpp"
#include "io/Snapshot.hpp"

namespace fs = std::filesystem;
using namespace cassini;

int main(int argc, char** argv) {
  // Large arrays (particle columns, lists, buffers: >= 256 KiB) each get their own mapping and go
  // back to the system when freed or moved. glibc otherwise raises this threshold as such blocks
  // are freed and serves them from the heap, where the transient buffers of a rebuild fragment
  // it and the resident set keeps their high-water mark.
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  MPI_Init(&argc, &argv);
  int rank = 0, nranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &nranks);

  CLI::App app{"cassini: discrete element simulation of granular scenes (MPI slabs)"};
  std::string case_path, out_dir;
  std::vector<std::string> overrides;
  bool force = false;
  std::string restart;
  app.add_option("case", case_path, "case directory (holding case.toml) or case file")->required();
  app.add_option("--set", overrides, "override a case key, e.g. --set time.end=1.0 (repeatable)");
  app.add_option("--out", out_dir, "output directory (default runs/<case name>)");
  app.add_flag("--force", force, "replace an existing output directory");
  app.add_option("--restart", restart, "continue from a snapshot file (snap_<step>.h5md) of an earlier run");
  int ensemble = 0;
  app.add_option("--ensemble", ensemble,
                 "run N independent copies with seeds seed, seed+1, ...; each rank runs whole simulations "
                 "(clogging statistics); writes ensemble.csv")
      ->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help prints and succeeds; every command-line error exits 2, like a bad case file.
    const int shown = rank == 0 ? app.exit(e) : e.get_exit_code();
    MPI_Finalize();
    return shown == 0 ? 0 : 2;
  }
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // HDF5 failures are reported by cassini, once
  // HDF5 keeps freed blocks for reuse only up to 256 KiB per list by default; opening a file
  // allocates a ~0.5 MB metadata cache, which above the mmap threshold (above) was a fresh mapping
  // whose every page faulted at each observables row (5 ms a row, 7 % of a clogging run). Kept,
  // the blocks are reused (peak resident memory of that run +0.3 MB).
  H5set_free_list_limits(-1, -1, -1, -1, -1, -1);
  install_interrupt_handlers();  // SIGTERM/SIGINT: stop at the next step boundary, say so
  std::string command;
  for (int k = 0; k < argc; ++k) {
    const std::string a = argv[k];
    const bool quote = a.empty() || a.find_first_of(" \t\"'[]$*?;&|<>()") != std::string::npos;
    command += (k ? " " : "") + (quote ? "'" + a + "'" : a);
  }

  int code = 0;
  std::unique_ptr<RunOutput> out_ptr;  // once the output directory exists, errors go to its run.log too
  try {
    std::string file = case_path;
    if (fs::is_directory(case_path)) file = (fs::path(case_path) / "case.toml").string();
    CaseFile cf = CaseFile::load(file, overrides);
    Config cfg = read_config(cf);
    if (ensemble > 0 && !restart.empty()) throw ConfigError("--ensemble and --restart cannot be combined");
    if (!restart.empty()) check_restart_case(restart, cf);  // before anything is created
    // A snapshot made before contact.scheme existed ran Verlet, then the only scheme: a
    // restart continues the system it was, whatever today's default.
    // The case is read again with that key, so the run and its resolved case.toml say "verlet".
    const bool legacy_scheme = !restart.empty() && snapshot_parameter(restart, "contact_scheme").empty();
    if (legacy_scheme) {
      overrides.push_back("contact.scheme=\"verlet\"");
      cf = CaseFile::load(file, overrides);
      cfg = read_config(cf);
    }
    if (out_dir.empty()) out_dir = "runs/" + fs::path(file).parent_path().filename().string();
    std::vector<RunInput> inputs = {{file, "the case file"}, {restart, "--restart"}, {cfg.init_file, "particles.file"}};
    for (const auto& [path, key] : cfg.module_inputs) inputs.push_back({path, key});
    out_ptr = std::make_unique<RunOutput>(out_dir, force, MPI_COMM_WORLD, inputs);
    RunOutput& out = *out_ptr;
    out.command = command;
    out.restarted_from = restart.empty() ? "" : fs::absolute(restart).lexically_normal().string();
    std::ostringstream resolved;
    resolved << cf.table();
    out.write_text("case.toml", resolved.str() + "\n");
    out.case_text = resolved.str();
    // A run's name: new for a fresh run, inherited by a continuation (cassini-cg mixes frames
    // of one run only). Not a physics choice: the clock and process id are fine here.
    out.run_id = restart.empty() ? "" : snapshot_parameter(restart, "run_id");
    if (out.run_id.empty()) {
      std::uint64_t h = std::hash<std::string>{}(out.case_text) ^
                        std::uint64_t(std::chrono::system_clock::now().time_since_epoch().count()) * 0x9E3779B97F4A7C15ull ^
                        std::uint64_t(getpid());
      MPI_Bcast(&h, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
      std::ostringstream id;
      id << std::hex << h;
      out.run_id = id.str();
    }

    out.log(out.provenance_line());
    if (ensemble > 0) {
      out.log("cassini: " + file + ": ensemble of " + std::to_string(ensemble) + " runs on " + std::to_string(nranks) +
              " rank(s), one whole run per rank at a time");
      if (cfg.snapshot_every > 0 || cfg.dump_every > 0)
        out.log("note: --ensemble writes one row of ensemble.csv per run and no frames: output.snapshot_every and "
                "output.dump_every are not used (run one seed without --ensemble for its frames)");
      code = run_ensemble(cfg, ensemble, out);
      MPI_Finalize();
      return code;
    }
    Simulation sim(cfg, MPI_COMM_WORLD);
    if (!restart.empty()) read_snapshot(sim, restart);
    sim.setup();
    if (!restart.empty()) out.log("restarted from " + restart + " at step " + std::to_string(sim.step_count));
    if (legacy_scheme)
      out.log("contact.scheme: " + restart + " predates the exact contact scheme; continuing with \"verlet\", "
              "the scheme it was made with");
    std::ostringstream head;
    head << "cassini: " << file << " on " << nranks << " rank(s), " << sim.total_particles() << " particles, dt = "
         << sim.dt << " s, end = " << cfg.t_end << " s\nactive modules:";
    for (const auto& n : sim.module_names()) head << " [" << n << "]";
    out.log(head.str());
    for (const auto& m : sim.modules)
      if (const std::string report = m->setup_report(); !report.empty()) out.log(report);
    const auto t0 = std::chrono::steady_clock::now();
    const long start = sim.step_count;
    std::string status = "completed", reason = "reached time.end";
    try {
      sim.run(&out);
      if (sim.record.finished) reason = sim.record.finish_reason;
      if (sim.record.interrupted) {
        status = "interrupted";
        std::ostringstream os;
        os << reason << " at step " << sim.step_count << ", t = " << sim.time << " s"
           << (cfg.snapshot_on_signal ? "; last snapshot written (continue with --restart)" : "");
        reason = os.str();
        out.log("INTERRUPTED: " + reason);
        code = 128 + sim.record.interrupted;
      }
    } catch (const GuardError& e) {
      out.log(std::string("STOPPED: ") + e.what() + "\ndiagnostic dump (the state of that step) written to " +
              out_dir + "/dump/");
      status = "stopped by a guard";
      reason = e.what();
      code = 3;
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.summary(sim, wall, sim.step_count - start, status, reason);
    std::ostringstream tail;
    tail << "done: " << sim.step_count - start << " steps, " << sim.total_particles() << " particles, " << wall
         << " s wall, " << double(sim.total_particles()) * (sim.step_count - start) / wall
         << " particle-steps/s; " << sim.rebuilds << " neighbour rebuilds\noutput: " << out_dir
         << "/ (run.log, observables.csv, summary.json, dump/)";
    out.log(tail.str());
    if (rank == 0) out.log(out.timing());
  } catch (const ConfigError& e) {  // thrown alike on every rank
    if (rank == 0) std::cerr << "error: " << e.what() << std::endl;
    if (out_ptr) {
      out_ptr->log_only(std::string("error: ") + e.what());
      out_ptr->error_summary(e.what());
    }
    code = 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "error (rank " << rank << "): out of memory" << std::endl;
    if (out_ptr) {
      out_ptr->log_only("error: out of memory on rank " + std::to_string(rank));
      // Unwinding to here has freed the simulation (particles, lists, meshes), so the few
      // kilobytes of summary.json can be had; if not, abort without it.
      try { out_ptr->error_summary("rank " + std::to_string(rank) + ": out of memory", true); } catch (...) {}
    }
    MPI_Abort(MPI_COMM_WORLD, 4);
  } catch (const std::exception& e) {  // possibly on one rank only: the others cannot be waited for
    std::cerr << "error (rank " << rank << "): " << e.what() << std::endl;
    if (out_ptr) {
      out_ptr->log_only(std::string("error (rank ") + std::to_string(rank) + "): " + e.what());
      // The failing rank says so in summary.json, whichever it is (rank 0 is aborted with it;
      // a full disk may refuse that too: abort anyway).
      try { out_ptr->error_summary(std::string("rank ") + std::to_string(rank) + ": " + e.what(), true); } catch (...) {}
    }
    MPI_Abort(MPI_COMM_WORLD, 4);
  }
  MPI_Finalize();
  return code;
}
