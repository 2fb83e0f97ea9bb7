#pragma once
/// @file successive_projection.hpp
/// The naive baseline: cyclic projection onto one violated half-space at a time.
#include "ccfr/feasibility/projector.hpp"

namespace ccfr {

/// Cyclic successive projection ("successive_projection"): for up to `sweeps` sweeps, visit the
/// half-spaces in their stored order and project onto each violated one,
/// \f$\mathbf{x} \leftarrow \mathbf{x} - \frac{\rho_k}{\mathbf{n}_k\cdot\mathbf{n}_k}\mathbf{n}_k\f$;
/// stop after a sweep that finds no violation. Converges to a feasible point (not the projection)
/// when the region is non-empty, but may need many sweeps in narrow wedges. No ε retraction.
/// Ends outside after the last sweep: status `infeasible`, and the last iterate is returned, so the
/// caller sees exactly what the baseline produced. Non-finite input: `infeasible`, x = anchor.
class SuccessiveProjectionProjector final : public Projector {
 public:
  explicit SuccessiveProjectionProjector(const ProjectorParams& params = {});
  ProjectResult project(const Vec3& x_anchor, const Vec3& x_candidate,
                        std::span<const HalfSpace> planes) const override;
  std::string_view name() const override { return "successive_projection"; }

 private:
  ProjectorParams params_;
};

}  // namespace ccfr
