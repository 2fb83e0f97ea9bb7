#include "ccfr/solvers/kinematics.hpp"

#include <Eigen/Geometry>
#include <algorithm>

namespace ccfr {

Vec3 Motion::apply(const Vec3& p0, double t) const {
  const double te = std::max(0.0, std::min(t, end) - start);
  if (te <= 0.0) return p0;
  Vec3 p = p0;
  if (angular_velocity != 0.0 && axis.squaredNorm() > 0.0) {
    const Eigen::AngleAxisd rot(angular_velocity * te, axis.normalized());
    p = center + rot * (p0 - center);
  }
  return p + velocity * te;
}

}  // namespace ccfr
