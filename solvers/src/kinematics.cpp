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
  size_t k0 = 0, k1 = 0;
  double a = 0.0;
  if (t >= times.back()) {
    k0 = k1 = times.size() - 1;
  } else if (t > times.front()) {
    k1 = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
    k0 = k1 - 1;
    a = (t - times[k0]) / (times[k1] - times[k0]);
  }
  if (!rotations.empty()) {
    const Eigen::Quaterniond q = rotations[k0].slerp(a, rotations[k1]);
    return center + q * (rest[local] - center) + (1.0 - a) * translations[k0] + a * translations[k1];
  }
  return (1.0 - a) * keys[k0][local] + a * keys[k1][local];
}

}  // namespace ccfr
