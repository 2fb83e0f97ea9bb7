// Mass properties of closed triangle meshes against closed forms and brute-force voxel integration,
// and the vertex masses (plus core) that carry them.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "l_prism.hpp"

namespace ccfr {
namespace {

using Mat3 = Eigen::Matrix3d;

struct Mesh {
  Positions v;
  std::vector<Vec3i> f;
};

Mesh from(const gen::TriMesh& m) { return {m.v, m.f}; }

void move(Mesh& m, const Mat3& r, const Vec3& t) {
  for (Vec3& x : m.v) x = r * x + t;
}

Mat3 some_rotation() { return Eigen::AngleAxisd(0.7, Vec3(1, 2, -0.5).normalized()).toRotationMatrix(); }

Mesh l_prism(double depth, int levels = 3) {
  auto m = test::l_prism(depth, levels);
  return {m.v, m.f};
}

/// Volume, centroid and second moment of the L prism by the midpoint rule on voxels of size h.
SolidMassProperties l_prism_voxels(double depth, double h) {
  double vol = 0.0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  const int nx = static_cast<int>(std::lround(2 / h)), ny = static_cast<int>(std::lround(3 / h)),
            nz = static_cast<int>(std::lround(depth / h));
  const double cell = h * h * h;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      const double x = (i + 0.5) * h, y = (j + 0.5) * h;
      if (!((x < 2 && y < 1) || (x < 1 && y < 3))) continue;
      for (int k = 0; k < nz; ++k) {
        const Vec3 p(x, y, (k + 0.5) * h);
        vol += cell;
        first += cell * p;
        // ∫ over the cube of x xᵀ = cell (p pᵀ + h²/12 1): exact per voxel.
        second += cell * (p * p.transpose() + h * h / 12.0 * Mat3::Identity());
      }
    }
  SolidMassProperties s;
  s.volume = vol;
  s.centroid = first / vol;
  s.second_moment = second - vol * s.centroid * s.centroid.transpose();
  return s;
}

/// Mass, centre and second moment about `c` of the vertex masses plus the core at c.
void expect_carried(const Mesh& m, const RigidVertexMasses& w, double rho, const SolidMassProperties& p, double tol) {
  double total = w.core;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  for (size_t i = 0; i < m.v.size(); ++i) {
    ASSERT_GE(w.vertex[i], 0.0) << i;
    total += w.vertex[i];
    const Vec3 q = m.v[i] - p.centroid;
    first += w.vertex[i] * q;
    second += w.vertex[i] * q * q.transpose();
  }
  const double mass = rho * p.volume;
  const double len = std::sqrt(p.second_moment.trace() / p.volume);
  EXPECT_NEAR(total, mass, tol * mass);
  EXPECT_LT(first.norm(), tol * mass * len);
  EXPECT_LT((second - rho * p.second_moment).norm(), tol * mass * len * len);
}

TEST(SolidMassProperties, OffCentreRotatedBoxMatchesClosedForm) {
  const Vec3 size(0.4, 1.3, 2.9);
  Mesh m = from(gen::box(size));
  const Mat3 r = some_rotation();
  const Vec3 t(3.0, -2.0, 7.5);
  move(m, r, t);
  const SolidMassProperties p = solid_mass_properties(m.v, m.f);
  const double vol = size.prod();
  EXPECT_NEAR(p.volume, vol, 1e-12 * vol);
  EXPECT_FALSE(p.inverted);
  EXPECT_LT((p.centroid - t).norm(), 1e-12 * t.norm());
  const Mat3 s = r * (vol / 12.0 * size.cwiseProduct(size)).asDiagonal() * r.transpose();
  EXPECT_LT((p.second_moment - s).norm(), 1e-11 * s.norm());
  // Inertia: I_xx = M (b² + c²) / 12 in the box frame.
  const double rho = 7.0;
  const Mat3 i_box = r.transpose() * p.inertia(rho) * r;
  EXPECT_NEAR(i_box(0, 0), rho * vol * (size.y() * size.y() + size.z() * size.z()) / 12.0, 1e-10);
  EXPECT_NEAR(i_box(2, 2), rho * vol * (size.x() * size.x() + size.y() * size.y()) / 12.0, 1e-10);
  EXPECT_NEAR(i_box(0, 1), 0.0, 1e-10);
}

TEST(SolidMassProperties, InwardWindingGivesTheSameSolid) {
  Mesh m = from(gen::box(Vec3(1, 2, 3)));
  move(m, Mat3::Identity(), Vec3(1, 1, 1));
  const SolidMassProperties out = solid_mass_properties(m.v, m.f);
  for (Vec3i& f : m.f) std::swap(f[1], f[2]);
  const SolidMassProperties in = solid_mass_properties(m.v, m.f);
  EXPECT_TRUE(in.inverted);
  EXPECT_NEAR(in.volume, 6.0, 1e-12);
  EXPECT_LT((in.centroid - out.centroid).norm(), 1e-12);
  EXPECT_LT((in.second_moment - out.second_moment).norm(), 1e-12);
}

TEST(SolidMassProperties, IcosphereMatchesItsPolyhedralVolumeAndSymmetry) {
  for (int level : {0, 1, 2}) {
    const double radius = 0.8;
    Mesh m = from(gen::sphere(radius, level));
    const Vec3 t(-1.0, 0.25, 4.0);
    move(m, Mat3::Identity(), t);
    // Independent: a sum of pyramids from the centre, (1/3) area × height of every face.
    double pyramids = 0.0, inradius = radius;
    for (const Vec3i& f : m.f) {
      const Vec3 a = m.v[f[0]] - t, b = m.v[f[1]] - t, c = m.v[f[2]] - t;
      const Vec3 n = (b - a).cross(c - a);
      const double height = n.normalized().dot(a);
      pyramids += n.norm() / 2.0 * height / 3.0;
      inradius = std::min(inradius, height);
    }
    const SolidMassProperties p = solid_mass_properties(m.v, m.f);
    EXPECT_NEAR(p.volume, pyramids, 1e-12 * pyramids) << level;
    EXPECT_LT((p.centroid - t).norm(), 1e-12) << level;
    // Icosahedral symmetry makes the second moment isotropic; per unit mass it lies between the
    // balls of the in- and circumradius (tr S / V = 3/5 r² for a ball).
    const double s = p.second_moment.trace() / 3.0;
    EXPECT_LT((p.second_moment - s * Mat3::Identity()).norm(), 1e-12 * s) << level;
    EXPECT_GT(3.0 * s / p.volume, 0.6 * inradius * inradius) << level;
    EXPECT_LT(3.0 * s / p.volume, 0.6 * radius * radius) << level;
  }
}

TEST(SolidMassProperties, NonConvexLPrismMatchesVoxelIntegration) {
  const double depth = 0.5;
  Mesh m = l_prism(depth);
  const SolidMassProperties local = solid_mass_properties(m.v, m.f);
  const SolidMassProperties voxels = l_prism_voxels(depth, 0.02);
  // The voxels tile the L exactly, and each voxel's moments are exact: agreement to round-off.
  EXPECT_NEAR(local.volume, 2.0, 1e-12);  // area 4 (two 2x1 rectangles) x depth 0.5
  EXPECT_NEAR(voxels.volume, 2.0, 1e-9);
  EXPECT_LT((local.centroid - voxels.centroid).norm(), 1e-9);
  EXPECT_LT((local.second_moment - voxels.second_moment).norm(), 1e-8 * voxels.second_moment.norm());
  EXPECT_LT((local.centroid - Vec3(0.75, 1.25, 0.25)).norm(), 1e-12);  // ((1, ½) + (½, 2)) / 2 in x, y
  // Moved off-centre and rotated: the moments follow.
  const Mat3 r = some_rotation();
  const Vec3 t(-4, 2, 9);
  move(m, r, t);
  const SolidMassProperties world = solid_mass_properties(m.v, m.f);
  EXPECT_NEAR(world.volume, 2.0, 1e-11);
  EXPECT_LT((world.centroid - (r * voxels.centroid + t)).norm(), 1e-9);
  EXPECT_LT((world.second_moment - r * voxels.second_moment * r.transpose()).norm(), 1e-8);
}

TEST(SolidMassProperties, FlatAndOpenSurfacesHaveNoVolume) {
  // A closed but flat surface (two squares glued at the rim, different diagonals).
  const Positions v{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  const std::vector<Vec3i> f{Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(1, 0, 3), Vec3i(1, 3, 2)};
  EXPECT_EQ(solid_mass_properties(v, f).volume, 0.0);
  EXPECT_EQ(solid_mass_properties(v, {}).volume, 0.0);
}

TEST(RigidVertexMasses, TetrahedronNeedsFourFifthsInTheCore) {
  // A solid tet's second moment is V/20 Σ qᵢqᵢᵀ about its centroid: masses M/20 on the vertices and
  // 4M/5 at the centroid carry it, and nothing else does (10 equations, 5 unknowns).
  Mesh m;
  m.v = {Vec3(0, 0, 0), Vec3(1.5, 0, 0), Vec3(0.2, 1, 0), Vec3(0.3, 0.4, 2)};
  m.f = {Vec3i(0, 2, 1), Vec3i(0, 1, 3), Vec3i(1, 2, 3), Vec3i(0, 3, 2)};
  const SolidMassProperties p = solid_mass_properties(m.v, m.f);
  EXPECT_NEAR(p.volume, 0.5, 1e-12);  // |det| / 6 = 1.5 · 1 · 2 / 6
  const double rho = 3.0, mass = rho * 0.5;
  const RigidVertexMasses w = rigid_vertex_masses(m.v, m.f, rho, p);
  ASSERT_TRUE(w.exact);
  for (double mi : w.vertex) EXPECT_NEAR(mi, mass / 20.0, 1e-10);
  EXPECT_NEAR(w.core, 0.8 * mass, 1e-10);
  expect_carried(m, w, rho, p, 1e-9);
}

TEST(RigidVertexMasses, BoxSphereAndLCarryTheSolidExactly) {
  const Mat3 r = some_rotation();
  std::vector<std::pair<std::string, Mesh>> cases;
  cases.emplace_back("box", from(gen::box(Vec3(0.4, 1.3, 2.9))));
  cases.emplace_back("icosphere", from(gen::sphere(0.5, 2)));
  cases.emplace_back("L", l_prism(0.5));
  for (auto& [name, m] : cases) {
    move(m, r, Vec3(2, -1, 3));
    const SolidMassProperties p = solid_mass_properties(m.v, m.f);
    const RigidVertexMasses w = rigid_vertex_masses(m.v, m.f, 900.0, p);
    ASSERT_TRUE(w.exact) << name;
    EXPECT_GT(w.core, 0.0) << name;
    EXPECT_EQ(w.inertia_error, 0.0) << name;
    expect_carried(m, w, 900.0, p, 1e-9);
  }
  // The L with its two corner rings only: every vertex at z = ±d/2 fixes Σm = M/3 (as for the box),
  // and six corners per ring cannot then give the L's x-y moments: the fallback, centre exact.
  const Mesh rings = l_prism(0.5, 2);
  const SolidMassProperties pc = solid_mass_properties(rings.v, rings.f);
  const RigidVertexMasses wc = rigid_vertex_masses(rings.v, rings.f, 1.0, pc);
  EXPECT_FALSE(wc.exact);
  EXPECT_EQ(wc.core, 0.0);
  EXPECT_GT(wc.inertia_error, 0.01);
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < rings.v.size(); ++i) c += wc.vertex[i] * rings.v[i];
  EXPECT_LT((c / pc.volume - pc.centroid).norm(), 1e-9);
  // The box: its corners carry a third of the mass (Σ m x² = M a²/3 with every |x| = a).
  Mesh box = from(gen::box(Vec3(1, 2, 3)));
  const SolidMassProperties p = solid_mass_properties(box.v, box.f);
  const RigidVertexMasses w = rigid_vertex_masses(box.v, box.f, 1.0, p);
  double corners = 0.0;
  for (double mi : w.vertex) corners += mi;
  EXPECT_NEAR(corners, 6.0 / 3.0, 1e-9);
  EXPECT_NEAR(w.core, 6.0 * 2.0 / 3.0, 1e-9);
}

TEST(RigidVertexMasses, RimOnlyPrismFallsBackToMassAndCentre) {
  // A hexagonal prism whose caps are triangulated between rim vertices: every vertex lies on the
  // cylinder x² + z² = R² and on y = ±h, so Σm(x²+z²) = R² Σm and Σm y² = h² Σm fix Σm twice,
  // to different values: no nonnegative masses carry the solid's second moment.
  Mesh m;
  const double radius = 1.0, h = 0.9;
  for (double y : {-h, h})
    for (int k = 0; k < 6; ++k) {
      const double a = k * std::numbers::pi / 3.0;
      m.v.push_back(Vec3(radius * std::cos(a), y, radius * std::sin(a)));
    }
  for (Index k = 0; k < 6; ++k) {
    const Index j = (k + 1) % 6;
    m.f.push_back(Vec3i(k, 6 + k, 6 + j));
    m.f.push_back(Vec3i(k, 6 + j, j));
  }
  for (Index k : {1, 2, 3, 4}) {
    m.f.push_back(Vec3i(0, k, k + 1));          // bottom, -y
    m.f.push_back(Vec3i(6, 6 + k + 1, 6 + k));  // top, +y
  }
  const SolidMassProperties p = solid_mass_properties(m.v, m.f);
  ASSERT_FALSE(p.inverted);
  EXPECT_NEAR(p.volume, 1.5 * std::sqrt(3.0) * radius * radius * 2 * h, 1e-12);
  const RigidVertexMasses w = rigid_vertex_masses(m.v, m.f, 2.0, p);
  EXPECT_FALSE(w.exact);
  EXPECT_EQ(w.core, 0.0);
  EXPECT_GT(w.inertia_error, 0.05);
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < m.v.size(); ++i) {
    EXPECT_GE(w.vertex[i], 0.0);
    total += w.vertex[i];
    c += w.vertex[i] * m.v[i];
  }
  EXPECT_NEAR(total, 2.0 * p.volume, 1e-9);
  EXPECT_LT((c / total - p.centroid).norm(), 1e-9);
}

}  // namespace
}  // namespace ccfr
