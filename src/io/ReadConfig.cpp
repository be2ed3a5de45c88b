#include "io/ReadConfig.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/ModuleRegistry.hpp"
#include "physics/contact/HertzMindlin.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"

namespace cassini {

namespace {

int axis_index(CaseFile& f, const std::string& key, const std::string& v) {
  if (v == "x") return 0;
  if (v == "y") return 1;
  if (v == "z") return 2;
  f.fail(key, "one of \"x\", \"y\", \"z\"");
}


}  // namespace

Config read_config(CaseFile& f) {
  Config c;
  c.source = f.source();

  // ---- domain
  c.lo = f.vec3("domain.lo");
  c.hi = f.vec3("domain.hi");
  for (int d = 0; d < 3; ++d)
    if (!(c.hi[d] > c.lo[d])) f.fail("domain.hi", "every component larger than domain.lo");
  const auto bounds = f.strings("domain.boundary", std::vector<std::string>{"periodic", "periodic", "periodic"});
  if (bounds.size() != 3) f.fail("domain.boundary", "3 entries (x, y, z), each \"periodic\", \"wall\" or \"open\"");
  for (int d = 0; d < 3; ++d) {
    if (bounds[d] == "periodic") c.boundary[d] = Boundary::Periodic;
    else if (bounds[d] == "wall") c.boundary[d] = Boundary::Wall;
    else if (bounds[d] == "open") c.boundary[d] = Boundary::Open;
    else if (bounds[d] == "lees_edwards" && d == 1) c.boundary[d] = Boundary::LeesEdwards;
    else f.fail("domain.boundary", "each entry \"periodic\", \"wall\" or \"open\" (\"lees_edwards\" on y only)");
  }
  if (c.sheared() && c.boundary[0] != Boundary::Periodic)
    f.fail("domain.boundary", "x periodic when y is \"lees_edwards\" (the shear shifts images along x)");
  c.planar = f.boolean("domain.planar", false);
  c.slab_axis = axis_index(f, "domain.slab_axis", f.string("domain.slab_axis", "x"));
  if (c.planar && c.slab_axis == 2) f.fail("domain.slab_axis", "\"x\" or \"y\" in a planar scene");
  c.decomposition = f.string("domain.decomposition", "slabs");
  if (c.decomposition != "slabs" && c.decomposition != "metis")
    f.fail("domain.decomposition", "\"slabs\" (cuts along domain.slab_axis) or \"metis\" (a METIS partition of cells)");
  c.balance_every = f.integer("domain.balance_every", 0);
  if (c.balance_every < 0) f.fail("domain.balance_every", "an integer >= 0 (rebuilds between load balancing; 0 = off)");

  // ---- species
  const auto ns = f.array_size("species");
  if (ns == 0) f.fail("species", "at least one [[species]] table");
  for (std::size_t i = 0; i < ns; ++i) {
    const std::string p = "species[" + std::to_string(i) + "].";
    Species s;
    s.name = f.string(p + "name", "species" + std::to_string(i));
    s.density = f.positive(p + "density");
    const std::string sizes = f.string(p + "size_distribution", f.has(p + "radii") ? "list" : "uniform");
    if (sizes == "list") {
      s.sizes.kind = SizeDistribution::List;
      s.sizes.radii = f.numbers(p + "radii");
      if (s.sizes.radii.empty()) f.fail(p + "radii", "a list of radii (m)");
      for (double a : s.sizes.radii)
        if (!(a > 0)) f.fail(p + "radii", "positive radii");
      s.sizes.weights = f.has(p + "radius_weights") ? f.numbers(p + "radius_weights")
                                                    : std::vector<double>(s.sizes.radii.size(), 1.0);
      if (s.sizes.weights.size() != s.sizes.radii.size())
        f.fail(p + "radius_weights", "one number fraction per entry of radii (" + std::to_string(s.sizes.radii.size()) + ")");
      double total = 0;
      for (double w : s.sizes.weights) {
        if (!(w >= 0)) f.fail(p + "radius_weights", "non-negative number fractions");
        total += w;
      }
      if (!(total > 0)) f.fail(p + "radius_weights", "fractions with a positive sum");
      std::vector<std::size_t> order(s.sizes.radii.size());
      for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
      std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return s.sizes.radii[x] < s.sizes.radii[y]; });
      std::vector<double> r, w;
      for (std::size_t k : order) { r.push_back(s.sizes.radii[k]); w.push_back(s.sizes.weights[k] / total); }
      s.sizes.radii = r;
      s.sizes.weights = w;
      s.radius_min = r.front();
      s.radius_max = r.back();
    } else if (f.has(p + "radius")) {
      s.radius_min = s.radius_max = f.positive(p + "radius");
    } else {
      s.radius_min = f.positive(p + "radius_min");
      s.radius_max = f.positive(p + "radius_max");
      if (s.radius_max < s.radius_min) f.fail(p + "radius_max", "a value >= radius_min");
    }
    if (sizes == "power_law") {
      s.sizes.kind = SizeDistribution::PowerLaw;
      s.sizes.q = f.number(p + "size_exponent", 3.0);
      if (!std::isfinite(s.sizes.q)) f.fail(p + "size_exponent", "a finite exponent q of dN/da ~ a^-q");
    } else if (sizes != "uniform" && sizes != "list") {
      f.fail(p + "size_distribution", "\"uniform\", \"power_law\" (dN/da ~ a^-size_exponent) or \"list\" (radii, radius_weights)");
    }
    const std::string model = f.string(p + "model", "linear");
    if (model == "hertz") {
      s.youngs_modulus = f.positive(p + "youngs_modulus");
      s.poisson_ratio = f.number(p + "poisson_ratio", 0.3);
      if (!(s.poisson_ratio >= 0 && s.poisson_ratio < 0.5)) f.fail(p + "poisson_ratio", "a Poisson ratio in [0, 0.5)");
      s.impact_speed = f.positive(p + "impact_speed");
      if (f.has(p + "t_c"))
        f.fail(p + "t_c", "no t_c with model = \"hertz\" (the contact lasts longer the slower the impact: give "
                          "impact_speed, the fastest expected, and t_c follows)");
    } else if (model == "linear") {
      for (const char* k : {"youngs_modulus", "poisson_ratio", "impact_speed"})
        if (f.has(p + k)) f.fail(p + k, std::string(k) + " only with model = \"hertz\"");
      s.t_c = f.positive(p + "t_c");
    } else {
      f.fail(p + "model", "\"linear\" (spring-dashpot, t_c and e) or \"hertz\" (Hertz-Mindlin: youngs_modulus, poisson_ratio, e)");
    }
    const std::string law = f.string(p + "restitution", "constant");
    if (law == "bridges") {
      if (f.has(p + "e"))
        f.fail(p + "e", "no e with restitution = \"bridges\" (each impact's e comes from its speed: (u/v_c)^-0.234)");
      s.v_c = f.positive(p + "v_c", kBridgesVc);
      s.e = 1;
    } else if (law == "constant") {
      if (f.has(p + "v_c")) f.fail(p + "v_c", "v_c only with restitution = \"bridges\"");
      s.e = f.number(p + "e");
      if (!(s.e > 0 && s.e <= 1)) f.fail(p + "e", "a restitution coefficient in (0, 1]");
    } else {
      f.fail(p + "restitution", "\"constant\" (a fixed e) or \"bridges\" (e = (u/v_c)^-0.234 per impact)");
    }
    s.mu_s = f.non_negative(p + "mu_s", 0.0);
    s.mu_d = f.non_negative(p + "mu_d", s.mu_s);
    s.mu_r = f.non_negative(p + "mu_r", 0.0);
    s.mu_o = f.non_negative(p + "mu_o", 0.0);
    s.eta_r = f.non_negative(p + "eta_r", 0.3);
    if ((s.mu_r > 0 || s.mu_o > 0) && !(s.mu_s > 0))
      f.fail(p + (s.mu_r > 0 ? "mu_r" : "mu_o"), "rolling or twisting resistance only with sliding friction (mu_s > 0)");
    if (s.mu_d > s.mu_s) f.fail(p + "mu_d", "a dynamic friction <= mu_s");
    // Walls may be slipperier or rougher than the particles (glass channel, coated beads).
    const bool own_wall = f.has(p + "wall_mu_s");
    s.wall_mu_s = f.non_negative(p + "wall_mu_s", s.mu_s);
    s.wall_mu_d = f.non_negative(p + "wall_mu_d", own_wall ? s.wall_mu_s : s.mu_d);
    if (s.wall_mu_d > s.wall_mu_s) f.fail(p + "wall_mu_d", "a dynamic friction <= wall_mu_s");
    s.kt_ratio = f.non_negative(p + "kt_ratio", 2.0 / 7.0);
    s.gammat_ratio = f.non_negative(p + "gammat_ratio", 2.0 / 7.0);
    if ((s.mu_s > 0 || s.wall_mu_s > 0) && !(s.kt_ratio > 0))  // a sliding spring is stretched to mu_d f_n / k_t
      f.fail(p + "kt_ratio", "a tangential stiffness ratio > 0 when the species has friction (mu_s > 0)");
    if (s.youngs_modulus > 0) {
      if (s.v_c > 0) f.fail(p + "restitution", "\"constant\" with model = \"hertz\"");
      const double m = s.density * 4.0 / 3.0 * std::numbers::pi * std::pow(s.radius_min, 3);
      const double E = hertz_e_star(s.youngs_modulus, s.poisson_ratio, s.youngs_modulus, s.poisson_ratio);
      s.t_c = hertz_contact_time(0.5 * m, 0.5 * s.radius_min, E, s.impact_speed);
    }
    for (const ContactParameter& q : LinearSpringDashpot::parameters()) {
      const double v = f.number(p + q.key, q.fallback);
      if (!(v >= q.min)) f.fail(p + q.key, q.expected);
      s.declared[q.key] = v;
    }
    for (const auto& other : c.species)
      if (other.name == s.name) f.fail(p + "name", "a name not used by another species");
    c.species.push_back(s);
  }

  // ---- contact parameters per species pair: mixed by default, [[pair]] tables override
  const std::size_t n = c.species.size();
  c.pairs.resize(n * n);
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      const Species &s = c.species[a], &t = c.species[b];
      c.pairs[a * n + b] = {0.5 * (s.t_c + t.t_c), 0.5 * (s.e + t.e), std::min(s.mu_s, t.mu_s), std::min(s.mu_d, t.mu_d),
                            0.5 * (s.kt_ratio + t.kt_ratio), 0.5 * (s.gammat_ratio + t.gammat_ratio),
                            0.5 * (s.v_c + t.v_c), std::min(s.mu_r, t.mu_r), std::min(s.mu_o, t.mu_o),
                            0.5 * (s.eta_r + t.eta_r)};
      for (const ContactParameter& q : LinearSpringDashpot::parameters())
        c.pairs[a * n + b].declared[q.key] = a == b ? s.declared.at(q.key) : q.mix(s.declared.at(q.key), t.declared.at(q.key));
      if (s.youngs_modulus > 0 && t.youngs_modulus > 0) {
        c.pairs[a * n + b].e_star = hertz_e_star(s.youngs_modulus, s.poisson_ratio, t.youngs_modulus, t.poisson_ratio);
        c.pairs[a * n + b].g_star = hertz_g_star(s.youngs_modulus, s.poisson_ratio, t.youngs_modulus, t.poisson_ratio);
      } else if ((s.youngs_modulus > 0) != (t.youngs_modulus > 0)) {
        f.fail("species", "one contact model for all species (species '" + s.name + "' and '" + t.name +
                              "' differ: a Hertz and a linear species have no common law)");
      }
    }
  // Unlike species with different restitution laws have no mean: a [[pair]] table must say.
  std::vector<bool> law_set(n * n, false);
  std::vector<int> pair_table(n * n, -1);  // which [[pair]] table set a pair (one each)
  for (std::size_t k = 0, np = f.has("pair") ? f.array_size("pair") : 0; k < np; ++k) {
    const std::string p = "pair[" + std::to_string(k) + "].";
    const auto names = f.strings(p + "species");
    std::size_t idx[2];
    if (names.size() != 2) f.fail(p + "species", "two species names, e.g. [\"glass\", \"steel\"]");
    for (int q = 0; q < 2; ++q) {
      auto it = std::find_if(c.species.begin(), c.species.end(), [&](const Species& s) { return s.name == names[q]; });
      if (it == c.species.end()) f.fail(p + "species", "names of [[species]]; unknown species '" + names[q] + "'");
      idx[q] = std::size_t(it - c.species.begin());
    }
    if (const int before = pair_table[idx[0] * n + idx[1]]; before >= 0)
      f.fail(p + "species", "one [[pair]] table per species pair; pair[" + std::to_string(before) + "] already sets '" +
                                names[0] + "' and '" + names[1] + "'");
    pair_table[idx[0] * n + idx[1]] = pair_table[idx[1] * n + idx[0]] = static_cast<int>(k);
    PairParameters pp = c.pairs[idx[0] * n + idx[1]];
    pp.t_c = f.positive(p + "t_c", pp.t_c);
    // A table that gives e means a constant e; one that gives neither keeps the mixed law.
    const std::string law = f.string(p + "restitution", pp.v_c > 0 && !f.has(p + "e") ? "bridges" : "constant");
    if (law == "bridges") {
      if (f.has(p + "e")) f.fail(p + "e", "no e with restitution = \"bridges\"");
      pp.v_c = f.positive(p + "v_c", pp.v_c > 0 ? pp.v_c : kBridgesVc);
      pp.e = 1;
    } else if (law == "constant") {
      if (f.has(p + "v_c")) f.fail(p + "v_c", "v_c only with restitution = \"bridges\"");
      pp.v_c = 0;
      pp.e = f.number(p + "e", pp.e);
      if (!(pp.e > 0 && pp.e <= 1)) f.fail(p + "e", "a restitution coefficient in (0, 1]");
    } else {
      f.fail(p + "restitution", "\"constant\" or \"bridges\"");
    }
    law_set[idx[0] * n + idx[1]] = law_set[idx[1] * n + idx[0]] = f.has(p + "restitution") || f.has(p + "e");
    pp.mu_s = f.non_negative(p + "mu_s", pp.mu_s);
    pp.mu_d = f.non_negative(p + "mu_d", std::min(pp.mu_d, pp.mu_s));
    pp.mu_r = f.non_negative(p + "mu_r", pp.mu_r);
    pp.mu_o = f.non_negative(p + "mu_o", pp.mu_o);
    pp.eta_r = f.non_negative(p + "eta_r", pp.eta_r);
    if ((pp.mu_r > 0 || pp.mu_o > 0) && !(pp.mu_s > 0))
      f.fail(p + "mu_r", "rolling or twisting resistance only with sliding friction (mu_s > 0)");
    if (pp.mu_d > pp.mu_s) f.fail(p + "mu_d", "a dynamic friction <= mu_s");
    pp.kt_ratio = f.non_negative(p + "kt_ratio", pp.kt_ratio);
    pp.gammat_ratio = f.non_negative(p + "gammat_ratio", pp.gammat_ratio);
    if (pp.mu_s > 0 && !(pp.kt_ratio > 0)) f.fail(p + "kt_ratio", "a tangential stiffness ratio > 0 with friction");
    for (const ContactParameter& q : LinearSpringDashpot::parameters()) {
      double& v = pp.declared[q.key];
      v = f.number(p + q.key, v);
      if (!(v >= q.min)) f.fail(p + q.key, q.expected);
    }
    c.pairs[idx[0] * n + idx[1]] = c.pairs[idx[1] * n + idx[0]] = pp;
  }
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if ((c.species[a].v_c > 0) != (c.species[b].v_c > 0) && !law_set[a * n + b])
        f.fail("pair", "a [[pair]] table for species '" + c.species[a].name + "' and '" + c.species[b].name +
                           "' giving restitution (one uses the Bridges law, the other a constant e)");

  // ---- modules: names and dependencies from the registry; each reads its own tables
  c.modules = f.strings("modules", std::vector<std::string>{"contact"});
  const bool has_walls = std::find(c.boundary.begin(), c.boundary.end(), Boundary::Wall) != c.boundary.end();
  if (has_walls && !c.has_module("walls")) c.modules.push_back("walls");  // walls are geometry
  const auto& kinds = module_kinds();
  for (const auto& m : c.modules)
    if (std::none_of(kinds.begin(), kinds.end(), [&](const ModuleKind& k) { return k.name == m; })) {
      std::string known;
      for (const auto& k : kinds) known += (known.empty() ? "" : ", ") + k.name;
      f.fail("modules", "module names from {" + known + "}; unknown module '" + m + "'");
    }
  for (const auto& k : kinds)
    for (const auto& need : k.needs)
      if (c.has_module(k.name) && !c.has_module(need))
        f.fail("modules", "\"" + need + "\" with \"" + k.name + "\" (it needs it)");
  c.modified_lees_edwards = f.boolean("domain.modified_lees_edwards", false);
  if (c.modified_lees_edwards && !c.sheared())
    f.fail("domain.modified_lees_edwards", "a \"lees_edwards\" y boundary (the feed copy LE2 is a sheared box)");
  for (const auto& k : kinds)
    if (k.read && c.has_module(k.name)) k.read(f, c);
  if (c.sheared()) {
    // A module may give the natural default (the Hill frame's Keplerian shear 1.5 Omega0).
    c.shear_rate = c.shear_rate != 0 ? f.number("domain.shear_rate", c.shear_rate) : f.number("domain.shear_rate");
  } else {
    c.shear_rate = 0;
  }
  if (c.planar && c.boundary[2] == Boundary::Wall) f.fail("domain.boundary", "no z walls in a planar scene");

  // ---- contact
  c.clip_normal = f.boolean("contact.clip_normal", false);
  const std::string scheme = f.string("contact.scheme", c.clip_normal ? "verlet" : "exact");
  if (scheme != "exact" && scheme != "verlet") f.fail("contact.scheme", "\"exact\" or \"verlet\"");
  c.exact_contacts = scheme == "exact";
  if (c.exact_contacts && c.clip_normal)
    f.fail("contact.scheme", "\"verlet\" with contact.clip_normal = true (the exact scheme integrates the unclipped law)");
  c.damping_limit = f.boolean("contact.damping_limit", true);
  c.skin = f.number("contact.skin", 0.2 * c.max_radius());
  if (!(c.skin > 0)) f.fail("contact.skin", "a positive length");
  c.max_rebuild_every = f.integer("contact.rebuild_every", 0);
  if (c.max_rebuild_every < 0) f.fail("contact.rebuild_every", "an integer >= 0");

  // ---- time: dt given directly or as t_c / n_c of the stiffest species
  double tc_min = 1e300;
  for (const auto& s : c.species) tc_min = std::min(tc_min, s.t_c);
  for (const auto& q : c.pairs) tc_min = std::min(tc_min, q.t_c);  // a [[pair]] may be stiffer
  c.force_dt = f.boolean("time.force", false);
  if (f.has("time.dt") && f.has("time.n_c")) f.fail("time.n_c", "either time.dt or time.n_c, not both");
  if (f.has("time.dt")) {
    c.dt = f.positive("time.dt");
  } else {
    const double nc = f.positive("time.n_c", 50.0);
    c.dt = tc_min / nc;
  }
  // Below N_c = 10 Verlet's restitution is badly wrong; the exact scheme is exact at any N_c
  // but dense packings need a few steps per contact time (see docs/accuracy-cost.md).
  const double soft = c.exact_contacts ? 5 : 10;
  if (c.dt > tc_min / soft && !c.force_dt)
    f.fail(f.has("time.dt") ? "time.dt" : "time.n_c",
           "dt <= t_c/" + std::to_string(static_cast<int>(soft)) + " = " + std::to_string(tc_min / soft) +
               (c.exact_contacts ? " (dense packings are not stable beyond" : " (the restitution is badly wrong beyond") +
               "; set time.force = true to run anyway)");
  // Beyond the stability limit on one contact a run is refused even with time.force: for
  // Verlet 0.64 t_c at e -> 1, 0.29 t_c at e = 0.1 (verlet_stability_limit); the exact scheme
  // follows a lone contact at any step, but its onset step assumes the contact lasts longer
  // than two steps (t_c / 2).
  // Under the Bridges law Verlet's limit is taken at e = 0.05, an impact 3.6e5 v_c fast.
  auto lowest_e = [](double v_c, double e) { return v_c > 0 ? 0.05 : e; };
  double dt_stable = 1e300;
  for (const auto& s : c.species)
    dt_stable = std::min(dt_stable, c.exact_contacts ? 0.5 * s.t_c : verlet_stability_limit(s.t_c, lowest_e(s.v_c, s.e)));
  for (const auto& q : c.pairs)
    dt_stable = std::min(dt_stable, c.exact_contacts ? 0.5 * q.t_c : verlet_stability_limit(q.t_c, lowest_e(q.v_c, q.e)));
  if (c.dt >= dt_stable)
    f.fail(f.has("time.dt") ? "time.dt" : "time.n_c",
           "dt below the stability limit " + std::to_string(dt_stable) +
               " of the contact scheme (unstable beyond, even with time.force)");
  f.forget("time.n_c");  // the step, however it was given
  f.record("time.dt", c.dt);
  c.t_end = f.positive("time.end");
  // Step counts are 64-bit and the clock a double: beyond 2^53 steps neither counts exactly.
  if (!(c.t_end / c.dt <= 9.0e15)) {
    std::ostringstream os;
    os << "an end time of at most 9e15 steps (time.end / dt = " << c.t_end / c.dt << " steps at dt = " << c.dt << " s)";
    f.fail("time.end", os.str());
  }
  c.integrator = f.string("time.integrator", integrator_kinds().front().name);
  {
    const auto& ik = integrator_kinds();
    const auto it = std::find_if(ik.begin(), ik.end(), [&](const ModuleKind& k) { return k.name == c.integrator; });
    if (it == ik.end()) {
      std::string known;
      for (const auto& k : ik) known += (known.empty() ? "\"" : " or \"") + k.name + "\"";
      f.fail("time.integrator", known);
    }
    if (it->read) it->read(f, c);
  }

  // ---- initial particles
  c.init = f.string("particles.init", "random");
  c.seed = static_cast<std::uint64_t>(f.integer("seed", 1));
  const auto sp_name = f.string("particles.species", c.species[0].name);
  auto it = std::find_if(c.species.begin(), c.species.end(), [&](const Species& s) { return s.name == sp_name; });
  if (it == c.species.end()) f.fail("particles.species", "the name of a [[species]]");
  c.init_species = static_cast<int>(it - c.species.begin());
  c.velocity_mean = f.vec3("particles.velocity", Vec3(0, 0, 0));
  c.velocity_sigma = f.non_negative("particles.velocity_sigma", 0.0);
  c.shear_flow = f.boolean("particles.shear_flow", false);
  if (c.shear_flow && !c.sheared()) f.fail("particles.shear_flow", "a \"lees_edwards\" y boundary (it sets the flow)");
  c.dispersion_fraction = f.non_negative("particles.dispersion", 0.0);
  if (c.init == "random" || c.init == "lattice") {
    const int given = f.has("particles.count") + f.has("particles.volume_fraction") + f.has("particles.optical_depth");
    if (given != 1)
      f.fail("particles.count", "exactly one of particles.count, particles.volume_fraction, particles.optical_depth");
    if (f.has("particles.optical_depth")) {
      if (!c.planar) f.fail("particles.optical_depth", "a planar scene (domain.planar = true)");
      c.optical_depth = f.number("particles.optical_depth");
      if (!(c.optical_depth > 0 && c.optical_depth < 0.5)) f.fail("particles.optical_depth", "a value in (0, 0.5)");
    } else if (f.has("particles.count")) {
      c.count = f.integer("particles.count");
      if (c.count < 1) f.fail("particles.count", "a positive integer");
    } else {
      c.volume_fraction = f.number("particles.volume_fraction");
      if (!(c.volume_fraction > 0 && c.volume_fraction < 0.74))
        f.fail("particles.volume_fraction", "a volume fraction in (0, 0.74)");
    }
    if (c.init == "random" && f.has("particles.layer")) {
      if (c.planar) f.fail("particles.layer", "a 3D scene (a planar one has no thickness)");
      c.init_layer = f.number("particles.layer");
      if (!(c.init_layer > 0 && c.init_layer <= c.hi[2] - c.lo[2]))
        f.fail("particles.layer", "a thickness in (0, the box's z length] (m)");
    }
    if (c.init == "lattice") {
      c.lattice_jitter = f.number("particles.jitter", 0.0);
      // Each site moves by up to +-jitter gap/2 per axis: two neighbours never close the gap for jitter <= 1.
      if (c.lattice_jitter < 0 || c.lattice_jitter > 1) f.fail("particles.jitter", "a fraction of the gap in [0, 1]");
    }
  } else if (c.init == "file") {
    c.init_file = f.string("particles.file");
    if (!c.init_file.empty() && c.init_file[0] != '/') c.init_file = f.directory() + "/" + c.init_file;
  } else if (c.init != "none") {  // "none": no initial particles (programmatic use, tests)
    f.fail("particles.init", "\"random\", \"lattice\", \"file\" or \"none\"");
  }

  // ---- output
  c.dump_every = f.non_negative("output.dump_every", 0.0);
  c.snapshot_every = f.non_negative("output.snapshot_every", 0.0);
  c.snapshot_from = f.non_negative("output.snapshot_from", 0.0);
  c.observe_every = f.positive("output.observe_every", c.t_end / 100);
  c.snapshot_on_signal = f.boolean("output.snapshot_on_signal", false);
  c.progress_every = f.positive("output.progress_every", 2.0);

  // ---- guards
  c.max_overlap_fraction = f.positive("guards.max_overlap", 0.2);
  c.energy_growth = f.positive("guards.energy_growth", 1e3);
  c.max_step = f.positive("guards.max_step", 0.5);

  // A box too small for the interaction range cannot be decomposed or imaged correctly.
  const double range = c.halo_range();
  for (int d = 0; d < (c.planar ? 2 : 3); ++d)
    if (c.periodic_like(d) && c.hi[d] - c.lo[d] < 2 * range)
      f.fail("domain.hi", "a periodic box at least 2 x (2 a_max + lubrication reach + skin, or self-gravity's pair reach + skin) = " +
                              std::to_string(2 * range) + " long on every periodic axis");

  f.reject_unknown_keys();
  return c;
}

}  // namespace cassini
