#include "ccfr/solvers/obstacles.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace ccfr {

namespace {
// Rigid transform of the motion at time t: p_world = R p_rest_rel + c(t).
struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Vec3 c = Vec3::Zero();
};

Pose pose_at(const AnalyticShape& s, const Motion& m, double t) {
  Pose p;
  const Vec3 c0 = s.center;
  p.c = m.apply(c0, t);
  const Vec3 ex = m.apply(c0 + Vec3::UnitX(), t) - p.c;
  const Vec3 ey = m.apply(c0 + Vec3::UnitY(), t) - p.c;
  const Vec3 ez = m.apply(c0 + Vec3::UnitZ(), t) - p.c;
  Eigen::Matrix3d Rm;
  Rm << ex, ey, ez;
  p.R = Rm * s.rotation;
  return p;
}
}  // namespace

double analytic_sdf(const AnalyticShape& s, const Motion& m, double t, const Vec3& pw, Vec3& normal) {
  const Pose pose = pose_at(s, m, t);
  const Vec3 q = pose.R.transpose() * (pw - pose.c);  // shape-local coordinates
  Vec3 nl = Vec3::UnitY();
  double d = 0.0;
  switch (s.type) {
    case AnalyticShape::Type::sphere: {
      const double len = q.norm();
      nl = len > 1e-15 ? Vec3(q / len) : Vec3::UnitY();
      d = len - s.radius;
      break;
    }
    case AnalyticShape::Type::plane:
      nl = Vec3::UnitY();
      d = q.y();
      break;
    case AnalyticShape::Type::box: {
      const Vec3 a = q.cwiseAbs() - s.half_extent;
      if ((a.array() > 0).any()) {
        const Vec3 out = a.cwiseMax(0.0);
        d = out.norm();
        nl = out.cwiseProduct(q.cwiseSign()).normalized();
      } else {
        Index k;
        d = a.maxCoeff(&k);
        nl = Vec3::Zero();
        nl[k] = q[k] >= 0 ? 1.0 : -1.0;
      }
      break;
    }
    case AnalyticShape::Type::cylinder: {
      const double rho = std::hypot(q.x(), q.z());
      const Vec3 radial = rho > 1e-15 ? Vec3(q.x() / rho, 0, q.z() / rho) : Vec3::UnitX();
      const double dr = rho - s.radius, dy = std::abs(q.y()) - s.half_height;
      const Vec3 axial(0, q.y() >= 0 ? 1.0 : -1.0, 0);
      if (dr > 0 && dy > 0) {
        d = std::hypot(dr, dy);
        nl = (dr * radial + dy * axial) / d;
      } else if (dr > dy) {
        d = dr;
        nl = radial;
      } else {
        d = dy;
        nl = axial;
      }
      break;
    }
    case AnalyticShape::Type::none:
      normal = Vec3::UnitY();
      return std::numeric_limits<double>::infinity();
  }
  normal = pose.R * nl;
  return d;
}

}  // namespace ccfr
