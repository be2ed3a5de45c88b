#pragma once
// The channel's side walls as geometry: two polylines in the xy plane, extruded over the
// channel height. Each wall is a set of features a sphere can touch: faces (segments) and
// vertical edges (interior vertices). A sphere touches a vertex only when it lies in that
// vertex's own region (beyond the ends of both adjacent segments), so a sphere is never
// pushed twice by one corner, and the force is continuous when it rolls from a face onto an
// edge. At a concave corner that region lies behind the walls: there the sphere feels both
// faces, as it should.
#include <cstdint>
#include <vector>

#include "physics/channel/ChannelConfig.hpp"

namespace cassini {

struct WallContact {
  int feature;     // index into features() (tangential-history slot)
  double distance; // centre to feature, in the xy plane
  double nx, ny;   // unit normal from the wall towards the centre
};

class ChannelGeometry {
 public:
  explicit ChannelGeometry(const ChannelConfig& c);

  // y of a polyline (x increasing) at x; constant beyond its ends.
  static double interpolate(const std::vector<Point2>& line, double x);
  double upper_y(double x) const { return interpolate(upper_, x); }
  double lower_y(double x) const { return interpolate(lower_, x); }
  bool inside(double x, double y) const { return y < upper_y(x) && y > lower_y(x); }
  // Smallest distance from (x, y) to any wall (positive inside the fluid).
  double clearance(double x, double y) const;
  int features() const { return static_cast<int>(faces_.size() + vertices_.size()); }
  // Every feature within `reach` of the centre (x, y), appended to out.
  void contacts(double x, double y, double reach, std::vector<WallContact>& out) const;
  // Feature k alone (same test as contacts()).
  void feature_contact(int k, double x, double y, double reach, std::vector<WallContact>& out) const {
    const int nf = static_cast<int>(faces_.size());
    k < nf ? face_contact(k, x, y, reach, out) : vertex_contact(k - nf, x, y, reach, out);
  }
  // Bit k set when feature k itself (the segment, or the edge's point) is within `reach` of
  // (x, y), whatever region the point lies in: a superset of what contacts() can return for
  // any point closer than reach - r0 to (x, y) at a reach r0. Faces and edges up to 64.
  std::uint64_t near_features(double x, double y, double reach) const;
  // Speeds up contacts() for reaches up to `reach`: candidate features per x bin over [x0, x1]
  // (in a straight stretch only the two side faces can be touched).
  void index(double reach, double x0, double x1);

 private:
  struct Face { double x0, y0, tx, ty, len, nx, ny; bool open0, open1; double xmin, xmax; };
  struct Vertex { double x, y; int before, after; };  // faces on either side
  void add_wall(const std::vector<Point2>& line, double side);
  void face_contact(int k, double x, double y, double reach, std::vector<WallContact>& out) const;
  void vertex_contact(int k, double x, double y, double reach, std::vector<WallContact>& out) const;
  std::vector<Point2> upper_, lower_;
  std::vector<Face> faces_;
  std::vector<Vertex> vertices_;
  std::vector<std::vector<int>> bins_;  // feature indices, ascending (the full scan's order)
  double bin_x0_ = 0, bin_width_ = 1, bin_reach_ = -1;
};

}  // namespace cassini
