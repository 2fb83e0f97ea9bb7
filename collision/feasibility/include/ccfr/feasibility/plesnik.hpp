#pragma once
/// @file plesnik.hpp
/// Plesník's orthogonal projection onto an affine subspace, built one equation at a time along
/// equiresidual orthogonal (ERO) lines, and the CCFR projector that applies it to the violated
/// half-spaces of a vertex (paper appendix, Alg. orthogonalProjection and Alg. projectOntoConvexRegion).
#include <array>

#include "ccfr/feasibility/projector.hpp"

namespace ccfr {

/// Incremental orthogonal projection of a start point \f$\mathbf{x}^{(0)}\f$ onto
/// \f$S_m = \{\mathbf{x} : \mathbf{a}_i\cdot\mathbf{x} = b_i,\ i = 0..m\}\f$ (Plesník 2007; paper
/// Alg. orthogonalProjection). After each accepted equation, `x` equals the closed form
/// \f$\mathbf{x}^{(0)} - A^\top (A A^\top)^{-1} (A\mathbf{x}^{(0)} - \mathbf{b})\f$.
///
/// Invariants: every stored direction \f$\mathbf{v}_j\f$ spans the ERO line of equations 0..j,
/// i.e. \f$\mathbf{a}_i\cdot\mathbf{v}_j = \mathbf{a}_0\cdot\mathbf{v}_j\f$ for all \f$i \le j\f$, and
/// \f$\mathbf{v}_j \in \operatorname{span}(\mathbf{a}_0..\mathbf{a}_j)\f$. In \f$\mathbb{R}^3\f$ at most
/// three equations are independent, so the lists hold three entries.
struct PlesnikRecursion {
  enum class Step : std::uint8_t {
    added,     ///< the equation was independent; `x` is the projection onto the enlarged system
    redundant  ///< dependent on the stored equations (or a zero normal); `x` unchanged
  };

  Vec3 x0 = Vec3::Zero();     ///< start point \f$\mathbf{x}^{(0)}\f$
  Vec3 x = Vec3::Zero();      ///< current projection \f$\mathbf{x}^{(m+1)}\f$
  std::array<Vec3, 3> v{};    ///< ERO directions \f$\mathcal{V}\f$
  std::array<Vec3, 3> a{};    ///< stored normals \f$\mathcal{A}\f$ (sign as used)
  std::array<double, 3> b{};  ///< stored right-hand sides \f$\mathcal{B}\f$
  int m = 0;                  ///< number of stored independent equations

  /// Starts a new system at `start` (Alg. projectOntoConvexRegion, lines 5-7).
  void reset(const Vec3& start);

  /// Adds the equation \f$\mathbf{n}\cdot\mathbf{x} = \beta\f$ and moves `x` to the projection of
  /// `x0` onto all stored equations (Alg. orthogonalProjection).
  ///
  /// First equation (lines 1-6): \f$\mathbf{x} \leftarrow \mathbf{x} + \frac{\beta -
  /// \mathbf{n}\cdot\mathbf{x}}{\mathbf{n}\cdot\mathbf{n}}\mathbf{n}\f$. Later equations (lines 8-36): the equiresidual
  /// point on the current ERO line, \f$\mathbf{u} = \mathbf{x} + \frac{\beta_m -
  /// \mathbf{a}_m\cdot\mathbf{x}}{(\mathbf{a}_m - \mathbf{a}_0)\cdot\mathbf{v}_{m-1}}\mathbf{v}_{m-1}\f$, a second
  /// equiresidual point \f$\mathbf{w}\f$ from \f$\mathbf{w}_0 = \mathbf{x}^{(0)} + \mathbf{a}_m\f$ by \f$\mathbf{w}
  /// \leftarrow \mathbf{w} + \frac{b_j - b_0 - (\mathbf{a}_j - \mathbf{a}_0)\cdot\mathbf{w}}{(\mathbf{a}_j -
  /// \mathbf{a}_0)\cdot\mathbf{v}_{j-1}}\mathbf{v}_{j-1}\f$ for j = 1..m, where **j = m is the new equation itself**
  /// (design clarification 1; without it \f$\mathbf{w}\f$ is not equiresidual for the new plane), then \f$\mathbf{v}_m
  /// = \mathbf{w} - \mathbf{u}\f$ and \f$\mathbf{x} \leftarrow \mathbf{u} + \frac{b_0 -
  /// \mathbf{a}_0\cdot\mathbf{u}}{\mathbf{a}_0\cdot\mathbf{v}_m}\mathbf{v}_m\f$ (the ERO line meets \f$P_0\f$).
  ///
  /// Difference from the printed algorithm: the paper skips the equation when the denominator of
  /// line 14 vanishes. That also happens for independent planes (e.g. \f$\mathbf{a}_m\cdot\mathbf{v}_{m-1} =
  /// \mathbf{a}_0\cdot\mathbf{v}_{m-1}\f$), so, as in Plesník's original, we may flip the sign of the new
  /// equation (same hyperplane) and take the orientation with the larger denominator, which is at
  /// least \f$|\mathbf{a}_0\cdot\mathbf{v}_{m-1}|\f$. Dependence is then detected only by a vanishing
  /// \f$\mathbf{v}_m\f$ (line 27), relative to the lengths of \f$\mathbf{u}-\mathbf{x}^{(0)}\f$ and
  /// \f$\mathbf{w}-\mathbf{x}^{(0)}\f$.
  /// @param tolerance the redundancy tolerance (1e-12 in the paper)
  Step add(const Vec3& n, double beta, double tolerance);
};

/// The CCFR projector (paper §3.2, appendix Alg. projectOntoConvexRegion) with Plesník's
/// recursion as the inner step. Per call:
///  1. values \f$\rho_k = (\mathbf{x}' - \mathbf{x}_a)\cdot\mathbf{n}_k + d_k\f$; none below -tol: `feasible` (line
///  1-3);
///  2. if some \f$d_k < 0\f$ the anchor itself is outside (clarification 7): its fallback would not be
///     feasible, so the vertex is handed to the exact projector (see ExactProjector), which returns
///     the closest feasible point or reports `infeasible` for an empty region, keeping the anchor;
///  3. sort by \f$\rho_k\f$ ascending, deepest first (lines 2-3);
///  4. up to `max_iterations` passes (line 4): restart the recursion at the pass's start point,
///     visit the planes in sorted order, skip the satisfied ones (line 9-10), add the violated ones
///     as equations \f$\mathbf{n}_k\cdot(\mathbf{x}-\mathbf{x}_a) = -d_k\f$ (lines 11-13), retract by ε
///     toward the anchor (lines 15-19); after the pass re-check every plane and return `projected`
///     when none is violated (clarification 2: a budget of 1 is one projection plus a re-check);
///  5. budget exhausted: fall back to the anchor, status `halted` (line 24);
///  6. a feasible point farther from the candidate than the anchor,
///     \f$\|\mathbf{x} - \mathbf{x}'\| > \|\mathbf{x}_a - \mathbf{x}'\|\f$, is not a projection (the anchor is a
///     better feasible point): the exact projector's answer replaces it, or the anchor (`halted`)
///     if that fails, and `fell_back` is set (0.7 % of random 1-16 plane problems, docs/feasibility.md).
///
/// The ε retraction is applied to a copy: the recursion keeps the unretracted projection, so the
/// ERO lines stay exact and later equations are not biased by the ε shifts of earlier ones; the
/// retracted copy is what the constraints are checked at and what is returned.
/// All arithmetic is done relative to the anchor, which keeps the tolerances scale-free.
class PlesnikProjector final : public Projector {
 public:
  explicit PlesnikProjector(const ProjectorParams& params = {});
  ProjectResult project(const Vec3& x_anchor, const Vec3& x_candidate,
                        std::span<const HalfSpace> planes) const override;
  std::string_view name() const override { return "plesnik"; }
  const ProjectorParams& params() const { return params_; }

 private:
  ProjectorParams params_;
};

/// Pulls `p` (a displacement from the anchor) back toward the anchor by `epsilon`:
/// \f$\mathbf{p} \leftarrow \frac{\|\mathbf{p}\| - \varepsilon}{\|\mathbf{p}\|}\mathbf{p}\f$, or 0 when
/// \f$\|\mathbf{p}\| \le \varepsilon\f$ (paper §3.2, "Numerical Treatment").
Vec3 retract_toward_anchor(const Vec3& p, double epsilon);

}  // namespace ccfr
