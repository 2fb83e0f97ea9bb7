#pragma once
/// @file obstacles.hpp
/// Exact signed distance of analytic obstacle shapes, for `contact.analytic_obstacles`.
#include "ccfr/solvers/kinematics.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

/// Signed distance from `p` to `shape` placed by `motion` at time `t` (negative inside), and the
/// outward unit normal at the closest surface point in `normal`.
double analytic_sdf(const AnalyticShape& shape, const Motion& motion, double t, const Vec3& p, Vec3& normal);

}  // namespace ccfr
