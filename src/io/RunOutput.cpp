#include "io/RunOutput.hpp"

#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"
#include "physics/ContactForces.hpp"
#include "io/Snapshot.hpp"
#include "physics/Moonlet.hpp"

namespace fs = std::filesystem;

namespace cassini {

RunOutput::RunOutput(const std::string& dir, bool force, MPI_Comm comm) : dir_(dir), comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  std::string error;
  if (rank_ == 0) {
    std::error_code ec;
    if (fs::exists(dir) && !fs::is_empty(dir)) {
      if (!force) error = "output directory '" + dir + "' exists and is not empty: choose another --out or pass --force";
      else fs::remove_all(dir, ec);
    }
    if (error.empty()) {
      fs::create_directories(dir + "/dump", ec);
      if (ec) error = "cannot create output directory '" + dir + "': " + ec.message();
    }
  }
  int len = static_cast<int>(error.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, comm);
  error.resize(len);
  MPI_Bcast(error.data(), len, MPI_CHAR, 0, comm);
  if (!error.empty()) throw ConfigError(error);
  if (rank_ == 0) {
    log_.open(dir + "/run.log");
    obs_.open(dir + "/observables.csv");
    h5obs_ = std::make_unique<ObservablesFile>(dir + "/observables.h5md");
    obs_ << "step,time,particles,kinetic_energy,elastic_energy,px,py,pz,T_xx,T_yy,T_zz,contacts,collisions,"
            "mean_overlap_over_radius,max_overlap_over_radius,moonlet_contacts\n";
  }
}

void RunOutput::log(const std::string& line) {
  if (rank_ != 0) return;
  std::cout << line << std::endl;
  log_ << line << "\n";
  log_.flush();
}

void RunOutput::write_text(const std::string& name, const std::string& text) {
  if (rank_ != 0) return;
  std::ofstream(dir_ + "/" + name) << text;
}

void RunOutput::observe(Simulation& sim) {
  // Granular temperature per component: mass-weighted variance of the velocity relative to
  // the imposed flow (the Lees-Edwards shear) or, without one, to the mean velocity.
  const ParticleStore& p = sim.particles;
  const double ke = sim.kinetic_energy(), pe = sim.elastic_energy();
  const Vec3 mom = sim.momentum();
  const long n = sim.total_particles();
  double local[10] = {0};
  for (std::size_t i = 0; i < p.nlocal; ++i) local[0] += p.mass[i];
  double mass = 0;
  MPI_Allreduce(&local[0], &mass, 1, MPI_DOUBLE, MPI_SUM, comm_);
  const Vec3 mean = sim.domain.shear.enabled ? Vec3::Zero() : Vec3(mom / mass);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Vec3 dv = p.v[i] - mean - sim.imposed_flow(p.x[i]);
    for (int d = 0; d < 3; ++d) local[1 + d] += p.mass[i] * dv[d] * dv[d];
  }
  local[4] = sim.contact ? double(sim.contact->contacts()) : 0.0;
  local[5] = sim.contact ? double(sim.contact->take_collisions()) : 0.0;
  local[6] = sim.contact ? sim.contact->overlap_sum() : 0.0;
  local[7] = sim.moonlet ? double(sim.moonlet->contacts()) : 0.0;
  double sums[10];
  MPI_Allreduce(local, sums, 8, MPI_DOUBLE, MPI_SUM, comm_);
  double overlap = sim.contact ? sim.contact->max_overlap_fraction() : 0.0, max_overlap = 0;
  MPI_Allreduce(&overlap, &max_overlap, 1, MPI_DOUBLE, MPI_MAX, comm_);
  if (rank_ != 0) return;
  const double contacts = sums[4];
  obs_ << std::setprecision(12) << sim.step_count << "," << sim.time << "," << n << "," << ke << "," << pe << ","
       << mom[0] << "," << mom[1] << "," << mom[2] << "," << sums[1] / mass << "," << sums[2] / mass << ","
       << sums[3] / mass << "," << contacts / 2 << "," << sums[5] << "," << (contacts > 0 ? sums[6] / contacts : 0.0)
       << "," << max_overlap << "," << sums[7] << "\n";
  obs_.flush();
  // Granular temperature: the mean velocity variance over the axes that move.
  const int dims = sim.cfg.planar ? 2 : 3;
  const std::vector<double> variance = {sums[1] / mass, sums[2] / mass, sums[3] / mass};
  h5obs_->append(sim.step_count, sim.time,
                 {{"particles", {double(n)}},
                  {"kinetic_energy", {ke}},
                  {"elastic_energy", {pe}},
                  {"momentum", {mom[0], mom[1], mom[2]}},
                  {"velocity_variance", variance},
                  {"granular_temperature", {(variance[0] + variance[1] + (dims == 3 ? variance[2] : 0.0)) / dims}},
                  {"contacts", {contacts / 2}},
                  {"collisions", {sums[5]}},
                  {"mean_overlap_over_radius", {contacts > 0 ? sums[6] / contacts : 0.0}},
                  {"max_overlap_over_radius", {max_overlap}},
                  {"moonlet_contacts", {sums[7]}}});
}

void RunOutput::snapshot(Simulation& sim) {
  const double start = MPI_Wtime();
  const std::string file = write_snapshot(sim, dir_, case_text);
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
  }
  fs::rename(tmp, name.str());
}

void RunOutput::summary(Simulation& sim, double wall, long steps) {
  const double ke = sim.kinetic_energy();
  const long n = sim.total_particles();
  const double mine = wall > 0 ? double(sim.particles.nlocal) * steps / wall : 0.0;
  std::vector<double> rates(sim.domain.nranks);
  MPI_Gather(&mine, 1, MPI_DOUBLE, rates.data(), 1, MPI_DOUBLE, 0, comm_);
  if (rank_ != 0) return;
  std::ostringstream js;
  js << std::setprecision(10) << "{\n"
     << "  \"case\": \"" << sim.cfg.source << "\",\n"
     << "  \"ranks\": " << sim.domain.nranks << ",\n"
     << "  \"steps\": " << steps << ",\n"
     << "  \"final_step\": " << sim.step_count << ",\n"
     << "  \"simulated_time\": " << sim.time << ",\n"
     << "  \"dt\": " << sim.dt << ",\n"
     << "  \"particles\": " << n << ",\n"
     << "  \"wall_seconds\": " << wall << ",\n"
     << "  \"particle_steps_per_second\": " << (wall > 0 ? double(n) * steps / wall : 0.0) << ",\n"
     << "  \"particle_steps_per_second_per_rank\": [";
  for (int r = 0; r < sim.domain.nranks; ++r) js << (r ? ", " : "") << rates[r];
  js << "],\n  \"neighbour_rebuilds\": " << sim.rebuilds << ",\n  \"slab_cuts\": [";
  for (std::size_t r = 0; r < sim.domain.cuts.size(); ++r) js << (r ? ", " : "") << sim.domain.cuts[r];
  js << "],\n  \"decomposition\": \"" << sim.cfg.decomposition << "\"";
  js << ",\n  \"imbalance_at_last_balancing\": " << sim.imbalance;
  js << ",\n  \"imbalance_mean\": " << (sim.imbalance_samples ? sim.imbalance_sum / sim.imbalance_samples : 1.0);
  js << ",\n  \"imbalance_worst\": " << sim.imbalance_worst << ",\n  \"active_modules\": [";
  const auto names = sim.module_names();
  for (std::size_t k = 0; k < names.size(); ++k) js << (k ? ", " : "") << "\"" << names[k] << "\"";
  js << "],\n  \"final_kinetic_energy\": " << ke;
  if (sim.finished) js << ",\n  \"ended\": \"" << sim.finish_reason << "\"";
  for (const auto& [k, v] : sim.results) js << ",\n  \"" << k << "\": " << v;
  js << "\n}\n";
  write_text("summary.json", js.str());
}

}  // namespace cassini
