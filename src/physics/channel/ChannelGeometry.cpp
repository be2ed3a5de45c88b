#include "physics/channel/ChannelGeometry.hpp"

#include <algorithm>
#include <cmath>

namespace cassini {

ChannelGeometry::ChannelGeometry(const ChannelConfig& c) : upper_(c.upper), lower_(c.lower) {
  add_wall(upper_, -1);  // fluid below the upper wall
  add_wall(lower_, +1);  // and above the lower one
}

double ChannelGeometry::interpolate(const std::vector<Point2>& line, double x) {
  if (x <= line.front()[0]) return line.front()[1];
  const auto it = std::lower_bound(line.begin(), line.end(), x, [](const Point2& p, double v) { return p[0] < v; });
  if (it == line.end()) return line.back()[1];
  const Point2& b = *it;
  const Point2& a = *(it - 1);
  return a[1] + (x - a[0]) / (b[0] - a[0]) * (b[1] - a[1]);
}

void ChannelGeometry::add_wall(const std::vector<Point2>& line, double side) {
  const int first = static_cast<int>(faces_.size());
  const int n = static_cast<int>(line.size()) - 1;
  for (int k = 0; k < n; ++k) {
    const double dx = line[k + 1][0] - line[k][0], dy = line[k + 1][1] - line[k][1];
    const double len = std::hypot(dx, dy), tx = dx / len, ty = dy / len;
    // Normal towards the fluid: the tangent turned by -90 deg (upper wall) or +90 deg (lower).
    const double nx = side < 0 ? ty : -ty, ny = side < 0 ? -tx : tx;
    // The outline's end segments continue beyond the domain: no end there.
    const double xmin = k == 0 ? -1e300 : line[k][0], xmax = k == n - 1 ? 1e300 : line[k + 1][0];
    faces_.push_back({line[k][0], line[k][1], tx, ty, len, nx, ny, k == 0, k == n - 1, xmin, xmax});
  }
  for (int k = 1; k < n; ++k) vertices_.push_back({line[k][0], line[k][1], first + k - 1, first + k});
}

void ChannelGeometry::face_contact(int k, double x, double y, double reach, std::vector<WallContact>& out) const {
  const Face& f = faces_[k];
  if (x < f.xmin - reach || x > f.xmax + reach) return;  // cheap reject: most faces are far
  const double px = x - f.x0, py = y - f.y0;
  const double t = px * f.tx + py * f.ty;
  if ((t < 0 && !f.open0) || (t > f.len && !f.open1)) return;  // the vertex's business
  const double s = px * f.nx + py * f.ny;
  if (s < reach && s > -reach) out.push_back({k, s, f.nx, f.ny});
}

void ChannelGeometry::vertex_contact(int k, double x, double y, double reach, std::vector<WallContact>& out) const {
  const Vertex& v = vertices_[k];
  const Face& a = faces_[v.before];
  const Face& b = faces_[v.after];
  const double px = x - v.x, py = y - v.y;
  // In the vertex's region: past the end of the face before and before the start of the next.
  if (px * a.tx + py * a.ty <= 0 || px * b.tx + py * b.ty >= 0) return;
  const double d = std::hypot(px, py);
  if (d < reach && d > 0) out.push_back({static_cast<int>(faces_.size()) + k, d, px / d, py / d});
}

std::uint64_t ChannelGeometry::near_features(double x, double y, double reach) const {
  std::uint64_t near = 0;
  const int nf = static_cast<int>(faces_.size());
  for (int k = 0; k < nf; ++k) {
    const Face& f = faces_[k];
    const double px = x - f.x0, py = y - f.y0;
    const double t = std::clamp(px * f.tx + py * f.ty, f.open0 ? -1e300 : 0.0, f.open1 ? 1e300 : f.len);
    if (std::hypot(px - t * f.tx, py - t * f.ty) < reach) near |= std::uint64_t{1} << k;
  }
  for (int k = 0; k < static_cast<int>(vertices_.size()); ++k)
    if (std::hypot(x - vertices_[k].x, y - vertices_[k].y) < reach) near |= std::uint64_t{1} << (nf + k);
  return near;
}

void ChannelGeometry::contacts(double x, double y, double reach, std::vector<WallContact>& out) const {
  const int nf = static_cast<int>(faces_.size());
  if (reach <= bin_reach_) {
    const int b = std::clamp(static_cast<int>(std::floor((x - bin_x0_) / bin_width_)), 0, static_cast<int>(bins_.size()) - 1);
    for (const int k : bins_[b]) k < nf ? face_contact(k, x, y, reach, out) : vertex_contact(k - nf, x, y, reach, out);
    return;
  }
  for (int k = 0; k < nf; ++k) face_contact(k, x, y, reach, out);
  for (int k = 0; k < static_cast<int>(vertices_.size()); ++k) vertex_contact(k, x, y, reach, out);
}

void ChannelGeometry::index(double reach, double x0, double x1) {
  // Bins one reach wide; the end bins extend to infinity. A feature is a candidate in a bin
  // when its x extent, widened by the reach, meets the bin's.
  const int n = std::max(1, static_cast<int>(std::ceil((x1 - x0) / reach)));
  bins_.assign(n, {});
  bin_x0_ = x0;
  bin_width_ = (x1 - x0) / n;
  bin_reach_ = reach;
  const int nf = static_cast<int>(faces_.size());
  for (int b = 0; b < n; ++b) {
    const double lo = b == 0 ? -1e300 : x0 + b * bin_width_, hi = b == n - 1 ? 1e300 : x0 + (b + 1) * bin_width_;
    for (int k = 0; k < nf; ++k)
      if (faces_[k].xmin - reach <= hi && faces_[k].xmax + reach >= lo) bins_[b].push_back(k);
    for (int k = 0; k < static_cast<int>(vertices_.size()); ++k)
      if (vertices_[k].x - reach <= hi && vertices_[k].x + reach >= lo) bins_[b].push_back(nf + k);
  }
}

double ChannelGeometry::clearance(double x, double y) const {
  if (!inside(x, y)) return -1;
  std::vector<WallContact> near;
  contacts(x, y, 1e300, near);
  double best = 1e300;
  for (const auto& c : near) best = std::min(best, c.distance);
  return best;
}

}  // namespace cassini
