#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/generators.hpp"

using namespace ccfr;

namespace {
double signed_volume(const Positions& v, const std::vector<Vec3i>& f) {
  double vol = 0.0;
  for (const auto& t : f) vol += v[t[0]].dot(v[t[1]].cross(v[t[2]])) / 6.0;
  return vol;
}
}  // namespace

TEST(Generators, GridCountsAreaAndNormal) {
  const auto m = gen::grid(2.0, 1.0, 4, 2);
  EXPECT_EQ(m.v.size(), 15u);
  EXPECT_EQ(m.f.size(), 16u);
  double area = 0.0;
  for (const auto& t : m.f) {
    const Vec3 n = (m.v[t[1]] - m.v[t[0]]).cross(m.v[t[2]] - m.v[t[0]]);
    EXPECT_GT(n.y(), 0.0);  // every triangle faces +y
    area += 0.5 * n.norm();
  }
  EXPECT_NEAR(area, 2.0, 1e-12);
}

TEST(Generators, ClosedMeshesEncloseTheirVolume) {
  const auto s = gen::sphere(0.5, 4);
  EXPECT_NEAR(signed_volume(s.v, s.f), 4.0 / 3.0 * std::numbers::pi * 0.125, 0.01);  // converges from below
  for (const auto& p : s.v) EXPECT_NEAR(p.norm(), 0.5, 1e-12);
  const auto b = gen::box(Vec3(1, 2, 3));
  EXPECT_NEAR(signed_volume(b.v, b.f), 6.0, 1e-12);
  const auto c = gen::cylinder(1.0, 2.0, 64, true);
  EXPECT_NEAR(signed_volume(c.v, c.f), 64 * 0.5 * std::sin(2 * std::numbers::pi / 64) * 2.0, 1e-9);  // inscribed prism
  // Open box: inward normals, so its "volume" is negative of the box minus the lid contribution.
  const auto ob = gen::open_box(Vec3(1, 1, 1));
  EXPECT_EQ(ob.f.size(), 10u);
}

TEST(Generators, TetBoxFillsItsVolumePositively) {
  const auto m = gen::tet_box(Vec3(1, 2, 0.5), Vec3i(3, 2, 2));
  EXPECT_EQ(m.t.size(), 6u * 12u);
  double vol = 0.0;
  for (const auto& t : m.t) {
    const double v6 = (m.v[t[1]] - m.v[t[0]]).cross(m.v[t[2]] - m.v[t[0]]).dot(m.v[t[3]] - m.v[t[0]]);
    EXPECT_GT(v6, 0.0);
    vol += v6 / 6.0;
  }
  EXPECT_NEAR(vol, 1.0, 1e-12);
  // A conforming mesh: the boundary is exactly the box surface (2 triangles per boundary cell face).
  const auto faces = tet_boundary(m.t);
  EXPECT_EQ(faces.size(), 2u * 2u * (3 * 2 + 3 * 2 + 2 * 2));
  EXPECT_NEAR(signed_volume(m.v, faces), 1.0, 1e-12);
}

TEST(Generators, StrandsAndParticles) {
  const auto s = gen::curly_strands(4, 10, 1.0, 0.2, 0.05, 2.0);
  ASSERT_EQ(s.lines.size(), 4u);
  for (const auto& l : s.lines) {
    ASSERT_EQ(l.size(), 10u);
    EXPECT_NEAR(s.v[l.front()].y() - s.v[l.back()].y(), 1.0, 1e-12);
  }
  const auto st = gen::straight_strands(1, 5, 2.0, 0.0);
  for (size_t i = 0; i < 5; ++i) EXPECT_NEAR(st.v[i].y(), -0.5 * i, 1e-12);
  const auto p = gen::particle_block(3, 2, 4, 0.1);
  ASSERT_EQ(p.size(), 24u);
  Vec3 mean = Vec3::Zero();
  for (const auto& q : p) mean += q;
  EXPECT_LT((mean / 24.0).norm(), 1e-12);
}

TEST(Generators, DegenerateParametersThrow) {
  EXPECT_THROW(gen::grid(1, 1, 0, 1), std::invalid_argument);
  EXPECT_THROW(gen::curly_strands(1, 1, 1, 0, 0, 0), std::invalid_argument);
  EXPECT_THROW(gen::cylinder(1, 1, 2, true), std::invalid_argument);
}

TEST(Generators, VoxelTetsAreConformingAndOctopusIsOneSolid) {
  // Two face-adjacent cells: shared face merged, boundary = 10 cell faces = 20 triangles.
  const auto two = gen::tet_voxels({{0, 0, 0}, {1, 0, 0}}, 0.5);
  EXPECT_EQ(two.v.size(), 12u);
  EXPECT_EQ(tet_boundary(two.t).size(), 20u);
  const auto o = gen::octopus(0.1, 3, 8, 5);
  double vol = 0.0;
  for (const auto& t : o.t) {
    const double v6 = (o.v[t[1]] - o.v[t[0]]).cross(o.v[t[2]] - o.v[t[0]]).dot(o.v[t[3]] - o.v[t[0]]);
    EXPECT_GT(v6, 0.0);
    vol += v6 / 6.0;
  }
  EXPECT_NEAR(vol, 0.001 * static_cast<double>(o.t.size()) / 6.0, 1e-12);  // 6 tets per 0.1^3 cell
  // Connected: a union-find over tets sharing vertices finds one component.
  std::vector<Index> parent(o.v.size());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<Index>(i);
  std::function<Index(Index)> find = [&](Index i) { return parent[i] == i ? i : parent[i] = find(parent[i]); };
  for (const auto& t : o.t)
    for (int k = 1; k < 4; ++k) parent[find(t[k])] = find(t[0]);
  const Index root = find(0);
  for (size_t i = 0; i < parent.size(); ++i) EXPECT_EQ(find(static_cast<Index>(i)), root);
  // The boundary is a closed surface enclosing the same volume.
  EXPECT_NEAR(signed_volume(o.v, tet_boundary(o.t)), vol, 1e-12);
}

TEST(Generators, CombEnclosesSpineAndTeeth) {
  const auto c = gen::comb(1.0, 0.05, 0.1, 10, 0.4, 0.02);
  EXPECT_EQ(c.v.size(), 8u * 11u);
  EXPECT_NEAR(signed_volume(c.v, c.f), 1.0 * 0.1 * 0.05 + 10 * 0.02 * 0.4 * 0.05, 1e-12);
}

TEST(Generators, CountsBeyond32BitIndicesThrowBeforeAllocating) {
  constexpr Index kMax = std::numeric_limits<Index>::max();
  // (res + 1) and the vertex count used to wrap to negative and the loops then read through null.
  EXPECT_THROW(gen::grid(1.0, 1.0, kMax, 1), std::invalid_argument);
  EXPECT_THROW(gen::grid(1.0, 1.0, 70000, 70000), std::invalid_argument);
  EXPECT_THROW(gen::tet_box(Vec3(1, 1, 1), Vec3i(kMax, 1, 1)), std::invalid_argument);
  EXPECT_THROW(gen::tet_box(Vec3(1, 1, 1), Vec3i(1000, 1000, 1000)), std::invalid_argument);  // 6e9 tets
  EXPECT_THROW(gen::particle_block(kMax, kMax, 2, 0.1), std::invalid_argument);
  EXPECT_THROW(gen::curly_strands(kMax, kMax, 1.0, 0.0, 0.0, 0.0), std::invalid_argument);
  try {
    gen::grid(1.0, 1.0, kMax, 1);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("32-bit"), std::string::npos) << e.what();
  }
}

TEST(Generators, TetBoxSizesMustBePositive) {
  EXPECT_THROW(gen::tet_box(Vec3(1, 0, 1), Vec3i(1, 1, 1)), std::invalid_argument);
  EXPECT_THROW(gen::tet_box(Vec3(-1, 1, 1), Vec3i(1, 1, 1)), std::invalid_argument);  // used to be mirrored
}
