#pragma once
/// @file kinematics.hpp
/// Scripted rigid motion of kinematic vertices (obstacles, pinned handles).
#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// Positions of an object's vertices at increasing times (an OBJ sequence), interpolated linearly
/// between keys and held before the first and after the last.
struct VertexAnimation {
  std::vector<double> times;    ///< strictly increasing
  std::vector<Positions> keys;  ///< per time: the object's vertices, in its local order
  /// Keyframed rigid transforms instead of `keys` (non-empty rotations): at times[k] a vertex at
  /// rest position p0 is at center + rotations[k] (p0 - center) + translations[k]; between keys
  /// the rotation is slerped and the translation lerped.
  std::vector<Eigen::Quaterniond> rotations;
  std::vector<Vec3> translations;
  Vec3 center = Vec3::Zero();
  Positions rest;  ///< the object's rest positions (keyframed mode)
  /// Position of local vertex `local` at time t.
  Vec3 at(Index local, double t) const;
};

/// A rigid motion from the rest pose: rotation by `angular_velocity` (rad/s) about `axis` through
/// `center`, then translation by `velocity` (m/s), active during [start, end] and held outside.
struct Motion {
  Vec3 velocity = Vec3::Zero();
  Vec3 axis = Vec3::UnitY();
  Vec3 center = Vec3::Zero();
  double angular_velocity = 0.0;
  double start = 0.0;
  double end = std::numeric_limits<double>::infinity();

  /// Obstacles animated by a vertex sequence (docs/interop.md); replaces the rigid motion.
  std::shared_ptr<const VertexAnimation> animation;

  bool moves() const { return velocity.squaredNorm() > 0.0 || angular_velocity != 0.0 || animation; }
  /// Position at time `t` of the point whose rest position is `p0`.
  Vec3 apply(const Vec3& p0, double t) const;
};

}  // namespace ccfr
