// The material constraint `dihedral_bending`: bending of cloth and shells across interior edges
// (BendingBatch, xpbd::solve_dihedral_bending), its compliance read from materials.*.bend_compliance.
#include "ccfr/solvers/materials/dihedral_bending.hpp"

#include <cmath>
#include <numbers>

#include "ccfr/core/log.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

namespace xpbd {

namespace {
/// Wraps an angle difference into (-π, π], so a dihedral angle crossing ±π does not jump by 2π.
double wrap_angle(double a) {
  constexpr double pi = std::numbers::pi;
  while (a > pi) a -= 2.0 * pi;
  while (a <= -pi) a += 2.0 * pi;
  return a;
}

/// A triangle whose doubled area |n| is below this fraction of |e|² has a numerically meaningless
/// normal; its dihedral gradient (∝ 1/height) is then skipped rather than amplified.
constexpr double kRelativeArea = 1e-12;
}  // namespace

double dihedral_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  const Vec3 e = x1 - x0;
  const Vec3 n1 = e.cross(x2 - x0), n2 = (x3 - x0).cross(e);
  const double l = e.norm(), a1 = n1.norm(), a2 = n2.norm();
  if (!(l > 0.0) || !(a1 > kRelativeArea * l * l) || !(a2 > kRelativeArea * l * l)) return 0.0;
  // atan2 of unnormalised sine and cosine: both carry the same factor |n1||n2|.
  return std::atan2(n1.cross(n2).dot(e) / l, n1.dot(n2));
}

bool dihedral_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double& theta,
                             std::array<Vec3, 4>& grad) {
  const Vec3 e = x1 - x0;
  const Vec3 n1 = e.cross(x2 - x0), n2 = (x3 - x0).cross(e);
  const double l2 = e.squaredNorm(), a1 = n1.squaredNorm(), a2 = n2.squaredNorm();
  const double l = std::sqrt(l2);
  const double min_area2 = kRelativeArea * kRelativeArea * l2 * l2;
  if (!(l > 0.0) || !(a1 > min_area2) || !(a2 > min_area2) || !std::isfinite(a1 + a2)) return false;
  const double inv_l = 1.0 / l;  // one division each instead of nine: the sweep is latency-bound
  theta = std::atan2(n1.cross(n2).dot(e) * inv_l, n1.dot(n2));
  const Vec3 m1 = n1 * (1.0 / a1), m2 = n2 * (1.0 / a2);  // n / |n|²
  grad[2] = -l * m1;
  grad[3] = -l * m2;
  grad[0] = -((x2 - x1).dot(e) * inv_l) * m1 - ((x3 - x1).dot(e) * inv_l) * m2;
  grad[1] = -grad[0] - grad[2] - grad[3];
  return true;
}

void solve_dihedral_bending(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_angle,
                            double alpha_tilde, double& lambda) {
  double theta = 0.0;
  std::array<Vec3, 4> g;
  if (!dihedral_angle_gradient(*x[0], *x[1], *x[2], *x[3], theta, g)) return;
  apply_update<4>(x, w, g, wrap_angle(theta - rest_angle), alpha_tilde, lambda);
}

}  // namespace xpbd

// ---- BendingBatch -------------------------------------------------------------------------------

void BendingBatch::add(const Vec4i& v, double theta0, double alpha) {
  ids.push_back(v);
  rest_angle.push_back(theta0);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void BendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void BendingBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Vec4i& v = ids[c];
    xpbd::solve_dihedral_bending({&x[v[0]], &x[v[1]], &x[v[2]], &x[v[3]]}, {w[v[0]], w[v[1]], w[v[2]], w[v[3]]},
                                 rest_angle[c], compliance[c] * inv_dt2, lambda[c]);
  }
}

namespace {

std::unique_ptr<ConstraintBatch> build(const MaterialContext& ctx) {
  auto b = std::make_unique<BendingBatch>();
  const Topology& topo = ctx.topo;
  const Positions& rest = ctx.state.rest;
  // The two faces incident to an edge, from face_edges. Boundary edges (one face) get no bending;
  // non-manifold edges (three or more faces) are skipped because no single dihedral angle
  // describes them.
  std::vector<Index> edge_face_count(static_cast<size_t>(topo.num_edges()), 0);
  std::vector<Vec2i> edge_faces(static_cast<size_t>(topo.num_edges()), Vec2i(-1, -1));
  for (Index f = 0; f < topo.num_faces(); ++f) {
    const auto kind = topo.objects[topo.face_object[f]].kind;
    if (kind != ObjectKind::cloth && kind != ObjectKind::shell) continue;
    for (int k = 0; k < 3; ++k) {
      const Index e = topo.face_edges[f][k];
      if (edge_face_count[e] < 2) edge_faces[e][edge_face_count[e]] = f;
      ++edge_face_count[e];
    }
  }
  Index skipped = 0;
  for (Index e = 0; e < topo.num_edges(); ++e) {
    if (edge_face_count[e] != 2) continue;
    const Index a = topo.edges[e][0], c0 = topo.edges[e][1];
    auto opposite = [&](Index f) {
      const Vec3i& t = topo.faces[f];
      for (int k = 0; k < 3; ++k)
        if (t[k] != a && t[k] != c0) return t[k];
      return Index{-1};
    };
    const Index c = opposite(edge_faces[e][0]), d = opposite(edge_faces[e][1]);
    std::array<Vec3, 4> g;
    double theta0 = 0.0;
    if (c < 0 || d < 0 || c == d || !xpbd::dihedral_angle_gradient(rest[a], rest[c0], rest[c], rest[d], theta0, g)) {
      ++skipped;
      continue;
    }
    b->add(Vec4i(a, c0, c, d), theta0, ctx.object_params[topo.edge_object[e]]->number("compliance"));
  }
  if (skipped > 0) log::warn("{} interior edges with degenerate rest triangles get no bending constraint", skipped);
  return b;
}

}  // namespace

void register_material_constraint_dihedral_bending(MaterialConstraintRegistry& registry) {
  registry.add({"dihedral_bending",
                "bending of cloth and shells across interior edges",
                {bend_compliance_param()},
                [](const ParamValues&, const MaterialContext& ctx) { return build(ctx); }});
}

}  // namespace ccfr
