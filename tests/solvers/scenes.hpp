#pragma once
// Small scenes built in code for the solver tests.
#include <string>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/solvers/scene.hpp"

namespace ccfr::test {

/// A scripted obstacle mesh (displaced by `shift`) and one particle named `particle`, the last
/// vertex, at the origin and at rest (mass still 0: the caller sets it).
inline Scene obstacle_and_particle(const gen::TriMesh& obstacle, const std::string& obstacle_name,
                                   const std::string& particle, const Vec3& shift = Vec3::Zero()) {
  TopologyBuilder tb;
  tb.add_object(obstacle_name, ObjectKind::obstacle, static_cast<Index>(obstacle.v.size()), obstacle.f);
  tb.add_object(particle, ObjectKind::particles, 1);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  for (size_t i = 0; i < obstacle.v.size(); ++i) s.state.x[i] = obstacle.v[i] + shift;
  s.params.objects.resize(2);
  return s;
}

/// One particle (mass 0.01) over a kinematic 4 m floor (plane y = 0, 4 x 4 cells, shifted so the
/// particle starts at x = 0 over its first cells), at `height`, sliding along +x at `speed`.
/// r = ξ = 0.01, 10 substeps x 4 iterations. The particle is the last vertex.
inline Scene floor_puck_scene(double height, double speed, const std::string& solver, double repulsion_range = 0.0,
                              double mu_s = 0.0, double mu_k = 0.0) {
  Scene s = obstacle_and_particle(gen::plane(4.0, 4), "floor", "puck", Vec3(1.5, 0, 0));
  const Index p = s.topo.num_vertices() - 1;
  s.params.contact.offset = 0.01;
  s.params.contact.radius = 0.01;
  s.params.contact.repulsion_range = repulsion_range;
  s.params.contact.stiffness = 1e5;
  s.params.contact.friction_static = mu_s;
  s.params.contact.friction_kinetic = mu_k;
  s.params.contact.solver = solver;
  s.params.time.substeps = 10;
  s.params.time.iterations = 4;
  s.state.x[p] = Vec3(0, height, 0);
  s.state.v[p] = Vec3(speed, 0, 0);
  s.state.mass[p] = 0.01;
  s.state.inv_mass[p] = 100.0;
  s.state.rest = s.state.x_prev = s.state.x;
  return s;
}

}  // namespace ccfr::test
