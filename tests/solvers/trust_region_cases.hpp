#pragma once
// Small hand-built scenes for the trust-region solvers (ogc, dat): a solver is initialised on
// them and its detect() / resolve() called directly, so the bounds and limits can be compared
// with closed forms. Shared by test_ogc.cpp and test_dat.cpp.
#include <memory>
#include <string>
#include <vector>

#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/scene.hpp"

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

}  // namespace ccfr::test
