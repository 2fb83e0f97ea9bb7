#pragma once
/// @file toi_clamp.hpp
/// `toi_clamp`: the time-of-impact baseline of the paper's comparison with XPBD-based IPC
/// (Lu et al. 2023). After XPBD and the contact response, the whole system is interpolated back
/// along the straight path from the anchors to the candidate positions, to the earliest time at
/// which any detected sub-pair reaches the minimum separation ξ. Times of impact come from
/// Additive CCD (Li et al. 2021): conservative advancement with a distance lower bound.
/// See docs/toi_clamp.md.
#include "ccfr/collision/additive_ccd.hpp"
#include "ccfr/solvers/detecting_solver.hpp"

namespace ccfr {

/// The solver's parameters are those of its Additive CCD queries.
using ToiClampParams = AdditiveCcdParams;

/// The Lu et al. baseline as a contact solver (factory name `toi_clamp`).
///
/// resolve(): every vertex's path ends at its candidate clamped to the step bound r,
/// \f$ \mathbf{e}_i = \mathbf{a}_i + \min(1, r / \|\mathbf{x}_i - \mathbf{a}_i\|)(\mathbf{x}_i - \mathbf{a}_i) \f$
/// (exactly what the substep loop's clamp would produce), every detected sub-pair c gets its
/// Additive CCD time \f$ t_c \f$ along \f$ \mathbf{a} \to \mathbf{e} \f$, and the whole system is
/// interpolated to
/// \f[ t^* = \min_c t_c ,\qquad \mathbf{x}_i \leftarrow \mathbf{a}_i + t^*(\mathbf{e}_i - \mathbf{a}_i) .\f]
/// Clamping to r before the time of impact keeps every pair on one common linear path (a
/// per-vertex clamp after the interpolation would tilt triangles off that path and could bring a
/// pair inside ξ), and keeps every vertex within r of its anchor, so pairs outside the detection
/// range ξ + 2r cannot meet either. When \f$ t^* = 1 \f$ the candidates are left as they are and
/// the loop's own clamp produces \f$ \mathbf{e} \f$, so clamped vertices still ask for another
/// outer iteration.
///
/// Reports: violations_detected = sub-pairs with \f$ t_c < 1 \f$; violations_remaining = sub-pairs
/// closer than \f$ \xi (1 - 10^{-9}) \f$ at the final positions (0 when the anchors are feasible);
/// halted_vertices = dynamic vertices that wanted to move but stay at their anchor because
/// \f$ t^* = 0 \f$ (the stall of persistent contact described in the paper).
/// Parallel over pairs with a min-reduction: the result does not depend on the thread count.
class TimeOfImpactClampSolver final : public DetectingSolver {
 public:
  explicit TimeOfImpactClampSolver(ToiClampParams params = {});
  std::string_view name() const override { return "toi_clamp"; }
  SolveResult resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;
  bool clamps_to_radius() const override { return true; }

  const ToiClampParams& params() const { return params_; }

 private:
  ToiClampParams params_;
  Positions end_;  ///< #V path ends e_i of the current resolve()
};

}  // namespace ccfr
