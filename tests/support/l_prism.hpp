#pragma once
// An asymmetric, non-convex closed surface for the rigid-body mass tests (tests/geometry, tests/io).
#include <array>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr::test {

struct LPrism {
  Positions v;
  std::vector<Vec3i> f;
};

/// The L-shaped prism {x<2,y<1 or x<1,y<3} x [0, depth] with `levels` rings of the L's six corners
/// (z = 0, ..., depth; two rings: corners only), outward faces; centre of mass (0.75, 1.25, depth/2).
inline LPrism l_prism(double depth, int levels = 3) {
  const std::array<Vec3, 6> p{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 3, 0), Vec3(0, 3, 0)};
  LPrism m;
  for (int l = 0; l < levels; ++l)
    for (const Vec3& q : p) m.v.push_back(q + Vec3(0, 0, depth * l / (levels - 1)));
  const Index top = 6 * (levels - 1);
  // A fan from the reflex corner 3 (the L is star-shaped about it).
  for (Index k : {4, 5, 0, 1}) {
    const Index next = k == 5 ? 0 : k + 1;
    m.f.push_back(Vec3i(top + 3, top + k, top + next));  // top, +z
    m.f.push_back(Vec3i(3, next, k));                    // bottom, -z
  }
  for (Index l = 0; l + 1 < levels; ++l)
    for (Index i = 0; i < 6; ++i) {
      const Index j = (i + 1) % 6, a = 6 * l, b = 6 * (l + 1);
      m.f.push_back(Vec3i(a + i, a + j, b + j));
      m.f.push_back(Vec3i(a + i, b + j, b + i));
    }
  return m;
}

}  // namespace ccfr::test
