// Contact solvers inside the simulation loop, against closed-form motion.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/solvers/contact_response.hpp"
#include "ccfr/solvers/region_projection_solver.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {
/// The puck of scenes.hpp resting in the repulsion band (at the offset plus most of δ = 0.002).
Scene floor_scene(double speed, double mu_s, double mu_k, const std::string& solver) {
  return ccfr::test::floor_puck_scene(0.0115, speed, solver, 0.002, mu_s, mu_k);
}

/// 20,000 contacts at gaps in [0, 0.006) beyond an offset of 0.01, their query vertex drawn from
/// [0, n): with `distinct`, all four vertices are distinct ones of [0, n); otherwise the other
/// three are n + 100, n + 101, n + 102.
std::vector<ContactPair> random_contacts(std::uint64_t seed, Index n, bool distinct) {
  auto rng = ccfr::test::rng(seed);
  std::uniform_int_distribution<Index> vertex(0, n - 1);
  std::uniform_real_distribution<double> U(0.0, 0.006);
  std::vector<ContactPair> cs(20000);
  for (auto& c : cs) {
    if (distinct) {
      Index v[4];
      for (int k = 0; k < 4; ++k) {
        bool again = true;
        while (again) {
          v[k] = vertex(rng);
          again = false;
          for (int j = 0; j < k; ++j) again = again || v[j] == v[k];
        }
      }
      c.v = {v[0], v[1], v[2], v[3]};
    } else {
      c.v = {vertex(rng), n + 100, n + 101, n + 102};
    }
    c.distance = 0.01 + U(rng);
    c.offset = 0.01;
  }
  return cs;
}
}  // namespace

TEST(FloorSliding, FrictionlessVertexKeepsItsTangentialVelocityUnderCcfr) {
  // The paper's floor comparison: the region of a vertex near a floor only cuts motion toward the
  // floor, so sliding along it is not slowed (a distance-based trust region of radius
  // d - xi = 0.0015 m per iteration would allow at most 0.0015 * 4 * 10 * 60 = 3.6 m/s... and a
  // TOI bound would not limit this motion either; the CCFR bound is the step r per iteration).
  Simulation sim(floor_scene(1.0, 0.0, 0.0, "ccfr"));
  const Index p = sim.topology().num_vertices() - 1;
  for (int f = 0; f < 30; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0);
    EXPECT_GE(sim.positions()[p].y(), 0.01 - 1e-9) << "frame " << f;
  }
  // 0.5 s at 1 m/s; vertical motion only within the repulsion band.
  EXPECT_NEAR(sim.positions()[p].x(), 0.5, 0.005);
  EXPECT_NEAR(sim.scene().state.v[p].x(), 1.0, 0.01);
}

TEST(FloorSliding, KineticFrictionDeceleratesLikeCoulomb) {
  // Closed form: a puck sliding with mu_k stops after v0^2 / (2 mu_k g).
  const double v0 = 1.0, mu = 0.3, g = 9.81;
  Simulation sim(floor_scene(v0, mu, mu, "ccfr"));
  const Index p = sim.topology().num_vertices() - 1;
  for (int f = 0; f < 60; ++f) sim.step_frame();
  const double expected = v0 * v0 / (2 * mu * g);
  EXPECT_NEAR(sim.positions()[p].x(), expected, 0.15 * expected);
  EXPECT_LT(std::abs(sim.scene().state.v[p].x()), 0.02);
  EXPECT_GE(sim.positions()[p].y(), 0.01 - 1e-9);
}

TEST(FloorSliding, EveryRegionSolverKeepsTheOffset) {
  for (const char* solver : {"ccfr", "exact_projection", "successive_projection"}) {
    Scene s = floor_scene(0.5, 0.0, 0.0, solver);
    s.params.contact.repulsion_range = 0.0;  // no response: the region alone must hold the puck
    s.state.x.back().y() = 0.0101;
    s.state.rest = s.state.x_prev = s.state.x;
    Simulation sim(std::move(s));
    const Index p = sim.topology().num_vertices() - 1;
    for (int f = 0; f < 20; ++f) sim.step_frame();
    EXPECT_GE(sim.positions()[p].y(), 0.01 - 1e-9) << solver;
    // Resting at exactly xi, the puck is slowed where it crosses the floor's diagonal edges: the
    // neighbouring triangle's closest point lies on the shared edge, so its half-space is tilted
    // (docs/results.md, "Sliding at exactly xi"). It must still advance.
    EXPECT_GT(sim.positions()[p].x(), 0.8 * 0.5 * 20 / 60.0) << solver;
    EXPECT_LE(sim.positions()[p].x(), 0.5 * 20 / 60.0 + 1e-9) << solver;
  }
}

TEST(Halting, TightRegionsReportHaltingInsteadOfHanging) {
  // A particle caged at the centre of a small icosphere whose radius barely exceeds xi: all 80
  // faces are within range and their half-spaces bound a tiny polytope. Gravity and a sideways
  // kick push the candidate through many of them at once; with one projection pass allowed the
  // sequential recursion (at most three independent planes in 3-D) cannot always finish. Without
  // the exact fallback (the paper) those projections fall back to the anchor and must be counted;
  // with it (the default) the same projections take the exact projection and nothing halts.
  // Either way nothing may stay outside its region, and nothing may become non-finite.
  const auto cage = gen::sphere(0.0112, 1);  // inradius 0.0105 > xi: every pair starts outside the offset
  for (const bool fallback : {false, true}) {
    Scene s = test::obstacle_and_particle(cage, "cage", "grain");
    const Index p = s.topo.num_vertices() - 1;
    s.state.x[p] = Vec3(0.0001, 0.0002, -0.0001);
    s.state.v[p] = Vec3(0.3, -0.5, 0.2);
    s.state.mass[p] = 1e-3;
    s.state.inv_mass[p] = 1e3;
    s.state.rest = s.state.x_prev = s.state.x;
    s.params.contact.offset = 0.01;
    s.params.contact.radius = 0.005;
    s.params.contact.repulsion_range = 0.0;
    s.params.contact.solver_params.set("max_iterations", 1LL);
    s.params.contact.solver_params.set("exact_fallback", fallback);
    // The projector's own path: contact.momentum would close the grain's contacts in the response,
    // before any projection is asked for.
    s.params.contact.momentum = false;
    s.params.time.substeps = 4;
    s.params.time.iterations = 2;
    Simulation sim(std::move(s));
    Index halted = 0, rescues = 0, halted_distinct = 0;
    for (int f = 0; f < 30; ++f) {
      const FrameStats fs = sim.step_frame();
      halted += fs.halted_vertices;
      rescues += fs.projector_rescues;
      halted_distinct += fs.halted_vertices_distinct;
      EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
      // One particle: it halts in a frame or not, however many passes it halts in.
      EXPECT_EQ(fs.halted_vertices_distinct, fs.halted_vertices > 0 ? 1 : 0) << "frame " << f;
      EXPECT_EQ(fs.contact_vertices_distinct, fs.contact_vertices > 0 ? 1 : 0) << "frame " << f;
      if (std::getenv("CCFR_TEST_VERBOSE"))
        std::printf("frame %d: x = %s, violations %d, halted %d, rescued %d\n", f,
                    ::testing::PrintToString(sim.positions()[p].transpose()).c_str(), fs.violations_detected,
                    fs.halted_vertices, fs.projector_rescues);
    }
    if (fallback) {
      EXPECT_EQ(halted, 0) << "the exact projection exists whenever the anchor is feasible";
      EXPECT_GT(rescues, 0) << "the scene was meant to make single-pass projections fail";
    } else {
      EXPECT_GT(halted, 0) << "the scene was meant to make single-pass projections halt";
      EXPECT_GT(halted_distinct, 0);
      EXPECT_EQ(rescues, 0);
    }
    const Vec3 x = sim.positions()[p];
    ASSERT_TRUE(x.allFinite());
    for (const auto& f : cage.f) {  // still inside, at least xi from every face's plane
      const Vec3 n = (cage.v[f[1]] - cage.v[f[0]]).cross(cage.v[f[2]] - cage.v[f[0]]).normalized();
      EXPECT_GE(n.dot(cage.v[f[0]] - x), 0.01 - 1e-9) << "fallback " << fallback;
    }
  }
}

TEST(ContactResponse, VisibilityWeightsMatchTheProductDefinition) {
  // Brute force of w_c = prod_{j != c} (1 - S((d_c - d_j) / width)) over contacts of one query vertex.
  auto rng = ccfr::test::rng(7);
  std::uniform_real_distribution<double> U(0.0, 0.01);
  // Mixed offsets (pairs that started closer than ξ keep a reduced one): the gap is d - offset.
  std::vector<ContactPair> cs;
  for (int i = 0; i < 40; ++i) {
    ContactPair c;
    c.v = {i % 3, 10, 11, 12};
    c.distance = i % 5 == 1 ? cs.back().distance : 0.01 + U(rng);  // some ties: a factor of exactly 1
    c.offset = i % 4 == 0 ? 0.006 : 0.01;
    cs.push_back(c);
  }
  const double width = 0.004;
  const auto w = visibility_weights(cs, width);
  auto gap = [&](size_t i) { return cs[i].distance - cs[i].offset; };
  for (size_t c = 0; c < cs.size(); ++c) {
    double expect = 1.0;
    for (size_t j = 0; j < cs.size(); ++j)
      if (j != c && cs[j].v[0] == cs[c].v[0]) expect *= 1.0 - smoothstep((gap(c) - gap(j)) / width);
    // Bit-identical: the weights skip factors of exactly 1 and stop at 0, in the same order.
    EXPECT_EQ(w[c], expect) << c;
  }
}

TEST(ContactResponse, VisibilityWeightsOfManyShuffledGroupsMatchTheProductAtAnyThreadCount) {
  // 20,000 contacts of 500 query vertices in random order (the grouping runs in 32 blocks, which
  // split most groups), gaps within a few widths so that windows hold several contacts: every
  // weight equals the brute-force product over the same vertex's other contacts, taken in index
  // order, bit for bit, at 1 and 2 threads.
  const std::vector<ContactPair> cs = random_contacts(19, 500, false);
  const double width = 0.002;
  auto gap = [&](size_t i) { return cs[i].distance - cs[i].offset; };
  std::vector<std::vector<size_t>> groups(500);
  for (size_t i = 0; i < cs.size(); ++i) groups[static_cast<size_t>(cs[i].v[0])].push_back(i);
  std::vector<double> expect(cs.size());
  size_t partial = 0;
  for (size_t c = 0; c < cs.size(); ++c) {
    double w = 1.0;
    for (size_t j : groups[static_cast<size_t>(cs[c].v[0])])
      if (j != c && gap(j) < gap(c)) w *= 1.0 - smoothstep((gap(c) - gap(j)) / width);
    expect[c] = w;
    partial += w > 0.0 && w < 1.0;
  }
  EXPECT_GT(partial, 1000u) << "the test wants many weights strictly between 0 and 1";
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    const auto w = visibility_weights(cs, width);
    for (size_t c = 0; c < cs.size(); ++c)
      ASSERT_EQ(w[c], expect[c]) << "contact " << c << ", " << threads << " threads";
  }
  set_thread_count(0);
}

TEST(ContactResponse, VisibilityWeightsOfWideWindowsMatchTheProductBitForBit) {
  // Groups of 2 to 400 contacts whose gaps all lie within one width (windows past the 4 that are
  // scanned and past one 64-bit word of the nearer set), gaps on a coarse grid so that many tie,
  // and a NaN gap in some groups (never nearer than anything, nothing nearer than it: weight 1).
  // Expected: the product over the same vertex's strictly nearer contacts in index order.
  auto rng = ccfr::test::rng(41);
  std::uniform_int_distribution<int> grid(0, 40);
  const std::vector<int> sizes = {2, 4, 5, 16, 63, 64, 65, 130, 400};
  std::vector<ContactPair> cs;
  for (size_t g = 0; g < sizes.size(); ++g)
    for (int i = 0; i < sizes[g]; ++i) {
      ContactPair c;
      c.v = {static_cast<Index>(g), 900, 901, 902};
      c.distance = i == 1 && g % 2 == 1 ? std::numeric_limits<double>::quiet_NaN() : 0.01 + 5e-5 * grid(rng);
      c.offset = 0.01;
      cs.push_back(c);
    }
  std::shuffle(cs.begin(), cs.end(), rng);
  const double width = 0.0021;  // wider than the grid's 2 mm span: every contact is in its window
  auto gap = [&](size_t i) { return cs[i].distance - cs[i].offset; };
  std::vector<double> expect(cs.size());
  size_t partial = 0, nan = 0;
  for (size_t c = 0; c < cs.size(); ++c) {
    double w = 1.0;
    for (size_t j = 0; j < cs.size(); ++j)
      if (cs[j].v[0] == cs[c].v[0] && gap(j) < gap(c)) w *= 1.0 - smoothstep((gap(c) - gap(j)) / width);
    expect[c] = w;
    partial += w > 0.0 && w < 1.0;
    nan += std::isnan(gap(c));
  }
  EXPECT_GT(partial, 300u);
  EXPECT_EQ(nan, 4u);
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    const auto w = visibility_weights(cs, width);
    for (size_t c = 0; c < cs.size(); ++c)
      ASSERT_EQ(w[c], expect[c]) << "contact " << c << " of vertex " << cs[c].v[0] << ", " << threads << " threads";
  }
  set_thread_count(0);
}

TEST(ContactResponse, VisibilityWeightsFromTheIncidenceEqualTheGroupedOnes) {
  // 20,000 contacts of 4 vertices each among 900; a third of the vertices immovable (pinned or
  // scripted), so many contacts have a query vertex that lists nothing and are grouped by the scan.
  // The incidence is built as the region assembly builds it: every contact's slot under each of its
  // movable vertices, in contact order. Both ways must give the same weights bit for bit.
  const std::vector<ContactPair> cs = random_contacts(23, 900, true);
  std::vector<std::uint8_t> movable(900);
  for (Index v = 0; v < 900; ++v) movable[v] = v % 3 != 0;
  std::vector<Index> row_start(901, 0), slots;
  for (const auto& c : cs)
    for (int k = 0; k < 4; ++k) row_start[c.v[k] + 1] += movable[c.v[k]];
  for (size_t v = 0; v < 900; ++v) row_start[v + 1] += row_start[v];
  slots.resize(static_cast<size_t>(row_start.back()));
  std::vector<Index> at(row_start.begin(), row_start.end() - 1);
  for (size_t i = 0; i < cs.size(); ++i)
    for (int k = 0; k < 4; ++k)
      if (movable[cs[i].v[k]]) slots[at[cs[i].v[k]]++] = static_cast<Index>(4 * i + k);
  const double width = 0.002;
  const auto expect = visibility_weights(cs, width);
  size_t partial = 0;
  for (double w : expect) partial += w > 0.0 && w < 1.0;
  EXPECT_GT(partial, 1000u) << "the test wants many weights strictly between 0 and 1";
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    std::vector<double> w;
    VisibilityWorkspace ws;
    visibility_weights(cs, row_start, slots, width, w, ws);
    ASSERT_EQ(w.size(), cs.size());
    for (size_t c = 0; c < cs.size(); ++c)
      ASSERT_EQ(w[c], expect[c]) << "contact " << c << ", " << threads << " threads";
    // The grouping's own path: one cursor block at one thread, several at two.
    EXPECT_EQ(visibility_weights(cs, width), expect) << threads << " threads";
  }
  set_thread_count(0);
  std::vector<double> w;
  VisibilityWorkspace ws;
  const std::vector<Index> short_row_start(row_start.begin(), row_start.end() - 1);
  EXPECT_THROW(visibility_weights(cs, short_row_start, slots, width, w, ws), Error);
}

TEST(ContactResponse, VisibilityWeightsSkipOnlyGroupsTheResponseCannotMove) {
  // The same contacts with the response's inverse masses given: a third of the vertices listed but
  // masked (an unpinned rigid body's, resolved by its pose solve). A group (a listed query vertex's
  // contacts) in which some contact has a vertex of inverse mass > 0 keeps its exact weights (those
  // of the definition); the others, which apply() skips, weigh 1. With every inverse mass 0, every
  // weight is 1.
  std::vector<ContactPair> cs = random_contacts(29, 900, true);
  // Vertices 600-899 are masked, and the contacts of their queries stay among them (a body's own
  // contacts with another body): those groups are the ones the response cannot move.
  for (auto& c : cs)
    if (c.v[0] >= 600)
      for (int k = 1; k < 4; ++k) c.v[k] = 600 + (c.v[0] - 600 + 7 * k) % 300;
  std::vector<Index> row_start(901, 0), slots;
  for (const auto& c : cs)
    for (int k = 0; k < 4; ++k) ++row_start[c.v[k] + 1];
  for (size_t v = 0; v < 900; ++v) row_start[v + 1] += row_start[v];
  slots.resize(static_cast<size_t>(row_start.back()));
  std::vector<Index> at(row_start.begin(), row_start.end() - 1);
  for (size_t i = 0; i < cs.size(); ++i)
    for (int k = 0; k < 4; ++k) slots[at[cs[i].v[k]]++] = static_cast<Index>(4 * i + k);
  std::vector<double> inv_mass(900);
  for (Index v = 0; v < 900; ++v) inv_mass[v] = v >= 600 ? 0.0 : 2.0;
  const double width = 0.002;
  const auto expect = visibility_weights(cs, width);
  std::vector<std::uint8_t> group_moves(900, 0);
  for (const auto& c : cs)
    for (int k = 0; k < 4; ++k) group_moves[c.v[0]] |= inv_mass[c.v[k]] > 0.0;
  std::vector<double> w;
  VisibilityWorkspace ws;
  visibility_weights(cs, row_start, slots, width, w, ws, inv_mass);
  ASSERT_EQ(w.size(), cs.size());
  size_t skipped = 0;
  for (size_t c = 0; c < cs.size(); ++c) {
    if (group_moves[cs[c].v[0]]) {
      ASSERT_EQ(w[c], expect[c]) << "contact " << c;
    } else {
      ++skipped;
      ASSERT_EQ(w[c], 1.0) << "contact " << c;
    }
  }
  EXPECT_GT(skipped, 5000u);
  size_t partial = 0;
  for (size_t c = 0; c < cs.size(); ++c) partial += group_moves[cs[c].v[0]] && expect[c] > 0.0 && expect[c] < 1.0;
  EXPECT_GT(partial, 500u) << "the test wants many exact weights strictly between 0 and 1";
  const std::vector<double> none(900, 0.0);
  visibility_weights(cs, row_start, slots, width, w, ws, none);
  for (size_t c = 0; c < cs.size(); ++c) ASSERT_EQ(w[c], 1.0) << "contact " << c;
  std::fill(inv_mass.begin(), inv_mass.end(), 0.0);
  inv_mass[cs[0].v[1]] = 1.0;  // one movable vertex: only groups with a contact on it are weighed
  visibility_weights(cs, row_start, slots, width, w, ws, inv_mass);
  EXPECT_EQ(w[0], expect[0]);
}

TEST(ContactResponse, RepulsionOverManyBlocksOfMostlyInactiveContactsMatchesTheClosedForm) {
  // 7,001 vertex-vertex contacts, each a movable vertex (m⁻¹ = 2) at height h over its own pinned
  // one, n = +y: the contacts span 4 of the response's blocks and two in three lie beyond δ. A
  // lone contact within δ moves its vertex by m⁻¹ Δλ, Δλ = (δ - g) / (m⁻¹ + α̃), g = h - ξ,
  // α̃ = 1 / (k dt²); the others stay, at 1 and 2 threads alike, bit for bit.
  const Index n = 7001;
  ContactParams params;
  params.offset = 0.006;
  params.repulsion_range = 0.002;
  params.friction_static = params.friction_kinetic = 0.0;
  const double dt = 1.0 / 240.0, alpha = 1.0 / (params.stiffness * dt * dt);
  Positions x(static_cast<size_t>(2 * n));
  std::vector<double> inv_mass(x.size(), 0.0);
  std::vector<ContactPair> cs(static_cast<size_t>(n));
  std::vector<double> expect_y(static_cast<size_t>(n));
  Index within = 0;
  for (Index i = 0; i < n; ++i) {
    // Every third contact inside δ, each at its own gap; the others at 1.5 δ and exactly δ
    // (outside: g ≥ δ is inactive).
    const double inside = 0.1 + 0.8 * static_cast<double>((37 * i) % 101) / 100.0;
    const double g = (i % 3 == 0 ? inside : i % 3 == 1 ? 1.5 : 1.0) * params.repulsion_range;
    const double h = params.offset + g;
    x[static_cast<size_t>(2 * i)] = Vec3(0.1 * i, 0.0, 0.0);
    x[static_cast<size_t>(2 * i + 1)] = Vec3(0.1 * i, h, 0.0);
    inv_mass[static_cast<size_t>(2 * i + 1)] = 2.0;
    ContactPair& c = cs[static_cast<size_t>(i)];
    c.kind = ContactKind::vv;
    c.v = {2 * i + 1, 2 * i, -1, -1};
    c.w = {1.0, -1.0, 0.0, 0.0};
    c.n = Vec3::UnitY();
    c.distance = h;
    c.offset = params.offset;
    const bool active = g < params.repulsion_range;
    within += active;
    expect_y[static_cast<size_t>(i)] = active ? h + 2.0 * ((params.repulsion_range - g) / (2.0 + alpha)) : h;
  }
  Positions first;
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    ContactResponse response;
    response.prepare(cs, static_cast<Index>(x.size()), params);
    Positions moved = x;
    response.apply(moved, x, inv_mass, params, dt, {});
    EXPECT_EQ(response.active(), within);
    for (Index i = 0; i < n; ++i) {
      const Vec3& p = moved[static_cast<size_t>(2 * i + 1)];
      ASSERT_NEAR(p.y(), expect_y[static_cast<size_t>(i)], 1e-15) << "contact " << i << ", " << threads << " threads";
      ASSERT_EQ(p.x(), 0.1 * i);
      ASSERT_EQ(moved[static_cast<size_t>(2 * i)], x[static_cast<size_t>(2 * i)]) << "a pinned vertex moved";
    }
    if (first.empty())
      first = moved;
    else
      EXPECT_EQ(moved, first) << "the thread count changed the response";
  }
  set_thread_count(0);
}

TEST(ContactResponse, DetectorIncidenceGivesTheResponseOfItsOwnIndex) {
  // Three stacked sheets 8 mm apart (r = 5 mm, ξ = 6 mm), jittered, the bottom one pinned: the
  // incidence the detector records beside its half-spaces must name, for every plane, a contact
  // of that vertex with that plane's normal, and drive the response to bit-identical positions.
  TopologyBuilder tb;
  Positions x;
  std::vector<double> inv_mass;
  auto rng = ccfr::test::rng(11);
  std::uniform_real_distribution<double> jitter(-0.0008, 0.0008);
  for (int layer = 0; layer < 3; ++layer) {
    const gen::TriMesh m = gen::plane(0.2, 12);
    tb.add_object("sheet" + std::to_string(layer), layer == 0 ? ObjectKind::obstacle : ObjectKind::cloth,
                  static_cast<Index>(m.v.size()), m.f);
    for (const Vec3& p : m.v) {
      x.push_back(p + Vec3(jitter(rng), 0.008 * layer + jitter(rng), jitter(rng)));
      inv_mass.push_back(layer == 0 ? 0.0 : 1.0 + (x.size() % 3));
    }
  }
  const Topology topo = tb.finish();
  ContactParams params;
  params.radius = 0.005;
  params.offset = 0.006;
  params.repulsion_range = 0.002;
  params.friction_static = 0.4;
  params.friction_kinetic = 0.3;
  CollisionDetector det(topo, x, params, make_broad_phase("bvh"));
  det.set_record_plane_sources(true);
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(x, inv_mass, regions, contacts, stats);
  const std::span<const Index> sources = det.plane_sources();
  ASSERT_GT(contacts.size(), 100u);
  ASSERT_EQ(sources.size(), regions.total());
  for (Index v = 0; v < regions.num_vertices(); ++v) {
    Index previous = -1;
    for (Index i = regions.row_start[v]; i < regions.row_start[v + 1]; ++i) {
      const Index s = sources[i], ci = s / 4, k = s % 4;
      ASSERT_LT(static_cast<size_t>(ci), contacts.size());
      const ContactPair& c = contacts[ci];
      ASSERT_EQ(c.v[k], v);
      EXPECT_GT(ci, previous) << "contact order";
      previous = ci;
      EXPECT_EQ(regions.plane(i).n, k < c.side_a() ? c.n : Vec3(-c.n));
    }
  }

  // The recorded incidence against the response's own index, on positions pushed into the band.
  Positions moved = x;
  for (size_t i = 0; i < moved.size(); ++i)
    if (inv_mass[i] > 0.0) moved[i].y() -= 0.003 * static_cast<double>(i % 2);
  ContactResponse own, recorded;
  own.prepare(contacts, topo.num_vertices(), params);
  recorded.prepare(contacts, regions.row_start, sources, params);
  Positions a = moved, b = moved;
  own.apply(a, x, inv_mass, params, 1.0 / 240.0, {});
  recorded.apply(b, x, inv_mass, params, 1.0 / 240.0, {});
  EXPECT_GT(own.active(), 0);
  EXPECT_EQ(own.active(), recorded.active());
  size_t moved_count = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i], b[i]) << i;  // bit-identical
    moved_count += a[i] != moved[i];
  }
  EXPECT_GT(moved_count, 50u);

  // An incidence whose row starts do not span its slots is refused.
  std::vector<Index> short_row_start(regions.row_start.begin(), regions.row_start.end() - 1);
  EXPECT_THROW(recorded.prepare(contacts, short_row_start, sources, params), Error);
  // Prepared without a repulsion range, the response has no weights: applying one is refused.
  ContactParams no_repulsion = params;
  no_repulsion.repulsion_range = 0.0;
  recorded.prepare(contacts, regions.row_start, sources, no_repulsion);
  Positions c = moved;
  recorded.apply(c, x, inv_mass, no_repulsion, 1.0 / 240.0, {});  // nothing to do
  EXPECT_EQ(c, moved);
  EXPECT_THROW(recorded.apply(c, x, inv_mass, params, 1.0 / 240.0, {}), Error);
  // Without recording nothing is listed.
  det.set_record_plane_sources(false);
  det.detect(x, inv_mass, regions, contacts, stats);
  EXPECT_TRUE(det.plane_sources().empty());
}

namespace {
/// A rigid body answering `n` vertex-face contacts of one side: vertex i (movable, mass m_i) over a
/// face of the body (its three vertices masked, at 1 m below), each overlapping its offset by
/// E_i along n = +z. The body gives way along -z with inverse mass 1/M and world inverse inertia
/// I⁻¹; each contact's closest point sits at arm r_i from its centre.
struct BodyAndVertices {
  std::vector<ContactPair> contacts;
  Positions x;
  std::vector<double> inv_mass;
  std::vector<Index> body;
  std::vector<double> w_o;
  std::vector<Vec3> arm, away;
  std::vector<double> body_inv_mass;
  std::vector<Eigen::Matrix3d> body_inv_inertia;
  AnsweringBodies view() const { return {body, w_o, arm, away, body_inv_mass, body_inv_inertia}; }
};

BodyAndVertices body_under_vertices(const std::vector<double>& mass, const std::vector<double>& overlap,
                                    const std::vector<Vec3>& arms, double body_mass,
                                    const Eigen::Matrix3d& inv_inertia) {
  BodyAndVertices s;
  const Index n = static_cast<Index>(mass.size());
  s.x.assign(static_cast<size_t>(n) + 3, Vec3::Zero());
  s.inv_mass.assign(static_cast<size_t>(n) + 3, 0.0);
  s.x[n] = Vec3(-1, -1, -1), s.x[n + 1] = Vec3(1, -1, -1), s.x[n + 2] = Vec3(0, 1, -1);
  s.body_inv_mass = {1.0 / body_mass};
  s.body_inv_inertia = {inv_inertia};
  const double offset = 0.01;
  for (Index i = 0; i < n; ++i) {
    s.x[i] = arms[static_cast<size_t>(i)];
    s.inv_mass[i] = 1.0 / mass[static_cast<size_t>(i)];
    ContactPair c;
    c.kind = ContactKind::vf;
    c.v = {i, n, n + 1, n + 2};
    c.w = {1.0, -1.0 / 3, -1.0 / 3, -1.0 / 3};
    c.n = Vec3::UnitZ();
    c.offset = offset;
    c.distance = offset - overlap[static_cast<size_t>(i)];
    s.contacts.push_back(c);
    const Vec3 away = -Vec3::UnitZ(), r = arms[static_cast<size_t>(i)];
    s.body.push_back(0);
    s.arm.push_back(r);
    s.away.push_back(away);
    s.w_o.push_back(1.0 / body_mass + r.cross(away).dot(inv_inertia * r.cross(away)));
  }
  return s;
}

/// `response` run on `s` as RegionProjectionSolver runs it, the body answering.
void separate_from_body(BodyAndVertices& s, ContactResponse& response) {
  response.prepare(s.contacts, static_cast<Index>(s.x.size()), ContactParams{});
  const Positions anchor = s.x;
  const AnsweringBodies bodies = s.view();
  response.separate(s.x, anchor, s.inv_mass, DetectingSolver::kSeparateSweeps, 0.0, &bodies);
}

/// The perfectly inelastic answer: impulses J_i >= 0 along n on the vertices (-J_i on the body)
/// with every contact closed, w = A J - E >= 0, and J_i w_i = 0 (a contact the others open takes
/// none), A_ij = δ_ij / m_i + d·(M⁻¹ d + I⁻¹(r_j × d) × r_i). A is positive definite, so this
/// LCP has one solution: found by trying every active set (n <= 8).
Eigen::VectorXd inelastic_impulses(const BodyAndVertices& s, const std::vector<double>& mass,
                                   const std::vector<double>& overlap) {
  const Index n = static_cast<Index>(mass.size());
  Eigen::MatrixXd a(n, n);
  Eigen::VectorXd e(n);
  const Vec3 d = -Vec3::UnitZ();
  for (Index i = 0; i < n; ++i) {
    e(i) = overlap[static_cast<size_t>(i)];
    for (Index j = 0; j < n; ++j) {
      const Vec3 shift = s.body_inv_mass[0] * d + (s.body_inv_inertia[0] * s.arm[j].cross(d)).cross(s.arm[i]);
      a(i, j) = d.dot(shift) + (i == j ? 1.0 / mass[static_cast<size_t>(i)] : 0.0);
    }
  }
  for (unsigned set = 1; set < (1u << n); ++set) {
    std::vector<Index> in;
    for (Index i = 0; i < n; ++i)
      if (set & (1u << i)) in.push_back(i);
    const Index k = static_cast<Index>(in.size());
    Eigen::MatrixXd as(k, k);
    Eigen::VectorXd es(k);
    for (Index i = 0; i < k; ++i) {
      es(i) = e(in[i]);
      for (Index j = 0; j < k; ++j) as(i, j) = a(in[i], in[j]);
    }
    const Eigen::VectorXd js = as.llt().solve(es);
    Eigen::VectorXd j = Eigen::VectorXd::Zero(n);
    for (Index i = 0; i < k; ++i) j(in[i]) = js(i);
    const Eigen::VectorXd w = a * j - e;
    if ((j.array() >= 0.0).all() && (w.array() >= -1e-12).all()) return j;
  }
  return Eigen::VectorXd::Zero(n);
}
}  // namespace

TEST(ContactResponse, ABodyInManyContactsAnswersTheirSummedImpulsesOnceAndClosesEveryOverlap) {
  // Eight vertices of 1 kg on a 1 kg body, each overlapping by 1 mm: asked for its share by each
  // contact as if alone (1/2 E each), summed, the body moved 4 E where the inelastic answer is
  // 8/9 E. Then unequal masses, overlaps and arms, on a body that translates and on one that turns.
  // Independent answers: the closed form, and the LCP of the inelastic impulses (every active set).
  {
    const std::vector<double> mass(8, 1.0), overlap(8, 0.001);
    const std::vector<Vec3> arms(8, Vec3::Zero());
    BodyAndVertices s = body_under_vertices(mass, overlap, arms, 1.0, Eigen::Matrix3d::Zero());
    ContactResponse response;
    const Positions anchor = s.x;
    separate_from_body(s, response);
    ASSERT_EQ(response.body_impulse().size(), 1u);
    const double body_shift = -response.body_impulse()[0].z() / 1.0;
    EXPECT_NEAR(body_shift, 8.0 / 9.0 * 0.001, 1e-9);
    for (Index i = 0; i < 8; ++i) EXPECT_NEAR(s.x[i].z(), 0.001 / 9.0, 1e-9) << i;
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst_excess = 0.0, worst_opening = 0.0;
  for (int trial = 0; trial < 40; ++trial) {
    // The first 20 on a body that only translates (its contacts parallel), then on one that turns.
    const bool turns = trial >= 20;
    const int n = 3 + trial % 6;
    std::vector<double> mass, overlap;
    std::vector<Vec3> arms;
    for (int i = 0; i < n; ++i) {
      mass.push_back(std::pow(10.0, 2.0 * u(rng) - 1.0));  // 0.1 to 10 kg
      overlap.push_back(0.001 * (0.2 + u(rng)));
      arms.push_back(Vec3(0.2 * (2 * u(rng) - 1), 0.2 * (2 * u(rng) - 1), 0.0));
    }
    const double body_mass = 0.5 + 2.0 * u(rng);
    const Eigen::Matrix3d inv_inertia =
        turns ? Eigen::Matrix3d(Eigen::Vector3d(6, 8, 4).asDiagonal()) : Eigen::Matrix3d::Zero();
    BodyAndVertices s = body_under_vertices(mass, overlap, arms, body_mass, inv_inertia);
    const Eigen::VectorXd j = inelastic_impulses(s, mass, overlap);
    ASSERT_GT(j.sum(), 0.0) << trial;
    ContactResponse response;
    const Positions anchor = s.x;
    separate_from_body(s, response);
    // Equal and opposite: the body's impulse and moment are minus the vertices' momenta.
    Vec3 p = Vec3::Zero(), l = Vec3::Zero();
    for (int i = 0; i < n; ++i) {
      const Vec3 given = mass[static_cast<size_t>(i)] * (s.x[i] - anchor[i]);
      p += given, l += arms[static_cast<size_t>(i)].cross(given);
    }
    EXPECT_LT((response.body_impulse()[0] + p).norm(), 1e-12) << trial;
    EXPECT_LT((response.body_moment()[0] + l).norm(), 1e-12) << trial;
    {
      // One sweep of every vertex's approach alone (the response's second stage, its bisected
      // share): the body's impulse still minus the vertices' momenta.
      BodyAndVertices once = body_under_vertices(mass, overlap, arms, body_mass, inv_inertia);
      ContactResponse one;
      one.prepare(once.contacts, static_cast<Index>(once.x.size()), ContactParams{});
      const Positions start = once.x;
      const AnsweringBodies view = once.view();
      one.separate(once.x, start, once.inv_mass, 1, 0.0, &view);
      Vec3 given = Vec3::Zero();
      for (int i = 0; i < n; ++i) given += mass[static_cast<size_t>(i)] * (once.x[i] - start[i]);
      EXPECT_GT(given.norm(), 0.0) << trial;
      EXPECT_LT((one.body_impulse()[0] + given).norm(), 1e-9 * given.norm()) << trial;
    }
    // Every overlap closed, with about the inelastic impulses: the sweeps only push apart, so a
    // contact that the body's answer to the others opens keeps what it pushed before (not the least
    // impulse, but no more than a quarter above it, and no contact opened by more than half the
    // largest overlap beyond what the inelastic impulses open it; measured +17.9 % and 0.44).
    const double largest = *std::max_element(overlap.begin(), overlap.end());
    Vec3 p_lcp = Vec3::Zero(), l_lcp = Vec3::Zero();
    for (int i = 0; i < n; ++i) {
      const Vec3 on_body = -j(i) * Vec3::UnitZ();
      p_lcp += on_body, l_lcp += arms[static_cast<size_t>(i)].cross(on_body);
    }
    auto left_after = [&](int i, const Vec3& push, const Vec3& twist, double vertex_shift) {
      const Vec3 shift =
          s.body_inv_mass[0] * push + (s.body_inv_inertia[0] * twist).cross(s.arm[static_cast<size_t>(i)]);
      return overlap[static_cast<size_t>(i)] - vertex_shift + shift.z();
    };
    double total = 0.0;
    for (int i = 0; i < n; ++i) {
      const double left = left_after(i, response.body_impulse()[0], response.body_moment()[0], s.x[i].z());
      const double inelastic = left_after(i, p_lcp, l_lcp, j(i) / mass[static_cast<size_t>(i)]);
      EXPECT_LT(left, 1e-3 * overlap[static_cast<size_t>(i)]) << trial << ", contact " << i;
      worst_opening = std::max(worst_opening, (inelastic - left) / largest);
      total += mass[static_cast<size_t>(i)] * s.x[i].z();
    }
    worst_excess = std::max(worst_excess, total / j.sum() - 1.0);
  }
  std::printf(
      "body in 3-8 contacts: impulse at most %+.1f %% of the inelastic one's, contacts opened beyond it by at most "
      "%.2f of the "
      "largest overlap\n",
      100.0 * worst_excess, worst_opening);
  EXPECT_LT(worst_excess, 0.25);
  EXPECT_LT(worst_opening, 0.5);
}

namespace {
/// Layers of vertices stacked along z, each vertex of a layer in a vertex-face contact with the
/// layer below and edge-edge contacts across the layers at random normals: a push on one layer
/// reaches the next through contacts that did not overlap before it. Random masses (a tenth
/// pinned), candidates moved from the anchors, overlaps from -0.5 to 1 mm, a few mesh neighbours.
struct StackedContacts {
  Positions x, anchor;
  std::vector<double> inv_mass;
  std::vector<ContactPair> contacts;
};

StackedContacts stacked_contacts(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr Index kLayers = 6, kSide = 5, kPerLayer = kSide * kSide;
  constexpr double kOffset = 0.01;
  StackedContacts s;
  for (Index l = 0; l < kLayers; ++l)
    for (Index i = 0; i < kPerLayer; ++i) {
      s.anchor.push_back(Vec3(0.02 * (i % kSide), 0.02 * (i / kSide), kOffset * static_cast<double>(l)));
      s.inv_mass.push_back(u(rng) < 0.1 ? 0.0 : 0.5 + 1.5 * u(rng));
    }
  s.x = s.anchor;
  for (Vec3& p : s.x) p += 0.0005 * Vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
  auto at = [&](Index l, Index i) { return l * kPerLayer + i; };
  for (Index l = 1; l < kLayers; ++l)
    for (Index i = 0; i < kPerLayer; ++i) {
      const Index col = std::min<Index>(i % kSide, kSide - 2), row = std::min<Index>(i / kSide, kSide - 2);
      const Index base = row * kSide + col;
      const double b1 = u(rng), b2 = (1.0 - b1) * u(rng), b3 = 1.0 - b1 - b2;
      ContactPair c;
      c.kind = ContactKind::vf;
      c.v = {at(l, i), at(l - 1, base), at(l - 1, base + 1), at(l - 1, base + kSide)};
      c.w = {1.0, -b1, -b2, -b3};
      c.n = Vec3::UnitZ();
      c.offset = kOffset;
      c.distance = kOffset - 0.001 * (1.5 * u(rng) - 0.5);
      c.neighbours = u(rng) < 0.03;
      s.contacts.push_back(c);
      ContactPair e;
      e.kind = ContactKind::ee;
      const Index j = static_cast<Index>(u(rng) * (kPerLayer - 1));
      const double t = u(rng), r = u(rng);
      e.v = {at(l, i), at(l, (i + 1) % kPerLayer), at(l - 1, j), at(l - 1, j + 1)};
      e.w = {1.0 - t, t, -(1.0 - r), -r};
      e.n = Vec3(0.3 * (2 * u(rng) - 1), 0.3 * (2 * u(rng) - 1), 1.0).normalized();
      e.offset = kOffset;
      e.distance = kOffset - 0.001 * (1.5 * u(rng) - 0.5);
      s.contacts.push_back(e);
    }
  return s;
}
}  // namespace

TEST(ContactResponse, SweepsMeasuringOnlyContactsTheirBoundsLeaveOverlappingEqualMeasuringEvery) {
  // The brute-force reference measures every contact in every sweep; the response measures those
  // that overlapped and those around the last sweep's steps whose grown bound leaves them
  // overlapping. Positions must agree bit for bit, with resting overlap left or not, with few or
  // all sweeps (the vertex sweeps start from bounds carried through the barycentric ones).
  int moved_beyond_first = 0;
  for (unsigned seed = 1; seed <= 12; ++seed)
    for (const double rest : {0.0, 0.0002})
      for (const int sweeps : {5, DetectingSolver::kSeparateSweeps}) {
        StackedContacts listed = stacked_contacts(seed), every = listed;
        ContactResponse a, b;
        a.prepare(listed.contacts, static_cast<Index>(listed.x.size()), ContactParams{});
        b.prepare(every.contacts, static_cast<Index>(every.x.size()), ContactParams{});
        b.measure_every_sweep(true);
        const Index most_a = a.separate(listed.x, listed.anchor, listed.inv_mass, sweeps, rest);
        const Index most_b = b.separate(every.x, every.anchor, every.inv_mass, sweeps, rest);
        EXPECT_EQ(most_a, most_b) << seed;
        for (size_t v = 0; v < listed.x.size(); ++v)
          for (int d = 0; d < 3; ++d) ASSERT_EQ(listed.x[v][d], every.x[v][d]) << seed << " vertex " << v;
        // The stack carries pushes to vertices the first sweep left where they were: they are
        // moved through contacts that overlapped only later.
        const StackedContacts start = stacked_contacts(seed);
        StackedContacts once = start;
        ContactResponse c;
        c.prepare(once.contacts, static_cast<Index>(once.x.size()), ContactParams{});
        c.separate(once.x, once.anchor, once.inv_mass, 1, rest);
        for (size_t v = 0; v < once.x.size(); ++v)
          moved_beyond_first += once.x[v] == start.x[v] && listed.x[v] != start.x[v];
      }
  EXPECT_GT(moved_beyond_first, 0);
  // A body answering its contacts: a moved body lists every one of its contacts again, and the
  // first vertex sweep lists them too. The same up to the order of the sums on the body.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    std::vector<double> mass, overlap;
    std::vector<Vec3> arms;
    // Pushed down on one side (+x), the body turns up into the vertices on the other, which did
    // not overlap before it moved.
    for (int i = 0; i < 3 + trial % 5; ++i) {
      const bool pushing = i % 2 == 0;
      mass.push_back(0.1 + 2.0 * u(rng));
      overlap.push_back(pushing ? 0.001 * (0.5 + u(rng)) : -0.00002 * u(rng));
      arms.push_back(Vec3((pushing ? 1.0 : -1.0) * (0.8 + 0.2 * u(rng)), 0.1 * (2 * u(rng) - 1), 0.0));
    }
    const Eigen::Matrix3d inv_inertia = Eigen::Vector3d(6, 8, 4).asDiagonal();
    BodyAndVertices listed = body_under_vertices(mass, overlap, arms, 0.5 + u(rng), inv_inertia), every = listed;
    ContactResponse a, b;
    b.measure_every_sweep(true);
    separate_from_body(listed, a);
    separate_from_body(every, b);
    // The turn reaches the vertices on the far side (9 to 380 µm measured).
    bool reached = false;
    for (size_t i = 1; i < mass.size(); i += 2) reached = reached || every.x[i] != arms[i];
    EXPECT_TRUE(reached) << trial;
    for (size_t v = 0; v < listed.x.size(); ++v) EXPECT_LT((listed.x[v] - every.x[v]).norm(), 1e-15) << trial;
    ASSERT_EQ(a.body_impulse().size(), 1u);
    EXPECT_LT((a.body_impulse()[0] - b.body_impulse()[0]).norm(), 1e-12 * b.body_impulse()[0].norm()) << trial;
    EXPECT_LT((a.body_moment()[0] - b.body_moment()[0]).norm(), 1e-12 * b.body_moment()[0].norm() + 1e-18) << trial;
  }
}
