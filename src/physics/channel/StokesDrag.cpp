#include "physics/channel/StokesDrag.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

#include "core/Simulation.hpp"
#include "physics/channel/ChannelWalls.hpp"

namespace cassini {

ModuleKind StokesDrag::kind() {
  auto make = [](Simulation& sim) { return std::make_unique<StokesDrag>(sim.cfg, sim.find<ChannelWalls>()->geometry()); };
  auto prepare = [](const Config& cfg, MPI_Comm comm) { FlowField solve_or_load(cfg, comm); };
  return {"drag", {"channel"}, nullptr, make, prepare};
}

StokesDrag::StokesDrag(const Config& cfg, const ChannelGeometry& geo)
    : cfg_(cfg), voidage_(cfg.get<ChannelConfig>().voidage), viscosity_(cfg.get<ChannelConfig>().viscosity),
      self_volume_(cfg.get<ChannelConfig>().self_volume), faxen_(cfg.get<ChannelConfig>().confinement == "faxen"), height_(cfg.hi[2] - cfg.lo[2]),
      phi_field_(geo, cfg.lo[0], cfg.hi[0], cfg.lo[1], cfg.hi[1], cfg.hi[2] - cfg.lo[2], cfg.get<ChannelConfig>().phi_width) {}

double StokesDrag::voidage(double phi) const {
  phi = std::min(phi, 0.7);  // beyond random close packing the correlations are meaningless
  if (voidage_ == "thesis") return 2 * 5.34 * phi / ((1 - phi) * (1 - phi));
  if (voidage_ == "stokes") return 1.0;
  const double s = 1 - phi;
  return 10 * phi / (s * s) + s * s * (1 + 1.5 * std::sqrt(phi));
}

double StokesDrag::confinement(double a) const {
  if (!faxen_) return 1.0;
  // Faxen (1923) for a sphere midway between two plane walls a gap h apart, lambda = a / (h/2)
  // (Happel & Brenner 1965, eq. 7-4.39). Accurate to ~1 % for lambda <~ 0.6; closer to the walls
  // it underestimates the drag (the exact one diverges as the gaps close).
  const double l = std::min(2 * a / height_, 0.99);
  return 1 / (1 - 1.004 * l + 0.418 * l * l * l + 0.21 * l * l * l * l - 0.169 * l * l * l * l * l);
}

void StokesDrag::setup(Simulation& sim) {
  flow_ = std::make_unique<FlowField>(cfg_, sim.domain.comm);
  if (cfg_.get<ChannelConfig>().two_way) coupling_ = std::make_unique<FlowCoupling>(cfg_);
  refresh_every_ = std::max(1L, std::lround(cfg_.get<ChannelConfig>().phi_refresh / sim.dt));
  refresh(sim, true);
}

void StokesDrag::refresh(Simulation& sim, bool solve) {
  // phi, and with it the relaxation factor, is held between refreshes: compute it once here.
  phi_field_.update(sim.particles, sim.domain.comm);
  sample(sim);
  if (!coupling_) return;
  const ParticleStore& p = sim.particles;
  one_way_.resize(p.nlocal);
  for (std::size_t i = 0; i < p.nlocal; ++i) one_way_[i] = flow_->velocity(p.x[i]);
  coupling_->update(p, beta_, one_way_, phi_field_, sign_, solve, sim.domain.comm);
}

void StokesDrag::sample(Simulation& sim) {
  const ParticleStore& p = sim.particles;
  phi_.resize(p.nlocal);
  factor_.resize(p.nlocal);
  rate_.resize(p.nlocal);
  lag_.resize(p.nlocal);
  if (coupling_) beta_.resize(p.nlocal);
  const double c = 6 * std::numbers::pi * viscosity_;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    phi_[i] = phi_field_.at(p.x[i][0], p.x[i][1]);
    if (!self_volume_) {  // the suspension around the bead, without the bead (dilute limit f -> 1)
      const double vol = 4.0 / 3.0 * std::numbers::pi * p.radius[i] * p.radius[i] * p.radius[i];
      phi_[i] = std::max(0.0, phi_[i] - phi_field_.own(p.x[i][0], p.x[i][1], vol));
    }
    double coefficient = c * p.radius[i] * voidage(phi_[i]) * confinement(p.radius[i]);
    if (coupling_) {
      coefficient /= 1 - std::min(phi_[i], 0.7);  // the relative velocity is (u - v) / (1 - phi)
      beta_[i] = coefficient;
    }
    const double beta = coefficient * p.inv_mass[i], x = beta * sim.dt;
    factor_[i] = -std::expm1(-x) / sim.dt;  // -> beta for beta dt -> 0
    rate_[i] = beta;
    lag_[i] = x > 0 ? 1 + std::expm1(-x) / x : 0.0;  // 1 - (1 - e^-x) / x: -> x / 2 for x -> 0
  }
}

void StokesDrag::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal && i < factor_.size(); ++i)
    F[i] += p.mass[i] * rate_[i] * (fluid_velocity(p.x[i]) - p.v[i]);  // the physical drag at this state
}

void StokesDrag::post_rebuild(Simulation& sim) {
  // Slots were reordered and particles may have come or gone: sample the held phi field again.
  // The field itself is refreshed on its schedule, and at a snapshot, which is where a
  // restart recomputes it (setup) - so a restarted run continues bitwise.
  if (!flow_) return;
  if (sim.restart_point) refresh(sim, true);
  else sample(sim);
}

void StokesDrag::force(Simulation& sim) {
  if (sim.step_count % refresh_every_ == 0) refresh(sim);
  ParticleStore& p = sim.particles;
  double power = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    // The other forces on the bead so far (contacts, walls, lubrication: modules before this one)
    // relax with it over the step; lag_ of them is what the drag takes back.
    const Vec3 f = p.mass[i] * factor_[i] * (fluid_velocity(p.x[i]) - p.v[i]) - lag_[i] * p.f[i];
    p.f[i] += f;
    power += f.dot(p.v[i]);  // the half-step velocity: the work of this force over the step
  }
  work_ += power * sim.dt;
}

std::string StokesDrag::setup_report() const {
  const FlowReport& r = flow_->report();
  std::ostringstream os;
  os << "flow field: " << flow_->cache_file() << (r.from_cache ? " (cached)" : " (solved now)")
     << "\n  Stokes solve " << r.solve_seconds << " s, " << r.iterations << " CG iterations, residual " << r.residual
     << ", max |div u| " << r.max_divergence << "\n  flow rate error over all cross-sections " << r.flux_error
     << "; neck mean / far mean " << r.neck_mean_over_mean << "; far field vs duct series (4 D upstream) "
     << r.far_field_error << " (L2); centre / mean " << r.centre_over_mean;
  if (coupling_)
    os << "\n  two-way coupling (" << (cfg_.get<ChannelConfig>().pressure_drive ? "fixed pressure drop" : "fixed flow rate")
       << "): coarse Stokes-Brinkman grid of D / " << cfg_.get<ChannelConfig>().coupling_resolution
       << " over the channel; bead-free pressure drop " << coupling_->bead_free_pressure_drop() << " Pa at "
       << coupling_->flow_rate() << " m^3/s";
  return os.str();
}

void StokesDrag::observables(Simulation&, std::vector<std::pair<std::string, double>>& out) {
  if (!coupling_) return;
  out.emplace_back("flow_rate", coupling_->flow_rate());
  out.emplace_back("pressure_drop", coupling_->pressure_drop());
  out.emplace_back("flow_solves", double(coupling_->solves()));
}

}  // namespace cassini
