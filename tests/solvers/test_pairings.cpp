// Contact carries momentum in every pairing of movable kinds (issue #54, item 1): a body of each
// kind (rigid, tet solid, cloth, strands, particles) shot off centre into a resting body of each
// kind, in zero gravity with no obstacle, under the defaults (the free islands) and under
// contact.momentum (the inelastic response between the two). Independent answer: nothing
// outside the pair acts, so the total linear momentum and the angular momentum about the common
// centre of mass must be what they were before the impact, measured from positions and velocities.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// One body before it is placed: its mesh about its centre of mass, vertex masses, and for a rigid
/// body the solid's mass (its core: the mass no vertex carries moves with the vertices' centre).
struct Body {
  ObjectKind kind = ObjectKind::particles;
  Positions x;
  std::vector<double> mass;
  std::vector<Vec3i> faces;
  std::vector<Vec4i> tets;
  std::vector<std::vector<Index>> lines;
  double solid = 0.0;  ///< kg; 0 unless rigid
  double density = 0.0;
};

/// Moves `b` so that its vertices' mass centre is at the origin.
void centre(Body& b) {
  Vec3 c = Vec3::Zero();
  double m = 0.0;
  for (size_t i = 0; i < b.x.size(); ++i) c += b.mass[i] * b.x[i], m += b.mass[i];
  for (Vec3& p : b.x) p -= c / m;
}

/// A body of each kind about 8 cm across, 0.1-0.3 kg. `across`: strands run along z instead of y
/// (two bundles then cross instead of lying parallel).
Body make_body(ObjectKind kind, bool across) {
  Body b;
  b.kind = kind;
  switch (kind) {
    case ObjectKind::rigid: {  // icosphere, r = 4 cm, density 1000: 0.27 kg with its core
      const gen::TriMesh ball = gen::sphere(0.04, 2);
      const SolidMassProperties props = solid_mass_properties(ball.v, ball.f);
      const RigidVertexMasses m = rigid_vertex_masses(ball.v, ball.f, 1000.0, props);
      for (size_t i = 0; i < ball.v.size(); ++i) b.x.push_back(ball.v[i] - props.centroid);
      b.mass = m.vertex;
      b.faces = ball.f;
      b.density = 1000.0;
      b.solid = 1000.0 * props.volume;
      return b;
    }
    case ObjectKind::tet_solid: {  // 6 cm cube, 5 cells a side, 1 g a vertex: 0.216 kg
      const auto box = gen::tet_box(Vec3(0.06, 0.06, 0.06), Vec3i(5, 5, 5));
      b.x = box.v;
      b.tets = box.t;
      break;
    }
    case ObjectKind::cloth: {  // 8 cm square facing x, 10 x 10 cells
      const gen::TriMesh g = gen::grid(0.08, 0.08, 10, 10);
      for (const Vec3& p : g.v) b.x.emplace_back(p.y(), p.x(), p.z());  // normal +y -> +x
      b.faces = g.f;
      break;
    }
    case ObjectKind::strand: {  // 4 x 4 strands 8 cm long, 2.4 cm apart, 9 vertices each
      const gen::PolylineSet s = gen::straight_strands(16, 9, 0.08, 0.072);
      for (const Vec3& p : s.v) b.x.push_back(across ? Vec3(p.x(), p.z(), p.y()) : p);
      b.lines = s.lines;
      break;
    }
    case ObjectKind::particles:  // 4 x 4 x 4 grains 2.4 cm apart
      b.x = gen::particle_block(4, 4, 4, 0.024);
      break;
    default:
      ADD_FAILURE() << "no body of kind " << to_string(kind);
  }
  b.mass.assign(b.x.size(), 0.001);
  if (kind == ObjectKind::cloth) b.mass.assign(b.x.size(), 0.1 / static_cast<double>(b.x.size()));
  centre(b);
  return b;
}

double extent_x(const Body& b, double sign) {
  double e = 0.0;
  for (const Vec3& p : b.x) e = std::max(e, sign * p.x());
  return e;
}

/// Body a shot at 2 m/s along +x into body b at rest, b's centre `lateral` off a's path along y,
/// the two 6 mm apart; r = 4 mm, ξ = 2 mm, δ = 0.5 mm, 60 fps x 10 substeps, no gravity.
Scene shot(const Body& a, const Body& b, const std::string& solver, bool momentum, double lateral) {
  TopologyBuilder tb;
  const Body* bodies[2] = {&a, &b};
  const char* names[2] = {"a", "b"};
  for (int k = 0; k < 2; ++k)
    tb.add_object(names[k], bodies[k]->kind, static_cast<Index>(bodies[k]->x.size()), bodies[k]->faces, bodies[k]->tets,
                  bodies[k]->lines);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Vec3 offset[2] = {Vec3::Zero(), Vec3(extent_x(a, 1) + extent_x(b, -1) + 0.006, lateral, 0.001)};
  const Vec3 velocity[2] = {Vec3(2.0, 0, 0), Vec3::Zero()};
  s.params.objects.resize(2);
  Index v = 0;
  for (int k = 0; k < 2; ++k) {
    for (size_t i = 0; i < bodies[k]->x.size(); ++i, ++v) {
      s.state.x[v] = bodies[k]->x[i] + offset[k];
      s.state.v[v] = velocity[k];
      s.state.mass[v] = bodies[k]->mass[i];
      s.state.inv_mass[v] = s.state.mass[v] > 0.0 ? 1.0 / s.state.mass[v] : 0.0;
    }
    auto& material = s.params.objects[static_cast<size_t>(k)].material;
    if (bodies[k]->density > 0.0) material.density = bodies[k]->density;
    if (bodies[k]->kind == ObjectKind::tet_solid) {
      set_material_key(material, "volume_compliance", 1e-6);
      set_material_key(material, "shear_compliance", 1e-5);
    } else if (bodies[k]->kind == ObjectKind::cloth || bodies[k]->kind == ObjectKind::strand) {
      set_material_key(material, "stretch_compliance", 1e-7);
      set_material_key(material, "bend_compliance", 1e-2);
    }
    material.friction = 0.0;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.004;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0005;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = 10;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 8;
  s.params.time.damping = 0.0;
  s.params.time.gravity = Vec3::Zero();
  return s;
}

/// The pair's linear momentum, its angular momentum about the common centre of mass, and b's
/// momentum; a rigid body's core counted at its vertices' centre with their mean velocity.
struct Momenta {
  Vec3 p = Vec3::Zero(), l = Vec3::Zero(), p_b = Vec3::Zero();
};
Momenta momenta(const Simulation& sim, const double (&solid)[2]) {
  const auto& st = sim.scene().state;
  Vec3 c[2], v[2];
  double m[2], total[2];
  for (int k = 0; k < 2; ++k) {
    const auto& o = sim.topology().objects[static_cast<size_t>(k)];
    c[k] = v[k] = Vec3::Zero();
    m[k] = 0.0;
    for (Index i = o.vertex_begin; i < o.vertex_end; ++i)
      m[k] += st.mass[i], c[k] += st.mass[i] * st.x[i], v[k] += st.mass[i] * st.v[i];
    c[k] /= m[k], v[k] /= m[k];
    total[k] = std::max(solid[k], m[k]);
  }
  const Vec3 centre = (total[0] * c[0] + total[1] * c[1]) / (total[0] + total[1]);
  Momenta out;
  for (int k = 0; k < 2; ++k) {
    const auto& o = sim.topology().objects[static_cast<size_t>(k)];
    for (Index i = o.vertex_begin; i < o.vertex_end; ++i) out.l += st.mass[i] * (st.x[i] - centre).cross(st.v[i]);
    out.l += (total[k] - m[k]) * (c[k] - centre).cross(v[k]);
    out.p += total[k] * v[k];
  }
  out.p_b = total[1] * v[1];
  return out;
}

const char* label(ObjectKind k) {
  switch (k) {
    case ObjectKind::rigid:
      return "rigid";
    case ObjectKind::tet_solid:
      return "tet";
    case ObjectKind::cloth:
      return "cloth";
    case ObjectKind::strand:
      return "strands";
    default:
      return "particles";
  }
}

constexpr ObjectKind kKinds[] = {ObjectKind::rigid, ObjectKind::tet_solid, ObjectKind::cloth, ObjectKind::strand,
                                 ObjectKind::particles};

}  // namespace

/// Shot, hit, solver, contact.momentum.
using Pairing = std::tuple<ObjectKind, ObjectKind, const char*, bool>;
class Pairings : public ::testing::TestWithParam<Pairing> {};

TEST_P(Pairings, AnOffCentreShotIntoARestingBodyKeepsTheMomenta) {
  // a (0.1-0.27 kg) at 2 m/s along x hits b, at rest and a third of its size off a's path. Over
  // 10 frames: no violation after any substep, every frame audited at ξ; the pair's linear
  // momentum within 2 % of a's in every frame, its angular momentum about the common centre within
  // 5 % at the end; b carries at least 3 % of it (a pushed b: a sphere through a loose grain
  // cloud hits a few grains only); and no vertex flung, faster than 3 times the shot.
  // On 16679cc islands held bodies only: with strands or grains the momentum moved by 2-12 %, and
  // the material sweeps' own loss of a spin (below) cost up to 12 % of the angular momentum. Under
  // the defaults on bd714e1 (the islands restored a pair's loss as one motion of both, where
  // the loss fell on one side) rigid with grains or strands missed by 5.1-5.5 % and 7.1 %.
  // A soft impact may end a substep's passes with a vertex still held by r (the speed warning,
  // counted in clamped_vertices); this test measures what the contact leaves of the momenta.
  const test::ExpectWarnings held_in_impacts;
  const auto [kind_a, kind_b, solver, momentum] = GetParam();
  const Body a = make_body(kind_a, false), b = make_body(kind_b, kind_a == ObjectKind::strand);
  Scene scene = shot(a, b, solver, momentum, 0.025);
  const double solid[2] = {a.solid, b.solid};
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  const Momenta before = momenta(sim, solid);
  double worst = 0.0;
  for (int f = 1; f <= 10; ++f) {
    const FrameStats fs = sim.step_frame();
    ASSERT_EQ(fs.violations_remaining, 0) << "frame " << f;
    ASSERT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << "frame " << f;
    worst = std::max(worst, (momenta(sim, solid).p - before.p).norm());
    for (const Vec3& v : sim.scene().state.v) ASSERT_LT(v.norm(), 6.0) << "frame " << f;
  }
  const auto& logged = test::counting_sink();
  if (logged->warnings > 0) {  // the speed warning only, once per object at most
    EXPECT_LE(logged->warnings, 2);
    EXPECT_NE(logged->last.find("wants to move"), std::string::npos) << logged->last;
  }
  const Momenta after = momenta(sim, solid);
  const std::string tag = std::string(label(kind_a)) + " into " + label(kind_b) + ", " + solver +
                          (momentum ? " (contact.momentum)" : " (defaults)");
  test::report_physics(tag + ": momentum's largest deviation in 10 frames", before.p.x(), before.p.x() + worst,
                       "kg m/s");
  test::report_physics(tag + ": angular momentum after 10 frames", before.l.z(), after.l.z(), "kg m²/s");
  if (!test::asserts_closed_form(solver)) return;  // measured for the table (test::physics_solvers)
  EXPECT_LT(worst, 0.02 * before.p.norm());
  EXPECT_LT((after.l - before.l).norm(), 0.05 * before.l.norm());
  EXPECT_GT(after.p_b.x(), 0.03 * before.p.x()) << "b was not pushed";
}

namespace {
std::vector<Pairing> every_pairing() {
  std::vector<Pairing> out;
  for (size_t i = 0; i < std::size(kKinds); ++i)
    for (size_t j = 0; j < std::size(kKinds); ++j)
      for (const char* solver : kKinds[i] == ObjectKind::rigid || kKinds[j] == ObjectKind::rigid
                                    ? test::physics_solvers_with_rigid()
                                    : test::physics_solvers())
        for (const bool momentum : {false, true}) out.emplace_back(kKinds[i], kKinds[j], solver, momentum);
  return out;
}
}  // namespace

INSTANTIATE_TEST_SUITE_P(Solvers, Pairings, ::testing::ValuesIn(every_pairing()),
                         [](const ::testing::TestParamInfo<Pairing>& info) {
                           return std::string(label(std::get<0>(info.param))) + "_into_" +
                                  label(std::get<1>(info.param)) + "_" + std::get<2>(info.param) +
                                  (std::get<3>(info.param) ? "_momentum" : "_defaults");
                         });

class FreeSpin : public ::testing::TestWithParam<ObjectKind> {};

TEST_P(FreeSpin, ASpinningBodyTouchingNothingKeepsItsAngularMomentum) {
  // A body spun at ω = (5, 20, 3) rad/s (ω dt ≈ 1/29 a substep), touching nothing, no gravity. The
  // material sweeps project each prediction x + v dt back onto the body's shape, which shortens a
  // turn by about (ω dt)² a substep: without the free islands (contact.free_islands: false) over 10
  // frames the tet cube loses 10.2 % of its angular momentum and the cloth 9.3 % (a strand spun
  // mostly about its own line 0.9 %, the flat rigid box, whose pose solve turns it, 0.06 %). By
  // default (and under contact.momentum) a free island gets back the angular momentum it had at the
  // substep's start.
  const ObjectKind kind = GetParam();
  Body a = make_body(kind, false);
  if (kind == ObjectKind::strand) {  // one strand: a bundle's strands are separate pieces that fly apart
    const gen::PolylineSet one = gen::straight_strands(1, 9, 0.08, 0.0);
    a.x = one.v, a.lines = one.lines, a.mass.assign(a.x.size(), 0.001);
    centre(a);
  } else if (kind == ObjectKind::rigid) {  // a flat box 8 x 4 x 1 cm: three different moments
    const gen::TriMesh box = gen::box(Vec3(0.08, 0.04, 0.01));
    const SolidMassProperties props = solid_mass_properties(box.v, box.f);
    const RigidVertexMasses m = rigid_vertex_masses(box.v, box.f, 1000.0, props);
    a.x.clear();
    for (const Vec3& p : box.v) a.x.push_back(p - props.centroid);
    a.faces = box.f, a.mass = m.vertex, a.solid = 1000.0 * props.volume;
  }
  const Body b = make_body(ObjectKind::particles, false);
  Scene scene = shot(a, b, GetParam() == ObjectKind::cloth ? "exact_projection" : "ccfr", false, 0.0);
  const Index na = static_cast<Index>(a.x.size());
  for (Index i = 0; i < na; ++i) scene.state.v[i] = Vec3(5.0, 20.0, 3.0).cross(scene.state.x[i]);
  for (Index i = na; i < scene.topo.num_vertices(); ++i) scene.state.x[i] += Vec3(5, 0, 0), scene.state.v[i].setZero();
  scene.state.rest = scene.state.x_prev = scene.state.x;
  const double solid[2] = {a.solid, b.solid};
  auto spin_after_10_frames = [&](bool free_islands) {
    Scene s = scene;
    s.params.contact.free_islands = free_islands;
    Simulation sim(std::move(s));
    const Momenta before = momenta(sim, solid);
    for (int f = 1; f <= 10; ++f) sim.step_frame();
    return std::pair(before, momenta(sim, solid));
  };
  const auto [before, after] = spin_after_10_frames(true);
  const std::string body = kind == ObjectKind::strand ? "strand" : label(kind);
  test::report_physics("a free " + body + " spun at 21 rad/s: angular momentum after 10 frames", before.l.norm(),
                       after.l.norm(), "kg m²/s");
  EXPECT_LT((after.l - before.l).norm(), 0.005 * before.l.norm());
  if (kind == ObjectKind::tet_solid || kind == ObjectKind::cloth) {  // the sweeps' loss, without the islands
    const Momenta lost = spin_after_10_frames(false).second;
    EXPECT_GT((lost.l - before.l).norm(), 0.05 * before.l.norm());
  }
}

INSTANTIATE_TEST_SUITE_P(Kinds, FreeSpin,
                         ::testing::Values(ObjectKind::rigid, ObjectKind::tet_solid, ObjectKind::cloth,
                                           ObjectKind::strand),
                         [](const ::testing::TestParamInfo<ObjectKind>& info) { return label(info.param); });
