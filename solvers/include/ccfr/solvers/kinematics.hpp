#pragma once
/// @file kinematics.hpp
/// Scripted rigid motion of kinematic vertices (obstacles, pinned handles).
#include <limits>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// A rigid motion from the rest pose: rotation by `angular_velocity` (rad/s) about `axis` through
/// `center`, then translation by `velocity` (m/s), active during [start, end] and held outside.
struct Motion {
  Vec3 velocity = Vec3::Zero();
  Vec3 axis = Vec3::UnitY();
  Vec3 center = Vec3::Zero();
  double angular_velocity = 0.0;
  double start = 0.0;
  double end = std::numeric_limits<double>::infinity();

  bool moves() const { return velocity.squaredNorm() > 0.0 || angular_velocity != 0.0; }
  /// Position at time `t` of the point whose rest position is `p0`.
  Vec3 apply(const Vec3& p0, double t) const;
};

}  // namespace ccfr
