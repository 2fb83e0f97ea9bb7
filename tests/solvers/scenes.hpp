#pragma once
// Small scenes built in code for the solver tests.
#include <string>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/scene.hpp"
#include "test_support.hpp"

namespace ccfr::test {

/// test::physics_solvers() less those that refuse a rigid body (the trust-region solvers truncate
/// each vertex's step on its own, and say so when initialised with one): the solvers a closed-form
/// test with a rigid body runs.
inline std::vector<const char*> physics_solvers_with_rigid() {
  TopologyBuilder tb;
  const gen::TriMesh box = gen::box(Vec3(0.1, 0.1, 0.1));
  tb.add_object("probe", ObjectKind::rigid, static_cast<Index>(box.v.size()), box.f);
  const Topology topo = tb.finish();
  SimState state;
  state.resize(topo.num_vertices());
  state.x = state.rest = state.x_prev = box.v;
  SimulationParams params;
  params.objects.resize(1);
  std::vector<const char*> out;
  for (const char* solver : physics_solvers()) {
    try {
      make_contact_solver(solver)->initialize(topo, state, params);
      out.push_back(solver);
    } catch (const Error&) {
      if (asserts_closed_form(solver)) throw;
    }
  }
  return out;
}

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

/// Particles of 10 g at `x`, at rest, in one object named "dust"; r = 5 mm, ξ = 10 mm.
inline Scene particle_scene(const Positions& x) {
  const Index n = static_cast<Index>(x.size());
  TopologyBuilder tb;
  tb.add_object("dust", ObjectKind::particles, n);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(n);
  for (Index i = 0; i < n; ++i) {
    s.state.x[i] = x[i];
    s.state.mass[i] = 0.01;
    s.state.inv_mass[i] = 100.0;
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(1);
  s.params.contact.radius = 0.005;
  s.params.contact.offset = 0.01;
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

/// Gives the rigid mesh `ball`, whose vertices are the scene's from `first` on, its place and
/// motion: its centre of mass at `centre`, every vertex at `velocity`, and the vertex masses that
/// carry a uniform solid of `density` (kg/m³; rigid_vertex_masses). Returns the solid's properties.
inline SolidMassProperties place_solid(Scene& s, const gen::TriMesh& ball, Index first, double density,
                                       const Vec3& centre, const Vec3& velocity) {
  const SolidMassProperties props = solid_mass_properties(ball.v, ball.f);
  const RigidVertexMasses m = rigid_vertex_masses(ball.v, ball.f, density, props);
  for (size_t i = 0; i < ball.v.size(); ++i) {
    const Index v = first + static_cast<Index>(i);
    s.state.x[v] = ball.v[i] - props.centroid + centre;
    s.state.v[v] = velocity;
    s.state.mass[v] = m.vertex[i];
    s.state.inv_mass[v] = m.vertex[i] > 0.0 ? 1.0 / m.vertex[i] : 0.0;
  }
  return props;
}

/// A square cloth in the x-z plane pinned at its four corners (stretch compliance 1e-7, bending
/// 1e-2) and a rigid icosphere above it moving down: what test_guarantee and test_tethers drop.
struct BallOverCloth {
  double size = 1.0;                   ///< cloth side (m)
  Index res = 16;                      ///< cells per side
  double cloth_mass = 0.2;             ///< kg
  double radius = 0.1;                 ///< ball (m)
  int subdivisions = 2;                ///< of the icosphere
  double ball_mass = 4.0;              ///< kg
  Vec3 start = Vec3(0.05, 0.2, 0.03);  ///< ball centre
  double speed = 3.0;                  ///< downward (m/s)
};

/// The scene of `b` with r = 0.01, ξ = 0.005, δ = 0.002, k = 1e5, 8 substeps x 2 iterations,
/// 10 sweeps. Cloth first (object 0, its corners pinned), ball second.
inline Scene ball_over_pinned_cloth(const BallOverCloth& b) {
  const auto cloth = gen::grid(b.size, b.size, b.res, b.res);
  const auto ball = gen::sphere(b.radius, b.subdivisions);
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("ball", ObjectKind::rigid, static_cast<Index>(ball.v.size()), ball.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index nc = static_cast<Index>(cloth.v.size());
  for (Index i = 0; i < nc; ++i) s.state.x[i] = cloth.v[i];
  for (size_t i = 0; i < ball.v.size(); ++i) s.state.x[nc + i] = ball.v[i] + b.start;
  for (Index v = 0; v < s.topo.num_vertices(); ++v) {
    s.state.mass[v] = v < nc ? b.cloth_mass / double(nc) : b.ball_mass / double(ball.v.size());
    s.state.inv_mass[v] = 1.0 / s.state.mass[v];
    if (v >= nc) s.state.v[v] = Vec3(0, -b.speed, 0);
  }
  const std::vector<Index> corners = {0, b.res, b.res * (b.res + 1), (b.res + 1) * (b.res + 1) - 1};
  for (Index v : corners) s.state.mass[v] = s.state.inv_mass[v] = 0.0;
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  set_material_key(s.params.objects[0].material, "stretch_compliance", 1e-7);
  set_material_key(s.params.objects[0].material, "bend_compliance", 1e-2);
  s.params.objects[0].pins.push_back({corners, {}});
  s.params.contact.radius = 0.01;
  s.params.contact.offset = 0.005;
  s.params.contact.repulsion_range = 0.002;
  s.params.contact.stiffness = 1e5;
  s.params.time.substeps = 8;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 10;
  return s;
}

}  // namespace ccfr::test
