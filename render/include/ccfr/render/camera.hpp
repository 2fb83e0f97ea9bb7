#pragma once
/// @file camera.hpp
/// Pinhole cameras: parsing `--camera`, fitting a camera to a scene's bounds, projecting points.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <limits>
#include <optional>
#include <string_view>

#include "ccfr/core/types.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::render {

/// An axis-aligned box; empty until a point is added.
struct Bounds {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return !(lo.array() <= hi.array()).all(); }
  void extend(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void extend(const Bounds& b) {
    if (b.empty()) return;
    extend(b.lo);
    extend(b.hi);
  }
  Vec3 center() const { return 0.5 * (lo + hi); }
  double diagonal() const { return empty() ? 0.0 : (hi - lo).norm(); }
};

/// Bounds of every vertex of a frame.
Bounds frame_bounds(const io::Frame& frame);

/// A pinhole camera looking from `eye` at `target`; `fov_deg` is the vertical field of view.
struct Camera {
  Vec3 eye = Vec3(0, 0, 3);
  Vec3 target = Vec3::Zero();
  Vec3 up = Vec3::UnitY();
  double fov_deg = 40.0;

  /// Orthonormal frame: right, true up, and forward (from eye towards target).
  void basis(Vec3& right, Vec3& true_up, Vec3& forward) const;
};

/// Parses "eye_x,eye_y,eye_z,target_x,target_y,target_z,fov_deg" (the `--camera` option).
/// Throws ccfr::Error naming the problem (count, non-number, eye == target, fov outside (0, 180)).
Camera parse_camera(std::string_view text, const Vec3& up = Vec3::UnitY());

/// The unit vector for an axis name "x", "y" or "z" (optionally signed, e.g. "-z").
/// Throws ccfr::Error for anything else.
Vec3 parse_axis(std::string_view text);

/// A camera that sees all of `bounds` from a three-quarter view above the front-right
/// (front = the axis after `up` in x, y, z order), as close as the field of view allows with a
/// margin of `margin` (fraction of the image). `aspect` is width / height.
Camera fit_camera(const Bounds& bounds, double aspect, const Vec3& up = Vec3::UnitY(), double fov_deg = 40.0,
                  double margin = 0.06);

/// Pixel coordinates (x right, y down, pixel centres at +0.5) of a world point in a
/// `width` by `height` image, or nothing when the point is behind the camera.
std::optional<Eigen::Vector2d> project(const Camera& camera, int width, int height, const Vec3& p);

/// World length covered by one pixel at distance `distance` from the camera.
double pixel_size_at(const Camera& camera, int height, double distance);

}  // namespace ccfr::render
