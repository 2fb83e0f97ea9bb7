#pragma once
/// @file aabb.hpp
/// Axis-aligned bounding boxes of primitives.
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

struct AABB {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());

  void expand(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void expand(const AABB& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  void inflate(double r) {
    lo.array() -= r;
    hi.array() += r;
  }
  /// Closed boxes: touching counts; a NaN coordinate overlaps nothing. The six comparisons are
  /// combined with & rather than &&: one branch instead of six, which a broad phase's box tests
  /// (about half of them pass, in no pattern a predictor learns) mispredicted.
  bool overlaps(const AABB& b) const {
    return (lo.x() <= b.hi.x()) & (b.lo.x() <= hi.x()) & (lo.y() <= b.hi.y()) & (b.lo.y() <= hi.y()) &
           (lo.z() <= b.hi.z()) & (b.lo.z() <= hi.z());
  }
  bool valid() const { return lo.allFinite() && hi.allFinite() && (lo.array() <= hi.array()).all(); }
  /// Whether b lies more than `gap` beyond this box along some axis (then every point of one is
  /// more than `gap` from every point of the other).
  bool apart(const AABB& b, double gap) const {
    return (b.lo.array() - hi.array() > gap).any() || (lo.array() - b.hi.array() > gap).any();
  }
  Vec3 center() const { return 0.5 * (lo + hi); }
  Vec3 extent() const { return hi - lo; }

  static AABB of(const Vec3& a) {
    AABB b;
    b.lo = b.hi = a;
    return b;
  }
  static AABB of(const Vec3& a, const Vec3& c) {
    AABB b;
    b.lo = a.cwiseMin(c);
    b.hi = a.cwiseMax(c);
    return b;
  }
  static AABB of(const Vec3& a, const Vec3& c, const Vec3& d) {
    AABB b = of(a, c);
    b.expand(d);
    return b;
  }
};

/// Whether every box of `a` is apart from every box of `b` by more than `gap` (AABB::apart), the
/// same answer as testing all |a| x |b| pairs: only the boxes within `gap` of the other set's bounding
/// box can meet it, and those of `b`, sorted by lower x, are searched per box of `a` in the window
/// its x extent allows. `scratch` (reused) holds b's boxes that pass.
bool all_apart(std::span<const AABB> a, std::span<const AABB> b, double gap, std::vector<AABB>& scratch);

}  // namespace ccfr
