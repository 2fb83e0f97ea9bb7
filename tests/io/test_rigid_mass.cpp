// Rigid bodies from closed surface meshes move as their homogeneous solids: the loader's vertex
// masses (plus RigidBodies' core) carry the solid's mass, centre of mass and inertia tensor; a
// correction at one vertex gives the solid's impulse response; an L-shaped body in free flight spins
// about its true centre of mass. Bad surfaces are refused with a clear message.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "l_prism.hpp"
#include "test_support.hpp"

using namespace ccfr;
namespace fs = std::filesystem;

namespace {

using Mat3 = Eigen::Matrix3d;

io::MeshArrays l_prism(double depth, int levels = 3) {
  auto m = test::l_prism(depth, levels);
  return {m.v, m.f, {}, {}};
}

std::string scene(const std::string& extra_time = "", const std::string& placement = "") {
  return R"(scene: rigid_mass
time: {fps: 60, frames: 30, substeps: 4, iterations: 2, damping: 0)" +
         extra_time + R"(}
contact: {radius: 0.05, offset: 0.01}
materials:
  stone: {density: 2500}
objects:
  - name: ell
    kind: rigid
    material: stone
    shape: {type: mesh, path: ell})" +
         placement + "\n";
}

io::LoadedScene load(const io::MeshArrays& m, const std::string& yaml = scene()) {
  return io::load_scene_arrays(yaml, "scene.yaml", {{"ell", m}});
}

fs::path scratch() {
  const fs::path d = fs::temp_directory_path() / ("ccfr_test_rigid_mass_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

void write_obj(const fs::path& file, const Positions& v, const std::vector<Vec3i>& f) {
  std::ofstream out(file);
  for (const Vec3& x : v) out << "v " << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
  for (const Vec3i& t : f) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(RigidMass, LoaderMassesCarryTheSolidsMomentsAboutItsCentre) {
  const io::LoadedScene ls = load(l_prism(0.5));
  const auto& st = ls.scene.state;
  const SolidMassProperties p =
      solid_mass_properties(st.x, std::vector<Vec3i>(ls.scene.topo.faces.begin(), ls.scene.topo.faces.end()));
  const double rho = 2500.0, mass = rho * p.volume;
  EXPECT_NEAR(p.volume, 2.0, 1e-12);
  double total = 0.0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  for (size_t i = 0; i < st.x.size(); ++i) {
    EXPECT_GT(st.mass[i], 0.0);
    total += st.mass[i];
    first += st.mass[i] * (st.x[i] - Vec3(0.75, 1.25, 0.25));
    second += st.mass[i] * (st.x[i] - Vec3(0.75, 1.25, 0.25)) * (st.x[i] - Vec3(0.75, 1.25, 0.25)).transpose();
  }
  EXPECT_LT(total, mass);  // the rest is the core at the centre of mass
  EXPECT_LT(first.norm(), 1e-9 * mass);
  EXPECT_LT((second - rho * p.second_moment).norm(), 1e-9 * (rho * p.second_moment).norm());
  // The uniform masses of before put the centre at the vertex mean (1, 4/3, 0.25), 0.26 m away.
}

TEST(RigidMass, OneVertexCorrectionGivesTheSolidsImpulseResponse) {
  io::LoadedScene ls = load(l_prism(0.5), scene("",
                                                "\n    transform: {translate: [1, 2, -3], rotate_axis: [1, 1, 0], "
                                                "rotate_deg: 35}"));
  const Scene& s = ls.scene;
  const std::vector<Vec3i> faces(s.topo.faces.begin(), s.topo.faces.end());
  const SolidMassProperties p = solid_mass_properties(s.state.x, faces);
  const double rho = 2500.0, mass = rho * p.volume;
  const Mat3 inertia = p.inertia(rho);
  RigidBodies bodies(s.topo, s.state, &s.params);
  ASSERT_EQ(bodies.size(), 1);
  RegionSet regions;
  regions.clear(s.state.size());
  for (Index k : {0, 4, 9}) {
    const Vec3 delta = 1e-6 * Vec3(0.3, -1.0, 0.6);
    Positions x = s.state.x;
    x[k] += delta;
    const std::vector<Vec3> cores{p.centroid};
    bodies.enforce(x, s.state.x, regions, 1.0, 0.01, cores);
    // A rigid body given the impulse m_k δ at q_k: Δc = m_k δ / M, θ = I⁻¹ (q_k × m_k δ).
    const Vec3 impulse = s.state.mass[k] * delta;
    const Vec3 dc = impulse / mass;
    const Vec3 theta = inertia.ldlt().solve((s.state.x[k] - p.centroid).cross(impulse));
    double worst = 0.0, scale = 0.0;
    for (Index i = 0; i < s.state.size(); ++i) {
      const Vec3 expected = dc + theta.cross(s.state.x[i] - p.centroid);
      worst = std::max(worst, (x[i] - s.state.x[i] - expected).norm());
      scale = std::max(scale, expected.norm());
    }
    EXPECT_GT(scale, 1e-3 * delta.norm()) << k;
    EXPECT_LT(worst, 1e-4 * scale) << "vertex " << k;
    // Without the core the centre would move by m_k δ / Σm, too far.
    EXPECT_LT((solid_mass_properties(x, faces).centroid - p.centroid - dc).norm(), 1e-4 * dc.norm()) << k;
  }
}

TEST(RigidMass, LShapeInFreeFlightSpinsAboutItsTrueCentreOfMass) {
  io::LoadedScene ls = load(l_prism(0.5));
  Scene& s = ls.scene;
  const std::vector<Vec3i> faces(s.topo.faces.begin(), s.topo.faces.end());
  const Vec3 c0(0.75, 1.25, 0.25), v0(1.0, 2.0, 0.0), omega(0, 0, 2.0);  // z is a principal axis
  for (Index i = 0; i < s.state.size(); ++i) s.state.v[i] = v0 + omega.cross(s.state.x[i] - c0);
  const Positions rest = s.state.x;
  const Vec3 g = s.params.time.gravity;
  const double dt = 1.0 / (60.0 * 4);
  Simulation sim(std::move(s));
  double max_com = 0.0, max_mean = 0.0, max_rigid = 0.0, max_angle = 0.0, turned = 0.0;
  for (int frame = 1; frame <= 30; ++frame) {
    sim.step_frame();
    const double n = 4.0 * frame, t = n * dt;
    // Symplectic Euler's exact path: c0 + n dt v0 + g dt² n(n+1)/2.
    const Vec3 path = c0 + n * dt * v0 + g * dt * dt * n * (n + 1) / 2.0;
    const Positions& x = sim.positions();
    const Vec3 com = solid_mass_properties(x, faces).centroid;
    max_com = std::max(max_com, (com - path).norm());
    Vec3 mean = Vec3::Zero();
    for (const Vec3& q : x) mean += q / static_cast<double>(x.size());
    max_mean = std::max(max_mean, (mean - (path + Vec3(0.25, 1.0 / 12.0, 0.0))).norm());
    // The body turned about z through its centre of mass by the angle of corner 1 (2, 0) about it.
    const Vec3 r0 = rest[1] - c0, r1 = x[1] - com;
    const double angle = std::atan2(r0.x() * r1.y() - r0.y() * r1.x(), r0.x() * r1.x() + r0.y() * r1.y());
    const Mat3 r = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
    for (size_t i = 0; i < x.size(); ++i) max_rigid = std::max(max_rigid, (x[i] - com - r * (rest[i] - c0)).norm());
    max_angle = std::max(max_angle, std::abs(angle - omega.norm() * t));
    turned = angle;
  }
  EXPECT_LT(max_com, 1e-9);    // the solid's centre of mass on the parabola
  EXPECT_LT(max_rigid, 1e-9);  // the body turns rigidly about it, about z only
  EXPECT_GT(turned, 0.95);     // by 1 rad in 0.5 s: 2 rad/s ...
  // ... less the O((ω dt)²) per substep that shape matching of the linearly extrapolated positions
  // takes from the spin (polar rotation of 2 R(θ) - 1 turns by θ - 2θ³/3).
  EXPECT_LT(max_angle, 1e-2);
  EXPECT_GT(max_mean, 0.1);  // the vertex mean is off the parabola by R(ωt)o - o, |o| = 0.26 m
}

TEST(RigidMass, RimOnlyMeshFallsBackToExactMassAndCentre) {
  // A hexagonal prism with caps triangulated between rim vertices: every vertex on x² + z² = R²
  // and y = ±h, so no nonnegative masses carry the solid's second moment (an info line says so).
  io::MeshArrays m;
  for (double y : {-0.4, 0.4})
    for (int k = 0; k < 6; ++k)
      m.vertices.push_back(Vec3(std::cos(k * std::numbers::pi / 3.0), y, std::sin(k * std::numbers::pi / 3.0)) +
                           Vec3(5, 1, 0));
  for (Index k = 0; k < 6; ++k) {
    const Index j = (k + 1) % 6;
    m.faces.push_back(Vec3i(k, 6 + k, 6 + j));
    m.faces.push_back(Vec3i(k, 6 + j, j));
  }
  for (Index k : {1, 2, 3, 4}) {
    m.faces.push_back(Vec3i(0, k, k + 1));
    m.faces.push_back(Vec3i(6, 6 + k + 1, 6 + k));
  }
  const io::LoadedScene ls = load(m);
  const auto& st = ls.scene.state;
  const SolidMassProperties p =
      solid_mass_properties(st.x, std::vector<Vec3i>(ls.scene.topo.faces.begin(), ls.scene.topo.faces.end()));
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < st.x.size(); ++i) {
    total += st.mass[i];
    c += st.mass[i] * st.x[i];
  }
  EXPECT_NEAR(total, 2500.0 * p.volume, 1e-9 * total);  // no core
  EXPECT_LT((c / total - p.centroid).norm(), 1e-9);
  // RigidBodies then adds no core: a correction moves the centre by m_k δ / M.
  RigidBodies bodies(ls.scene.topo, st, &ls.scene.params);
  RegionSet regions;
  regions.clear(st.size());
  Positions x = st.x;
  const Vec3 delta(0, 1e-6, 0);
  x[2] += delta;
  const std::vector<Vec3> cores{p.centroid};
  bodies.enforce(x, st.x, regions, 1.0, 0.01, cores);
  Vec3 moved = Vec3::Zero();
  for (size_t i = 0; i < st.x.size(); ++i) moved += st.mass[i] * x[i] / total;
  EXPECT_LT((moved - p.centroid - st.mass[2] * delta / total).norm(), 1e-6 * st.mass[2] * 1e-6 / total);
}

TEST(RigidMass, OpenFlatMiswoundAndInvertedSurfaces) {
  auto m = l_prism(0.5);
  // Inverted (every face inward): the same solid, the same masses.
  auto inverted = m;
  for (Vec3i& f : inverted.faces) std::swap(f[1], f[2]);
  const auto a = load(m), b = load(inverted);
  for (size_t i = 0; i < m.vertices.size(); ++i)
    EXPECT_NEAR(a.scene.state.mass[i], b.scene.state.mass[i], 1e-9 * a.scene.state.mass[i]);
  // One face flipped: refused, naming both faces.
  auto miswound = m;
  std::swap(miswound.faces[5][1], miswound.faces[5][2]);
  std::string e = error_of([&] { load(miswound); });
  EXPECT_NE(e.find("is wound against face"), std::string::npos) << e;
  EXPECT_NE(e.find("objects[0]"), std::string::npos) << e;
  // Open: refused with the rigid wording.
  auto open = m;
  open.faces.pop_back();
  e = error_of([&] { load(open); });
  EXPECT_NE(e.find("a rigid body needs a closed surface"), std::string::npos) << e;
  // Flat but closed: two squares glued at the rim, different diagonals.
  io::MeshArrays flat{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)},
                      {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(1, 0, 3), Vec3i(1, 3, 2)},
                      {},
                      {}};
  e = error_of([&] { load(flat); });
  EXPECT_NE(e.find("encloses no volume"), std::string::npos) << e;
}

TEST(RigidMass, OpenObjAsTetSolidGetsTheTetSolidWording) {
  const fs::path dir = scratch();
  const auto box = gen::box(Vec3(1, 1, 1));
  std::vector<Vec3i> faces(box.f.begin(), box.f.end() - 1);  // one face missing
  write_obj(dir / "open_box.obj", box.v, faces);
  const std::string yaml = R"(scene: t
time: {fps: 60, frames: 1}
contact: {radius: 0.01}
objects:
  - name: jelly
    kind: tet_solid
    shape: {type: mesh, path: open_box.obj}
)";
  const std::string e = error_of([&] { io::load_scene_text(yaml, "scene.yaml", dir); });
  EXPECT_NE(e.find("open_box.obj"), std::string::npos) << e;
  EXPECT_NE(e.find("tet_solid"), std::string::npos) << e;
  EXPECT_NE(e.find("tetgen fills the inside"), std::string::npos) << e;
  EXPECT_EQ(e.find("rigid body"), std::string::npos) << e;
  EXPECT_NE(e.find("objects[0].shape.path"), std::string::npos) << e;
  fs::remove_all(dir);
}

}  // namespace
