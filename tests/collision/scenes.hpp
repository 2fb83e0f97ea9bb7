#pragma once
// Small scenes for the collision tests: cloth (flat and accordion-folded with sine ripples, free of
// self-intersections by construction), strand bundles, particles, obstacles, rigids and tet solids.
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/generators.hpp"

namespace ccfr::test {

struct TestScene {
  Topology topo;
  Positions x;
  std::vector<double> inv_mass;
};

class SceneBuilder {
 public:
  SceneBuilder& mesh(const std::string& name, ObjectKind kind, const gen::TriMesh& m, double inv_mass = 1.0) {
    b_.add_object(name, kind, static_cast<Index>(m.v.size()), m.f);
    append(m.v, inv_mass);
    return *this;
  }
  SceneBuilder& tets(const std::string& name, const gen::TetMesh& m, double inv_mass = 1.0) {
    b_.add_object(name, ObjectKind::tet_solid, static_cast<Index>(m.v.size()), {}, m.t);
    append(m.v, inv_mass);
    return *this;
  }
  SceneBuilder& strands(const std::string& name, const gen::PolylineSet& s, double inv_mass = 1.0) {
    b_.add_object(name, ObjectKind::strand, static_cast<Index>(s.v.size()), {}, {}, s.lines);
    append(s.v, inv_mass);
    return *this;
  }
  SceneBuilder& particles(const std::string& name, const Positions& p, double inv_mass = 1.0) {
    b_.add_object(name, ObjectKind::particles, static_cast<Index>(p.size()));
    append(p, inv_mass);
    return *this;
  }
  TestScene finish() {
    TestScene s;
    s.topo = b_.finish();
    s.x = std::move(x_);
    s.inv_mass = std::move(w_);
    return s;
  }

 private:
  void append(const Positions& p, double inv_mass) {
    x_.insert(x_.end(), p.begin(), p.end());
    w_.insert(w_.end(), p.size(), inv_mass);
  }
  TopologyBuilder b_;
  Positions x_;
  std::vector<double> w_;
};

/// A square sheet of side `size` with res x res cells, folded `folds` times like an accordion
/// (half-circle turns of radius `rho`, layers 2 rho apart) and rippled by sines of amplitude
/// `amp` < rho along the surface normal: the offset surface of a curve of curvature <= 1/rho
/// with |offset| < rho never intersects itself, and layers stay >= 2 (rho - amp) apart.
inline gen::TriMesh accordion_cloth(double size, Index res, int folds, double rho, double amp) {
  gen::TriMesh m = gen::grid(size, size, res, res);
  const double pi = std::numbers::pi;
  const double straight = (size - folds * pi * rho) / (folds + 1);
  for (Vec3& p : m.v) {
    const double u = p.x() + 0.5 * size, z = p.z();
    double s = u, x0 = 0.0, dir = 1.0;
    Vec3 c, t;
    for (int k = 0;; ++k) {
      if (s <= straight || k == folds) {
        c = Vec3(x0 + dir * s, 2.0 * rho * k, 0.0);
        t = Vec3(dir, 0.0, 0.0);
        break;
      }
      s -= straight;
      const double x_end = x0 + dir * straight;
      if (s <= pi * rho) {
        const double th = s / rho;
        c = Vec3(x_end + dir * rho * std::sin(th), 2.0 * rho * k + rho - rho * std::cos(th), 0.0);
        t = Vec3(dir * std::cos(th), std::sin(th), 0.0);
        break;
      }
      s -= pi * rho;
      x0 = x_end;
      dir = -dir;
    }
    const Vec3 normal(-t.y(), t.x(), 0.0);
    const double h = amp * (0.6 * std::sin(2 * pi * 3.0 * u / size + 0.3) * std::sin(2 * pi * 2.0 * z / size) +
                            0.4 * std::sin(2 * pi * 7.0 * z / size + 1.1 * u));
    p = c + h * normal + Vec3(0, 0, z);
  }
  return m;
}

/// Uniform random point in the ball of radius r.
inline Vec3 random_in_ball(std::mt19937_64& g, double r) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (;;) {
    Vec3 p(u(g), u(g), u(g));
    if (p.squaredNorm() <= 1.0) return r * p;
  }
}

/// Degenerate input for detection tests: a zero-area triangle (collinear corners) in a small sheet,
/// two parallel strand segments 1.5 cm apart and 1.2 cm above it, two coincident particles (no
/// contact normal) and a third, and an obstacle floor at rest under them.
inline TestScene degenerate_mixed_scene() {
  gen::TriMesh sheet;
  sheet.v = {Vec3(0, 0, 0), Vec3(0.02, 0, 0), Vec3(0.04, 0, 0), Vec3(0, 0, 0.02), Vec3(0.02, 0, 0.02)};
  sheet.f = {Vec3i(0, 1, 2), Vec3i(0, 3, 1), Vec3i(1, 3, 4)};  // (0, 1, 2) has zero area
  gen::PolylineSet wires;
  wires.v = {Vec3(0, 0.012, 0),     Vec3(0.02, 0.012, 0),     Vec3(0.04, 0.012, 0),
             Vec3(0, 0.012, 0.015), Vec3(0.02, 0.012, 0.015), Vec3(0.04, 0.012, 0.015)};
  wires.lines = {{0, 1, 2}, {3, 4, 5}};  // parallel segments 1.5 cm apart, 1.2 cm above the sheet
  const Positions grains = {Vec3(0.01, -0.01, 0.01), Vec3(0.01, -0.01, 0.01), Vec3(0.022, -0.01, 0.01)};
  gen::TriMesh floor;
  floor.v = {Vec3(-0.05, -0.025, -0.05), Vec3(0.1, -0.025, -0.05), Vec3(-0.05, -0.025, 0.1), Vec3(0.1, -0.025, 0.1)};
  floor.f = {Vec3i(0, 2, 1), Vec3i(1, 2, 3)};
  return SceneBuilder()
      .mesh("sheet", ObjectKind::cloth, sheet)
      .strands("wires", wires)
      .particles("grains", grains)
      .mesh("floor", ObjectKind::obstacle, floor, 0.0)
      .finish();
}

}  // namespace ccfr::test
