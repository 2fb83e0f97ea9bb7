// stats.csv's lag_mean / lag_max (FrameStats): how far contact handling kept the vertices from
// their unconstrained (material) step, against closed forms on one particle and a floor.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "trust_region_cases.hpp"

using namespace ccfr;
using test::Part;

namespace {

constexpr double kXi = 0.01, kR = 0.01;

// One particle at height h over a fixed floor, at rest, no repulsion (so no response moves it):
// one substep of dt = 1/600 s per frame.
Simulation particle_over_floor(double h, const std::string& solver) {
  Scene s = test::build_case({test::square("floor", Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ(), 0.2),
                              Part{"dot", ObjectKind::particles, {Vec3(0.05, h, 0.07)}}},
                             kXi, kR);
  s.params.contact.solver = solver;
  s.params.time.fps = 600.0;
  s.params.time.substeps = 1;
  return Simulation(std::move(s));
}

constexpr double kDt = 1.0 / 600.0;
const double kFall = 9.81 * kDt * kDt;  // the material step of a particle at rest: g dt²

}  // namespace

TEST(Lag, AFreeParticleDoesNotLag) {
  Simulation sim = particle_over_floor(0.5, "ccfr");
  for (int f = 0; f < 5; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.lag_mean, 0.0) << f;
    EXPECT_EQ(fs.lag_max, 0.0) << f;
  }
}

// Resting at exactly ξ: every region solver holds the particle where it is, so it lags its
// material step by the whole fall g dt², in every frame.
TEST(Lag, AParticleRestingAtTheOffsetLagsItsWholeFall) {
  for (const char* solver : {"ccfr", "exact_projection", "ogc", "dat"}) {
    Simulation sim = particle_over_floor(kXi, solver);
    for (int f = 0; f < 3; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_NEAR(fs.lag_mean, kFall, 1e-12) << solver << " frame " << f + 1;
      EXPECT_NEAR(fs.lag_max, kFall, 1e-12) << solver << " frame " << f + 1;
      EXPECT_NEAR(sim.positions().back().y(), kXi, 1e-12) << solver;
    }
  }
}

// Without contact handling the particle falls through the floor: no lag at all.
TEST(Lag, NoContactHandlingMeansNoLag) {
  Simulation sim = particle_over_floor(kXi, "none");
  const FrameStats fs = sim.step_frame();
  EXPECT_EQ(fs.lag_mean, 0.0);
  EXPECT_EQ(fs.lag_max, 0.0);
  EXPECT_LT(sim.positions().back().y(), kXi);
}

// Two particles, one free and one resting: the mean is over the movable vertices, the max the
// resting one's; the same at one and two threads (fixed chunks).
TEST(Lag, TheMeanIsOverTheMovableVerticesAndTheSameAtAnyThreadCount) {
  auto run = [](int threads) {
    set_thread_count(threads);
    Scene s = test::build_case({test::square("floor", Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ(), 0.2),
                                Part{"dots", ObjectKind::particles, {Vec3(0.05, kXi, 0.07), Vec3(-0.1, 0.5, 0.0)}}},
                               kXi, kR);
    s.params.contact.solver = "ccfr";
    s.params.time.fps = 600.0;
    s.params.time.substeps = 2;
    Simulation sim(std::move(s));
    return sim.step_frame();
  };
  const FrameStats one = run(1), two = run(2);
  set_thread_count(0);
  const double fall = 9.81 * (kDt / 2) * (kDt / 2);  // per substep of dt / 2
  EXPECT_NEAR(one.lag_mean, fall / 2, 1e-12);        // the floor's obstacle vertices do not count
  EXPECT_NEAR(one.lag_max, fall, 1e-12);
  EXPECT_EQ(one.lag_mean, two.lag_mean);
  EXPECT_EQ(one.lag_max, two.lag_max);
}
