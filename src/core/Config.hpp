#pragma once
// The resolved, validated description of a run. Built once from a case file; everything
// downstream reads this plain struct, never the TOML.
#include <algorithm>
#include <any>
#include <array>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <typeindex>
#include <utility>
#include <vector>

#include "core/CaseFile.hpp"
#include "core/SizeDistribution.hpp"
#include "core/Vec3.hpp"

namespace cassini {

// LeesEdwards: only on y, with x periodic: a periodic image across y is shifted in x by the
// growing shear offset and moves faster by shear_rate * Ly (spec section 2).
enum class Boundary { Periodic, Wall, Open, LeesEdwards };

// A species' geometry (its contact law: ContactSettings, physics/contact).
struct Species {
  std::string name;
  double density = 0;
  double radius_min = 0, radius_max = 0;  // equal for monodisperse; distributed by `sizes` otherwise
  SizeDistribution sizes;
};

inline constexpr double kGravitationalConstant = 6.674e-11;

struct Config {
  std::string source;  // case file path, for messages

  // domain
  Vec3 lo{0, 0, 0}, hi{1, 1, 1};
  std::array<Boundary, 3> boundary{Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  bool planar = false;  // centres stay on z = lo_z..hi_z midplane; z is never integrated
  int slab_axis = 0;
  std::string decomposition = "slabs";  // slabs | grid (blocks of a px x py x pz grid) | metis (cells partitioned by METIS)
  std::array<int, 3> grid_shape{0, 0, 0};  // "grid": regions per axis (0: the least surface for the box)
  long balance_every = 0;  // move the slab cuts to balance cost every this many rebuilds (0: never)
  double shear_rate = 0;  // Lees-Edwards gamma_dot (1/s); v_x = shear_rate * y is the imposed flow
  // Modified Lees-Edwards boundaries (thesis fig. 9.1): a second, moonlet-free copy LE2 of the
  // box runs alongside the main one LE1 and feeds it through the x boundaries (HaloExchange).
  bool modified_lees_edwards = false;

  // What modules tell the core about the scene when they read their tables (ModuleKind::read):
  double frame_rotation = 0;  // angular velocity (about z) of a rotating frame: the Coriolis term
  double pair_reach = 0;      // pairs interact across gaps up to this (lubrication), beyond contact
  double halo_reach = 0;      // centre distance of pairs the neighbour list does not cover (self-gravity)
  double obstacle_radius = 0; // a fixed sphere at the origin (the moonlet) initial particles keep clear of
  bool rotation = false;      // particles turn (some contact has friction): spin, torque (the contact law's reader)
  // Settings a case may leave to a default that has changed, recorded with their resolved values
  // as attributes of a snapshot's parameters/ group (e.g. contact_scheme).
  std::vector<std::pair<std::string, std::string>> recorded_settings;

  // Each module's own settings, read from its case-file table by its ModuleKind::read and kept
  // here by type: the core carries them without knowing them (cfg.get<ChannelConfig>()).
  std::map<std::type_index, std::any> settings;
  template <class T>
  void set(T value) { settings[typeid(T)] = std::move(value); }
  template <class T>
  bool has() const { return settings.count(typeid(T)) > 0; }
  template <class T>
  const T& get() const { return std::any_cast<const T&>(find_settings(typeid(T))); }
  template <class T>
  T& edit() { return std::any_cast<T&>(find_settings(typeid(T))); }

  std::vector<Species> species;

  // Files and folders a module's settings name as inputs ({path, case key}): the output
  // directory must not be one of them or lie inside one (e.g. the drag's flow.cache).
  std::vector<std::pair<std::string, std::string>> module_inputs;

  // initial particles
  std::string init = "random";  // random | lattice | file
  long count = 0;               // random/lattice: number of particles (0 = from volume_fraction)
  double volume_fraction = 0;
  std::string init_file;
  int init_species = 0;
  Vec3 velocity_mean{0, 0, 0};
  double velocity_sigma = 0;  // Gaussian dispersion per velocity component
  bool shear_flow = false;      // add the imposed flow shear_rate * y e_x
  double dispersion_fraction = 0;  // extra Gaussian dispersion, fraction of |shear_rate y|
  double optical_depth = 0;     // planar ring: N pi a^2 / (Lx Ly)
  double lattice_jitter = 0;  // random displacement, as a fraction of the lattice gap
  double init_layer = 0;      // random, 3D: centres within +-layer/2 of the box's mid-plane (0: the whole box)

  std::vector<std::string> modules;
  double skin = 0;                // Verlet skin; default 0.1 x largest diameter
  double max_rebuild_every = 0;   // 0: rebuild only on displacement

  double dt = 0, t_end = 0;
  bool force_dt = false;
  // time.integrator: one of integrator_kinds() (ModuleRegistry.hpp), "verlet" by default
  std::string integrator = "verlet";

  double dump_every = 0;      // simulated time between text dumps (0: none)
  double snapshot_every = 0;  // simulated time between H5MD snapshots (0: none)
  double snapshot_from = 0;   // no snapshots before this simulated time
  double observe_every = 0;   // simulated time between observables rows (0: 100 rows per run)
  double progress_every = 2;  // wall seconds between progress lines
  bool snapshot_on_signal = false;  // SIGTERM/SIGINT: write a last snapshot to continue from

  // guards
  double max_overlap_fraction = 0.2;  // stop when an overlap exceeds this fraction of a radius
  double energy_growth = 1e3;         // stop when kinetic energy grows by this factor (no source)
  double max_step = 0.5;              // stop when a step moves a particle (relative to the imposed
                                      // flow) further than this fraction of the smallest radius
  double min_radius() const;

  std::uint64_t seed = 1;

  double max_radius() const;
  // Largest centre distance at which two particles touch (or lubricate), plus the skin: the
  // neighbour list's range, and the halo's unless halo_range() is wider.
  double pair_range() const { return 2 * max_radius() + pair_reach + skin; }
  // The ghost halo's width: the pair range, or wider for the short range of self-gravity.
  double halo_range() const { return std::max(pair_range(), halo_reach + skin); }
  bool has_module(const std::string& name) const;
  bool sheared() const { return boundary[1] == Boundary::LeesEdwards; }
  bool periodic_like(int d) const { return boundary[d] == Boundary::Periodic || boundary[d] == Boundary::LeesEdwards; }

 private:
  const std::any& find_settings(const std::type_index& type) const;
  std::any& find_settings(const std::type_index& type) {
    return const_cast<std::any&>(static_cast<const Config&>(*this).find_settings(type));
  }
};

}  // namespace cassini
