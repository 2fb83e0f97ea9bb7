// The loader's memory estimate (io::memory_model) against a count by hand: shapes whose every
// vertex has edges of one length (an equilateral triangle, a regular octahedron, a regular
// tetrahedron), so each term follows from closed forms (areas, 3 volume / area, the reach), not
// from the loader's own passes over the geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "ccfr/io/scene_loader.hpp"

using namespace ccfr;
using namespace ccfr::io::memory_model;

namespace {

constexpr double kR = 0.01, kXi = 0.004, kDelta = 0.001;  // radius, offset, repulsion range
constexpr double kReach = 2 * kR + kXi + kDelta;          // D: the detection reach
constexpr double kL = 0.02;                               // the triangle's side
constexpr double kA = 0.1;                                // the octahedron's edge
constexpr double rel = 1e-12;

const double kSqrt3 = std::sqrt(3.0);

std::string header() {
  return "scene: t\ntime: {fps: 60, frames: 1}\n"
         "contact: {radius: 0.01, offset: 0.004, repulsion_range: 0.001}\n"
         "materials: {m: {density: 500}}\nobjects:\n";
}

io::MeshArrays triangle(double side, double y) {
  io::MeshArrays m;
  m.vertices = {Vec3(0, y, 0), Vec3(side, y, 0), Vec3(side / 2, y, side * std::sqrt(3.0) / 2)};
  m.faces = {Vec3i(0, 2, 1)};
  return m;
}

/// A regular octahedron of edge `a`, centred at height `y`, outward-facing triangles.
io::MeshArrays octahedron(double a, double y) {
  const double c = a / std::sqrt(2.0);
  io::MeshArrays m;
  m.vertices = {Vec3(c, y, 0), Vec3(-c, y, 0), Vec3(0, y + c, 0), Vec3(0, y - c, 0), Vec3(0, y, c), Vec3(0, y, -c)};
  m.faces = {Vec3i(0, 2, 4), Vec3i(2, 1, 4), Vec3i(1, 3, 4), Vec3i(3, 0, 4),
             Vec3i(2, 0, 5), Vec3i(1, 2, 5), Vec3i(3, 1, 5), Vec3i(0, 3, 5)};
  return m;
}

const io::ObjectMemory& object(const io::MemoryEstimate& m, const std::string& name) {
  for (const auto& o : m.objects)
    if (o.name == name) return o;
  ADD_FAILURE() << "no object " << name;
  return m.objects.front();
}

/// F = ((h_i + h_j) / 2 + D)² / h_j²: half-spaces per vertex of i per unit, against j.
double per_vertex(double hi, double hj) { return std::pow((hi + hj) / 2 + kReach, 2) / (hj * hj); }

}  // namespace

// A shell triangle above a rigid octahedron above an open floor plane. The triangle (3 vertices,
// h = L) pays its elements, its fine self-contact 3 (D / L)² and contact with both others (each
// larger than it: share 1, two layers); the octahedron pays body elements, contact with the
// triangle over the triangle's share of its area, and its patch on the floor: a cap 2π D ρ with
// ρ = 3 volume / area = a / √6 (the floor, open, counts as a plane); the floor, an obstacle,
// holds no half-space and pays its elements only.
TEST(MemoryEstimate, MatchesTheFormulaCountedByHand) {
  const std::map<std::string, io::MeshArrays> arrays{{"tri", triangle(kL, 1.0)}, {"oct", octahedron(kA, 0.5)}};
  const auto loaded = io::load_scene_arrays(header() +
                                                "  - {name: floor, kind: obstacle, shape: {type: plane, size: 1, "
                                                "resolution: 1}}\n"
                                                "  - {name: ball, kind: rigid, material: m, shape: {type: mesh, "
                                                "path: oct}}\n"
                                                "  - {name: sheet, kind: shell, material: m, shape: {type: mesh, "
                                                "path: tri}}\n",
                                            "scene.yaml", arrays);
  const io::MemoryEstimate& m = loaded.memory;
  ASSERT_EQ(m.objects.size(), 3u);

  const double h_floor = (2 + std::sqrt(2.0)) / 3;  // two sides and a diagonal of a unit square
  const double area_tri = kSqrt3 / 4 * kL * kL, area_oct = 2 * kSqrt3 * kA * kA;
  const double rho_oct = kA / std::sqrt(6.0);

  const auto& sheet = object(m, "sheet");
  EXPECT_NEAR(sheet.mean_edge, kL, rel * kL);
  EXPECT_NEAR(sheet.area, area_tri, rel * area_tri);
  const double fine = 3 * std::pow(kReach / kL, 2);
  EXPECT_NEAR(sheet.fine_contact, fine, rel * fine);
  EXPECT_EQ(sheet.driven_contact, 0.0);
  const double sheet_cross = 3 * (per_vertex(kL, kA) + per_vertex(kL, h_floor));
  EXPECT_NEAR(sheet.cross_contact, sheet_cross, rel * sheet_cross);
  EXPECT_EQ(sheet.patch_contact, 0.0);
  const double sheet_bytes =
      kBytesPerVertex * 3 + kBytesPerFace * 1 + kBytesPerFineUnit * fine + kBytesPerCrossUnit * sheet_cross;
  EXPECT_NEAR(sheet.bytes, sheet_bytes, rel * sheet_bytes);

  const auto& ball = object(m, "ball");
  EXPECT_NEAR(ball.body_radius, rho_oct, rel * rho_oct);
  EXPECT_NEAR(ball.area, area_oct, rel * area_oct);
  const double ball_cross = 6 * (area_tri / area_oct) * per_vertex(kA, kL);
  EXPECT_NEAR(ball.cross_contact, ball_cross, rel * ball_cross);
  const double cap = 2 * std::numbers::pi * kReach * rho_oct;
  ASSERT_LT(cap, area_oct);
  const double patch = cap / (kA * kA) * per_vertex(kA, h_floor);
  EXPECT_NEAR(ball.patch_contact, patch, rel * patch);
  EXPECT_EQ(ball.fine_contact, 0.0);  // a body never pairs with itself
  const double ball_bytes =
      kBytesPerBodyVertex * 6 + kBytesPerBodyFace * 8 + kBytesPerCrossUnit * ball_cross + kBytesPerPatchUnit * patch;
  EXPECT_NEAR(ball.bytes, ball_bytes, rel * ball_bytes);

  const auto& floor = object(m, "floor");
  EXPECT_EQ(floor.cross_contact + floor.patch_contact + floor.fine_contact, 0.0);
  const double floor_bytes = kBytesPerBodyVertex * 4 + kBytesPerBodyFace * 2;
  EXPECT_NEAR(floor.bytes, floor_bytes, rel * floor_bytes);
  EXPECT_NEAR(m.total_bytes, kBaseBytes + sheet_bytes + ball_bytes + floor_bytes, rel * m.total_bytes);
}

// Degenerate partners and limits: a body alone touches nothing; two obstacles never pair;
// particles have no edges (F = 1 against them, and their own h is 0); a sheet among many layers
// is charged two (its two sides), scaled from the shares it would otherwise sum.
TEST(MemoryEstimate, LoneBodiesObstaclePairsParticlesAndLayers) {
  const std::map<std::string, io::MeshArrays> arrays{{"oct", octahedron(kA, 0.5)}};
  auto lone = io::load_scene_arrays(
      header() + "  - {name: ball, kind: rigid, material: m, shape: {type: mesh, path: oct}}\n", "s.yaml", arrays);
  EXPECT_EQ(object(lone.memory, "ball").cross_contact + object(lone.memory, "ball").patch_contact, 0.0);
  EXPECT_NEAR(lone.memory.total_bytes, kBaseBytes + kBytesPerBodyVertex * 6 + kBytesPerBodyFace * 8, 1e-6);

  auto two = io::load_scene_arrays(header() +
                                       "  - {name: a, kind: obstacle, shape: {type: mesh, path: oct}}\n"
                                       "  - {name: b, kind: obstacle, shape: {type: mesh, path: oct}, transform: "
                                       "{translate: [0, 1, 0]}}\n",
                                   "s.yaml", arrays);
  EXPECT_NEAR(two.memory.total_bytes, kBaseBytes + 2 * (kBytesPerBodyVertex * 6 + kBytesPerBodyFace * 8), 1e-6);

  // Particles against a rigid octahedron: the octahedron holds F = 1 per particle contact over a
  // share 1 (particles have no area), each particle F against the octahedron's surface.
  auto grains = io::load_scene_arrays(header() +
                                          "  - {name: ball, kind: rigid, material: m, shape: {type: mesh, path: oct}}\n"
                                          "  - {name: sand, kind: particles, material: m, shape: {type: particles, "
                                          "counts: [2, 2, 2], spacing: 0.05}, transform: {translate: [0, 1, 0]}}\n",
                                      "s.yaml", arrays);
  const auto& sand = object(grains.memory, "sand");
  EXPECT_EQ(sand.mean_edge, 0.0);
  EXPECT_EQ(sand.fine_contact, 0.0);
  const double sand_cross = 8 * std::pow(kA / 2 + kReach, 2) / (kA * kA);
  EXPECT_NEAR(sand.cross_contact, sand_cross, rel * sand_cross);
  EXPECT_NEAR(object(grains.memory, "ball").cross_contact, 6.0, rel);

  // Equal triangles stacked: each has every other as a partner of share 1. Layers kept ξ apart fit
  // floor(D / ξ) = 6 per side here, the k-th holding (L + √(D² − (k ξ)²))² / L² primitives, so a
  // sheet is charged at most cap = 2 Σ_k that / the first's: all three partners of a stack of four
  // (cap 5.7, n limited to the 3 other sheets), 9.17 of the eleven of a stack of twelve.
  const auto stack_of = [&](int count, const std::string& head = header(), double spacing = 0.01) {
    std::map<std::string, io::MeshArrays> stack;
    std::string yaml = head;
    for (int k = 0; k < count; ++k) {
      const std::string n = "t" + std::to_string(k);
      stack[n] = triangle(kL, spacing * k);
      yaml += "  - {name: " + n + ", kind: cloth, material: m, shape: {type: mesh, path: " + n + "}}\n";
    }
    return io::load_scene_arrays(yaml, "s.yaml", stack);
  };
  const auto cap = [](int layers_per_side) {
    const auto within = [](int k) { return std::pow(kL + std::sqrt(kReach * kReach - std::pow(k * kXi, 2)), 2); };
    double sum = 0;
    for (int k = 1; k <= layers_per_side; ++k) sum += within(k);
    return 2 * sum / within(1);
  };
  ASSERT_EQ(std::floor(kReach / kXi), 6.0);
  EXPECT_NEAR(cap(6), 9.17, 0.01);  // by hand: 2 (1.996 + 1.908 + 1.758 + 1.537 + 1.225 + 0.729) / 1.996
  const auto four = stack_of(4), twelve = stack_of(12);
  ASSERT_GT(cap(3), 3.0);
  const double three_partners = 3 * 3 * per_vertex(kL, kL), capped = 3 * cap(6) * per_vertex(kL, kL);
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(object(four.memory, "t" + std::to_string(k)).cross_contact, three_partners, rel * three_partners);
  for (int k = 0; k < 12; ++k)
    EXPECT_NEAR(object(twelve.memory, "t" + std::to_string(k)).cross_contact, capped, rel * capped);

  // With D < 2ξ only the nearest layer on each side fits: two, as before the stack model.
  auto near_header = header();
  near_header.replace(near_header.find("offset: 0.004"), 13, "offset: 0.025");
  const auto two_sided = stack_of(4, near_header, 0.05);
  const double reach25 = 2 * kR + 0.025 + kDelta;  // D = 0.046 < 2 ξ
  const double two_layers = 3 * 2 * std::pow(kL + reach25, 2) / (kL * kL);
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(object(two_sided.memory, "t" + std::to_string(k)).cross_contact, two_layers, rel * two_layers);
}

// A sheet whose pins are moved by a script is charged the driven self-contact (1 + D / h)² per
// vertex on top of its fine term; the same sheet with still pins is not.
TEST(MemoryEstimate, ScriptedPinsChargeTheWoundSheet) {
  const std::map<std::string, io::MeshArrays> arrays{{"tri", triangle(kL, 1.0)}};
  const std::string still = header() +
                            "  - {name: sheet, kind: cloth, material: m, shape: {type: mesh, path: tri}, pins: "
                            "[{indices: [0]}]}\n";
  const std::string moved = header() +
                            "  - {name: sheet, kind: cloth, material: m, shape: {type: mesh, path: tri}, pins: "
                            "[{indices: [0], motion: {velocity: [0.1, 0, 0]}}]}\n";
  const auto a = io::load_scene_arrays(still, "s.yaml", arrays), b = io::load_scene_arrays(moved, "s.yaml", arrays);
  EXPECT_EQ(object(a.memory, "sheet").driven_contact, 0.0);
  const double driven = 3 * std::pow(1 + kReach / kL, 2);
  EXPECT_NEAR(object(b.memory, "sheet").driven_contact, driven, rel * driven);
  EXPECT_NEAR(b.memory.total_bytes - a.memory.total_bytes, kBytesPerDrivenUnit * driven, 1e-6);
}

// A tet solid collides through its boundary: a single regular tetrahedron's four faces, edge s,
// give h = s, area √3 s², and 4 vertices that collide; its fine units are 4 (D / s)².
TEST(MemoryEstimate, TetSolidsAreChargedByTheirBoundary) {
  const double s = 0.05;
  io::MeshArrays t;
  t.vertices = {Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s / 2, 0, s * kSqrt3 / 2),
                Vec3(s / 2, s * std::sqrt(2.0 / 3.0), s * kSqrt3 / 6)};
  t.tets = {Vec4i(0, 1, 3, 2)};
  if ((t.vertices[1] - t.vertices[0]).cross(t.vertices[3] - t.vertices[0]).dot(t.vertices[2] - t.vertices[0]) < 0)
    t.tets = {Vec4i(0, 1, 2, 3)};
  const auto loaded = io::load_scene_arrays(
      header() + "  - {name: solid, kind: tet_solid, material: m, shape: {type: mesh, path: tet}}\n", "s.yaml",
      {{"tet", t}});
  const auto& o = object(loaded.memory, "solid");
  EXPECT_EQ(o.faces, 4.0);
  EXPECT_NEAR(o.mean_edge, s, rel * s);
  EXPECT_NEAR(o.area, kSqrt3 * s * s, rel * s * s);
  const double fine = 4 * std::pow(kReach / s, 2);
  EXPECT_NEAR(o.fine_contact, fine, rel * fine);
}

// A vertex pairs with at most every primitive of its object (its 3 vertices, 3 edges and 1 face
// here), however short its edges: a 0.1 µm triangle's (D / L)² = 6e10 units per vertex (a tetgen
// fill's 7 nm edges asked 1.7 PB of the triceratops) are capped at 7.
TEST(MemoryEstimate, EachVertexTermIsCappedByTheObjectsPrimitives) {
  const std::map<std::string, io::MeshArrays> arrays{{"tri", triangle(1e-7, 1.0)}};
  const std::string moved = header() +
                            "  - {name: sheet, kind: cloth, material: m, shape: {type: mesh, path: tri}, pins: "
                            "[{indices: [0], motion: {velocity: [0.1, 0, 0]}}]}\n";
  const auto s = io::load_scene_arrays(moved, "s.yaml", arrays);
  EXPECT_EQ(object(s.memory, "sheet").fine_contact, 3 * 7.0);
  EXPECT_EQ(object(s.memory, "sheet").driven_contact, 3 * 7.0);
  EXPECT_LT(s.memory.total_bytes, kBaseBytes + 1e6);
}

// A sheet moved by scripted pins is bunched against what holds it back (a napkin pulled through
// a ring): its share of a smaller partner's area grows by the layers a stack packs within D per
// side, sum_k (h + sqrt(D² - (k ξ)²))² / (h + sqrt(D² - ξ²))², k = 1 .. floor(D / ξ); a sheet at
// rest keeps the plain share A_j / A_i.
TEST(MemoryEstimate, ADrivenSheetBunchesAgainstWhatHoldsIt) {
  const double side = 1.0;  // the sheet: an equilateral triangle far larger than the octahedron
  const std::map<std::string, io::MeshArrays> arrays{{"tri", triangle(side, 1.0)}, {"oct", octahedron(kA, 0.0)}};
  const std::string obstacle = "  - {name: oct, kind: obstacle, shape: {type: mesh, path: oct}}\n";
  const std::string sheet =
      "  - {name: sheet, kind: cloth, material: m, shape: {type: mesh, path: tri}, pins: [{indices: [0]";
  const auto still = io::load_scene_arrays(header() + obstacle + sheet + "}]}\n", "s.yaml", arrays);
  const auto moved =
      io::load_scene_arrays(header() + obstacle + sheet + ", motion: {velocity: [0.1, 0, 0]}}]}\n", "s.yaml", arrays);
  const double share = 2 * kSqrt3 * kA * kA / (kSqrt3 / 4 * side * side);
  const auto layer = [&](int k) { return std::pow(side + std::sqrt(kReach * kReach - k * kXi * k * kXi), 2); };
  double bunch = 0;
  for (int k = 1; k <= static_cast<int>(std::floor(kReach / kXi)); ++k) bunch += layer(k) / layer(1);
  ASSERT_GT(bunch * share, share);
  ASSERT_LT(bunch * share, 1.0);
  const double f = per_vertex(side, kA);
  EXPECT_NEAR(object(still.memory, "sheet").cross_contact, 3 * share * f, rel * 3 * share * f);
  EXPECT_NEAR(object(moved.memory, "sheet").cross_contact, 3 * bunch * share * f, rel * 3 * bunch * share * f);
}

// A surface's thin parts pair across themselves at rest (a scan's fingers and ears, a folded
// sheet): two equilateral triangles of side L, a gap t apart and facing each other, each vertex
// within D of all three across (√(L² + t²) < D), add 2 · 3 · 3 facing pairs, over the π D² · 2 /
// (√3 h²) / (D / h)² = 2π / √3 vertices of one fine unit. The same two triangles facing one way
// (a stack, not a fold) add nothing.
TEST(MemoryEstimate, AThinPartPairsAcrossItself) {
  const double t = 0.005;
  ASSERT_LT(std::hypot(kL, t), kReach);
  auto pair_of = [&](bool facing) {
    io::MeshArrays m = triangle(kL, 0.0), top = triangle(kL, t);
    m.vertices.insert(m.vertices.end(), top.vertices.begin(), top.vertices.end());
    m.faces.push_back(facing ? Vec3i(3, 4, 5) : Vec3i(3, 5, 4));
    return io::load_scene_arrays(
        header() + "  - {name: sheet, kind: cloth, material: m, shape: {type: mesh, path: two}}\n", "s.yaml",
        {{"two", m}});
  };
  const double flat = 6 * std::pow(kReach / kL, 2);
  const double across = 2 * 3 * 3 / (2 * std::numbers::pi / kSqrt3);
  EXPECT_NEAR(object(pair_of(false).memory, "sheet").fine_contact, flat, rel * flat);
  EXPECT_NEAR(object(pair_of(true).memory, "sheet").fine_contact, flat + across, rel * (flat + across));
}
