#pragma once
/// @file post_process.hpp
/// `post_process`: conventional XPBD thickness constraints on the detected pairs inside ξ, no
/// regions and no step bound (the paper's baseline).
#include "ccfr/solvers/detecting_solver.hpp"

namespace ccfr {

/// The paper's baseline: after XPBD, every detected pair whose gap along its detection normal is
/// below ξ gets a thickness constraint \f$C = \mathbf{n}^\top\sum_k w_k\mathbf{x}_k - \xi \ge 0\f$,
/// solved Gauss-Seidel in pair order for `contact.post_process.sweeps` sweeps. No regions, no step bound.
class PostProcessSolver final : public DetectingSolver {
 public:
  static constexpr int kDefaultSweeps = 16;
  explicit PostProcessSolver(int sweeps = kDefaultSweeps) : sweeps_(sweeps) {}
  std::string_view name() const override { return "post_process"; }
  SolveResult resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;

 private:
  int sweeps_;
};

}  // namespace ccfr
