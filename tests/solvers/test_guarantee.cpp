// The guarantee on scenes the paper does not show (issue "No hollow certificates"): rigid bodies
// stay rigid, no silent speed cap, scripted steps beyond r subdivide, and a substep that cannot
// keep every pair apart stops the run before its frame exists. Independent answers: a Kabsch
// fit written here, closed-form free flight, brute-force distances over all primitive pairs.
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// Largest distance of an object's vertices from their best rigid fit to the rest shape (Kabsch,
/// unweighted; the bodies here have equal vertex masses).
double rigid_deviation(const Positions& x, const Positions& rest, Index begin, Index end) {
  Vec3 c = Vec3::Zero(), c0 = Vec3::Zero();
  for (Index v = begin; v < end; ++v) c += x[v], c0 += rest[v];
  c /= double(end - begin);
  c0 /= double(end - begin);
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (Index v = begin; v < end; ++v) h += (x[v] - c) * (rest[v] - c0).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  double worst = 0.0;
  for (Index v = begin; v < end; ++v) worst = std::max(worst, (r * (rest[v] - c0) + c - x[v]).norm());
  return worst;
}

/// Smallest distance between two objects over every vertex-triangle and edge-edge pair (brute force).
double min_distance_between(const Topology& t, const Positions& x, Index oa, Index ob) {
  double best = std::numeric_limits<double>::infinity();
  for (int side = 0; side < 2; ++side) {
    const auto& a = t.objects[side ? ob : oa];
    const auto& b = t.objects[side ? oa : ob];
    for (Index v = a.vertex_begin; v < a.vertex_end; ++v)
      for (Index f = b.face_begin; f < b.face_end; ++f) {
        const Vec3i& tri = t.faces[f];
        best = std::min(best, std::sqrt(point_triangle(x[v], x[tri[0]], x[tri[1]], x[tri[2]]).distance_sq));
      }
  }
  for (Index e = 0; e < t.num_edges(); ++e) {
    if (t.edge_object[e] != oa) continue;
    for (Index g = 0; g < t.num_edges(); ++g) {
      if (t.edge_object[g] != ob) continue;
      best = std::min(
          best,
          std::sqrt(edge_edge(x[t.edges[e][0]], x[t.edges[e][1]], x[t.edges[g][0]], x[t.edges[g][1]]).distance_sq));
    }
  }
  return best;
}

void set_mass(Scene& s, Index begin, Index end, double m) {
  for (Index v = begin; v < end; ++v) {
    s.state.mass[v] = m;
    s.state.inv_mass[v] = m > 0.0 ? 1.0 / m : 0.0;
  }
}

/// A cloth pinned at its corners with a rigid icosphere above it.
Scene ball_over_cloth(double speed) {
  test::BallOverCloth b;
  b.speed = speed;
  return test::ball_over_pinned_cloth(b);
}

}  // namespace

TEST(Guarantee, RigidBodyOnClothStaysRigidAndApart) {
  for (const char* solver : {"ccfr", "exact_projection"}) {
    Scene s = ball_over_cloth(3.0);
    s.params.contact.solver = solver;
    const Positions rest = s.state.rest;
    const auto& ball = s.topo.objects[1];
    const Index b = ball.vertex_begin, e = ball.vertex_end;
    Simulation sim(std::move(s));
    double worst = 0.0, closest = std::numeric_limits<double>::infinity();
    for (int f = 0; f < 30; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_EQ(fs.violations_remaining, 0) << solver << " frame " << f + 1;
      worst = std::max(worst, rigid_deviation(sim.positions(), rest, b, e));
      closest = std::min(closest, min_distance_between(sim.topology(), sim.positions(), 0, 1));
    }
    // Before rigid resolution the ball was crushed by centimetres at first contact.
    EXPECT_LT(worst, 1e-9) << solver;
    EXPECT_GE(closest, 0.005 * (1.0 - 1e-6)) << solver;
    EXPECT_LT(closest, 0.02) << solver << ": the ball never reached the cloth";
  }
}

TEST(Guarantee, DeformedRigidBodyIsCounted) {
  Scene s = ball_over_cloth(0.0);
  RigidBodies bodies(s.topo, s.state);
  ASSERT_EQ(bodies.size(), 1);
  Positions x = s.state.x;
  EXPECT_EQ(bodies.count_deformed(x, 1e-9), 0);
  // A rigid motion is not a deformation.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (Index v = s.topo.objects[1].vertex_begin; v < s.topo.objects[1].vertex_end; ++v)
    x[v] = r * x[v] + Vec3(0.3, -1, 2);
  EXPECT_EQ(bodies.count_deformed(x, 1e-9), 0);
  x[s.topo.objects[1].vertex_begin + 5] += Vec3(0, 1e-4, 0);  // one vertex pushed in by 0.1 mm
  EXPECT_GE(bodies.count_deformed(x, 1e-9), 1);
}

TEST(Guarantee, ABodysOwnStepBoundShortensItsStepAlongTheSameLine) {
  // No planes: the pose solve's only limit is the step bound. A translation t of 36 mm against a
  // bound of 10 mm ends at t 10/36; a body bound of 4 mm (enforce_carrying's cut) at t 4/36, and
  // a body bound above the scene's leaves the scene's.
  Scene s = ball_over_cloth(0.0);
  RigidBodies bodies(s.topo, s.state);
  RegionSet regions;
  regions.clear(s.state.size());
  const Vec3 t(0.03, -0.02, 0.0);
  const auto& ball = s.topo.objects[1];
  for (const double own : {-1.0, 0.004, 0.02}) {
    Positions x = s.state.x;
    for (Index v = ball.vertex_begin; v < ball.vertex_end; ++v) x[v] += t;
    const std::vector<double> bound(1, own);
    RigidContactOptions options;
    if (own > 0.0) options.body_step_bound = bound;
    bodies.enforce(x, s.state.x, regions, 0.01, 0.01, {}, options);
    const double expected = own > 0.0 ? std::min(own, 0.01) : 0.01;
    for (Index v = ball.vertex_begin; v < ball.vertex_end; ++v)
      ASSERT_LT((x[v] - s.state.x[v] - t * (expected / t.norm())).norm(), 1e-12) << own << " vertex " << v;
  }
}

TEST(Guarantee, FreeFlightIsNotCappedByTheStepBound) {
  // 30 m/s with r = 0.01 and 4 iterations: the old loop moved at most 0.4 m per frame (24 m/s).
  // The paper's projection alone (contact.free_islands false) takes more passes than
  // time.iterations; by default the grain, whose sweep meets nothing, is carried its whole step in
  // one pass a substep. Both arrive exactly.
  for (const bool islands : {false, true}) {
    Scene s = test::floor_puck_scene(5.0, 0.0, "ccfr");
    const Index p = s.topo.num_vertices() - 1;
    s.state.v[p] = Vec3(0, -30, 0);
    s.params.time.advance_tolerance = 0.0;  // exact arrival (the default accepts tol · r short per substep)
    s.params.contact.free_islands = islands;
    const double y0 = s.state.x[p].y();
    Simulation sim(std::move(s));
    const FrameStats fs = sim.step_frame();
    const double t = 1.0 / 60.0;
    // Discrete free flight over N equal pieces: y = y0 - 30 t + g t² (N + 1) / (2N), N = substeps run.
    const int n = fs.substeps_run;
    if (islands)
      EXPECT_EQ(fs.outer_iterations, n);
    else
      EXPECT_GT(fs.outer_iterations, 4 * n);  // the advance needed more than time.iterations passes
    EXPECT_NEAR(sim.positions()[p].y(), y0 - 30.0 * t - 9.81 * t * t * (n + 1) / (2.0 * n), 1e-9) << islands;
    EXPECT_EQ(fs.clamped_vertices, 0);
  }
}

// The step bound's sums, in closed form: the intended advance counts movable vertices only, the
// cut is what lies beyond r; kinematic vertices keep their step whatever its length.
TEST(Guarantee, StepBoundSumsTheIntendedAdvanceAndTheCut) {
  const Positions anchor = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  const Positions x = {Vec3(0.003, 0, 0), Vec3(0, 0.025, 0), Vec3(0, 0, -0.0101), Vec3(0.5, 0, 0)};
  const std::vector<double> w = {1.0, 1.0, 2.0, 0.0};  // the last one is scripted
  Positions out;
  const StepBoundResult sb = apply_step_bound(x, anchor, w, 0.01, 0.05, out);
  EXPECT_NEAR(sb.intended, 0.003 + 0.025 + 0.0101, 1e-15);
  EXPECT_NEAR(sb.cut, 0.015 + 0.0001, 1e-15);
  EXPECT_EQ(sb.held_back, 1);  // 0.0101 is within r (1 + 5 %)
  ASSERT_TRUE(sb.worst.has_value());
  EXPECT_EQ(*sb.worst, 1);
  EXPECT_NEAR(out[1].y(), 0.01, 1e-15);
  EXPECT_NEAR(out[2].z(), -0.01, 1e-15);
  EXPECT_EQ(out[3], x[3]);
}

namespace {

/// A 10 x 10 layer of particles `spacing` apart drifting at 0.3 m/s, particle 55 flying up at
/// `fast_speed` instead; no gravity, arrival up to rounding, up to 16 passes per substep.
Scene drifting_layer(double spacing, double fast_speed) {
  Positions x(100);
  for (Index i = 0; i < 100; ++i) x[i] = Vec3(spacing * (i % 10), 1.0, spacing * (i / 10));
  Scene s = test::particle_scene(x);
  for (Vec3& v : s.state.v) v = Vec3(0.3, 0, 0);
  s.state.v[55] = Vec3(0, fast_speed, 0);
  s.params.time.gravity = Vec3::Zero();
  s.params.time.iterations = 4;
  s.params.time.advance_tolerance = 1e-9;
  // The paper's step bound: a grain it held back keeps the cut (a free island of its own would get
  // its momentum back, and the fast one fly on at its speed).
  s.params.contact.free_islands = false;
  return s;
}

/// The layer for time.continuation: one substep of 1/240 s per frame, no repulsion.
Scene drifting_layer(double spacing, double fast_speed, TimeParams::Continuation mode) {
  Scene s = drifting_layer(spacing, fast_speed);
  s.params.contact.repulsion_range = 0.0;
  // The paper's mass-share planes, which stand still and cut the back particles of the drifting
  // layer: the cut is what the continuation modes are told apart by. With contact.momentum the
  // planes move with the layer and nothing is cut (docs/feasibility.md).
  s.params.contact.momentum = false;
  s.params.time.fps = 240.0;
  s.params.time.substeps = 1;
  s.params.time.continuation = mode;
  return s;
}
}  // namespace

// time.advance_shortfall: a hundred particles drift 1.25 mm per substep and one flies at 6 m/s
// (25 mm per substep, 5 r). The fast one's first pass cuts 20 mm of 148.75 mm intended (13.4 %).
// At 0.2 the substep ends there: one pass per substep, the fast particle keeps its step of r and
// flies on at r / dt. At 0.1 (and 0) the passes go on until it arrives: free flight, uncapped.
TEST(Guarantee, ShortfallRuleEndsThePassForFewOutliersOnly) {
  auto make = [](double shortfall) {
    Scene s = drifting_layer(0.1, 6.0);  // 0.1 m apart: beyond 2r + xi
    s.params.time.substeps = 4;          // 25 mm fits in one substep's 16 passes, no subdivision
    s.params.time.advance_shortfall = shortfall;
    return s;
  };
  const double dt = 1.0 / 240.0, r = 0.005;
  for (const double shortfall : {0.0, 0.1}) {
    Scene s = make(shortfall);
    const double y0 = s.state.x[55].y();
    Simulation sim(std::move(s));
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.outer_iterations, 4 * 5) << shortfall;  // 25 mm in steps of r, every substep
    EXPECT_EQ(fs.clamped_vertices, 0) << shortfall;
    EXPECT_NEAR(sim.positions()[55].y(), y0 + 4 * 6.0 * dt, 1e-12) << shortfall;
    EXPECT_NEAR(sim.velocities()[55].y(), 6.0, 1e-9) << shortfall;
  }
  Scene s = make(0.2);
  const double y0 = s.state.x[55].y(), x3 = s.state.x[3].x();
  Simulation sim(std::move(s));
  const FrameStats fs = sim.step_frame();
  EXPECT_EQ(fs.outer_iterations, 4);                        // one pass per substep
  EXPECT_EQ(fs.clamped_vertices, 1);                        // the fast particle, in the first substep only
  EXPECT_NEAR(sim.positions()[55].y(), y0 + 4 * r, 1e-12);  // then it moves r / dt: exactly r a substep
  EXPECT_NEAR(sim.velocities()[55].y(), r / dt, 1e-9);
  EXPECT_NEAR(sim.positions()[3].x(), x3 + 4 * 0.3 * dt, 1e-12);  // the others are unaffected
}

// The held-back marks are exactly the steps longer than r (1 + tolerance) of movable vertices.
TEST(Guarantee, StepBoundMarksExactlyTheHeldBackVertices) {
  const Positions anchor(5, Vec3::Zero());
  const Positions x = {Vec3(0.003, 0, 0), Vec3(0, 0.025, 0), Vec3(0, 0, -0.0101), Vec3(0.5, 0, 0), Vec3(0, 0, 0.02)};
  const std::vector<double> w = {1.0, 1.0, 2.0, 0.0, 1.0};  // vertex 3 is scripted
  Positions out;
  std::vector<std::uint8_t> held(5, 7);  // every entry is written
  const StepBoundResult sb = apply_step_bound(x, anchor, w, 0.01, 0.05, out, held);
  EXPECT_EQ(held, (std::vector<std::uint8_t>{0, 1, 0, 0, 1}));
  EXPECT_EQ(sb.held_back, 2);
  std::vector<std::uint8_t> wrong(4);
  EXPECT_THROW(apply_step_bound(x, anchor, w, 0.01, 0.05, out, wrong), Error);
}

// time.continuation: held_back against full. A 10 x 10 layer of particles drifts at 0.3 m/s
// (1.25 mm per substep) and one of them flies up at 6 m/s, 5 r per substep: the step bound holds it
// back in every pass until it arrives. Spaced 0.1 m apart nothing is in contact, both modes run
// the same passes on the same targets, and every position must be bit-identical.
//
// Spaced 12 mm apart (all within 2r + xi of their neighbours) the layer's contacts cut the back
// particles' steps by projection in the first pass. Full passes re-solve them in the fast
// particle's extra passes, so they catch up; held-back passes move the fast particle alone, so
// the layer ends exactly where a substep without the fast one (one pass: nothing held back) leaves
// it: the planes of the first pass depend on the anchors and masses only, the same in both.

TEST(Guarantee, HeldBackContinuationEqualsFullPassesWithoutContact) {
  Simulation full(drifting_layer(0.1, 6.0, TimeParams::Continuation::full));
  Simulation local(drifting_layer(0.1, 6.0, TimeParams::Continuation::held_back));
  for (int frame = 0; frame < 4; ++frame) {
    const FrameStats ff = full.step_frame(), fl = local.step_frame();
    EXPECT_EQ(ff.outer_iterations, 5);  // 25 mm in steps of r
    EXPECT_EQ(fl.outer_iterations, 5);
    EXPECT_EQ(fl.clamped_vertices, 0);
  }
  for (Index i = 0; i < 100; ++i) {
    EXPECT_EQ(full.positions()[i], local.positions()[i]) << i;
    EXPECT_EQ(full.velocities()[i], local.velocities()[i]) << i;
  }
}

TEST(Guarantee, HeldBackContinuationMovesOnlyTheHeldBack) {
  const auto held_back = TimeParams::Continuation::held_back;
  Simulation full(drifting_layer(0.012, 6.0, TimeParams::Continuation::full));
  Simulation local(drifting_layer(0.012, 6.0, held_back));
  Simulation alone(drifting_layer(0.012, 0.0, held_back));  // the same layer, nothing fast
  const double y0 = local.positions()[55].y();
  const FrameStats ff = full.step_frame(), fl = local.step_frame(), fa = alone.step_frame();
  EXPECT_EQ(fa.outer_iterations, 1);
  EXPECT_EQ(ff.outer_iterations, 5);
  EXPECT_EQ(fl.outer_iterations, 5);
  EXPECT_EQ(fl.clamped_vertices, 0);
  EXPECT_EQ(fl.violations_remaining, 0);
  EXPECT_GT(ff.candidates, 100);  // the layer's neighbour pairs
  // The first pass lists the layer, the later ones only the fast particle's pairs (none once it left).
  EXPECT_LT(fl.candidates_total, ff.candidates_total / 3) << fl.candidates_total << " vs " << ff.candidates_total;
  EXPECT_GT(fl.violations_detected, 0);  // the layer's back particles were projected
  EXPECT_NEAR(local.positions()[55].y(), y0 + 6.0 / 240.0, 1e-12);
  Index caught_up = 0;
  for (Index i = 0; i < 100; ++i) {
    if (i == 55) continue;
    EXPECT_EQ(local.positions()[i], alone.positions()[i]) << i;
    caught_up += full.positions()[i].x() > local.positions()[i].x();
  }
  EXPECT_GT(caught_up, 0);  // full passes let the layer finish its advance in the fast one's passes
  // Brute force over every pair: none closer than xi.
  double closest = 1.0;
  for (Index i = 0; i < 100; ++i)
    for (Index j = i + 1; j < 100; ++j)
      closest = std::min(closest, (local.positions()[i] - local.positions()[j]).norm());
  EXPECT_GE(closest, 0.01 * (1.0 - 1e-9));
}

// The recount names what a held-back pass must free: the vertices of every pair it counts and of
// every contact sharing a vertex with one. Six particles on a line 12 mm apart (neighbours within
// 2r + xi); particle 2 then moves 8 mm toward 3: only the pair (2, 3) is closer than xi, and the
// contacts touching 2 or 3 are (1, 2), (2, 3) and (3, 4).
TEST(Guarantee, RecountMarksTheVerticesAroundEveryViolatedPair) {
  Positions beads(6);
  for (Index i = 0; i < 6; ++i) beads[i] = Vec3(0.012 * i, 0, 0);
  const Scene s = test::particle_scene(beads);
  auto solver = make_contact_solver("ccfr");
  solver->initialize(s.topo, s.state, s.params);
  StageTimes times;
  StepContext ctx{s.topo, s.params, 1.0 / 240.0, 1, 0, 0, times};
  solver->detect(s.state.x, s.state, ctx);
  Positions x = s.state.x;
  x[2].x() += 0.008;
  EXPECT_EQ(solver->count_outside(x, s.state.x, s.state, ctx), 1);  // no marks asked: just the count
  std::vector<std::uint8_t> marks(6, 0);
  ctx.violated = marks;
  EXPECT_EQ(solver->count_outside(x, s.state.x, s.state, ctx), 1);
  EXPECT_EQ(marks, (std::vector<std::uint8_t>{0, 1, 1, 1, 1, 0}));
  std::fill(marks.begin(), marks.end(), 0);
  EXPECT_EQ(solver->count_outside(s.state.x, s.state.x, s.state, ctx), 0);  // clean: nothing marked
  EXPECT_EQ(marks, std::vector<std::uint8_t>(6, 0));
}

// A face that passes over a held vertex swallows it: the vertex ends beyond the face, farther than
// ξ from it, and a distance recount sees nothing. A strand segment (0, 1) hangs 6 mm above a fixed
// triangle (ξ = 4 mm); then its lower vertex is put 6 mm below the triangle's interior, the upper one
// stays: the segment crosses the face, every vertex-face and edge-edge pair is still farther than ξ.
// Control: the same drop beside the triangle crosses nothing.
TEST(Guarantee, RecountCountsASegmentSwallowedByAFaceThatDistancesMiss) {
  TopologyBuilder tb;
  tb.add_object("floor", ObjectKind::obstacle, 3, {Vec3i(0, 1, 2)});
  tb.add_object("strand", ObjectKind::strand, 2, {}, {}, {{0, 1}});
  Scene s;
  s.topo = tb.finish();
  s.state.resize(5);
  s.state.x = {Vec3(-0.1, 0, -0.1), Vec3(0.1, 0, -0.1), Vec3(0, 0, 0.1), Vec3(0, 0.026, 0), Vec3(0, 0.006, 0)};
  for (Index v = 3; v < 5; ++v) s.state.mass[v] = 1e-3, s.state.inv_mass[v] = 1e3;
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.contact.radius = 0.01;
  s.params.contact.offset = 0.004;
  for (const char* name : {"ccfr", "exact_projection"}) {
    auto solver = make_contact_solver(name);
    solver->initialize(s.topo, s.state, s.params);
    StageTimes times;
    StepContext ctx{s.topo, s.params, 1.0 / 240.0, 1, 0, 0, times};
    solver->detect(s.state.x, s.state, ctx);
    Positions x = s.state.x;
    x[4] = Vec3(0, -0.006, 0);  // through the face's interior
    std::vector<std::uint8_t> marks(5, 0);
    ctx.violated = marks;
    EXPECT_EQ(solver->count_outside(x, s.state.x, s.state, ctx), 1) << name;
    EXPECT_EQ(marks[4], 1) << name;
    EXPECT_NE(solver->last_violation().find("segment through a face"), std::string::npos) << solver->last_violation();
    // Its distance to the face is above ξ: only the crossing tells.
    EXPECT_GT(std::sqrt(point_triangle(x[4], x[0], x[1], x[2]).distance_sq), 0.004);
    x[4] = Vec3(0.3, -0.006, 0);  // the same depth beside the triangle: no crossing
    EXPECT_EQ(solver->count_outside(x, s.state.x, s.state, ctx), 0) << name;
    // A segment that already crossed at the substep's start is not counted again here.
    SimState started = s.state;
    started.x_prev[4] = Vec3(0, -0.006, 0);
    x[4] = Vec3(0.001, -0.006, 0);
    EXPECT_EQ(solver->count_outside(x, s.state.x, started, ctx), 0) << name;
  }
}

TEST(Guarantee, ScriptedStepsBeyondTheRadiusSubdivideOrStopWithAClearError) {
  auto make = [](int max_subdivision) {
    Scene s = test::floor_puck_scene(0.5, 0.0, "ccfr");
    // The floor rises at 3 m/s: 5 mm per substep at r = 1 mm.
    s.params.contact.radius = 0.001;
    s.params.objects[0].motion.velocity = Vec3(0, 3.0, 0);
    s.params.time.max_subdivision = max_subdivision;
    return s;
  };
  {
    Simulation sim(make(64));
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.substeps_run, 10 * 6);  // ceil(5 mm / (0.9 r))
  }
  Simulation sim(make(2));
  try {
    sim.step_frame();
    FAIL() << "expected a GuaranteeError";
  } catch (const GuaranteeError& e) {
    EXPECT_NE(std::string(e.what()).find("'floor'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("time.substeps"), std::string::npos) << e.what();
  }
}

TEST(Guarantee, ClosingPlatesStopBeforeAViolatedFrame) {
  // A cloth between two obstacle slabs closing at 0.3 m/s each: the gap falls below 2 ξ, no
  // admissible position remains, and the run must stop with every completed frame clean.
  const auto cloth = gen::grid(0.3, 0.3, 8, 8);
  const auto slab = gen::box(Vec3(0.6, 0.02, 0.6));
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(slab.v.size()), slab.f);
  tb.add_object("lid", ObjectKind::obstacle, static_cast<Index>(slab.v.size()), slab.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index nc = static_cast<Index>(cloth.v.size()), ns = static_cast<Index>(slab.v.size());
  for (Index i = 0; i < nc; ++i) s.state.x[i] = cloth.v[i] + Vec3(0, 0.05, 0);
  for (Index i = 0; i < ns; ++i) s.state.x[nc + i] = slab.v[i];
  for (Index i = 0; i < ns; ++i) s.state.x[nc + ns + i] = slab.v[i] + Vec3(0, 0.1, 0);
  set_mass(s, 0, nc, 0.001);
  set_mass(s, nc, s.topo.num_vertices(), 0.0);
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(3);
  s.params.objects[1].motion.velocity = Vec3(0, 0.3, 0);
  s.params.objects[2].motion.velocity = Vec3(0, -0.3, 0);
  s.params.time.gravity = Vec3::Zero();
  s.params.contact.offset = 0.01;
  s.params.contact.radius = 0.005;
  Simulation sim(std::move(s));
  int frames = 0;
  bool stopped = false;
  for (int f = 0; f < 20 && !stopped; ++f) {
    try {
      sim.step_frame();
      ++frames;
      for (Index slab_object : {Index(1), Index(2)})
        EXPECT_GE(min_distance_between(sim.topology(), sim.positions(), 0, slab_object), 0.01 * (1.0 - 1e-6))
            << "frame " << frames;
    } catch (const GuaranteeError& e) {
      stopped = true;
      EXPECT_NE(std::string(e.what()).find("violation"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(stopped) << "the slabs closed to " << 0.06 - 0.6 * frames / 60.0 << " and nothing stopped";
  EXPECT_GT(frames, 3);
}
