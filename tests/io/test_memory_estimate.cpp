// The loader's memory estimate (io::memory_model) against a count by hand: element counts, mean
// edge lengths, enclosed volumes and contact partners worked out from the shapes' closed forms,
// not from the loader's own passes over the geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ccfr/io/scene_loader.hpp"

using namespace ccfr;
using namespace ccfr::io::memory_model;

namespace {

constexpr double kR = 0.01, kXi = 0.004, kDelta = 0.001;  // radius, offset, repulsion range
constexpr double kRange = kXi + kR + kDelta;              // a deformable's contact range
constexpr double kReach = 2 * kR + kXi + kDelta;          // the detection reach

std::string scene(const std::string& objects) {
  return "scene: t\ntime: {fps: 60, frames: 1}\n"
         "contact: {radius: 0.01, offset: 0.004, repulsion_range: 0.001}\n"
         "materials: {m: {density: 500}}\nobjects:\n" +
         objects;
}

const io::ObjectMemory& object(const io::MemoryEstimate& m, const std::string& name) {
  for (const auto& o : m.objects)
    if (o.name == name) return o;
  ADD_FAILURE() << "no object " << name;
  return m.objects.front();
}

/// Mean of the three edge lengths of the two triangles of an a x b rectangle, halved by a diagonal.
double rectangle_mean_edge(double a, double b) { return (a + b + std::hypot(a, b)) / 3.0; }

/// A box generator's mean edge: two triangles per face, each with two sides and the diagonal.
double box_mean_edge(double x, double y, double z) {
  return (rectangle_mean_edge(y, z) + rectangle_mean_edge(x, y) + rectangle_mean_edge(x, z)) / 3.0;
}

/// 3 V / A of an x, y, z box.
double box_radius(double x, double y, double z) { return 3.0 * x * y * z / (2.0 * (x * y + y * z + z * x)); }

double body_contact(double vertices, double rho, double partner_h) {
  const double share = std::min(1.0, kReach / (2.0 * rho));
  const double s = std::isfinite(partner_h) ? 2.0 + kReach / partner_h : 1.0;
  return vertices * share * s * s;
}

constexpr double rel = 1e-12;

}  // namespace

// A floor obstacle (1 x 0.1 x 1), a wall obstacle beside it, a rigid cube (0.1) and a 2 x 2 cloth
// grid (0.5 m): the cloth is charged its elements and self-crowding, the cube and the floor their
// elements and contact with the finest object each can touch (the cloth's 0.25 m cells are
// coarser than the cube's edges, so the floor's finest partner is the cube), the wall only
// what the floor is: two obstacles never pair.
TEST(MemoryEstimate, MatchesTheFormulaCountedByHand) {
  const auto loaded =
      io::load_scene_text(scene("  - {name: floor, kind: obstacle, shape: {type: box, size: [1, 0.1, 1]}}\n"
                                "  - {name: wall, kind: obstacle, shape: {type: box, size: [0.2, 1, 0.3]},"
                                " transform: {translate: [3, 0, 0]}}\n"
                                "  - {name: cube, kind: rigid, material: m, shape: {type: box, size: [0.1, "
                                "0.1, 0.1]}, transform: {translate: [0, 0.5, 0]}}\n"
                                "  - {name: sheet, kind: cloth, material: m, shape: {type: grid, size: "
                                "[0.5, 0.5], resolution: [2, 2]}, transform: {translate: [0, 1, 0]}}\n"),
                          "scene.yaml", ".");
  const io::MemoryEstimate& m = loaded.memory;
  ASSERT_EQ(m.objects.size(), 4u);

  const double h_floor = box_mean_edge(1, 0.1, 1), h_wall = box_mean_edge(0.2, 1, 0.3);
  const double h_cube = box_mean_edge(0.1, 0.1, 0.1), h_sheet = rectangle_mean_edge(0.25, 0.25);
  ASSERT_LT(h_cube, h_sheet);

  const auto& sheet = object(m, "sheet");
  EXPECT_NEAR(sheet.mean_edge, h_sheet, rel * h_sheet);
  const double crowd = 9 * (kRange / h_sheet) * (kRange / h_sheet);
  EXPECT_NEAR(sheet.crowd, crowd, rel * crowd);
  EXPECT_EQ(sheet.contact, 0.0);  // a deformable's pairs are its crowding
  const double sheet_bytes = kBytesPerVertex * 9 + kBytesPerFace * 8 + kBytesPerCrowdedVertex * crowd;
  EXPECT_NEAR(sheet.bytes, sheet_bytes, rel * sheet_bytes);

  const auto& cube = object(m, "cube");
  EXPECT_NEAR(cube.body_radius, box_radius(0.1, 0.1, 0.1), 1e-15);
  EXPECT_NEAR(cube.partner_edge, std::min(h_floor, std::min(h_wall, h_sheet)), 1e-15);
  const double cube_contact = body_contact(8, box_radius(0.1, 0.1, 0.1), h_sheet);
  EXPECT_NEAR(cube.contact, cube_contact, rel * cube_contact);
  const double cube_bytes = kBytesPerBodyVertex * 8 + kBytesPerBodyFace * 12 + kBytesPerContactUnit * cube_contact;
  EXPECT_NEAR(cube.bytes, cube_bytes, rel * cube_bytes);

  const auto& floor = object(m, "floor");
  EXPECT_NEAR(floor.partner_edge, h_cube, 1e-15);  // the wall is not a partner
  const double floor_contact = body_contact(8, box_radius(1, 0.1, 1), h_cube);
  EXPECT_NEAR(floor.contact, floor_contact, rel * floor_contact);
  const auto& wall = object(m, "wall");
  const double wall_contact = body_contact(8, box_radius(0.2, 1, 0.3), h_cube);
  EXPECT_NEAR(wall.contact, wall_contact, rel * wall_contact);

  const double total = kBaseBytes + sheet_bytes + cube_bytes + 2 * (kBytesPerBodyVertex * 8 + kBytesPerBodyFace * 12) +
                       kBytesPerContactUnit * (floor_contact + wall_contact);
  EXPECT_NEAR(m.total_bytes, total, rel * total);
}

// Degenerate partners: a body alone touches nothing (no contact term), two obstacles alone never
// pair, particles have no edges (one half-space each: factor 1), and an open surface (a plane
// obstacle) can be touched all over (share 1).
TEST(MemoryEstimate, LoneBodiesObstaclePairsParticlesAndOpenSurfaces) {
  auto lone = io::load_scene_text(
      scene("  - {name: cube, kind: rigid, material: m, shape: {type: box, size: [0.1, 0.1, 0.1]}}\n"), "s.yaml", ".");
  EXPECT_EQ(object(lone.memory, "cube").contact, 0.0);
  EXPECT_EQ(object(lone.memory, "cube").partner_edge, 0.0);
  EXPECT_NEAR(lone.memory.total_bytes, kBaseBytes + kBytesPerBodyVertex * 8 + kBytesPerBodyFace * 12, 1e-6);

  auto two = io::load_scene_text(
      scene("  - {name: a, kind: obstacle, shape: {type: box, size: [1, 1, 1]}}\n"
            "  - {name: b, kind: obstacle, shape: {type: box, size: [1, 1, 1]}, transform: {translate: [0, 1, 0]}}\n"),
      "s.yaml", ".");
  EXPECT_EQ(object(two.memory, "a").contact, 0.0);
  EXPECT_EQ(object(two.memory, "b").contact, 0.0);

  auto grains = io::load_scene_text(
      scene("  - {name: ground, kind: obstacle, shape: {type: plane, size: 1, resolution: 3}}\n"
            "  - {name: sand, kind: particles, material: m, shape: {type: particles, counts: [2, 2, 2], spacing: "
            "0.05}, transform: {translate: [0, 0.2, 0]}}\n"),
      "s.yaml", ".");
  const auto& ground = object(grains.memory, "ground");
  EXPECT_EQ(ground.body_radius, 0.0);  // open
  EXPECT_EQ(ground.partner_edge, std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(ground.contact, 16.0);  // 16 vertices x share 1 x factor 1
  const auto& sand = object(grains.memory, "sand");
  EXPECT_EQ(sand.vertices, 8.0);
  EXPECT_EQ(sand.mean_edge, 0.0);
  EXPECT_DOUBLE_EQ(sand.bytes, kBytesPerVertex * 8);
}
