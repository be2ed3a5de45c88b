#pragma once
// Parameters of a channel scene (spec section 3): the wall outline, the Stokes flow through
// it, the drag on the particles, the inlet and the clog criterion. Plain data, read from the
// case file's [channel], [flow], [drag], [inlet] and [clog] tables.
#include <array>
#include <string>
#include <vector>

namespace cassini {

class CaseFile;
struct Config;

using Point2 = std::array<double, 2>;  // (x, y)

struct ChannelConfig {
  // Side walls: two polylines in the xy plane, x strictly increasing, extruded over the
  // channel height (the floor and ceiling are the domain's z walls). Fluid lies between them.
  std::vector<Point2> upper, lower;
  double neck_width = 0;           // D; the neck is the narrowest gap of the outline
  double neck_x0 = 0, neck_x1 = 0; // x range of the narrowest part (equal for a sharp neck)

  // [flow]: steady Stokes flow, cached as HDF5 next to the case
  double mean_velocity = 0;   // far-field mean velocity (m/s)
  double viscosity = 1.8e-3;  // Pa s
  double fluid_density = 1050;
  int resolution = 16;          // Stokes grid cells per neck width
  double solve_half_length = 0; // Stokes solve over |x| < this; the duct series beyond
  bool embedded_walls = true;   // flow.walls: angled walls at their true position, not staircased
  int series_terms = 40;        // odd terms of the duct series
  std::string cache_dir;        // where flow_<hash>.h5 goes
  bool two_way = false;           // flow.coupling = "two-way": the beads' drag acts on the fluid (FlowCoupling.hpp)
  bool pressure_drive = false;    // flow.drive = "pressure": fixed pressure drop instead of fixed flow rate
  int coupling_resolution = 4;    // coarse coupling grid cells per neck width
  double coupling_tolerance = 0.05;  // re-solve when the beads' forcing moved by this fraction of its size

  // [drag]
  std::string voidage = "beetstra";  // beetstra | thesis | stokes
  bool self_volume = true;           // phi counts the bead's own volume
  std::string confinement = "none";  // none | faxen: drag factor of floor and ceiling
  double phi_width = 100e-6;         // Gaussian coarse-graining width for phi
  double phi_refresh = 1e-3;         // simulated time between phi updates

  // [inlet]
  double inlet_x = 0;           // centre of the insertion zone
  double inlet_length = 0;      // length of the zone along x
  double inlet_fraction = 0.2;  // volume fraction kept in the zone
  double inlet_every = 0;       // simulated time between top-ups
  int inlet_attempts = 200;     // random tries per top-up before giving up until the next
  bool prefill = false;         // the channel starts filled at inlet_fraction from the zone to the neck's exit

  // [clog]
  double clog_window = 1.0;     // no passage and no change at the neck for this long = clogged
  double pass_x = 0;            // a particle has escaped once its centre is beyond this x
  double rest_speed = 0;        // every particle slower than this (and the inlet full) = at rest
  bool rest_neck_only = false;  // clog.rest_region = "neck": only the neck's beads need be at rest
  bool continuous = false;      // clog.mode = "continuous": clear the arch after each clog and go on
  int avalanches = 10;          // continuous mode: end after this many clogs
  double backflush = 0;         // continuous mode: reverse the flow this long after a clog (0: remove the arch)
  double clear_length = 0;      // continuous mode: also remove every bead this far upstream of the neck
  double recover = 0;           // continuous mode: the next avalanche counts from this long after a clearing
  bool clear_stalled = false;   // continuous mode: also remove every bead upstream that has stopped in the flow
  double front_fraction = 0.5;  // the front has passed once the approach holds this x inlet_fraction
  double count_from = -1;       // >= 0: also count escapees from this time on (the stationary regime)
};

// Reads the channel tables into cfg.get<ChannelConfig>() (only for scenes with the "channel" module).
void read_channel_config(CaseFile& f, Config& cfg);

}  // namespace cassini
