#include "ccfr/geometry_exact/predicates.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace ccfr::exact {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  auto p = [](const Vec3& v) { return K::Point_3(v.x(), v.y(), v.z()); };
  return static_cast<int>(CGAL::orientation(p(a), p(b), p(c), p(d)));
}

}  // namespace ccfr::exact
