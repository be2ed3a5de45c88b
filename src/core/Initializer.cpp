#include "core/Initializer.hpp"

#include <algorithm>
#include <cerrno>
#include <functional>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <unordered_map>

#include <unistd.h>

#include "core/CaseFile.hpp"

namespace cassini {

double Random::gaussian() {  // Box-Muller
  const double u1 = 1.0 - uniform(), u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
}

namespace {

struct Candidate {
  Vec3 x;
  double a;
};

[[noreturn]] void fail(const Config& cfg, const std::string& key, const std::string& msg) {
  throw ConfigError(cfg.source + ": key '" + key + "': " + msg);
}

// Region where centres may go: a radius away from walls and open faces; anywhere on periodic axes.
void centre_bounds(const Config& cfg, Vec3& lo, Vec3& hi) {
  const double a = cfg.max_radius();
  for (int d = 0; d < 3; ++d) {
    const bool per = cfg.periodic_like(d);
    lo[d] = cfg.lo[d] + (per ? 0 : a);
    hi[d] = cfg.hi[d] - (per ? 0 : a);
  }
  if (cfg.planar) lo[2] = hi[2] = 0.5 * (cfg.lo[2] + cfg.hi[2]);
  if (cfg.init_layer > 0) {  // a ring's initial layer about the mid-plane
    const double mid = 0.5 * (cfg.lo[2] + cfg.hi[2]);
    lo[2] = std::max(lo[2], mid - 0.5 * cfg.init_layer);
    hi[2] = std::min(hi[2], mid + 0.5 * cfg.init_layer);
  }
}

double mean_power(const Species& s, int k) { return s.sizes.mean_power(s.radius_min, s.radius_max, k); }

long resolve_count(const Config& cfg) {
  if (cfg.count > 0) return cfg.count;
  const Species& s = cfg.species[cfg.init_species];
  const Vec3 L = cfg.hi - cfg.lo;
  if (cfg.optical_depth > 0) return std::lround(cfg.optical_depth * L[0] * L[1] / (std::numbers::pi * mean_power(s, 2)));
  if (cfg.planar) return std::lround(cfg.volume_fraction * L[0] * L[1] / (std::numbers::pi * mean_power(s, 2)));
  return std::lround(cfg.volume_fraction * L[0] * L[1] * L[2] / (4.0 / 3.0 * std::numbers::pi * mean_power(s, 3)));
}

double draw_radius(const Species& s, Random& rng) {
  return s.radius_min == s.radius_max ? s.radius_min : s.sizes.quantile(s.radius_min, s.radius_max, rng.uniform(0.0, 1.0));
}

// Random sequential addition with a cell grid; refuses packings it cannot reach.
std::vector<Candidate> random_positions(const Config& cfg, long n, Random& rng) {
  const Species& s = cfg.species[cfg.init_species];
  Vec3 L = cfg.hi - cfg.lo;
  if (cfg.init_layer > 0) L[2] = std::max(cfg.init_layer, 2 * s.radius_max);  // the layer's volume
  const double fraction = cfg.planar ? n * std::numbers::pi * mean_power(s, 2) / (L[0] * L[1])
                                     : n * 4.0 / 3.0 * std::numbers::pi * mean_power(s, 3) / L.prod();
  const double limit = cfg.planar ? 0.50 : 0.35;  // below the random-sequential-addition jamming limits
  const std::string key = cfg.count > 0 ? "particles.count"
                          : cfg.optical_depth > 0 ? "particles.optical_depth" : "particles.volume_fraction";
  // Keep clear of the moonlet; under modified Lees-Edwards boundaries this is the moonlet-free
  // copy LE2, and place_particles leaves out of LE1 what the moonlet's body holds.
  const double moon = cfg.obstacle_radius > 0 && !cfg.modified_lees_edwards ? cfg.obstacle_radius : -1;
  if (fraction > limit) {
    std::ostringstream os;
    os << "expected at most a " << (cfg.planar ? "area" : "volume") << " fraction of " << limit
       << " for random placement, got " << fraction << " (" << n << " particles); use particles.init = \"lattice\"";
    fail(cfg, key, os.str());
  }
  Vec3 lo, hi;
  centre_bounds(cfg, lo, hi);
  const double cell = 2 * cfg.max_radius();
  int nc[3];
  for (int d = 0; d < 3; ++d) nc[d] = std::max(1, static_cast<int>(L[d] / cell));
  if (cfg.planar) nc[2] = 1;
  auto cell_of = [&](const Vec3& x, int c[3]) {
    for (int d = 0; d < 3; ++d) c[d] = std::clamp(static_cast<int>((x[d] - cfg.lo[d]) / L[d] * nc[d]), 0, nc[d] - 1);
  };
  std::unordered_map<long, std::vector<int>> grid;
  auto key_of = [&](int cx, int cy, int cz) { return (long(cz) * nc[1] + cy) * nc[0] + cx; };
  std::vector<Candidate> out;
  out.reserve(n);
  // A wide distribution (power law, list) is drawn first and placed largest first, as random
  // sequential addition of polydisperse discs is done: a large particle drawn late would find no
  // hole among the small ones. The uniform law keeps its interleaved draws (earlier runs' starts).
  std::vector<double> drawn;
  if (s.sizes.kind != SizeDistribution::Uniform) {
    for (long k = 0; k < n; ++k) drawn.push_back(draw_radius(s, rng));
    std::sort(drawn.begin(), drawn.end(), std::greater<>());
  }
  for (long k = 0; k < n; ++k) {
    const double a = drawn.empty() ? draw_radius(s, rng) : drawn[k];
    bool placed = false;
    for (int attempt = 0; attempt < 10000 && !placed; ++attempt) {
      Vec3 x;
      for (int d = 0; d < 3; ++d) x[d] = lo[d] == hi[d] ? lo[d] : rng.uniform(lo[d], hi[d]);
      int c[3];
      cell_of(x, c);
      bool ok = moon < 0 || x.norm() >= moon + a;
      for (int dz = (nc[2] > 1 ? -1 : 0); dz <= (nc[2] > 1 ? 1 : 0) && ok; ++dz)
        for (int dy = -1; dy <= 1 && ok; ++dy)
          for (int dx = -1; dx <= 1 && ok; ++dx) {
            int q[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
            bool skip = false;
            for (int d = 0; d < 3; ++d) {
              if (q[d] < 0 || q[d] >= nc[d]) {
                if (!cfg.periodic_like(d)) skip = true;
                q[d] = (q[d] + nc[d]) % nc[d];
              }
            }
            if (skip) continue;
            auto it = grid.find(key_of(q[0], q[1], q[2]));
            if (it == grid.end()) continue;
            for (int j : it->second) {
              Vec3 dvec = x - out[j].x;
              for (int d = 0; d < 3; ++d)
                if (cfg.periodic_like(d)) dvec[d] -= L[d] * std::round(dvec[d] / L[d]);
              const double R = a + out[j].a;
              if (dvec.squaredNorm() < R * R) { ok = false; break; }
            }
          }
      if (ok) {
        grid[key_of(c[0], c[1], c[2])].push_back(static_cast<int>(out.size()));
        out.push_back({x, a});
        placed = true;
      }
    }
    if (!placed) {
      std::ostringstream os;
      os << "expected a count that fits; placed only " << k << " of " << n << " particles without overlap";
      fail(cfg, key, os.str());
    }
  }
  return out;
}

// A simple-cubic lattice whose site k is drawn from the stream `draws_per_site * k` draws in,
// so that a rank can place its own sites without drawing everyone else's.
class Lattice {
 public:
  Lattice(const Config& cfg, long n) : cfg_(cfg), s_(cfg.species[cfg.init_species]), dims_(cfg.planar ? 2 : 3) {
    Vec3 hi;
    centre_bounds(cfg, lo_, hi);
    const Vec3 span = hi - lo_;
    // Periodic axes: sites at lo + (k + 1/2) L/n; walled axes: the centre range edge to edge.
    double len[3] = {0, 0, 0}, volume = 1;
    for (int d = 0; d < dims_; ++d) volume *= len[d] = cfg.periodic_like(d) ? span[d] : span[d] + 2 * s_.radius_max;
    double spacing = std::pow(volume / n, 1.0 / dims_);
    for (int iter = 0; iter < 2000; ++iter, spacing *= 0.995) {
      long sites = 1;
      for (int d = 0; d < dims_; ++d) sites *= m_[d] = std::max(1, static_cast<int>(len[d] / spacing));
      if (sites >= n) break;
    }
    for (int d = 0; d < dims_; ++d) {
      gap_[d] = len[d] / m_[d];
      if (gap_[d] < 2 * s_.radius_max)
        fail(cfg, cfg.count > 0 ? "particles.count" : "particles.volume_fraction",
             "expected a count whose simple-cubic lattice fits the domain (site spacing " + std::to_string(gap_[d]) +
                 " < diameter " + std::to_string(2 * s_.radius_max) + ")");
    }
  }
  // One jitter draw per axis, and one for the radius of a size distribution.
  long draws_per_site() const { return dims_ + (s_.radius_max == s_.radius_min ? 0 : 1); }
  Candidate site(long k, Random& rng) const {
    const long idx[3] = {k % m_[0], (k / m_[0]) % m_[1], k / (long(m_[0]) * m_[1])};
    Vec3 x = lo_;
    for (int d = 0; d < dims_; ++d) {
      const double base = cfg_.periodic_like(d) ? lo_[d] : lo_[d] - s_.radius_max;
      x[d] = base + (idx[d] + 0.5) * gap_[d];
      x[d] += cfg_.lattice_jitter * 0.5 * (gap_[d] - 2 * s_.radius_max) * rng.uniform(-1, 1);
    }
    return {x, s_.radius_max == s_.radius_min ? s_.radius_min : draw_radius(s_, rng)};
  }

 private:
  const Config& cfg_;
  const Species& s_;
  int dims_;
  Vec3 lo_;
  double gap_[3] = {0, 0, 0};
  int m_[3] = {1, 1, 1};
};

// A particle of the initial sequence that this rank keeps.
struct Drawn {
  long k;  // place in the sequence
  Candidate c;
  Vec3 v;
  int species;
};

}  // namespace

void place_particles(const Config& cfg, const Decomposition& dom, ParticleStore& p) {
  if (cfg.init == "none") return;
  auto wrapped = [&](Vec3 x) {  // periodic axes: into the box
    for (int d = 0; d < 3; ++d)
      if (cfg.periodic_like(d)) x[d] -= (cfg.hi[d] - cfg.lo[d]) * std::floor((x[d] - cfg.lo[d]) / (cfg.hi[d] - cfg.lo[d]));
    return x;
  };
  auto mine = [&](const Vec3& x) { return dom.owner(wrapped(x)) == dom.rank; };
  std::vector<Drawn> own;
  long N = 0;  // particles in the sequence, on every rank
  if (cfg.init == "file") {
    if (!std::filesystem::exists(cfg.init_file))
      throw ConfigError(cfg.source + ": key 'particles.file': no such file '" + cfg.init_file + "'");
    std::ifstream in(cfg.init_file);
    if (!in)
      throw ConfigError(cfg.source + ": key 'particles.file': cannot open '" + cfg.init_file + "': " + std::strerror(errno));
    std::string line;
    int lineno = 0;
    static const char* field[] = {"x", "y", "z", "vx", "vy", "vz", "radius", "species-index"};
    while (std::getline(in, line)) {
      ++lineno;
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ls(line);
      std::vector<std::string> words;
      for (std::string w; ls >> w;) words.push_back(w);
      const std::string where = cfg.init_file + ":" + std::to_string(lineno) + ": ";
      if (words.size() < 7 || words.size() > 8)
        throw ConfigError(where + "expected 'x y z vx vy vz radius [species-index]', got " +
                          std::to_string(words.size()) + " fields");
      double value[7];
      for (int k = 0; k < 7; ++k) {
        char* end = nullptr;
        value[k] = std::strtod(words[k].c_str(), &end);
        if (end != words[k].c_str() + words[k].size())
          throw ConfigError(where + "field '" + field[k] + "' is '" + words[k] + "', expected a number");
        if (!std::isfinite(value[k]))
          throw ConfigError(where + "field '" + field[k] + "' is " + words[k] + ", expected a finite number");
      }
      const Vec3 x(value[0], value[1], value[2]), v(value[3], value[4], value[5]);
      // A periodic axis would silently take the bead's image; an open or walled one would lose it.
      for (int d = 0; d < (cfg.planar ? 2 : 3); ++d)
        if (!(x[d] >= cfg.lo[d] && x[d] < cfg.hi[d])) {
          std::ostringstream os;
          os << where << "field '" << field[d] << "' is " << words[d] << ", outside the box [" << cfg.lo[d] << ", "
             << cfg.hi[d] << ") of domain.lo/hi; expected a position inside it";
          throw ConfigError(os.str());
        }
      const double a = value[6];
      if (!(a > 0)) throw ConfigError(where + "field 'radius' is " + words[6] + ", expected a positive number");
      int sp = cfg.init_species;
      if (words.size() == 8) {
        char* end = nullptr;
        const long k = std::strtol(words[7].c_str(), &end, 10);
        if (end != words[7].c_str() + words[7].size() || k < 0 || k >= long(cfg.species.size()))
          throw ConfigError(where + "field 'species-index' is '" + words[7] + "', expected an integer in [0, " +
                            std::to_string(cfg.species.size() - 1) + "]");
        sp = int(k);
      }
      if (mine(x)) own.push_back({N, {x, a}, v, sp});
      ++N;
    }
  } else {
    const long n = resolve_count(cfg);
    // A count that cannot fit is refused by name, not met with bad_alloc halfway through.
    // ~1 kB per particle: state, neighbour entries, ghosts and halo buffers (scripts/bench).
    const double need = 1000.0 * double(n), ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
    if (need > 0.8 * ram) {
      const std::string key = cfg.count > 0 ? "particles.count"
                              : cfg.optical_depth > 0 ? "particles.optical_depth" : "particles.volume_fraction";
      std::ostringstream os;
      os << cfg.source << ": key '" << key << "': " << n << " particles would need about " << need / 1e9
         << " GB (~1 kB each), more than this machine's " << ram / 1e9 << " GB";
      throw ConfigError(os.str());
    }
    Random rng(cfg.seed);
    if (cfg.init == "random") {
      const std::vector<Candidate> all = random_positions(cfg, n, rng);
      for (long k = 0; k < n; ++k)
        if (mine(all[k].x)) own.push_back({k, all[k], Vec3::Zero(), cfg.init_species});
    } else {
      const Lattice lattice(cfg, n);
      for (long k = 0; k < n; ++k) {
        Random at = rng;
        at.skip(k * lattice.draws_per_site());
        const Candidate c = lattice.site(k, at);
        if (mine(c.x)) own.push_back({k, c, Vec3::Zero(), cfg.init_species});
      }
      rng.skip(n * lattice.draws_per_site());
    }
    N = n;
    const int dims = cfg.planar ? 2 : 3;  // velocities follow the positions in the stream, 2 draws per axis
    for (Drawn& q : own) {
      Random at = rng;
      at.skip(q.k * 2 * dims);
      Vec3 v = cfg.velocity_mean;
      const double flow = cfg.shear_flow ? cfg.shear_rate * q.c.x[1] : 0.0;  // imposed shear v_x = gamma_dot y
      v[0] += flow;
      const double sigma = cfg.velocity_sigma + cfg.dispersion_fraction * std::abs(flow);
      for (int d = 0; d < dims; ++d) v[d] += sigma * at.gaussian();
      if (cfg.planar) v[2] = 0;
      q.v = v;
    }
  }
  // Modified Lees-Edwards boundaries: the same ring twice, LE1 (ids k) without what lies inside
  // the moonlet, and LE2 (ids N + k) whole.
  const double moon = cfg.obstacle_radius > 0 ? cfg.obstacle_radius : -1;
  for (int copy = 0; copy < (cfg.modified_lees_edwards ? 2 : 1); ++copy)
    for (const Drawn& q : own) {
      const Vec3 x = wrapped(q.c.x);
      const double a = q.c.a;
      if (cfg.modified_lees_edwards && copy == 0 && moon > 0 && x.norm() < moon + a) continue;
      const double m = cfg.species[q.species].density * 4.0 / 3.0 * std::numbers::pi * a * a * a;
      p.add(static_cast<std::int64_t>(copy * N + q.k), q.species, a, m, x, q.v);
      if (p.copies) p.le_copy.back() = static_cast<std::uint8_t>(copy);
    }
  p.nlocal = p.size();
}

}  // namespace cassini
