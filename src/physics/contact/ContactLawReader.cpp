#include "physics/contact/ContactLawReader.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "physics/contact/HertzMindlin.hpp"
#include "physics/contact/LinearSpringDashpot.hpp"

namespace cassini {

namespace {
ContactSettings& settings_of(Config& c) {
  if (!c.has<ContactSettings>()) c.set(ContactSettings{});
  return c.edit<ContactSettings>();
}
}  // namespace

void read_species_law(CaseFile& f, const std::string& p, const Species& geometry, Config& c) {
  SpeciesLaw s;
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
    const double a = geometry.radius_min, m = geometry.density * 4.0 / 3.0 * std::numbers::pi * a * a * a;
    const double E = hertz_e_star(s.youngs_modulus, s.poisson_ratio, s.youngs_modulus, s.poisson_ratio);
    s.t_c = hertz_contact_time(0.5 * m, 0.5 * a, E, s.impact_speed);
  }
  for (const ContactParameter& q : LinearSpringDashpot::parameters()) {
    const double v = f.number(p + q.key, q.fallback);
    if (!(v >= q.min)) f.fail(p + q.key, q.expected);
    s.declared[q.key] = v;
  }
  settings_of(c).species.push_back(s);
}

void read_pair_laws(CaseFile& f, Config& c) {
  // ---- contact parameters per species pair: mixed by default, [[pair]] tables override
  ContactSettings& cs = settings_of(c);
  const std::size_t n = cs.species.size();
  cs.pairs.resize(n * n);
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      const SpeciesLaw &s = cs.species[a], &t = cs.species[b];
      const std::string &s_name = c.species[a].name, &t_name = c.species[b].name;
      cs.pairs[a * n + b] = {0.5 * (s.t_c + t.t_c), 0.5 * (s.e + t.e), std::min(s.mu_s, t.mu_s), std::min(s.mu_d, t.mu_d),
                            0.5 * (s.kt_ratio + t.kt_ratio), 0.5 * (s.gammat_ratio + t.gammat_ratio),
                            0.5 * (s.v_c + t.v_c), std::min(s.mu_r, t.mu_r), std::min(s.mu_o, t.mu_o),
                            0.5 * (s.eta_r + t.eta_r)};
      for (const ContactParameter& q : LinearSpringDashpot::parameters())
        cs.pairs[a * n + b].declared[q.key] = a == b ? s.declared.at(q.key) : q.mix(s.declared.at(q.key), t.declared.at(q.key));
      if (s.youngs_modulus > 0 && t.youngs_modulus > 0) {
        cs.pairs[a * n + b].e_star = hertz_e_star(s.youngs_modulus, s.poisson_ratio, t.youngs_modulus, t.poisson_ratio);
        cs.pairs[a * n + b].g_star = hertz_g_star(s.youngs_modulus, s.poisson_ratio, t.youngs_modulus, t.poisson_ratio);
      } else if ((s.youngs_modulus > 0) != (t.youngs_modulus > 0)) {
        f.fail("species", "one contact model for all species (species '" + s_name + "' and '" + t_name +
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
    PairParameters pp = cs.pairs[idx[0] * n + idx[1]];
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
    cs.pairs[idx[0] * n + idx[1]] = cs.pairs[idx[1] * n + idx[0]] = pp;
  }
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if ((cs.species[a].v_c > 0) != (cs.species[b].v_c > 0) && !law_set[a * n + b])
        f.fail("pair", "a [[pair]] table for species '" + c.species[a].name + "' and '" + c.species[b].name +
                           "' giving restitution (one uses the Bridges law, the other a constant e)");
  c.rotation = cs.friction();
}

void read_contact_table(CaseFile& f, Config& c) {
  ContactSettings& cs = settings_of(c);
  cs.clip_normal = f.boolean("contact.clip_normal", false);
  const std::string scheme = f.string("contact.scheme", cs.clip_normal ? "verlet" : "exact");
  if (scheme != "exact" && scheme != "verlet") f.fail("contact.scheme", "\"exact\" or \"verlet\"");
  cs.exact = scheme == "exact";
  if (cs.exact && cs.clip_normal)
    f.fail("contact.scheme", "\"verlet\" with contact.clip_normal = true (the exact scheme integrates the unclipped law)");
  cs.damping_limit = f.boolean("contact.damping_limit", true);
  // The default has changed (it was Verlet): snapshots record the scheme in force.
  c.recorded_settings.emplace_back("contact_scheme", scheme);
}

void read_time_step(CaseFile& f, Config& c) {
  const ContactSettings& cs = c.get<ContactSettings>();
  double tc_min = 1e300;
  for (const auto& s : cs.species) tc_min = std::min(tc_min, s.t_c);
  for (const auto& q : cs.pairs) tc_min = std::min(tc_min, q.t_c);  // a [[pair]] may be stiffer
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
  const double soft = cs.exact ? 5 : 10;
  if (c.dt > tc_min / soft && !c.force_dt)
    f.fail(f.has("time.dt") ? "time.dt" : "time.n_c",
           "dt <= t_c/" + std::to_string(static_cast<int>(soft)) + " = " + std::to_string(tc_min / soft) +
               (cs.exact ? " (dense packings are not stable beyond" : " (the restitution is badly wrong beyond") +
               "; set time.force = true to run anyway)");
  // Beyond the stability limit on one contact a run is refused even with time.force: for
  // Verlet 0.64 t_c at e -> 1, 0.29 t_c at e = 0.1 (verlet_stability_limit); the exact scheme
  // follows a lone contact at any step, but its onset step assumes the contact lasts longer
  // than two steps (t_c / 2).
  // Under the Bridges law Verlet's limit is taken at e = 0.05, an impact 3.6e5 v_c fast.
  auto lowest_e = [](double v_c, double e) { return v_c > 0 ? 0.05 : e; };
  double dt_stable = 1e300;
  for (const auto& s : cs.species)
    dt_stable = std::min(dt_stable, cs.exact ? 0.5 * s.t_c : verlet_stability_limit(s.t_c, lowest_e(s.v_c, s.e)));
  for (const auto& q : cs.pairs)
    dt_stable = std::min(dt_stable, cs.exact ? 0.5 * q.t_c : verlet_stability_limit(q.t_c, lowest_e(q.v_c, q.e)));
  if (c.dt >= dt_stable)
    f.fail(f.has("time.dt") ? "time.dt" : "time.n_c",
           "dt below the stability limit " + std::to_string(dt_stable) +
               " of the contact scheme (unstable beyond, even with time.force)");
}

}  // namespace cassini
