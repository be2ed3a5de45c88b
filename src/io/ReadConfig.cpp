#include "io/ReadConfig.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/ModuleRegistry.hpp"
#include "physics/contact/ContactLawReader.hpp"

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
  if (c.decomposition != "slabs" && c.decomposition != "grid" && c.decomposition != "metis")
    f.fail("domain.decomposition", "\"slabs\" (cuts along domain.slab_axis), \"grid\" (blocks of a grid of regions) or "
                                   "\"metis\" (a METIS partition of cells)");
  if (f.has("domain.grid")) {
    if (c.decomposition != "grid") f.fail("domain.grid", "no key unless domain.decomposition = \"grid\"");
    const std::vector<double> shape = f.numbers("domain.grid");
    if (shape.size() != 3) f.fail("domain.grid", "three region counts [px, py, pz]");
    for (int d = 0; d < 3; ++d) {
      if (shape[d] < 1 || shape[d] != std::floor(shape[d])) f.fail("domain.grid", "whole numbers >= 1");
      c.grid_shape[d] = static_cast<int>(shape[d]);
    }
  }
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
    read_species_law(f, p, s, c);
    for (const auto& other : c.species)
      if (other.name == s.name) f.fail(p + "name", "a name not used by another species");
    c.species.push_back(s);
  }

  read_pair_laws(f, c);
  read_contact_table(f, c);

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

  // ---- neighbour list
  c.skin = f.number("contact.skin", 0.2 * c.max_radius());
  if (!(c.skin > 0)) f.fail("contact.skin", "a positive length");
  c.max_rebuild_every = f.integer("contact.rebuild_every", 0);
  if (c.max_rebuild_every < 0) f.fail("contact.rebuild_every", "an integer >= 0");

  // ---- time
  read_time_step(f, c);
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
