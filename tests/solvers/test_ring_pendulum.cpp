// A rigid ring hung on a fixed pin swings (issue #54): the pin holds it through contact alone,
// so the ring is a pendulum whose string is the pin's reach into its hole. Independent answer:
// the closed form of the large-amplitude pendulum, and the energy it must keep.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

constexpr double kPi = std::numbers::pi;

/// Torus about z through the origin: major radius `big`, minor `small`, `around` x `across` quads
/// split into triangles, outward normals.
gen::TriMesh torus(double big, double small, Index around, Index across) {
  gen::TriMesh m;
  for (Index i = 0; i < around; ++i)
    for (Index j = 0; j < across; ++j) {
      const double u = 2.0 * kPi * static_cast<double>(i) / static_cast<double>(around);
      const double w = 2.0 * kPi * static_cast<double>(j) / static_cast<double>(across);
      const double rho = big + small * std::cos(w);
      m.v.emplace_back(rho * std::cos(u), rho * std::sin(u), small * std::sin(w));
    }
  auto at = [&](Index i, Index j) { return (i % around) * across + (j % across); };
  for (Index i = 0; i < around; ++i)
    for (Index j = 0; j < across; ++j) {
      const Index a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      m.f.emplace_back(a, b, c);
      m.f.emplace_back(a, c, d);
    }
  return m;
}

/// A ring (torus of major radius 0.1 m, minor 0.01 m, 96 x 8 quads, density 1000) around a fixed
/// pin (a cylinder of radius 0.01 m along z through the origin, `pin_faces` faces around), its
/// centre `arm` from the pin's axis at angle `start` from straight down, so that its inner side
/// rests on the pin.
Scene ring_on_pin(const std::string& solver, double arm, double start, bool sliding, Index pin_faces, int substeps) {
  const gen::TriMesh ring = torus(0.1, 0.01, 96, 8);
  gen::TriMesh pin = gen::cylinder(0.01, 0.1, pin_faces, true);
  const Eigen::Matrix3d to_z = Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()).toRotationMatrix();
  for (Vec3& p : pin.v) p = to_z * p;
  TopologyBuilder tb;
  tb.add_object("pin", ObjectKind::obstacle, static_cast<Index>(pin.v.size()), pin.f);
  tb.add_object("ring", ObjectKind::rigid, static_cast<Index>(ring.v.size()), ring.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index np = static_cast<Index>(pin.v.size());
  for (Index i = 0; i < np; ++i) s.state.x[i] = pin.v[static_cast<size_t>(i)];
  const SolidMassProperties props = solid_mass_properties(ring.v, ring.f);
  const RigidVertexMasses m = rigid_vertex_masses(ring.v, ring.f, 1000.0, props);
  const Vec3 centre(arm * std::sin(start), -arm * std::cos(start), 0.0);
  for (size_t i = 0; i < ring.v.size(); ++i) {
    const Index v = np + static_cast<Index>(i);
    s.state.x[v] = ring.v[i] - props.centroid + centre;
    s.state.mass[v] = m.vertex[i];
    s.state.inv_mass[v] = m.vertex[i] > 0.0 ? 1.0 / m.vertex[i] : 0.0;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.objects[1].material.density = 1000.0;
  s.params.objects[1].material.friction = 0.0;
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.003;
  s.params.contact.offset = 0.002;
  s.params.time.fps = 60;
  s.params.time.substeps = substeps;
  s.params.time.iterations = 2;
  s.params.time.damping = 0.0;
  s.params.contact.sliding = sliding;
  return s;
}

/// The vertex-mass centre of object `object` (a rigid body's centre of mass: its vertex masses
/// are moment-matched).
Vec3 centre_of(const Simulation& sim, size_t object) {
  const auto& o = sim.topology().objects[object];
  const auto& st = sim.scene().state;
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (Index v = o.vertex_begin; v < o.vertex_end; ++v) total += st.mass[v], c += st.mass[v] * st.x[v];
  return c / total;
}

Vec3 ring_centre(const Simulation& sim) { return centre_of(sim, 1); }

constexpr double kG = 9.81, kOffset = 0.002;
constexpr double kArm = 0.1 - 0.01 - 0.01 - kOffset - 0.0005;  // the centre's distance from the pin's axis

struct Swing {
  double height = 0.0;  ///< the far side's highest point over the starting height, from the bottom
  double half_period = 0.0;
};

/// Releases the ring at 90° and measures its first swing to the far side from its centre, every
/// frame checked for violations.
Swing swing(const std::string& solver, bool sliding, Index pin_faces, int substeps) {
  Simulation sim(ring_on_pin(solver, kArm, -kPi / 2, sliding, pin_faces, substeps));
  const double y0 = ring_centre(sim).y();
  std::vector<double> t{0.0}, x{ring_centre(sim).x()}, y{y0};
  for (int f = 1; f <= 40; ++f) {
    EXPECT_EQ(sim.step_frame().violations_remaining, 0) << solver;
    const Vec3 c = ring_centre(sim);
    t.push_back(f / 60.0);
    x.push_back(c.x());
    y.push_back(c.y());
  }
  // The far side's highest point: the frame of largest y with x > 0, refined by the parabola
  // through it and its neighbours.
  size_t best = 0;
  for (size_t i = 1; i + 1 < y.size(); ++i)
    if (x[i] > 0.0 && (best == 0 || y[i] > y[best])) best = i;
  if (best == 0) {  // reported as height 0 under a compared solver (test::physics_solvers)
    if (test::asserts_closed_form(solver)) ADD_FAILURE() << solver << ": never reached the far side";
    return {};
  }
  const double y_m = y[best - 1], y_c = y[best], y_p = y[best + 1], h = 1.0 / 60.0;
  const double denom = y_m - 2.0 * y_c + y_p;
  const double shift = denom < 0.0 ? 0.5 * (y_m - y_p) / denom : 0.0;
  const double peak_y = y_c - 0.125 * (y_m - y_p) * (y_m - y_p) / (denom < 0.0 ? denom : -1.0);
  const double bottom = -kArm;  // the centre's lowest point
  return {(peak_y - bottom) / (y0 - bottom), t[best] + shift * h};
}

}  // namespace

TEST(RingPendulum, RingOnAFrictionlessPinSwingsToTheFarSideWithThePendulumsPeriod) {
  // The pin pushes along the normal of the ring's inner circle, through the ring's centre: no
  // torque, so the ring does not turn and its centre swings on a circle of radius
  // ℓ = 0.1 − 0.01 − 0.01 − ξ about the pin's axis, a pendulum on a string. Released at 90°, it
  // reaches the far side after half a period, T/2 = 2 √(ℓ/g) K(sin 45°), K = 1.854075 (the complete
  // elliptic integral), at its starting height.
  //
  // The closed form is of a round pin. A faceted one takes energy: the ring loses it in bursts
  // at its fastest, while its inner side passes the pin's corners, where the pairs' planes (a
  // pin face's normal each) turn by a face's angle and the motion across them is inelastic.
  // Measured (ccfr, height at 10 / 20 / 40 substeps):
  // a 32-face pin 0.81 / 0.86 / 0.70 (not monotonic: the corners and the substeps alias), 64
  // faces 0.85 / 0.92 / 0.95, 128 faces 0.85 / 0.91 / 0.95, 256 faces 0.83 / 0.89 / 0.93; with
  // the paper's planes alone (contact.sliding off) 0.33: the pin's tilted planes hold the ring's
  // inner side back (the chain that cannot swing). Asserted on a 128-face pin at 20
  // substeps: at least 0.85 of the height, the half period within 5 %.
  const double expected = 2.0 * std::sqrt(kArm / kG) * 1.854075;
  for (const char* solver : test::physics_solvers_with_rigid()) {
    const Swing s = swing(solver, true, 128, 20);
    const std::string tag = std::string(", 128-face pin, 20 substeps, ") + solver;
    test::report_physics("ring on a pin: height reached on the far side" + tag, 1.0, s.height, "");
    test::report_physics("ring on a pin: half period" + tag, expected, s.half_period, "s");
    if (!test::asserts_closed_form(solver)) continue;
    EXPECT_GE(s.height, 0.85) << solver;
    EXPECT_NEAR(s.half_period, expected, 0.05 * expected) << solver;
  }
  // Reported, not asserted: fewer substeps, the coarse pin, and the paper's planes alone.
  const struct {
    Index faces;
    int substeps;
    bool sliding;
  } more[] = {{128, 10, true}, {32, 10, true}, {32, 10, false}};
  for (const auto& m : more) {
    const Swing s = swing("ccfr", m.sliding, m.faces, m.substeps);
    const std::string tag = ", " + std::to_string(m.faces) + "-face pin, " + std::to_string(m.substeps) +
                            " substeps, ccfr" + (m.sliding ? "" : ", sliding off");
    test::report_physics("ring on a pin: height reached on the far side" + tag, 1.0, s.height, "");
    test::report_physics("ring on a pin: half period" + tag, expected, s.half_period, "s");
    EXPECT_GT(s.height, 0.0);
  }
}

namespace {

/// A chain of `links` interlocked rigid tori (major radius 0.05 m, minor 0.008 m, 48 x 8 quads,
/// density 1000) laid out along +x, turned alternately flat (in the xz plane) and upright (xy), the
/// first fixed (an obstacle at the origin), the gaps 2 mm beyond ξ: released, it swings down.
Scene rigid_chain(int links, bool momentum) {
  const gen::TriMesh upright = torus(0.05, 0.008, 48, 8);
  gen::TriMesh flat = upright;
  const Eigen::Matrix3d to_xz = Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()).toRotationMatrix();
  for (Vec3& p : flat.v) p = to_xz * p;
  const double spacing = 2 * 0.05 - 2 * 0.008 - kOffset - 0.002;
  TopologyBuilder tb;
  for (int i = 0; i < links; ++i)
    tb.add_object("link" + std::to_string(i), i == 0 ? ObjectKind::obstacle : ObjectKind::rigid,
                  static_cast<Index>(upright.v.size()), (i % 2 ? upright : flat).f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  s.params.objects.resize(static_cast<size_t>(links));
  for (int i = 0; i < links; ++i) {
    const gen::TriMesh& m = i % 2 ? upright : flat;
    const SolidMassProperties props = solid_mass_properties(m.v, m.f);
    const RigidVertexMasses masses = rigid_vertex_masses(m.v, m.f, 1000.0, props);
    const Index begin = s.topo.objects[static_cast<size_t>(i)].vertex_begin;
    for (size_t k = 0; k < m.v.size(); ++k) {
      const Index v = begin + static_cast<Index>(k);
      s.state.x[v] = m.v[k] + Vec3(i * spacing, 0.0, 0.0);
      if (i == 0) continue;
      s.state.mass[v] = masses.vertex[k];
      s.state.inv_mass[v] = masses.vertex[k] > 0.0 ? 1.0 / masses.vertex[k] : 0.0;
    }
    s.params.objects[static_cast<size_t>(i)].material.density = 1000.0;
    s.params.objects[static_cast<size_t>(i)].material.friction = 0.0;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.contact.solver = "ccfr";
  s.params.contact.radius = 0.003;
  s.params.contact.offset = kOffset;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = 10;
  s.params.time.iterations = 2;
  s.params.time.damping = 0.0;
  return s;
}

}  // namespace

TEST(RingPendulum, AChainOfRigidLinksSwingsPastTheVerticalUnderContactMomentum) {
  // Seven interlocked links hang from a fixed one, released straight out to the side. Each pair
  // of links is one contact between two unpinned bodies: under contact.momentum their repulsion
  // is the pair's (answer_pairs) and the dividing plane moves with them (split_by_motion), so the
  // chain falls as a chain and its last link swings through the vertical to the far side. Before,
  // each link stopped at a plane fixed between it and its neighbour every substep and the chain
  // sank slowly to a dead hang: its last link never passed x = 0.34 m.
  //
  // Independent answer: energy. The links' translational energy, from their centres' motion over
  // a frame (the rotation's is left out, and a frame's mean velocity has less energy than its
  // instants), can never exceed the potential energy the chain released; the slack of 2 mm per
  // joint and the faceted tubes (8 facets round) make some of the loss physical, the rest is the
  // integrator's first-order loss (10 substeps).
  constexpr int kLinks = 7, kFrames = 30;
  for (const bool momentum : {true, false}) {
    Simulation sim(rigid_chain(kLinks, momentum));
    std::vector<double> mass(kLinks, 0.0);
    for (int i = 1; i < kLinks; ++i) {
      const auto& o = sim.topology().objects[static_cast<size_t>(i)];
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) mass[static_cast<size_t>(i)] += sim.scene().state.mass[v];
    }
    std::vector<Vec3> before(kLinks);
    for (int i = 1; i < kLinks; ++i) before[static_cast<size_t>(i)] = centre_of(sim, static_cast<size_t>(i));
    double potential0 = 0.0;
    for (int i = 1; i < kLinks; ++i)
      potential0 += mass[static_cast<size_t>(i)] * kG * before[static_cast<size_t>(i)].y();
    // A percent of what the chain's whole drop (its length, 0.48 m) would release.
    double chain_mass = 0.0;
    for (const double m : mass) chain_mass += m;
    const double tolerance = 0.01 * chain_mass * kG * before[kLinks - 1].x();
    double last_x = before[kLinks - 1].x(), most_kept = 0.0, most_released = 0.0;
    for (int f = 1; f <= kFrames; ++f) {
      ASSERT_EQ(sim.step_frame().violations_remaining, 0) << "frame " << f;
      double kinetic = 0.0, potential = 0.0;
      for (int i = 1; i < kLinks; ++i) {
        const size_t k = static_cast<size_t>(i);
        const Vec3 now = centre_of(sim, k);
        const Vec3 v = (now - before[k]) * 60.0;
        kinetic += 0.5 * mass[k] * v.squaredNorm();
        potential += mass[k] * kG * 0.5 * (now.y() + before[k].y());
        before[k] = now;
      }
      const double released = potential0 - potential;
      EXPECT_LE(kinetic, released + tolerance) << "frame " << f << ": energy created";
      if (released > most_released) most_released = released, most_kept = kinetic / released;
      last_x = std::min(last_x, before[kLinks - 1].x());
    }
    const std::string setting = momentum ? "contact.momentum" : "defaults";
    test::report_physics("rigid chain of 7 links, " + setting + ": last link's least x in 0.5 s (starts 0.48 m)", 0.0,
                         last_x, "m");
    test::report_physics(
        "rigid chain of 7 links, " + setting + ": translational share of the energy released, lowest point", 1.0,
        most_kept, "");
    if (!momentum) continue;  // the defaults' fixed dividing planes: reported, not asserted
    EXPECT_LT(last_x, 0.0) << "the last link never passed the vertical";
    EXPECT_GE(most_kept, 0.5);
  }
}
