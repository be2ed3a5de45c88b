#include "physics/channel/ChannelConfig.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "physics/channel/ChannelGeometry.hpp"

namespace cassini {
namespace {

std::vector<Point2> polyline(CaseFile& f, const std::string& key) {
  std::vector<Point2> pts = f.points(key);
  if (pts.size() < 2) f.fail(key, "at least 2 points");
  for (std::size_t k = 1; k < pts.size(); ++k)
    if (!(pts[k][0] > pts[k - 1][0])) f.fail(key, "points with strictly increasing x");
  return pts;
}

}  // namespace

void read_channel_config(CaseFile& f, Config& c) {
  c.set(ChannelConfig{});
  ChannelConfig& ch = c.edit<ChannelConfig>();
  if (c.boundary[2] != Boundary::Wall) f.fail("domain.boundary", "z walls (the channel floor and ceiling)");
  if (c.boundary[1] == Boundary::Wall)
    f.fail("domain.boundary", "y \"open\": the channel's side walls are its outline, not the domain's y faces");
  const double yc = 0.5 * (c.lo[1] + c.hi[1]), half = 0.5 * (c.hi[1] - c.lo[1]);
  const double margin = c.hi[0] - c.lo[0];  // outline continues beyond the domain's x faces

  if (f.has("channel.upper") || f.has("channel.lower")) {
    ch.upper = polyline(f, "channel.upper");
    ch.lower = polyline(f, "channel.lower");
  } else {
    // The thesis's neck: straight walls at y = +-w/2 converging into a neck of width D at the
    // contraction angle (135 deg: walls at 45 deg to the axis), opening at the expansion angle.
    const double D = f.positive("channel.neck_width");
    if (D >= 2 * half) f.fail("channel.neck_width", "a width smaller than the domain's y extent");
    const double ca = f.number("channel.contraction_angle", 135.0), ea = f.number("channel.expansion_angle", 120.0);
    if (!(ca > 90 && ca < 180)) f.fail("channel.contraction_angle", "an angle in (90, 180) degrees");
    if (!(ea > 90 && ea < 180)) f.fail("channel.expansion_angle", "an angle in (90, 180) degrees");
    const double len = f.number("channel.neck_length", 0.0);
    if (len < 0) f.fail("channel.neck_length", "a length >= 0");
    const double x0 = f.number("channel.neck_x", 0.0) - 0.5 * len, x1 = x0 + len;
    const double deg = std::numbers::pi / 180, rise = half - 0.5 * D;
    const double dxc = rise / std::tan((180 - ca) * deg), dxe = rise / std::tan((180 - ea) * deg);
    std::vector<Point2> up = {{c.lo[0] - margin, half}, {x0 - dxc, half}, {x0, 0.5 * D}};
    if (len > 0) up.push_back({x1, 0.5 * D});
    up.push_back({x1 + dxe, half});
    up.push_back({c.hi[0] + margin, half});
    for (auto& p : up) {
      ch.upper.push_back({p[0], yc + p[1]});
      ch.lower.push_back({p[0], yc - p[1]});
    }
  }
  // The neck: the narrowest gap (a sharp neck is a single x).
  std::vector<double> xs;
  for (const auto& p : ch.upper) xs.push_back(p[0]);
  for (const auto& p : ch.lower) xs.push_back(p[0]);
  ch.neck_width = 1e300;
  for (double x : xs) {
    if (x < c.lo[0] || x > c.hi[0]) continue;
    const double gap = ChannelGeometry::interpolate(ch.upper, x) - ChannelGeometry::interpolate(ch.lower, x);
    if (gap < ch.neck_width - 1e-12 * half) { ch.neck_width = gap; ch.neck_x0 = ch.neck_x1 = x; }
    else if (gap < ch.neck_width + 1e-12 * half) ch.neck_x1 = std::max(ch.neck_x1, x);
  }
  if (!(ch.neck_width > 0)) f.fail("channel.upper", "an outline above channel.lower everywhere");
  if (ch.neck_width > 1e299) f.fail("channel.upper", "outline points inside the domain's x range");

  // [flow]
  const double D = ch.neck_width;
  ch.mean_velocity = f.positive("flow.mean_velocity");
  ch.viscosity = f.positive("flow.viscosity", 1.8e-3);
  ch.fluid_density = f.positive("flow.density", 1050.0);
  ch.resolution = static_cast<int>(f.integer("flow.resolution", 16));
  if (ch.resolution < 2 || ch.resolution % 2) f.fail("flow.resolution", "an even number of cells per neck width, >= 2");
  ch.solve_half_length = f.positive("flow.solve_half_length", 5 * D);
  const std::string walls = f.string("flow.walls", "embedded");
  ch.embedded_walls = walls == "embedded";
  if (walls != "embedded" && walls != "staircase")
    f.fail("flow.walls", "\"embedded\" (default: walls at their true position) or \"staircase\" (walls on cell faces)");
  ch.series_terms = static_cast<int>(f.integer("flow.series_terms", 40));
  if (ch.series_terms < 1) f.fail("flow.series_terms", "a positive number of odd terms");
  ch.cache_dir = f.string("flow.cache", "flow-cache");
  const std::string coupling = f.string("flow.coupling", "one-way");
  if (coupling != "one-way" && coupling != "two-way")
    f.fail("flow.coupling", "\"one-way\" (default: the beads do not change the flow) or \"two-way\" (Stokes-Brinkman)");
  ch.two_way = coupling == "two-way";
  const std::string drive = f.string("flow.drive", "rate");
  if (drive != "rate" && drive != "pressure")
    f.fail("flow.drive", "\"rate\" (default: fixed flow rate) or \"pressure\" (fixed pressure drop)");
  ch.pressure_drive = drive == "pressure";
  if (ch.pressure_drive && !ch.two_way)
    f.fail("flow.drive", "\"rate\": a fixed pressure drop differs from a fixed rate only when flow.coupling = \"two-way\"");
  ch.coupling_resolution = static_cast<int>(f.integer("flow.coupling_resolution", 4));
  if (ch.coupling_resolution < 1) f.fail("flow.coupling_resolution", "a positive number of cells per neck width");
  ch.coupling_tolerance = f.positive("flow.coupling_tolerance", 0.05);
  if (!ch.cache_dir.empty() && ch.cache_dir[0] != '/' && !f.directory().empty())
    ch.cache_dir = f.directory() + "/" + ch.cache_dir;
  c.module_inputs.push_back({ch.cache_dir, "flow.cache"});

  // [drag]
  ch.voidage = f.string("drag.voidage", "beetstra");
  if (ch.voidage != "beetstra" && ch.voidage != "thesis" && ch.voidage != "stokes")
    f.fail("drag.voidage", "\"beetstra\" (default, f -> 1 when dilute), \"thesis\" (2 k phi/(1-phi)^2) or \"stokes\" (f = 1)");
  ch.phi_width = f.positive("drag.width", 100e-6);
  ch.self_volume = f.boolean("drag.self_volume", true);
  ch.confinement = f.string("drag.confinement", "none");
  if (ch.confinement != "none" && ch.confinement != "faxen")
    f.fail("drag.confinement", "\"none\" (default) or \"faxen\" (Faxen's factor for a sphere midway between two walls)");
  ch.phi_refresh = f.positive("drag.refresh", 1e-3);

  // [inlet]
  ch.inlet_length = f.positive("inlet.length", D);
  ch.inlet_x = f.number("inlet.x", c.lo[0] + ch.inlet_length);
  // (Checked only where an inlet inserts: a fixed bed in a straight channel has no neck to be upstream of.)
  if (c.has_module("inlet") && (ch.inlet_x - 0.5 * ch.inlet_length < c.lo[0] || ch.inlet_x + 0.5 * ch.inlet_length > ch.neck_x0))
    f.fail("inlet.x", "an insertion zone (x +- length/2) inside the domain and upstream of the neck");
  ch.inlet_fraction = f.number("inlet.volume_fraction", 0.2);
  if (!(ch.inlet_fraction > 0 && ch.inlet_fraction < 0.5)) f.fail("inlet.volume_fraction", "a volume fraction in (0, 0.5)");
  ch.inlet_every = f.positive("inlet.every", ch.inlet_length / (4 * ch.mean_velocity));
  ch.inlet_attempts = static_cast<int>(f.integer("inlet.attempts", 200));
  if (ch.inlet_attempts < 1) f.fail("inlet.attempts", "a positive integer");
  ch.prefill = f.boolean("inlet.prefill", false);

  // [clog]
  ch.clog_window = f.positive("clog.window", 1.0);
  ch.pass_x = f.number("clog.pass_x", ch.neck_x1 + c.max_radius());
  // Under the pressure drive the flow through a clog falls but keeps bringing beads: the pile
  // never comes to rest, only the arch does, creeping as the pile's load grows: at 1e-6 of the
  // mean velocity it came 0.4-1 s after the clog, at 1e-4 within 0.03-0.8 s, with the window's
  // answer in 70 of 70 paired runs (docs/clogging.md "Ending once the arch is at rest").
  const std::string rest_region = f.string("clog.rest_region", ch.pressure_drive ? "neck" : "all");
  if (rest_region != "all" && rest_region != "neck")
    f.fail("clog.rest_region", "\"all\" (every bead at rest and the inlet full) or \"neck\" (the beads in the neck at rest)");
  ch.rest_neck_only = rest_region == "neck";
  ch.rest_speed = f.number("clog.rest_speed", (ch.rest_neck_only ? 1e-4 : 1e-6) * ch.mean_velocity);
  if (!(ch.rest_speed >= 0)) f.fail("clog.rest_speed", "a speed >= 0 (0 turns the early end at rest off)");
  if (c.has_module("clog") && (ch.pass_x < ch.neck_x1 || ch.pass_x >= c.hi[0])) f.fail("clog.pass_x", "an x between the neck's exit and the domain's end");
  const std::string mode = f.string("clog.mode", "single");
  if (mode != "single" && mode != "continuous")
    f.fail("clog.mode", "\"single\" (default: the run ends at the first clog) or \"continuous\" (the arch is removed and the flow goes on)");
  ch.continuous = mode == "continuous";
  if (!ch.continuous)  // a single run ends at its first clog: these keys would silently do nothing
    for (const char* key : {"clog.avalanches", "clog.backflush", "clog.clear_length", "clog.recover", "clog.clear_stalled"})
      if (f.has(key)) f.fail(key, std::string("no ") + key + " with clog.mode = \"single\" (it applies to clog.mode = \"continuous\")");
  ch.avalanches = static_cast<int>(f.integer("clog.avalanches", 10));
  if (ch.avalanches < 1) f.fail("clog.avalanches", "a number of clogs >= 1");
  ch.backflush = f.number("clog.backflush", 0.0);
  if (!(ch.backflush >= 0)) f.fail("clog.backflush", "a time >= 0 (s; 0 removes the arch instead)");
  ch.clear_length = f.number("clog.clear_length", 0.0);
  if (!(ch.clear_length >= 0)) f.fail("clog.clear_length", "a length >= 0 (m; 0 removes only the arch)");
  ch.recover = f.number("clog.recover", 0.0);
  if (!(ch.recover >= 0)) f.fail("clog.recover", "a time >= 0 (s)");
  ch.clear_stalled = f.boolean("clog.clear_stalled", false);
  if ((ch.clear_length > 0 || ch.recover > 0 || ch.clear_stalled) && ch.backflush > 0)
    f.fail(ch.clear_length > 0 ? "clog.clear_length" : ch.recover > 0 ? "clog.recover" : "clog.clear_stalled",
           "0 (false) with clog.backflush (a back-flush clears the clog itself)");
  ch.front_fraction = f.number("clog.front_fraction", 0.5);
  if (!(ch.front_fraction > 0 && ch.front_fraction <= 1)) f.fail("clog.front_fraction", "a fraction in (0, 1]");
  ch.count_from = f.has("clog.count_from") ? f.number("clog.count_from") : -1.0;  // -1: from the start
  if (f.has("clog.count_from") && !(ch.count_from >= 0)) f.fail("clog.count_from", "a time >= 0 (s)");
}

}  // namespace cassini
