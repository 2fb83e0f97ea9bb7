// The material constraint `tet_elasticity`: volume and deviatoric (co-rotational) terms per tet of
// tet solids (TetBatch), its compliances read from materials.*.volume_compliance (1/λ) and
// materials.*.shear_compliance (1/μ).
#include "ccfr/solvers/materials/tet_elasticity.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "ccfr/core/log.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

namespace xpbd {

double tet_six_volume(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  return (x1 - x0).dot((x2 - x0).cross(x3 - x0));
}

double tet_volume_constraint(const std::array<Vec3, 4>& x, double rest_volume, std::array<Vec3, 4>& grad) {
  const Vec3 d1 = x[1] - x[0], d2 = x[2] - x[0], d3 = x[3] - x[0];
  grad[1] = d2.cross(d3);
  grad[2] = d3.cross(d1);
  grad[3] = d1.cross(d2);
  grad[0] = -grad[1] - grad[2] - grad[3];
  return d1.dot(grad[1]) - 6.0 * rest_volume;
}

void solve_tet_volume(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_volume,
                      double alpha_tilde, double& lambda) {
  std::array<Vec3, 4> g;
  const double c = tet_volume_constraint({*x[0], *x[1], *x[2], *x[3]}, rest_volume, g);
  apply_update<4>(x, w, g, c, alpha_tilde, lambda);
}

namespace {

/// F = D_s D_m^{-1} of the tet at x.
Eigen::Matrix3d deformation_gradient(const std::array<Vec3, 4>& x, const Eigen::Matrix3d& rest_inverse) {
  Eigen::Matrix3d ds;
  ds.col(0) = x[1] - x[0];
  ds.col(1) = x[2] - x[0];
  ds.col(2) = x[3] - x[0];
  return ds * rest_inverse;
}

/// C_D = ‖F - R‖ and its gradient from F and its rotation R; false at (or within round-off of) a
/// rotation, where the constraint holds and its direction is undefined.
bool deviatoric_from(const Eigen::Matrix3d& f, const Eigen::Matrix3d& r, const Eigen::Matrix3d& rest_inverse, double& c,
                     std::array<Vec3, 4>& grad) {
  const Eigen::Matrix3d diff = f - r;
  const double norm = diff.norm();
  if (!(norm > 1e-14)) return false;
  c = norm;
  const Eigen::Matrix3d h = (diff * (1.0 / norm)) * rest_inverse.transpose();
  grad[1] = h.col(0);
  grad[2] = h.col(1);
  grad[3] = h.col(2);
  grad[0] = -grad[1] - grad[2] - grad[3];
  return true;
}

}  // namespace

bool tet_deviatoric_constraint(const std::array<Vec3, 4>& x, const Eigen::Matrix3d& rest_inverse, double& c,
                               std::array<Vec3, 4>& grad) {
  const Eigen::Matrix3d f = deformation_gradient(x, rest_inverse);
  if (!f.allFinite()) return false;
  // Newton instead of the SVD: the material stage of tet scenes is dominated by this (issue 13).
  return deviatoric_from(f, polar_rotation_newton(f), rest_inverse, c, grad);
}

void solve_tet_deviatoric_pair(const std::array<Vec3*, 4>& xa, const std::array<double, 4>& wa,
                               const Eigen::Matrix3d& rest_inverse_a, double alpha_tilde_a, double& lambda_a,
                               const std::array<Vec3*, 4>& xb, const std::array<double, 4>& wb,
                               const Eigen::Matrix3d& rest_inverse_b, double alpha_tilde_b, double& lambda_b) {
  const Eigen::Matrix3d fa = deformation_gradient({*xa[0], *xa[1], *xa[2], *xa[3]}, rest_inverse_a);
  const Eigen::Matrix3d fb = deformation_gradient({*xb[0], *xb[1], *xb[2], *xb[3]}, rest_inverse_b);
  if (!fa.allFinite() || !fb.allFinite()) {
    solve_tet_deviatoric(xa, wa, rest_inverse_a, alpha_tilde_a, lambda_a);
    solve_tet_deviatoric(xb, wb, rest_inverse_b, alpha_tilde_b, lambda_b);
    return;
  }
  Eigen::Matrix3d ra, rb;
  polar_rotation_newton(fa, fb, ra, rb);
  double ca = 0.0, cb = 0.0;
  std::array<Vec3, 4> ga, gb;
  if (deviatoric_from(fa, ra, rest_inverse_a, ca, ga)) apply_update<4>(xa, wa, ga, ca, alpha_tilde_a, lambda_a);
  if (deviatoric_from(fb, rb, rest_inverse_b, cb, gb)) apply_update<4>(xb, wb, gb, cb, alpha_tilde_b, lambda_b);
}

void solve_tet_deviatoric(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w,
                          const Eigen::Matrix3d& rest_inverse, double alpha_tilde, double& lambda) {
  double c = 0.0;
  std::array<Vec3, 4> g;
  if (!tet_deviatoric_constraint({*x[0], *x[1], *x[2], *x[3]}, rest_inverse, c, g)) return;
  apply_update<4>(x, w, g, c, alpha_tilde, lambda);
}

}  // namespace xpbd

// ---- TetBatch -----------------------------------------------------------------------------------

bool TetBatch::add(const Vec4i& v, const Positions& rest, double volume_compliance_per_volume,
                   double shear_compliance_per_volume) {
  Eigen::Matrix3d dm;
  dm.col(0) = rest[v[1]] - rest[v[0]];
  dm.col(1) = rest[v[2]] - rest[v[0]];
  dm.col(2) = rest[v[3]] - rest[v[0]];
  const double six_v = dm.determinant();
  // Scale-free degeneracy test: 6V against the cube of the longest edge of the rest tet.
  double lmax = std::max({dm.col(0).norm(), dm.col(1).norm(), dm.col(2).norm(), (dm.col(1) - dm.col(0)).norm(),
                          (dm.col(2) - dm.col(0)).norm(), (dm.col(2) - dm.col(1)).norm()});
  if (!(std::abs(six_v) > 1e-12 * lmax * lmax * lmax)) return false;
  const double v0 = six_v / 6.0;
  ids.push_back(v);
  rest_volume.push_back(v0);
  rest_inverse.push_back(dm.inverse());
  // Energy densities λ/2 (J-1)² and μ/2 ‖F-R‖² integrated over V_0 give these per-tet compliances,
  // so the stiffness does not depend on the mesh resolution.
  volume_compliance.push_back(36.0 * std::abs(v0) * volume_compliance_per_volume);
  deviatoric_compliance.push_back(shear_compliance_per_volume / std::abs(v0));
  lambda_volume.push_back(0.0);
  lambda_deviatoric.push_back(0.0);
  return true;
}

void TetBatch::reset_multipliers() {
  std::fill(lambda_volume.begin(), lambda_volume.end(), 0.0);
  std::fill(lambda_deviatoric.begin(), lambda_deviatoric.end(), 0.0);
}

namespace {

bool share_vertex(const Vec4i& a, const Vec4i& b) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (a[i] == b[j]) return true;
  return false;
}

}  // namespace

void TetBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  auto vertices = [&](Index c) {
    const Vec4i& v = ids[c];
    return std::array<Vec3*, 4>{&x[v[0]], &x[v[1]], &x[v[2]], &x[v[3]]};
  };
  auto masses = [&](Index c) {
    const Vec4i& v = ids[c];
    return std::array<double, 4>{w[v[0]], w[v[1]], w[v[2]], w[v[3]]};
  };
  const size_t n = order.size();
  for (size_t k = 0; k < n;) {
    const Index c = order[k];
    const std::array<Vec3*, 4> p = vertices(c);
    const std::array<double, 4> wv = masses(c);
    // Two consecutive tets without a common vertex (one colour) touch disjoint positions, so
    // solving them side by side is solving them one after the other, with the latency hidden.
    if (k + 1 < n && !share_vertex(ids[c], ids[order[k + 1]])) {
      const Index d = order[k + 1];
      const std::array<Vec3*, 4> q = vertices(d);
      const std::array<double, 4> wq = masses(d);
      xpbd::solve_tet_deviatoric_pair(p, wv, rest_inverse[c], deviatoric_compliance[c] * inv_dt2, lambda_deviatoric[c],
                                      q, wq, rest_inverse[d], deviatoric_compliance[d] * inv_dt2, lambda_deviatoric[d]);
      std::array<Vec3, 4> gp, gq;
      const double cp = xpbd::tet_volume_constraint({*p[0], *p[1], *p[2], *p[3]}, rest_volume[c], gp);
      const double cq = xpbd::tet_volume_constraint({*q[0], *q[1], *q[2], *q[3]}, rest_volume[d], gq);
      xpbd::apply_update<4>(p, wv, gp, cp, volume_compliance[c] * inv_dt2, lambda_volume[c]);
      xpbd::apply_update<4>(q, wq, gq, cq, volume_compliance[d] * inv_dt2, lambda_volume[d]);
      k += 2;
      continue;
    }
    xpbd::solve_tet_deviatoric(p, wv, rest_inverse[c], deviatoric_compliance[c] * inv_dt2, lambda_deviatoric[c]);
    xpbd::solve_tet_volume(p, wv, rest_volume[c], volume_compliance[c] * inv_dt2, lambda_volume[c]);
    ++k;
  }
}

void register_material_constraint_tet_elasticity(MaterialConstraintRegistry& registry) {
  registry.add(
      {"tet_elasticity",
       "volume and deviatoric terms per tet of tet solids",
       {ParamSpec::number("volume_compliance", 0.0, "tet solids: compliance of volume preservation, 1/λ (1/Pa)", 0.0,
                          kMaxCompliance)
            .from_material("volume_compliance"),
        ParamSpec::number("shear_compliance", 1e-6, "tet solids: compliance of the deviatoric (shape) term, 1/μ (1/Pa)",
                          0.0, kMaxCompliance)
            .from_material("shear_compliance")},
       [](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
         auto b = std::make_unique<TetBatch>();
         const Topology& topo = ctx.topo;
         for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
           const auto& o = topo.objects[oi];
           if (o.kind != ObjectKind::tet_solid) continue;
           const ParamValues& mat = *ctx.object_params[oi];
           const double volume = mat.number("volume_compliance"), shear = mat.number("shear_compliance");
           Index skipped = 0;
           for (Index t = o.tet_begin; t < o.tet_end; ++t)
             if (!b->add(topo.tets[t], ctx.state.rest, volume, shear)) ++skipped;
           if (skipped > 0)
             log::warn("object '{}': {} degenerate rest tets get no material constraint", o.name, skipped);
         }
         return b;
       }});
}

}  // namespace ccfr
