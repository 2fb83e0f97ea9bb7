// toi_clamp in the simulation loop (feasibility invariant, the stall of persistent contact); its
// time-of-impact kernel, Additive CCD, is tested in tests/collision/test_additive_ccd.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/toi_clamp.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// The puck of scenes.hpp with no repulsion and no friction: only the contact solver keeps it above ξ.
Scene puck_scene(double height, double speed, const std::string& solver) {
  return ccfr::test::floor_puck_scene(height, speed, solver);
}

}  // namespace

TEST(ToiClamp, IsRegisteredInTheFactory) {
  auto s = make_contact_solver("toi_clamp");
  EXPECT_EQ(s->name(), "toi_clamp");
  EXPECT_TRUE(s->clamps_to_radius());
}

TEST(ToiClamp, RestingOnTheFloorUnderGravityStallsWhileCcfrSlides) {
  // The paper's argument against XPBD-IPC: with persistent gravity-driven contact the minimum
  // time of impact stays (near) zero and the whole system stops, tangential motion included.
  const double speed = 0.5, xi = 0.01;
  const int frames = 20;
  const double free_x = speed * frames / 60.0;
  for (double height : {xi * (1.0 + 1e-3), xi * (1.0 + 1e-9)}) {
    Simulation ccfr_sim(puck_scene(height, speed, "ccfr"));
    Simulation toi_sim(puck_scene(height, speed, "toi_clamp"));
    const Index p = toi_sim.topology().num_vertices() - 1;
    Index halted = 0;
    for (int f = 0; f < frames; ++f) {
      ccfr_sim.step_frame();
      const FrameStats fs = toi_sim.step_frame();
      halted += fs.halted_vertices;
      EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
      EXPECT_GE(toi_sim.positions()[p].y(), xi * (1.0 - 1e-9)) << "frame " << f;
    }
    EXPECT_GT(ccfr_sim.positions()[p].x(), 0.8 * free_x) << height;
    EXPECT_LT(toi_sim.positions()[p].x(), 0.05 * free_x) << height;
    EXPECT_LT(std::abs(toi_sim.scene().state.v[p].x()), 1e-3 * speed) << height;
  }
}

TEST(ToiClamp, NoPairCloserThanTheOffsetAfterResolveFromFeasibleAnchors) {
  // A cloth patch dropped onto a tilted floor at random speeds: every resolve() starts from
  // feasible anchors, so every detected pair must end at least ξ apart, and the substep loop's
  // clamp must leave the interpolated state alone.
  auto rng = ccfr::test::rng(99);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const auto floor = gen::plane(1.0, 6);
  const auto cloth = gen::plane(0.3, 6);
  TopologyBuilder tb;
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.2, Vec3::UnitX()).toRotationMatrix();
  for (size_t i = 0; i < floor.v.size(); ++i) s.state.x[i] = tilt * floor.v[i];
  const Index c0 = static_cast<Index>(floor.v.size());
  for (size_t i = 0; i < cloth.v.size(); ++i) {
    const Index v = c0 + static_cast<Index>(i);
    s.state.x[v] = cloth.v[i] + Vec3(0, 0.05, 0);
    s.state.v[v] = Vec3(U(rng), -2.0 + 0.5 * U(rng), U(rng));
    s.state.mass[v] = 1e-3;
    s.state.inv_mass[v] = 1e3;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.contact.solver = "toi_clamp";
  s.params.contact.offset = 0.01;
  s.params.contact.radius = 0.005;
  s.params.contact.repulsion_range = 0.0;
  s.params.time.substeps = 4;
  s.params.time.iterations = 3;
  Simulation sim(std::move(s));
  Index detected = 0;
  for (int f = 0; f < 15; ++f) {
    const FrameStats fs = sim.step_frame();
    detected += fs.violations_detected;
    EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    EXPECT_GE(fs.min_distance, 0.01 * (1.0 - 1e-9)) << "frame " << f;
  }
  EXPECT_GT(detected, 0) << "the cloth was meant to reach the floor";
  // Brute-force check of the final state: every cloth vertex at least ξ from every floor triangle.
  const auto& x = sim.positions();
  double dmin = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < cloth.v.size(); ++i)
    for (const auto& f : floor.f)
      dmin = std::min(dmin,
                      sub_pair_distance(ContactKind::vf, {x[c0 + static_cast<Index>(i)], x[f[0]], x[f[1]], x[f[2]]}));
  EXPECT_GE(dmin, 0.01 * (1.0 - 1e-9));
}

TEST(ToiClamp, ScriptedVerticesHeldBackWithTheSystemStopNamingTheSolver) {
  // The clamp interpolates the whole system, the scripted floor too: with the puck touching, t* = 0
  // every substep, the floor falls behind its script by its whole step, and the next piece is
  // longer than r. The stop must blame the solver, not time.substeps; under ccfr the floor keeps
  // to its script exactly (rest + v t).
  const double xi = 0.01, floor_speed = 3.0;  // 5 mm per substep of 1/600 s, within r = 10 mm
  for (const std::string solver : {"toi_clamp", "ccfr"}) {
    Scene s = puck_scene(xi * (1.0 + 1e-9), 0.0, solver);
    s.params.objects[0].motion.velocity = Vec3(floor_speed, 0, 0);
    Simulation sim(std::move(s));
    if (solver == "toi_clamp") {
      try {
        for (int f = 0; f < 5; ++f) sim.step_frame();
        ADD_FAILURE() << "toi_clamp followed a script it halts";
      } catch (const GuaranteeError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("lag their script"), std::string::npos) << what;
        EXPECT_NE(what.find("'toi_clamp'"), std::string::npos) << what;
        EXPECT_EQ(what.find("raise time.substeps"), std::string::npos) << what;
      }
    } else {
      for (int f = 0; f < 5; ++f) sim.step_frame();
      const double t = 5.0 / 60.0;
      EXPECT_NEAR(sim.positions()[0].x(), sim.scene().state.rest[0].x() + floor_speed * t, 1e-9);
    }
  }
}
