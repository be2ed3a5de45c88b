#pragma once
// One 3-vector type for the whole code: Eigen's fixed-size vector (no heap, fully inlined).
#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

namespace cassini {
using Vec3 = Eigen::Vector3d;
}
