#pragma once
/// @file predicates.hpp
/// Exact geometric predicates (CGAL, Exact_predicates_inexact_constructions_kernel).
#include "ccfr/core/types.hpp"

namespace ccfr::exact {

/// Sign of the orientation of (a, b, c, d): +1 if d lies on the positive side of the plane
/// through a, b, c (counter-clockwise seen from d... CGAL::orientation convention), -1 negative, 0 coplanar.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

}  // namespace ccfr::exact
