// A sheet dropped onto a resting box drapes over it without stretching (issue #54): the vertices
// that land are stopped while their neighbours over the edges fall on, and the cloth must pull
// them along rather than tear. Independent answer: the cloth's own rest lengths (a stiff cloth,
// stretch compliance 1e-8 m/N, keeps every edge near its rest length).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// A 1 m cloth of 40 x 40 cells (0.2 kg/m², stretch compliance 1e-8) 5 cm above a 0.4 m rigid
/// box (500 kg/m³) that rests on a fixed floor, falling at 3 m/s; r = ξ = 1 cm as in the issue.
Scene sheet_over_box(const std::string& solver, int substeps, int sweeps) {
  const gen::TriMesh floor = gen::plane(3.0, 1);
  const gen::TriMesh box = gen::box(Vec3(0.4, 0.4, 0.4));
  const gen::TriMesh sheet = gen::grid(1.0, 1.0, 40, 40);
  TopologyBuilder tb;
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  tb.add_object("box", ObjectKind::rigid, static_cast<Index>(box.v.size()), box.f);
  tb.add_object("sheet", ObjectKind::cloth, static_cast<Index>(sheet.v.size()), sheet.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index v = 0;
  for (const Vec3& p : floor.v) s.state.x[v++] = p;
  const SolidMassProperties props = solid_mass_properties(box.v, box.f);
  const RigidVertexMasses m = rigid_vertex_masses(box.v, box.f, 500.0, props);
  const double offset = 0.01;
  for (size_t i = 0; i < box.v.size(); ++i, ++v) {
    s.state.x[v] = box.v[i] - props.centroid + Vec3(0, 0.2 + offset, 0);
    s.state.mass[v] = m.vertex[i];
    s.state.inv_mass[v] = 1.0 / m.vertex[i];
  }
  const double vertex_mass = 0.2 * 1.0 / static_cast<double>(sheet.v.size());
  for (const Vec3& p : sheet.v) {
    s.state.x[v] = p + Vec3(0, 0.4 + offset + 0.05, 0);
    s.state.v[v] = Vec3(0, -3.0, 0);
    s.state.mass[v] = vertex_mass;
    s.state.inv_mass[v] = 1.0 / vertex_mass;
    ++v;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(3);
  s.params.objects[1].material.density = 500.0;
  s.params.objects[2].material.density = 0.2;
  set_material_key(s.params.objects[2].material, "stretch_compliance", 1e-8);
  set_material_key(s.params.objects[2].material, "bend_compliance", 1e-2);
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.01;
  s.params.contact.offset = offset;
  s.params.time.fps = 60;
  s.params.time.substeps = substeps;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = sweeps;
  return s;
}

/// Largest edge of the sheet over its rest length, over the first 10 frames (the landing and the
/// fall of the sides over the box's edges), every frame free of violations.
double largest_stretch(const std::string& solver, int substeps, int sweeps) {
  Simulation sim(sheet_over_box(solver, substeps, sweeps));
  const auto& sheet = sim.topology().objects[2];
  double worst = 0.0;
  for (int f = 1; f <= 10; ++f) {
    EXPECT_EQ(sim.step_frame().violations_remaining, 0) << solver << " frame " << f;
    const auto& st = sim.scene().state;
    for (const Vec2i& e : sim.topology().edges)
      if (e[0] >= sheet.vertex_begin && e[1] >= sheet.vertex_begin)
        worst = std::max(worst, (st.x[e[0]] - st.x[e[1]]).norm() / (st.rest[e[0]] - st.rest[e[1]]).norm());
  }
  return worst;
}

}  // namespace

// The stretch at the landing is the material solve's, not the contact's: the vertices that land
// are moved back by their regions after the substep's XPBD sweeps, so their edges over the box's
// edges carry what the next substep's sweeps have not yet pulled in. It shrinks with the substep
// and the sweeps. Measured here (ccfr): 1.42 at 10 substeps x 1 sweep, 1.085 at 20 x 4; the same
// scene as a YAML file through `ccfr run` (16 frames): 10 x 1 1.34, 10 x 4 1.21, 10 x 10 1.15,
// 10 x 40 1.18, 20 x 4 1.10, 20 x 10 1.08, 40 x 1 1.08. Asserted at 20 substeps x 4 sweeps:
// under 1.15, the bound; the coarse setting is reported.
TEST(SheetDrop, ASheetDroppedOnARestingBoxDrapesWithoutStretching) {
  for (const char* solver : test::physics_solvers_with_rigid()) {
    const double stretch = largest_stretch(solver, 20, 4);
    test::report_physics(std::string("sheet dropped at 3 m/s on a resting box: largest stretch, 20 x 4, ") + solver,
                         1.0, stretch, "");
    if (test::asserts_closed_form(solver)) EXPECT_LT(stretch, 1.15) << solver;
  }
  const double coarse = largest_stretch("ccfr", 10, 1);
  test::report_physics("sheet dropped at 3 m/s on a resting box: largest stretch, 10 x 1, ccfr", 1.0, coarse, "");
  EXPECT_LT(coarse, 1.5);
}
