// Simulation's setters between frames: positions, velocities and kinematic targets (the C++ side
// of the Python module's; tests/python covers them through the binding too).
#include <gtest/gtest.h>

#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"

namespace ccfr {
namespace {

Scene still_puck() {
  Scene s = test::floor_puck_scene(0.5, 0.0, "ccfr");
  s.params.time.gravity = Vec3::Zero();
  s.params.time.damping = 0.0;
  return s;
}

TEST(Setters, VelocityAndPositionGiveTheClosedFormFreeFlight) {
  Simulation sim(still_puck());
  const Index p = sim.topology().num_vertices() - 1;
  const Vec3* buffer = sim.positions().data();
  Positions x = sim.positions(), v(x.size(), Vec3::Zero());
  x[p] = Vec3(0.2, 0.7, -0.1);
  v[p] = Vec3(0.6, -1.2, 0.3);
  sim.set_positions(x);
  sim.set_velocities(v);
  sim.step_frame();
  const double fps = sim.scene().params.time.fps;
  EXPECT_NEAR((sim.positions()[p] - (x[p] + v[p] / fps)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((sim.velocities()[p] - v[p]).norm(), 0.0, 1e-9);
  EXPECT_EQ(sim.positions().data(), buffer);  // one buffer for the simulation's lifetime
}

TEST(Setters, KinematicTargetsAreReachedAtTheFrameEndAndHeld) {
  Simulation sim(still_puck());
  const std::vector<Index> floor = {0, 1, 2};
  std::vector<Vec3> target;
  for (Index v : floor) target.push_back(sim.positions()[v] + Vec3(0.0, 0.01, 0.02));
  sim.set_kinematic_targets(floor, target);
  sim.step_frame();
  for (size_t k = 0; k < floor.size(); ++k) EXPECT_EQ(sim.positions()[floor[k]], target[k]);
  const double fps = sim.scene().params.time.fps;
  EXPECT_NEAR((sim.velocities()[0] - Vec3(0.0, 0.01, 0.02) * fps).norm(), 0.0, 1e-9);
  EXPECT_EQ(sim.positions()[3], sim.scene().state.rest[3]);  // not driven: its (still) motion
  sim.step_frame();
  for (size_t k = 0; k < floor.size(); ++k) EXPECT_EQ(sim.positions()[floor[k]], target[k]);
}

TEST(Setters, BadInputIsRefused) {
  Simulation sim(still_puck());
  const Index n = sim.topology().num_vertices();
  const std::vector<Index> puck = {n - 1}, outside = {n}, one = {0};
  const std::vector<Vec3> origin = {Vec3::Zero()}, two = {Vec3::Zero(), Vec3::Zero()};
  EXPECT_THROW(sim.set_kinematic_targets(puck, origin), Error);
  EXPECT_THROW(sim.set_kinematic_targets(outside, origin), Error);
  EXPECT_THROW(sim.set_kinematic_targets(one, two), Error);
  EXPECT_THROW(sim.set_kinematic_targets(one, std::vector<Vec3>{Vec3(0, NAN, 0)}), Error);
  EXPECT_THROW(sim.set_positions(Positions(n - 1, Vec3::Zero())), Error);
  Positions bad = sim.positions();
  bad[1].x() = INFINITY;
  EXPECT_THROW(sim.set_positions(bad), Error);
  EXPECT_THROW(sim.set_velocities(bad), Error);
  EXPECT_EQ(sim.positions()[1], sim.scene().state.rest[1]);  // a refused call changes nothing
}

}  // namespace
}  // namespace ccfr
