// Issue #54: a scripted obstacle that pushes a resting pile. Four coils settle on a box, which then
// rises 0.05 m at 1/7 m/s (t = 0.25 to 0.6 s). The box pushes the bottom coils up into the ones
// resting on them at gap ~0: the paper's split (half of a gap of 0 each) leaves their regions
// empty, and on d6dcf55 both region-projection solvers stopped in frame 16 with "a squeeze ...
// Held by: 'platform'". Now the momentum solve passes the push on through the resting pairs
// (push_through) and a substep that still ends inside an offset is solved again in halves; the
// test asserts that the halves were needed (where they run, the run would otherwise have stopped),
// that every frame is clean under the exact audit, and that the pile rides the box: its lowest
// vertex stays at the offset above the box's top, within the repulsion band, the whole way up.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>

#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"

using namespace ccfr;

namespace {

constexpr const char* kLiftedPile = R"(scene: lifted_pile
time: {fps: 60, frames: 36, substeps: 2, iterations: 2, xpbd_sweeps: 6}
contact:
  radius: 0.005
  offset: 0.004
  repulsion_range: 0.0008
  stiffness: 1.0e4
  friction: {static: 0.3, kinetic: 0.2}
materials:
  wire: {density: 0.01, stretch_compliance: 1.0e-7, bend_compliance: 1.0e-3}
objects:
  - name: platform
    kind: obstacle
    shape: {type: box, size: [0.3, 0.02, 0.3]}
    keyframes:
      - {time: 0, translate: [0, 0, 0]}
      - {time: 0.25, translate: [0, 0, 0]}
      - {time: 0.6, translate: [0, 0.05, 0]}
  - name: coils
    kind: strand
    material: wire
    shape: {type: strands, count: 4, vertices: 80, length: 0.1, spread: 0.05, coil_radius: 0.015, turns: 4}
    transform: {translate: [0.0, 0.12, 0.0]}
)";

class LiftedPile : public ::testing::TestWithParam<const char*> {};

}  // namespace

TEST_P(LiftedPile, ABoxRisingUnderRestingCoilsCarriesThemCleanWithoutAStop) {
  io::LoadedScene loaded =
      io::load_scene_text(kLiftedPile, "lifted_pile.yaml", ".", {std::string("contact.solver=") + GetParam()});
  const Scene& scene = loaded.scene;
  const Index box_end = scene.topo.objects[0].vertex_end;
  const double xi = scene.params.contact.offset, delta = scene.params.contact.repulsion_range;
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{xi, 1e-6});
  Simulation sim(std::move(loaded.scene));
  int halved = 0;
  double lowest_gap = std::numeric_limits<double>::infinity(), highest_gap = 0.0;
  double mean_before = 0.0;
  auto coil_mean_y = [&](const Positions& x) {
    double sum = 0.0;
    for (size_t v = static_cast<size_t>(box_end); v < x.size(); ++v) sum += x[v].y();
    return sum / static_cast<double>(x.size() - static_cast<size_t>(box_end));
  };
  for (int f = 1; f <= 36; ++f) {
    halved += sim.step_frame().substeps_halved;
    const Positions& x = sim.positions();
    ASSERT_EQ(audit.audit_next(x).penetrations(), 0) << GetParam() << " frame " << f;
    if (f == 15) mean_before = coil_mean_y(x);
    if (f < 17) continue;  // resting from frame 15; the box moves from frame 16
    double top = -std::numeric_limits<double>::infinity(), low = std::numeric_limits<double>::infinity();
    for (Index v = 0; v < box_end; ++v) top = std::max(top, x[v].y());
    for (size_t v = static_cast<size_t>(box_end); v < x.size(); ++v) low = std::min(low, x[v].y());
    lowest_gap = std::min(lowest_gap, low - top);
    highest_gap = std::max(highest_gap, low - top);
  }
  std::printf(
      "[ measure ] lifted pile (%s): lowest coil vertex %.6f to %.6f m above the box (xi %.4g, delta %.4g); "
      "mean rise %.5f m of the box's 0.05; %d substeps halved\n",
      GetParam(), lowest_gap, highest_gap, xi, delta, coil_mean_y(sim.positions()) - mean_before, halved);
  EXPECT_GT(halved, 0) << "the scene no longer needs the halves: it no longer tests them";
  // Riding the box: never behind it (the audit holds the offset), never left a band above it.
  EXPECT_GE(lowest_gap, xi * (1.0 - 1e-6));
  EXPECT_LE(highest_gap, xi + delta);
  // The pile as a whole rises with the box (it also settles flatter as it rides: 4 % measured).
  EXPECT_NEAR(coil_mean_y(sim.positions()) - mean_before, 0.05, 0.005);
}

INSTANTIATE_TEST_SUITE_P(RegionSolvers, LiftedPile, ::testing::Values("ccfr", "exact_projection"),
                         [](const auto& info) { return std::string(info.param); });
