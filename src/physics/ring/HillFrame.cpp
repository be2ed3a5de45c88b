#include "physics/ring/HillFrame.hpp"

#include <cmath>
#include <sstream>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"

namespace cassini {

ModuleKind HillFrame::kind() {
  auto read = [](CaseFile& f, Config& c) {
    HillSettings h;
    h.saturn_mass = f.positive("hill.saturn_mass", h.saturn_mass);
    h.orbit_radius = f.positive("hill.orbit_radius", h.orbit_radius);
    h.form = f.string("hill.form", "linear");
    if (h.form != "linear" && h.form != "exact") f.fail("hill.form", "\"linear\" or \"exact\"");
    h.vertical_frequency = f.number("hill.vertical_frequency", 1.0);
    if (!(h.vertical_frequency >= 1.0))
      f.fail("hill.vertical_frequency", "Omega_z / Omega0 >= 1 (1: Saturn's tide alone; ring codes use 2-3.6 to mimic self-gravity)");
    c.set(h);
    c.frame_rotation = h.omega0();
    // Hill's equations carry the Keplerian shear v_x = 1.5 Omega0 y (the default of
    // domain.shear_rate); a sheared boundary moving at another rate would feed the ring an
    // inconsistent flow at every crossing.
    const double kepler = 1.5 * h.omega0();
    if (c.sheared()) {
      const double rate = f.number("domain.shear_rate", kepler);
      if (std::abs(rate - kepler) > 1e-12 * kepler) {
        std::ostringstream os;
        os.precision(17);
        os << kepler << " 1/s (1.5 Omega0, or no key) with the \"hill\" module: the shear of Hill's equations";
        f.fail("domain.shear_rate", os.str());
      }
    }
    c.shear_rate = kepler;
  };
  return {"hill", {}, read, [](Simulation& sim) { return std::make_unique<HillFrame>(sim.cfg); }};
}

HillFrame::HillFrame(const Config& cfg) : HillFrame(cfg.get<HillSettings>(), cfg.planar) {}

HillFrame::HillFrame(const HillSettings& h, bool planar)
    : exact_(h.form == "exact"),
      planar_(planar),
      omega_(h.omega0()),
      gm_(kGravitationalConstant * h.saturn_mass),
      r0_(h.orbit_radius) {
  const double wz = h.vertical_frequency * omega_;
  extra_z2_ = exact_ ? wz * wz - omega_ * omega_ : wz * wz;
}

Vec3 HillFrame::acceleration(const Vec3& x) const {
  const double z = planar_ ? 0.0 : x[2];
  if (!exact_) return Vec3(0, 3 * omega_ * omega_ * x[1], -extra_z2_ * z);
  const Vec3 s(x[0], x[1] + r0_, z);  // from Saturn
  const double r = s.norm();
  const double g = gm_ / (r * r * r);
  return Vec3((omega_ * omega_ - g) * s[0], (omega_ * omega_ - g) * s[1], -(g + extra_z2_) * z);
}

double HillFrame::potential_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  double u = 0;
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double x = p.x[i][0], y = p.x[i][1], z = planar_ ? 0.0 : p.x[i][2];
    if (!exact_) {
      u += p.mass[i] * (-1.5 * omega_ * omega_ * y * y + 0.5 * extra_z2_ * z * z);
    } else {
      const double s2 = x * x + (y + r0_) * (y + r0_);
      u += p.mass[i] * (-gm_ / std::sqrt(s2 + z * z) - 0.5 * omega_ * omega_ * s2 + 0.5 * extra_z2_ * z * z);
    }
  }
  return u;
}

void HillFrame::add_body_forces(const Simulation& sim, std::vector<Vec3>& F) const {
  const ParticleStore& p = sim.particles;
  for (std::size_t i = 0; i < p.nlocal; ++i) F[i] += p.mass[i] * acceleration(p.x[i]);
}

void HillFrame::force(Simulation& sim) {
  ParticleStore& p = sim.particles;
  if (!exact_) {
    const double k = 3 * omega_ * omega_, kz = extra_z2_;
    const Vec3* X = p.x.data();  // raw views: the stores to f could alias the vectors' pointers
    const double* M = p.mass.data();
    Vec3* F = p.f.data();
    const Simulation::TargetList T = sim.target_list();
    if (planar_) {
      if (!T.list)  // the plain loop for all: it vectorises
        for (std::size_t i = 0; i < T.count; ++i) F[i][1] += M[i] * k * X[i][1];
      else
        for (std::size_t t = 0; t < T.count; ++t) F[T[t]][1] += M[T[t]] * k * X[T[t]][1];
    } else {
      for (std::size_t t = 0; t < T.count; ++t) {
        const std::size_t i = T[t];
        F[i][1] += M[i] * k * X[i][1];
        F[i][2] -= M[i] * kz * X[i][2];
      }
    }
    return;
  }
  const Simulation::TargetList T = sim.target_list();
  for (std::size_t t = 0; t < T.count; ++t) p.f[T[t]] += p.mass[T[t]] * acceleration(p.x[T[t]]);
}

void HillFrame::observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) {
  if (planar_) return;
  const ParticleStore& p = sim.particles;
  const double mid = 0.5 * (sim.cfg.lo[2] + sim.cfg.hi[2]);
  double local[2] = {0, 0}, global[2];
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    local[0] += p.mass[i] * (p.x[i][2] - mid) * (p.x[i][2] - mid);
    local[1] += p.mass[i];
  }
  MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  out.emplace_back("ring_thickness", global[1] > 0 ? std::sqrt(global[0] / global[1]) : 0.0);
}

}  // namespace cassini
