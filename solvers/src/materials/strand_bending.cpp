// The material constraint `strand_bending`: turning-angle bending at interior polyline vertices
// of strands (StrandBendingBatch, xpbd::solve_strand_bending), its compliance read from
// materials.*.bend_compliance.
#include "ccfr/solvers/materials/strand_bending.hpp"

#include <cmath>

#include "../builtin_materials.hpp"

namespace ccfr {

namespace xpbd {

double turning_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x1;
  if (!(e1.squaredNorm() > 0.0) || !(e2.squaredNorm() > 0.0)) return 0.0;
  return std::atan2(e1.cross(e2).norm(), e1.dot(e2));
}

bool turning_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, double& phi, std::array<Vec3, 3>& grad) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x1;
  const double l1 = e1.norm(), l2 = e2.norm();
  if (!(l1 > 0.0) || !(l2 > 0.0) || !std::isfinite(l1 + l2)) return false;
  const Vec3 u = e1 / l1, v = e2 / l2;
  const double s = u.cross(v).norm(), c = u.dot(v);
  // Below this sine the direction of the in-plane normal is round-off; the angle is a cone point.
  if (!(s > 1e-12)) return false;
  phi = std::atan2(s, c);
  const Vec3 p1 = (v - c * u) / s, p2 = (u - c * v) / s;
  grad[0] = p1 / l1;
  grad[2] = -p2 / l2;
  grad[1] = -grad[0] - grad[2];
  return true;
}

void solve_strand_bending(const std::array<Vec3*, 3>& x, const std::array<double, 3>& w, double rest_angle,
                          double alpha_tilde, double& lambda) {
  double phi = 0.0;
  std::array<Vec3, 3> g;
  if (!turning_angle_gradient(*x[0], *x[1], *x[2], phi, g)) return;
  apply_update<3>(x, w, g, phi - rest_angle, alpha_tilde, lambda);
}

}  // namespace xpbd

// ---- StrandBendingBatch -------------------------------------------------------------------------

void StrandBendingBatch::add(const Vec3i& v, double phi0, double alpha) {
  ids.push_back(v);
  rest_angle.push_back(phi0);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void StrandBendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void StrandBendingBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w,
                                        double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Vec3i& v = ids[c];
    xpbd::solve_strand_bending({&x[v[0]], &x[v[1]], &x[v[2]]}, {w[v[0]], w[v[1]], w[v[2]]}, rest_angle[c],
                               compliance[c] * inv_dt2, lambda[c]);
  }
}

void register_material_constraint_strand_bending(MaterialConstraintRegistry& registry) {
  registry.add({"strand_bending",
                "turning-angle bending of strands",
                {bend_compliance_param()},
                [](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
                  auto b = std::make_unique<StrandBendingBatch>();
                  const Topology& topo = ctx.topo;
                  const Positions& rest = ctx.state.rest;
                  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
                    const auto& o = topo.objects[oi];
                    if (o.kind != ObjectKind::strand) continue;
                    const double alpha = ctx.object_params[oi]->number("compliance");
                    for (Index p = o.polyline_begin; p < o.polyline_end; ++p) {
                      const auto row = topo.polylines.row(p);
                      for (size_t k = 1; k + 1 < row.size(); ++k) {
                        const Vec3i v(row[k - 1], row[k], row[k + 1]);
                        b->add(v, xpbd::turning_angle(rest[v[0]], rest[v[1]], rest[v[2]]), alpha);
                      }
                    }
                  }
                  return b;
                }});
}

}  // namespace ccfr
