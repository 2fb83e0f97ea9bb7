#include "ccfr/feasibility/successive_projection.hpp"

#include <cmath>

namespace ccfr {

SuccessiveProjectionProjector::SuccessiveProjectionProjector(const ProjectorParams& params) : params_(params) {
  validate(params_);
}

ProjectResult SuccessiveProjectionProjector::project(const Vec3& x_anchor, const Vec3& x_candidate,
                                                     std::span<const HalfSpace> planes) const {
  const double tol = params_.feasibility_tolerance;
  const ScreenedInput in = screen_input(x_anchor, x_candidate, planes, tol);
  if (!in.usable) return unusable_input(x_anchor);
  ProjectResult res;
  res.x = x_candidate;
  res.active = in.violated;
  Vec3 p = in.q;
  if (res.active == 0) return res;

  bool clean = false;
  for (int sweep = 1; sweep <= params_.sweeps && !clean; ++sweep) {
    clean = true;
    res.iterations = sweep;
    for (const auto& h : planes) {
      const double rho = h.n.dot(p) + h.d;
      if (rho >= -tol) continue;
      const double nn = h.n.dot(h.n);
      if (!(nn > 0.0)) continue;  // a zero normal cannot be projected onto
      clean = false;
      p -= (rho / nn) * h.n;
    }
  }
  // A sweep that moved the point may have broken earlier planes: judge the final point itself.
  bool inside = true;
  for (const auto& h : planes) inside = inside && h.n.dot(p) + h.d >= -tol;
  res.x = x_anchor + p;
  res.status = inside ? ProjectStatus::projected : ProjectStatus::infeasible;
  return res;
}

}  // namespace ccfr
