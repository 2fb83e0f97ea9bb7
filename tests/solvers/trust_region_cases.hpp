#pragma once
// Small hand-built scenes for the trust-region solvers (ogc, dat): a solver is initialised on
// them and its detect() / resolve() called directly, so the bounds and limits can be compared
// with closed forms. Shared by test_ogc.cpp and test_dat.cpp.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/scene.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::test {

/// One object of a case: obstacles are fixed (inverse mass 0), everything else has 1 g per vertex.
struct Part {
  std::string name;
  ObjectKind kind = ObjectKind::particles;
  std::vector<Vec3> v;
  std::vector<Vec3i> f = {};
  std::vector<std::vector<Index>> lines = {};
};

/// A square of two triangles in the plane through `o` spanned by `u` and `w` (each of length 2 h,
/// centred on o); its normal is u × w.
inline Part square(std::string name, const Vec3& o, const Vec3& u, const Vec3& w, double h) {
  Part p{std::move(name),
         ObjectKind::obstacle,
         {o - h * u - h * w, o + h * u - h * w, o + h * u + h * w, o - h * u + h * w}};
  p.f = {Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  return p;
}

inline Scene build_case(const std::vector<Part>& parts, double xi, double r) {
  TopologyBuilder tb;
  for (const Part& p : parts) tb.add_object(p.name, p.kind, static_cast<Index>(p.v.size()), p.f, {}, p.lines);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const Part& p : parts)
    for (const Vec3& x : p.v) {
      s.state.x[k] = x;
      if (p.kind != ObjectKind::obstacle) s.state.mass[k] = 1e-3, s.state.inv_mass[k] = 1e3;
      ++k;
    }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(parts.size());
  s.params.contact.offset = xi;
  s.params.contact.radius = r;
  s.params.contact.repulsion_range = 0.0;
  return s;
}

/// A solver initialised on a case, with detect() and resolve() as the substep loop calls them.
template <class Solver>
struct Probe {
  Scene scene;
  std::unique_ptr<Solver> solver;
  StageTimes times;
  int iteration = 0;
  std::vector<Vec3> kinematic;  ///< scripted steps of the pass (#V), or empty

  Probe(Scene s, std::unique_ptr<Solver> sol) : scene(std::move(s)), solver(std::move(sol)) {
    solver->initialize(scene.topo, scene.state, scene.params);
  }
  StepContext context() {
    StepContext ctx{scene.topo, scene.params, 1e-3, 1, 0, iteration, times};
    if (iteration == 0) ctx.kinematic_step = kinematic;
    return ctx;
  }
  DetectResult detect() {
    StepContext ctx = context();
    return solver->detect(scene.state.x, scene.state, ctx);
  }
  /// Resolves candidates x (anchored at the scene's positions) as the pass after detect().
  SolveResult resolve(Positions& x) {
    StepContext ctx = context();
    return solver->resolve(x, scene.state.x, scene.state, ctx);
  }
};

/// What a dropped cloth did: sub-pairs found inside their regions over the run, and its lowest y.
struct DropResult {
  Index detected = 0;
  double lowest = std::numeric_limits<double>::infinity();
};

/// A 0.3 m cloth (8 x 8 cells, 0.1 g per vertex) placed `lift` above a fixed obstacle and run for
/// 12 frames under `solver` (ξ = 0.01, r = 0.005, 4 substeps). Every frame must leave no vertex
/// outside its region and pass the exact (CGAL) audit at ξ, which is independent of the solver's
/// own detection.
inline DropResult drop_cloth_audited(const gen::TriMesh& obstacle, const Vec3& lift, const std::string& solver) {
  const auto cloth = gen::grid(0.3, 0.3, 8, 8);
  TopologyBuilder tb;
  tb.add_object("obstacle", ObjectKind::obstacle, static_cast<Index>(obstacle.v.size()), obstacle.f);
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const auto& q : obstacle.v) s.state.x[k++] = q;
  const Index c0 = k;
  for (const auto& q : cloth.v) s.state.x[k++] = q + lift;
  for (Index v = c0; v < k; ++v) s.state.mass[v] = 1e-4, s.state.inv_mass[v] = 1e4;
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.contact.solver = solver;
  s.params.contact.offset = 0.01;
  s.params.contact.radius = 0.005;
  s.params.time.substeps = 4;
  exact::PenetrationAudit audit(s.topo, s.state.x, exact::AuditOptions{0.01, 1e-6});
  Simulation sim(std::move(s));
  DropResult r;
  for (int f = 0; f < 12; ++f) {
    const FrameStats fs = sim.step_frame();
    r.detected += fs.violations_detected;
    EXPECT_EQ(fs.violations_remaining, 0) << solver << " frame " << f + 1;
    EXPECT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << solver << " frame " << f + 1;
  }
  for (Index v = c0; v < sim.topology().num_vertices(); ++v) r.lowest = std::min(r.lowest, sim.positions()[v].y());
  return r;
}

}  // namespace ccfr::test
