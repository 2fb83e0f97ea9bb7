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

Vec3 VertexAnimation::at(Index local, double t) const {
  // Linear in time between the keys around t: the per-substep step is then the key difference
  // times the substep's share of the interval, which the automatic subdivision bounds by r.
  if (t <= times.front()) return keys.front()[local];
  if (t >= times.back()) return keys.back()[local];
  const size_t k = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  const double a = (t - times[k - 1]) / (times[k] - times[k - 1]);
  return (1.0 - a) * keys[k - 1][local] + a * keys[k][local];
}

}  // namespace ccfr
