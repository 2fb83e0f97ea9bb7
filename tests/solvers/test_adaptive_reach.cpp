// contact.adaptive_reach: each outer iteration gives each vertex its own reach ρ instead of r,
// detection pairs primitives within ρ_A + ρ_B + ξ and the step bound keeps each vertex within its
// ρ (docs/feasibility.md, "Adaptive reach"). The reach's rule and the per-vertex step bound against
// their definitions; coils piling on a floor (their candidate pairs counted), a rigid box falling on
// them and a scripted paddle through hanging strands, audited exactly (CGAL predicates) at every
// frame or substep.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/frame_stats.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

constexpr double kR = 0.005;

// Each vertex is held to its own reach; scripted vertices keep their step; the marks are the
// steps longer than their reach (1 + tolerance).
TEST(AdaptiveReach, StepBoundHoldsEachVertexToItsOwnReach) {
  const Positions anchor(5, Vec3::Zero());
  const Positions x = {Vec3(0.003, 0, 0), Vec3(0, 0.004, 0), Vec3(0, 0, -0.002), Vec3(0.5, 0, 0), Vec3(0, 0, 0)};
  const std::vector<double> w = {1.0, 1.0, 2.0, 0.0, 1.0};  // vertex 3 is scripted
  const std::vector<double> reach = {0.001, 0.005, 0.002, 0.0, 0.0};
  Positions out;
  std::vector<std::uint8_t> held(5, 7);
  const StepBoundResult sb = apply_step_bound(x, anchor, w, 0.01, 1e-6, out, held, reach);
  EXPECT_NEAR(out[0].x(), 0.001, 1e-15);  // cut to its reach of 1 mm
  EXPECT_EQ(out[1], x[1]);                // within its 5 mm
  EXPECT_EQ(out[2], x[2]);                // exactly at its reach: not cut
  EXPECT_EQ(out[3], x[3]);                // scripted: its known motion
  EXPECT_EQ(out[4], x[4]);                // reach 0 and no step
  EXPECT_EQ(held, (std::vector<std::uint8_t>{1, 0, 0, 0, 0}));
  EXPECT_EQ(sb.held_back, 1);
  EXPECT_NEAR(sb.cut, 0.002, 1e-15);
  EXPECT_THROW(apply_step_bound(x, anchor, w, 0.01, 1e-6, out, held, std::vector<double>(4, kR)), Error);
}

// ρ = min(r, max(f r, δ) + 2 |s|) for a movable vertex, r where marked (rigid) or held back by the
// pass before or where the step is not finite, the known step for a vertex of inverse mass 0.
TEST(AdaptiveReach, ReachFollowsTheIntendedStep) {
  const Positions anchor(7, Vec3(1, 2, 3));
  Positions intended = anchor;
  intended[0] += Vec3(0.0004, 0, 0);  // slow: f r + 2 |s| = 1.25 + 0.8 mm
  intended[1] += Vec3(0, 0.003, 0);   // fast: capped at r
  intended[2] += Vec3(0, 0, 0.0001);  // rigid body's vertex: r
  intended[3] += Vec3(0.0001, 0, 0);  // held back in the pass before: r
  intended[4] += Vec3(0, -0.004, 0);  // scripted: its own step
  intended[5] = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  const std::vector<double> w = {1, 1, 1, 1, 0, 1, 0};  // vertex 6: fixed, no step
  const std::vector<std::uint8_t> full = {0, 0, 1, 0, 0, 0, 0}, held = {0, 0, 0, 1, 0, 0, 0};
  std::vector<double> reach;
  adaptive_vertex_reach(intended, anchor, w, full, held, kR, 0.25, 0.0008, reach);
  ASSERT_EQ(reach.size(), 7u);
  EXPECT_NEAR(reach[0], 0.25 * kR + 2 * 0.0004, 1e-15);
  EXPECT_EQ(reach[1], kR);
  EXPECT_EQ(reach[2], kR);
  EXPECT_EQ(reach[3], kR);
  EXPECT_NEAR(reach[4], 0.004, 1e-11);
  EXPECT_GE(reach[4], (intended[4] - anchor[4]).norm());
  EXPECT_EQ(reach[5], kR);
  EXPECT_EQ(reach[6], 0.0);
  // The first pass of a substep has no marks; f = 0 and δ = 0 leave twice the step; a floor
  // below δ is raised to δ.
  adaptive_vertex_reach(intended, anchor, w, {}, {}, kR, 0.0, 0.0, reach);
  EXPECT_NEAR(reach[0], 0.0008, 1e-15);
  EXPECT_NEAR(reach[2], 0.0002, 1e-15);
  adaptive_vertex_reach(intended, anchor, w, {}, {}, kR, 0.1, 0.0008, reach);
  EXPECT_NEAR(reach[0], 0.0008 + 0.0008, 1e-15);
  EXPECT_THROW(adaptive_vertex_reach(intended, anchor, std::vector<double>(6, 1.0), {}, {}, kR, 0.25, 0.0, reach),
               Error);
}

// contact.momentum's last pass: a step longer than r gets ρ = |s| + r; shorter steps, rigid
// vertices and immovable ones keep what they had, a larger reach given before is kept, a
// non-finite step (infinite or NaN) is left alone, and no reach passes 65 r.
TEST(AdaptiveReach, TheLastPassTakesTheRestOfAStepLongerThanR) {
  const Positions anchor(7, Vec3(1, 2, 3));
  Positions intended = anchor;
  intended[0] += Vec3(0.012, 0, 0);                                   // 12 mm
  intended[1] += Vec3(0, 0.0049, 0);                                  // within r
  intended[2] += Vec3(0, 0, 0.03);                                    // a rigid body's vertex: its pose solve bounds it
  intended[3] += Vec3(0.03, 0, 0);                                    // scripted
  intended[4] = Vec3(std::numeric_limits<double>::infinity(), 0, 0);  // left to check_finite
  intended[5] += Vec3(0, 0.006, 0);
  intended[6] += Vec3(0, 0, -0.0051);  // just past r
  const std::vector<double> w = {1, 1, 1, 0, 1, 1, 2};
  const std::vector<std::uint8_t> full = {0, 0, 1, 0, 0, 0, 0};
  std::vector<double> reach;
  EXPECT_TRUE(reach_long_steps(intended, anchor, w, full, kR, reach));
  ASSERT_EQ(reach.size(), 7u);
  EXPECT_NEAR(reach[0], 0.012 + kR, 1e-15);
  EXPECT_EQ(reach[1], kR);
  EXPECT_EQ(reach[2], kR);
  EXPECT_EQ(reach[3], kR);
  EXPECT_EQ(reach[4], kR);
  EXPECT_NEAR(reach[5], 0.006 + kR, 1e-15);
  EXPECT_NEAR(reach[6], 0.0051 + kR, 1e-15);
  // A larger reach given before (an adaptive reach, say) is kept; a NaN step is left alone too.
  reach.assign(7, kR);
  reach[5] = 0.1;
  intended[4] = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  EXPECT_TRUE(reach_long_steps(intended, anchor, w, full, kR, reach));
  EXPECT_EQ(reach[5], 0.1);
  EXPECT_EQ(reach[4], kR);
  // A finite step of a kilometre (a blow-up) widens detection by at most 64 r: the rest is cut.
  intended[0] = anchor[0] + Vec3(0, 1000.0, 0);
  reach.clear();
  EXPECT_TRUE(reach_long_steps(intended, anchor, w, full, kR, reach));
  EXPECT_NEAR(reach[0], 65.0 * kR, 1e-15);
  // Every step within r: nothing grows, the pass may run at the uniform r.
  Positions slow = anchor;
  slow[0] += Vec3(0.005, 0, 0);
  slow[3] += Vec3(0.03, 0, 0);
  reach.clear();
  EXPECT_FALSE(reach_long_steps(slow, anchor, w, full, kR, reach));
  EXPECT_EQ(reach, std::vector<double>(7, kR));
  EXPECT_THROW(reach_long_steps(intended, anchor, std::vector<double>(6, 1.0), {}, kR, reach), Error);
}

/// 25 coils (80 vertices, 4 turns of 1.5 cm, 0.2 m tall, about 0.4 m of wire at 0.01 kg/m each)
/// dropped from 5 cm onto a floor, the soft wires' contact (r = 5 mm, ξ = 4 mm, δ = 0.8 mm, friction 0.3 / 0.2,
/// 60 fps x 4 substeps x 2 iterations, 6 sweeps).
/// With `rigid_box`, a rigid 6 cm box of 20 g falls 10 cm above the coils' tops onto them.
Scene coils_on_a_floor(const std::string& solver, double adaptive, bool rigid_box = false) {
  gen::TriMesh floor = gen::box(Vec3(0.4, 0.02, 0.4));
  for (auto& p : floor.v) p.y() -= 0.01;
  const gen::TriMesh box = gen::box(Vec3(0.06, 0.06, 0.06));
  const Index nv = 80;
  const gen::PolylineSet coils = gen::curly_strands(25, nv, 0.2, 0.12, 0.015, 4.0);
  TopologyBuilder tb;
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  tb.add_object("coils", ObjectKind::strand, static_cast<Index>(coils.v.size()), {}, {}, coils.lines);
  if (rigid_box) tb.add_object("box", ObjectKind::rigid, static_cast<Index>(box.v.size()), box.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const auto& p : floor.v) s.state.x[k++] = p;
  const Index coils_end = k + static_cast<Index>(coils.v.size());
  for (const auto& p : coils.v) s.state.x[k++] = p + Vec3(0, 0.25, 0);
  if (rigid_box)
    for (const auto& p : box.v) s.state.x[k++] = p + Vec3(0.01, 0.38, 0.01);
  const double density = 0.01, seg = 0.4 / static_cast<double>(nv - 1);
  for (Index v = static_cast<Index>(floor.v.size()); v < s.topo.num_vertices(); ++v) {
    s.state.mass[v] = v < coils_end ? density * seg : 0.02 / static_cast<double>(box.v.size());
    s.state.inv_mass[v] = 1.0 / s.state.mass[v];
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(rigid_box ? 3 : 2);
  s.params.objects[1].material.density = density;
  set_material_key(s.params.objects[1].material, "stretch_compliance", 1e-7);
  set_material_key(s.params.objects[1].material, "bend_compliance", 1e-3);
  s.params.contact.solver = solver;
  s.params.contact.radius = kR;
  s.params.contact.offset = 0.004;
  s.params.contact.repulsion_range = 0.0008;
  s.params.contact.friction_static = 0.3;
  s.params.contact.friction_kinetic = 0.2;
  s.params.contact.adaptive_reach = adaptive;
  s.params.time.fps = 60;
  s.params.time.substeps = 4;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 6;
  return s;
}

struct PileRun {
  Index candidates = 0, penetrations = 0, remaining = 0;
  double lowest_centre = 0.0;  ///< the coils' centre of mass height in the last frame (m)
};

PileRun run_pile(const std::string& solver, double adaptive, int frames) {
  Scene scene = coils_on_a_floor(solver, adaptive);
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  PileRun out;
  for (int f = 1; f <= frames; ++f) {
    const FrameStats fs = sim.step_frame();
    out.candidates += fs.candidates_total;
    out.remaining += fs.violations_remaining;
    out.penetrations += audit.audit_next(sim.positions()).penetrations();
  }
  const auto& x = sim.positions();
  const Index first = 8;  // the floor's box
  for (Index v = first; v < static_cast<Index>(x.size()); ++v) out.lowest_centre += x[v].y();
  out.lowest_centre /= static_cast<double>(x.size() - first);
  return out;
}

/// A paddle (30 x 4 x 2 cm) driven at 1.2 m/s along z through a row of 12 strands hanging from
/// pinned roots (30 vertices, 0.2 m, 2 g/m): r = 3 mm, ξ = 2 mm, δ = 0.5 mm, 60 fps x 4, so the
/// paddle's 5 mm a substep is split into pieces and its vertices' known steps set their reach.
Scene paddle_through_strands(const std::string& solver, double adaptive, TimeParams::Continuation continuation) {
  gen::TriMesh paddle = gen::box(Vec3(0.3, 0.04, 0.02));
  for (auto& p : paddle.v) p += Vec3(0, 0.07, -0.05);
  const Index nv = 30;
  const gen::PolylineSet strands = gen::curly_strands(12, nv, 0.2, 0.22, 0.0, 0.0, true);
  TopologyBuilder tb;
  tb.add_object("paddle", ObjectKind::obstacle, static_cast<Index>(paddle.v.size()), paddle.f);
  tb.add_object("hair", ObjectKind::strand, static_cast<Index>(strands.v.size()), {}, {}, strands.lines);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const auto& p : paddle.v) s.state.x[k++] = p;
  for (const auto& p : strands.v) s.state.x[k++] = p + Vec3(0, 0.2, 0);
  const double density = 0.002, seg = 0.2 / static_cast<double>(nv - 1);
  s.params.objects.resize(2);
  PinGroup roots;
  const Index base = static_cast<Index>(paddle.v.size());
  for (const auto& line : strands.lines)
    for (size_t i = 0; i < line.size(); ++i) {
      const Index v = base + line[i];
      s.state.mass[v] = density * seg;
      s.state.inv_mass[v] = i == 0 ? 0.0 : 1.0 / s.state.mass[v];
      if (i == 0) roots.vertices.push_back(line[i]);
    }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects[1].pins.push_back(roots);
  s.params.objects[1].material.density = density;
  set_material_key(s.params.objects[1].material, "stretch_compliance", 1e-7);
  set_material_key(s.params.objects[1].material, "bend_compliance", 0.1);
  s.params.objects[0].motion.velocity = Vec3(0, 0, 1.2);
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.003;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0005;
  s.params.contact.adaptive_reach = adaptive;
  s.params.time.fps = 60;
  s.params.time.substeps = 4;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 4;
  s.params.time.continuation = continuation;
  return s;
}

/// Runs `frames` frames with the exact audit after every substep; the penetrations it counts.
Index audited_substeps(Scene scene, int frames, Index* remaining = nullptr) {
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  scene.params.debug.audit = AuditMode::every_substep;
  Simulation sim(std::move(scene));
  Index penetrations = 0;
  sim.set_audit([&](const Positions& x) {
    const Index n = audit.audit_next(x).penetrations();
    penetrations += n;
    return n;
  });
  for (int f = 1; f <= frames; ++f) {
    const FrameStats fs = sim.step_frame();
    if (remaining) *remaining += fs.violations_remaining;
  }
  return penetrations;
}

class AdaptiveReachSolvers : public ::testing::TestWithParam<std::string> {};

// Scripted vertices (the paddle, subdivided pieces), strands swept aside, and passes that fix
// every vertex the pass before did not hold back (time.continuation: held_back): every substep
// clean under the exact audit with the adaptive reach.
TEST_P(AdaptiveReachSolvers, PaddleThroughStrandsIsCleanAtEverySubstep) {
  test::ExpectWarnings may_warn;
  for (auto mode : {TimeParams::Continuation::full, TimeParams::Continuation::held_back}) {
    Index remaining = 0;
    EXPECT_EQ(audited_substeps(paddle_through_strands(GetParam(), 0.25, mode), 10, &remaining), 0)
        << GetParam() << (mode == TimeParams::Continuation::full ? ", full passes" : ", held_back");
    EXPECT_EQ(remaining, 0);
  }
}

// A rigid body (its vertices keep r) falls onto the coils as they pile, with and without
// contact.momentum: every substep clean.
TEST_P(AdaptiveReachSolvers, RigidBoxOnPilingCoilsIsCleanAtEverySubstep) {
  test::ExpectWarnings may_warn;
  for (bool momentum : {false, true}) {
    Scene s = coils_on_a_floor(GetParam(), 0.25, true);
    s.params.contact.momentum = momentum;
    Index remaining = 0;
    EXPECT_EQ(audited_substeps(std::move(s), 20, &remaining), 0) << GetParam() << ", momentum " << momentum;
    EXPECT_EQ(remaining, 0);
  }
}

// The coils land, tangle and pile (frames 12-40): every frame clean under the exact audit with
// and without the adaptive reach, and the adaptive run tests far fewer candidate pairs while the
// pile comes to the same height.
TEST_P(AdaptiveReachSolvers, CoilsPilingOnAFloorStayCleanAndTestFewerPairs) {
  test::ExpectWarnings may_warn;  // the coils' close turns start within ξ (reduced offsets)
  const int frames = 40;
  const PileRun uniform = run_pile(GetParam(), 0.0, frames);
  const PileRun adaptive = run_pile(GetParam(), 0.25, frames);
  EXPECT_EQ(uniform.penetrations, 0);
  EXPECT_EQ(uniform.remaining, 0);
  EXPECT_EQ(adaptive.penetrations, 0);
  EXPECT_EQ(adaptive.remaining, 0);
  EXPECT_LT(static_cast<double>(adaptive.candidates), 0.8 * static_cast<double>(uniform.candidates))
      << adaptive.candidates << " against " << uniform.candidates;
  EXPECT_NEAR(adaptive.lowest_centre, uniform.lowest_centre, 0.01);
  std::printf(
      "[ measure  ] coils on a floor, %s, %d frames: candidates %lld (adaptive 0.25) against %lld (r), "
      "centre height %.4f against %.4f m\n",
      GetParam().c_str(), frames, static_cast<long long>(adaptive.candidates),
      static_cast<long long>(uniform.candidates), adaptive.lowest_centre, uniform.lowest_centre);
}

/// The snapping scenes' settings, for the scene's last object (a strand): stiff edges, 60 fps x 10
/// substeps of 1 iteration and 20 sweeps, r = kR, ξ = 2 mm, free space, no damping.
void snapping_settings(Scene& s, const std::string& solver, bool momentum) {
  MaterialParams& m = s.params.objects.back().material;
  set_material_key(m, "stretch_compliance", 1e-9);
  set_material_key(m, "bend_compliance", 1.0);
  s.params.contact.solver = solver;
  s.params.contact.radius = kR;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0005;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = 10;
  s.params.time.iterations = 1;
  s.params.time.xpbd_sweeps = 20;
  s.params.time.damping = 0.0;
  s.params.time.gravity = Vec3::Zero();
}

/// Strand vertex v at rest at `rest`, placed at 10 times it; 10 g if `heavy`, else 1 g.
void stretched_vertex(Scene& s, Index v, const Vec3& rest, bool heavy) {
  s.state.rest[v] = rest;
  s.state.x[v] = 10.0 * rest;
  s.state.mass[v] = heavy ? 0.01 : 0.001;
  s.state.inv_mass[v] = 1.0 / s.state.mass[v];
}

/// A strand of 3 vertices and 10 mm rest edges, stretched along x to 10 times its length and let go
/// in free space (no gravity, no damping; two adjacent edges, so no pair of its own to detect): its
/// first vertex weighs ten times each other's. Its stiff edges snap it back within a substep, the
/// light end moving about 0.16 m (32 r) against the 4 passes x r = 20 mm a substep allows under
/// the paper's bound (60 fps x 10 substeps, 1 iteration).
Scene snapping_strand(const std::string& solver, bool momentum) {
  const Index nv = 3;
  TopologyBuilder tb;
  std::vector<Index> line(static_cast<size_t>(nv));
  for (Index i = 0; i < nv; ++i) line[static_cast<size_t>(i)] = i;
  tb.add_object("strand", ObjectKind::strand, nv, {}, {}, {line});
  Scene s;
  s.topo = tb.finish();
  s.state.resize(nv);
  for (Index i = 0; i < nv; ++i) stretched_vertex(s, i, Vec3(0.01 * static_cast<double>(i), 0, 0), i == 0);
  s.state.x_prev = s.state.x;
  s.params.objects.resize(1);
  snapping_settings(s, solver, momentum);
  return s;
}

/// The snapping strand's momentum along x after `frames` frames (it starts at 0), its length along
/// its edges, its vertices held back at the end of a substep and the warnings logged.
struct SnapRun {
  double momentum = 0.0, length = 0.0;
  Index clamped = 0;
  int warnings = 0;
};
SnapRun run_snap(const std::string& solver, bool momentum, int frames, bool free_islands = true) {
  test::ExpectWarnings may_warn;
  test::counting_sink()->warnings = 0;
  Scene s = snapping_strand(solver, momentum);
  s.params.contact.free_islands = free_islands;
  Simulation sim(std::move(s));
  SnapRun out;
  for (int f = 0; f < frames; ++f) out.clamped += sim.step_frame().clamped_vertices;
  const auto& st = sim.scene().state;
  for (Index i = 0; i < st.size(); ++i) out.momentum += st.mass[i] * st.v[i].x();
  for (Index i = 1; i < st.size(); ++i) out.length += (st.x[i] - st.x[i - 1]).norm();
  out.warnings = test::counting_sink()->warnings;
  return out;
}

// No force from outside, so the strand's momentum stays 0 (XPBD's constraints are equal and
// opposite, weighted by the inverse masses). The paper's bound (contact.free_islands: false) cuts the
// light end's step and not the heavy end's: momentum appears from nowhere and the speed cap warns.
// By default the strand, a free island of its own, gets back the momentum the cut took, though its
// light end is still held back. Under contact.momentum the last pass takes the rest of each step:
// the momentum stays 0 to round-off and nothing is held back.
TEST_P(AdaptiveReachSolvers, AStrandSnappingFartherThanThePassesAllowKeepsItsMomentum) {
  const SnapRun paper = run_snap(GetParam(), false, 2, false), shared = run_snap(GetParam(), true, 2);
  const SnapRun island = run_snap(GetParam(), false, 2);
  // Scale: the light end's momentum at the snap, 1 g at about 0.15 m in 1/600 s.
  const double scale = 0.001 * 0.15 * 600.0;
  EXPECT_GT(paper.clamped, 0);
  EXPECT_GT(std::abs(paper.momentum), 0.05 * scale) << "the scene does not reach the bound";
  EXPECT_GT(paper.warnings, 0);
  EXPECT_NEAR(island.momentum, 0.0, 1e-9 * scale);
  EXPECT_GT(island.clamped, 0);  // still held back: the islands give back momentum, not the step
  EXPECT_EQ(shared.clamped, 0);
  EXPECT_NEAR(shared.momentum, 0.0, 1e-9 * scale);
  EXPECT_EQ(shared.warnings, 0);
  EXPECT_NEAR(shared.length, 0.02, 0.002);  // back at its rest length
  std::printf(
      "[ measure  ] snapping strand, %s: momentum after 2 frames %.3g kg m/s (paper's bound: %.3g, %lld "
      "vertices held back), length %.4f m (rest 0.02)\n",
      GetParam().c_str(), shared.momentum, paper.momentum, static_cast<long long>(paper.clamped), shared.length);
}

/// An L-shaped strand (10 mm edges, stretched 10 times: corners at the origin, (0.1, 0, 0) and
/// (0.1, 0.1, 0)) whose free end snaps back toward the origin into a fixed box (x and y in [0.015,
/// 0.06], z in [-0.01, 0.01]; 41 mm or more from the free end and 12 mm from the strand's other
/// edge when the last pass starts), with the kept sub-pair list (collision.reuse_skin 1: pairs
/// listed within 2r + ξ + r = 17 mm). With `box` false, the strand alone.
Scene l_strand_at_a_box(const std::string& solver, bool box) {
  gen::TriMesh obstacle = gen::box(Vec3(0.045, 0.045, 0.02));
  for (auto& p : obstacle.v) p += Vec3(0.0375, 0.0375, 0.0);
  TopologyBuilder tb;
  if (box) tb.add_object("box", ObjectKind::obstacle, static_cast<Index>(obstacle.v.size()), obstacle.f);
  tb.add_object("strand", ObjectKind::strand, 3, {}, {}, {{0, 1, 2}});
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  if (box)
    for (const Vec3& p : obstacle.v) s.state.x[k++] = p;
  const std::vector<Vec3> rest = {Vec3::Zero(), Vec3(0.01, 0, 0), Vec3(0.01, 0.01, 0)};
  for (Index i = 0; i < 3; ++i, ++k) stretched_vertex(s, k, rest[static_cast<size_t>(i)], i == 0);
  for (Index i = 0; i < (box ? static_cast<Index>(obstacle.v.size()) : 0); ++i) s.state.rest[i] = s.state.x[i];
  s.state.x_prev = s.state.x;
  s.params.objects.resize(box ? 2 : 1);
  snapping_settings(s, solver, true);
  s.params.collision.reuse_skin = 1.0;
  return s;
}

// The last pass's reach runs past the kept list's 2r + ξ + s: such a pass must neither read nor
// build the list, or the box, out of the list's reach when the pass starts, is missed and the
// free end snaps into it. Independent answers: the strand alone, whose free end ends inside the
// box's space, and the exact audit after every substep with the box.
TEST_P(AdaptiveReachSolvers, ALastPassStepPastTheKeptListsReachStillMeetsWhatIsInIt) {
  {
    Scene scene = l_strand_at_a_box(GetParam(), false);
    scene.params.debug.audit = AuditMode::every_substep;
    Simulation alone(std::move(scene));
    Vec3 end = Vec3::Zero();
    int substeps = 0;
    alone.set_audit([&](const Positions& x) {
      if (substeps++ == 0) end = x[2];  // where the first substep leaves the free end
      return Index{0};
    });
    alone.step_frame();
    EXPECT_TRUE(end.x() > 0.015 && end.x() < 0.06 && end.y() > 0.015 && end.y() < 0.06)
        << "the free end does not reach the box's space: " << end.transpose();
  }
  Index remaining = 0;
  EXPECT_EQ(audited_substeps(l_strand_at_a_box(GetParam(), true), 3, &remaining), 0);
  EXPECT_EQ(remaining, 0);
}

INSTANTIATE_TEST_SUITE_P(Solvers, AdaptiveReachSolvers, ::testing::Values("ccfr", "exact_projection"),
                         [](const auto& info) { return info.param; });

// The kept list is built at the uniform reach: the two settings together are refused, naming the
// key; a solver that bounds every vertex by r warns and runs as with the setting off.
TEST(AdaptiveReach, RefusedWithTheKeptListIgnoredWithAWarningByOtherSolvers) {
  Scene listed = coils_on_a_floor("ccfr", 0.25);
  listed.params.collision.reuse_skin = 1.0;
  try {
    Simulation sim(std::move(listed));
    ADD_FAILURE() << "adaptive_reach with reuse_skin was accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("contact.adaptive_reach: ", 0), 0u) << what;
    EXPECT_NE(what.find("collision.reuse_skin"), std::string::npos) << what;
  }
  test::ExpectWarnings warns;
  Simulation off(coils_on_a_floor("ogc", 0.0)), on(coils_on_a_floor("ogc", 0.25));
  for (int f = 0; f < 3; ++f) {
    off.step_frame();
    on.step_frame();
  }
  EXPECT_EQ(off.positions(), on.positions());
}

}  // namespace
