#pragma once
/// @file toi_clamp.hpp
/// `toi_clamp`: the time-of-impact baseline of the paper's comparison with XPBD-based IPC
/// (Lu et al. 2023). After XPBD and the contact response, the whole system is interpolated back
/// along the straight path from the anchors to the candidate positions, to the earliest time at
/// which any detected sub-pair reaches the minimum separation ξ. Times of impact come from
/// Additive CCD (Li et al. 2021): conservative advancement with a distance lower bound.
/// See docs/toi_clamp.md.
#include <array>

#include "ccfr/collision/narrow_phase.hpp"
#include "ccfr/solvers/contact_solvers.hpp"

namespace ccfr {

/// Parameters of Additive CCD.
struct ToiClampParams {
  /// s in (0, 1]: each advancement covers the fraction s of what the distance bound allows, and the
  /// search stops once the gap has shrunk below (1 - s) of its initial value. s = 1 is exact in
  /// the limit of many iterations but may return a time at which the gap is zero.
  double scale = 0.9;
  /// Advancement steps per pair before giving up with the (still safe) time reached so far.
  int max_iterations = 1000;
  /// A pair whose initial gap d - ξ is at most this fraction of ξ counts as touching and gets
  /// toi = 0 at once: from such a gap the advancement moves by at most ~1e-9 of the step in
  /// max_iterations steps anyway, and the relative rounding of the distance is of this order
  /// (ipc-toolkit stops the same way below machine epsilon).
  double touch_tolerance = 1e-12;
};

/// Result of one Additive CCD query.
struct AccdResult {
  double toi = 1.0;     ///< t in [0, 1]: the pair keeps a distance > ξ on [0, t] (t = 1: no impact)
  int iterations = 0;   ///< advancement steps taken
  bool impact = false;  ///< the search stopped before t = 1 (toi < 1)
};

/// Distance of the sub-pair `kind` between its primitives at the stencil positions `x`
/// (vf: point x0, triangle x1 x2 x3; ee: edges (x0, x1) and (x2, x3); ve: point x0, segment
/// (x1, x2); vv: points x0, x1). Unused entries are ignored.
double sub_pair_distance(ContactKind kind, const std::array<Vec3, 4>& x);

/// Additive CCD (Li et al. 2021, Alg. 1) of the sub-pair `kind` whose stencil vertices move
/// linearly from `x0` to `x1`, \f$\mathbf{x}_k(t) = \mathbf{x}_k^0 + t\,\mathbf{p}_k\f$ with
/// \f$\mathbf{p}_k = \mathbf{x}_k^1 - \mathbf{x}_k^0\f$, against the minimum separation ξ.
///
/// The common translation \f$\bar{\mathbf{p}}\f$ (mean of the stencil's displacements) does not
/// change the distance and is removed first; then the closest points of the two sides approach
/// each other at most at the rate
/// \f[ l_p = \max_{k \in A} \|\mathbf{p}_k - \bar{\mathbf{p}}\| + \max_{k \in B} \|\mathbf{p}_k - \bar{\mathbf{p}}\| ,\f]
/// so \f$ d(t + \tau) \ge d(t) - \tau\, l_p \f$. With the gap
/// \f$ g(t) = d(t) - \xi = (d^2 - \xi^2) / (d + \xi) \f$ (the second form keeps the squared
/// distance of the closest-point routines and loses no digits when d is near ξ), each step
/// \f[ t \leftarrow t + \tau,\qquad \tau = s\, \frac{g(t)}{l_p} \f]
/// keeps \f$ g \ge (1 - s)\, g(t) > 0 \f$ on the whole step. The search stops at the last time
/// whose gap is still at least \f$ (1 - s)\, g(0) \f$ (the first step is always taken), after
/// `max_iterations` steps, or with toi = 1 once a step reaches past t = 1.
///
/// Never later than the true time of impact: d > ξ on [0, toi] whenever g(0) > 0. For a point
/// approaching a plane head-on at normal speed \f$v_n\f$ the answer is
/// \f$ s\,(d_0 - \xi)/v_n \f$. A pair already at or inside ξ (g(0) <= 0) gets toi = 0, as in
/// ipc-toolkit: no conservative step exists from there, whatever the direction of motion. So does
/// a pair whose gap is below `touch_tolerance` ξ.
AccdResult additive_ccd(ContactKind kind, const std::array<Vec3, 4>& x0, const std::array<Vec3, 4>& x1,
                        double min_separation, const ToiClampParams& params = {});

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
  /// \f$ t^* \f$ of the last resolve() (1 when nothing was detected).
  double last_toi() const { return last_toi_; }
  /// Advancement steps of the last resolve(), summed over pairs.
  long long last_iterations() const { return last_iterations_; }

 private:
  ToiClampParams params_;
  Positions end_;  ///< #V path ends e_i of the current resolve()
  double last_toi_ = 1.0;
  long long last_iterations_ = 0;
};

}  // namespace ccfr
