#pragma once
/// @file materials.hpp
/// XPBD material constraints beyond edge lengths: dihedral bending of cloth and shells, turning-angle
/// bending of strands, volume and deviatoric terms of tetrahedral solids, and shape matching of rigid
/// bodies; plus `MaterialSystem`, which builds the batch of every registered material constraint
/// (material_constraint.hpp) for a scene and sweeps them.
///
/// Every constraint type is a batch (struct of arrays) solved by a stateless kernel in `ccfr::xpbd`.
/// A kernel applies one XPBD update (Macklin et al. 2016, Eq. 18)
/// \f[ \Delta\lambda = \frac{-C - \tilde\alpha\lambda}{\sum_i w_i \|\nabla_i C\|^2 + \tilde\alpha}, \qquad
///     \mathbf{x}_i \mathrel{+}= w_i \nabla_i C\, \Delta\lambda, \qquad \tilde\alpha = \alpha / \Delta t^2 \f]
/// and writes only vertices with \f$w_i > 0\f$, so kinematic vertices shared by constraints of one
/// colour are never written concurrently. Batches are coloured once (`colour_constraints`): a colour's
/// constraints share no dynamic vertex and run in parallel, colours run in sequence, so the result is
/// identical for any thread count. Degenerate configurations (zero-area triangles, collinear strand
/// points, collapsed tets) skip the update instead of producing NaN. See docs/materials.md.
#include <array>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"
#include "ccfr/solvers/params.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

namespace xpbd {

/// Applies one XPBD update for a scalar constraint of `N` vertices given its value and gradient.
/// Returns Δλ (0 when every vertex is kinematic or the gradient vanishes).
template <int N>
double apply_update(const std::array<Vec3*, N>& x, const std::array<double, N>& w, const std::array<Vec3, N>& grad,
                    double c, double alpha_tilde, double& lambda) {
  double denom = alpha_tilde;
  for (int k = 0; k < N; ++k) denom += w[k] * grad[k].squaredNorm();
  if (!(denom > 0.0)) return 0.0;
  const double dl = (-c - alpha_tilde * lambda) / denom;
  lambda += dl;
  for (int k = 0; k < N; ++k)
    if (w[k] > 0.0) *x[k] += (w[k] * dl) * grad[k];
  return dl;
}

// ---------------------------------------------------------------------------------------------
// Cloth and shell bending

/// Signed dihedral angle \f$\theta \in (-\pi, \pi]\f$ across the edge \f$(\mathbf{x}_0, \mathbf{x}_1)\f$
/// shared by the triangles \f$(\mathbf{x}_0, \mathbf{x}_1, \mathbf{x}_2)\f$ and \f$(\mathbf{x}_0, \mathbf{x}_3,
/// \mathbf{x}_1)\f$: with \f$\mathbf{e} = \mathbf{x}_1 - \mathbf{x}_0\f$, \f$\mathbf{n}_1 = \mathbf{e} \times
/// (\mathbf{x}_2 - \mathbf{x}_0)\f$, \f$\mathbf{n}_2 = (\mathbf{x}_3 - \mathbf{x}_0) \times \mathbf{e}\f$, \f[ \theta =
/// \operatorname{atan2}\big((\hat{\mathbf{n}}_1 \times \hat{\mathbf{n}}_2) \cdot \hat{\mathbf{e}},\;
///     \hat{\mathbf{n}}_1 \cdot \hat{\mathbf{n}}_2\big). \f]
/// A flat pair (x_2 and x_3 on opposite sides of the edge) has θ = 0. Returns 0 for degenerate triangles.
double dihedral_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3);

/// θ (as `dihedral_angle`) and its gradient with respect to (x_0, x_1, x_2, x_3) (Bridson et al. 2003):
/// \f[ \nabla_2\theta = -\frac{|\mathbf{e}|}{|\mathbf{n}_1|^2}\mathbf{n}_1,\quad
///     \nabla_3\theta = -\frac{|\mathbf{e}|}{|\mathbf{n}_2|^2}\mathbf{n}_2,\quad
///     \nabla_0\theta = -\frac{(\mathbf{x}_2 -
///     \mathbf{x}_1)\cdot\mathbf{e}}{|\mathbf{e}|\,|\mathbf{n}_1|^2}\mathbf{n}_1
///                      -\frac{(\mathbf{x}_3 -
///                      \mathbf{x}_1)\cdot\mathbf{e}}{|\mathbf{e}|\,|\mathbf{n}_2|^2}\mathbf{n}_2,\quad
///     \nabla_1\theta = -\nabla_0\theta - \nabla_2\theta - \nabla_3\theta. \f]
/// Returns false (grad untouched) when the edge or either triangle is degenerate: the gradient
/// grows as 1/height and is undefined at zero area.
bool dihedral_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double& theta,
                             std::array<Vec3, 4>& grad);

/// Dihedral bending (Müller et al. 2007, in XPBD form): \f$C = \operatorname{wrap}(\theta - \theta_0)\f$ with
/// wrap into \f$(-\pi, \pi]\f$, compliance α in rad²/J = 1/(N·m). x = (x_0, x_1, x_2, x_3) as in
/// `dihedral_angle`. Skips degenerate triangles.
void solve_dihedral_bending(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_angle,
                            double alpha_tilde, double& lambda);

// ---------------------------------------------------------------------------------------------
// Strand bending

/// Turning angle at x_1 of the polyline x_0, x_1, x_2: the angle between \f$\mathbf{e}_1 = \mathbf{x}_1 -
/// \mathbf{x}_0\f$ and \f$\mathbf{e}_2 = \mathbf{x}_2 - \mathbf{x}_1\f$, \f$\varphi =
/// \operatorname{atan2}(|\mathbf{e}_1 \times \mathbf{e}_2|, \mathbf{e}_1 \cdot \mathbf{e}_2) \in [0, \pi]\f$ (0 for a
/// straight strand). Returns 0 for zero-length segments.
double turning_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2);

/// φ (as `turning_angle`) and its gradient with respect to (x_0, x_1, x_2): with unit directions
/// \f$\mathbf{u} = \hat{\mathbf{e}}_1\f$, \f$\mathbf{v} = \hat{\mathbf{e}}_2\f$,
/// \f$\mathbf{p}_1 = (\mathbf{v} - (\mathbf{u}\cdot\mathbf{v})\mathbf{u}) / \sin\varphi\f$,
/// \f$\mathbf{p}_2 = (\mathbf{u} - (\mathbf{u}\cdot\mathbf{v})\mathbf{v}) / \sin\varphi\f$:
/// \f[ \nabla_0\varphi = \frac{\mathbf{p}_1}{|\mathbf{e}_1|},\quad \nabla_2\varphi =
/// -\frac{\mathbf{p}_2}{|\mathbf{e}_2|},\quad
///     \nabla_1\varphi = -\nabla_0\varphi - \nabla_2\varphi. \f]
/// Returns false when a segment has zero length or the points are collinear (sin φ = 0): φ is not
/// differentiable there (a cone point, like a distance constraint at zero length).
bool turning_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, double& phi, std::array<Vec3, 3>& grad);

/// Strand bending: \f$C = \varphi - \varphi_0\f$ on consecutive segments, compliance α in rad²/J = 1/(N·m).
/// For a straight rest shape (φ_0 = 0) this is a cone constraint whose correction always straightens
/// the strand; collinear current points have C = -φ_0 ≤ 0 with no defined direction and are skipped.
void solve_strand_bending(const std::array<Vec3*, 3>& x, const std::array<double, 3>& w, double rest_angle,
                          double alpha_tilde, double& lambda);

// ---------------------------------------------------------------------------------------------
// Tetrahedral solids

/// Six times the signed volume, \f$6V = (\mathbf{x}_1 - \mathbf{x}_0) \cdot ((\mathbf{x}_2 - \mathbf{x}_0) \times
/// (\mathbf{x}_3 - \mathbf{x}_0))\f$ (positive for a positively oriented tet).
double tet_six_volume(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3);

/// Volume constraint \f$C_V = 6(V - V_0)\f$ and its gradient:
/// \f$\nabla_1 C_V = (\mathbf{x}_2 - \mathbf{x}_0)\times(\mathbf{x}_3 - \mathbf{x}_0)\f$,
/// \f$\nabla_2 C_V = (\mathbf{x}_3 - \mathbf{x}_0)\times(\mathbf{x}_1 - \mathbf{x}_0)\f$,
/// \f$\nabla_3 C_V = (\mathbf{x}_1 - \mathbf{x}_0)\times(\mathbf{x}_2 - \mathbf{x}_0)\f$,
/// \f$\nabla_0 C_V = -\sum_{k=1}^3 \nabla_k C_V\f$. Defined (and finite) for inverted and flat tets.
double tet_volume_constraint(const std::array<Vec3, 4>& x, double rest_volume, std::array<Vec3, 4>& grad);

/// Volume preservation: \f$C_V = 6(V - V_0)\f$, compliance α in m⁶/J (MaterialSystem uses
/// α = 36 V_0 · volume_compliance with volume_compliance = 1/λ in 1/Pa). Inverted tets are pushed back
/// toward V_0 > 0; a flat tet with a vanishing gradient (all points coincident or collinear) is skipped.
void solve_tet_volume(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_volume,
                      double alpha_tilde, double& lambda);

/// Deviatoric (co-rotational shape) constraint \f$C_D = \|\mathbf{F} - \mathbf{R}\|_F\f$ with
/// \f$\mathbf{F} = \mathbf{D}_s \mathbf{D}_m^{-1}\f$, \f$\mathbf{D}_s = [\mathbf{x}_1 - \mathbf{x}_0,\ \mathbf{x}_2 -
/// \mathbf{x}_0,\ \mathbf{x}_3 - \mathbf{x}_0]\f$ (3 by 3), `rest_inverse` = \f$\mathbf{D}_m^{-1}\f$ of the rest shape
/// and R = `polar_rotation_newton`(F) (det R = +1). Its energy \f$\tfrac12 C_D^2/\alpha\f$ is the as-rigid-as-possible
/// / co-rotational energy; since R minimises \f$\|\mathbf{F} - \mathbf{R}\|\f$ over rotations, \f$\partial
/// C_D/\partial\mathbf{F} = (\mathbf{F} - \mathbf{R})/C_D\f$, and the gradient is given by the columns of \f$\mathbf{H}
/// = (\mathbf{F} - \mathbf{R})\mathbf{D}_m^{-T} / C_D\f$ for x_1..x_3, \f$\nabla_0 C_D = -\sum_k \mathbf{H}_{:,k}\f$.
/// Unlike \f$\|\mathbf{F}\|_F - \sqrt{3}\f$ (the stable Neo-Hookean term shifted to vanish at rest), it resists
/// shear to first order. Returns false when C_D = 0 (a rotation: satisfied, direction undefined like a
/// zero-length distance constraint); inverted tets get R with det +1 and are pushed back to positive volume.
bool tet_deviatoric_constraint(const std::array<Vec3, 4>& x, const Eigen::Matrix3d& rest_inverse, double& c,
                               std::array<Vec3, 4>& grad);

/// Deviatoric (shape) term: \f$C_D = \|\mathbf{F} - \mathbf{R}\|_F\f$, compliance α in 1/J (MaterialSystem uses
/// α = shear_compliance / V_0 with shear_compliance = 1/μ in 1/Pa). Finite for inverted and flat tets.
void solve_tet_deviatoric(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w,
                          const Eigen::Matrix3d& rest_inverse, double alpha_tilde, double& lambda);

// ---------------------------------------------------------------------------------------------
// Rigid bodies

/// Rotation part of the polar decomposition \f$\mathbf{A} = \mathbf{R}\mathbf{S}\f$ from the SVD
/// \f$\mathbf{A} = \mathbf{U}\boldsymbol{\Sigma}\mathbf{V}^T\f$: \f$\mathbf{R} = \mathbf{U}\,\mathrm{diag}(1, 1,
/// \det(\mathbf{U}\mathbf{V}^T))\,\mathbf{V}^T\f$, so det R = +1 even for reflections or rank-deficient A (flat or
/// collinear bodies).
Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& a);

/// The same rotation by Higham's scaled Newton iteration (Higham 1986, "Computing the polar
/// decomposition with applications"): \f$\mathbf{X}_0 = \mathbf{A}\f$, \f$\mathbf{X}_{k+1} =
/// \tfrac12(\zeta_k\mathbf{X}_k + \zeta_k^{-1}\mathbf{X}_k^{-T})\f$ with \f$\zeta_k = (\|\mathbf{X}_k^{-1}\|_F /
/// \|\mathbf{X}_k\|_F)^{1/2}\f$, until the step is below 1e-7 (quadratic convergence leaves the last iterate within
/// about 5e-15 of the limit: 3-4 steps for a tet's F, 4-5x cheaper than the SVD and equal to it within a few ulps). The
/// iteration yields the orthogonal factor with det = sign det A, so an inverted, flat or nearly flat A (det A ≤ 1e-6
/// ‖A‖³) goes to polar_rotation() instead.
Eigen::Matrix3d polar_rotation_newton(const Eigen::Matrix3d& a);

/// Shape matching (Müller et al. 2005) with stiffness 1 of one body of n vertices. With weights
/// \f$m_i\f$, rest offsets \f$\mathbf{q}_i = \bar{\mathbf{x}}_i - \bar{\mathbf{c}}\f$ about the weighted rest centre,
/// \f$\mathbf{c} = \sum_i m_i \mathbf{x}_i / \sum_i m_i\f$, \f$\mathbf{A}_{pq} = \sum_i m_i (\mathbf{x}_i -
/// \mathbf{c})\mathbf{q}_i^T\f$ and R = `polar_rotation`(A_pq), every vertex with \f$w_i > 0\f$ moves to its goal
/// \f$\mathbf{g}_i = \mathbf{R}\mathbf{q}_i + \mathbf{c}\f$ (the constraint \f$\mathbf{C}_i = \mathbf{x}_i -
/// \mathbf{g}_i = 0\f$ projected exactly). x, w: #n; q, m: #n. Sums run in vertex order, so the result does not depend
/// on threads.
void solve_shape_matching(std::span<Vec3> x, std::span<const double> w, std::span<const Vec3> q,
                          std::span<const double> m);

}  // namespace xpbd

// -------------------------------------------------------------------------------------------------
// Batches

/// Dihedral bending on interior edges (the material constraint `dihedral_bending`):
/// ids(c) = (edge v0, edge v1, wing of face 1, wing of face 2), the vertex order of `xpbd::dihedral_angle`.
struct BendingBatch final : FixedArityBatch<4> {
  std::vector<double> rest_angle;  ///< #C, θ_0 (rad) from the rest state
  std::vector<double> compliance;  ///< #C, α (1/(N·m))
  std::vector<double> lambda;      ///< #C

  void add(const Vec4i& v, double theta0, double alpha);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 4.0; }
  int sweep_rank() const override { return 20; }
};

/// Turning-angle bending at interior polyline vertices (the material constraint `strand_bending`):
/// ids(c) = (x_{i-1}, x_i, x_{i+1}).
struct StrandBendingBatch final : FixedArityBatch<3> {
  std::vector<double> rest_angle;  ///< #C, φ_0 (rad) from the rest state
  std::vector<double> compliance;  ///< #C, α (1/(N·m))
  std::vector<double> lambda;      ///< #C

  void add(const Vec3i& v, double phi0, double alpha);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 3.0; }
  int sweep_rank() const override { return 30; }
};

/// Volume and deviatoric constraints per tet (the material constraint `tet_elasticity`; ids(t): its
/// four vertices), solved back to back (deviatoric first, volume last so the incompressibility term
/// has the final word within a sweep); both share one colouring.
struct TetBatch final : FixedArityBatch<4> {
  std::vector<double> rest_volume;                       ///< #T, V_0 (m³)
  std::vector<Eigen::Matrix3d> rest_inverse;             ///< #T, D_m^{-1} (1/m)
  std::vector<double> volume_compliance;                 ///< #T, α_V = 36 V_0 / λ (m⁶/J)
  std::vector<double> deviatoric_compliance;             ///< #T, α_D = 1 / (μ V_0) (1/J)
  std::vector<double> lambda_volume, lambda_deviatoric;  ///< #T each

  /// Adds a tet with per-volume compliances (1/λ and 1/μ, 1/Pa) from its rest positions `rest` (#V).
  /// Returns false and adds nothing when the rest tet is degenerate (|6 V_0| tiny against its edges³).
  bool add(const Vec4i& v, const Positions& rest, double volume_compliance_per_volume,
           double shear_compliance_per_volume);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 10.0; }
  int sweep_rank() const override { return 40; }
};

/// Shape matching of rigid bodies; body b owns the contiguous vertices [begin[b], end[b]) and the
/// entries [row_start[b], row_start[b+1]) of `rest_offset` and `weight`. Bodies are disjoint, so they are
/// solved in parallel, each one sequentially.
struct ShapeMatchingBatch {
  std::vector<Index> begin, end;  ///< #B vertex ranges
  std::vector<Index> row_start;   ///< #B + 1
  std::vector<Vec3> rest_offset;  ///< q_i = rest_i - weighted rest centre (m)
  std::vector<double> weight;     ///< m_i: mass 1/w_i of dynamic vertices; kinematic vertices dominate (see docs)

  /// Adds the body made of vertices [first, last) with rest positions `rest` and inverse masses `inv_mass` (#V).
  void add(Index first, Index last, const Positions& rest, std::span<const double> inv_mass);
  void solve(Positions& x, std::span<const double> inv_mass) const;
  /// Rigid prediction: every body without kinematic vertices repeats the rigid motion of its
  /// last substep, read from `x` and `x - dt v` (its centre moves by dt v_c + `g_dt2`, its
  /// rotation turns again by the last substep's ΔR), into `predicted`. The per-vertex prediction
  /// x + dt v followed by shape matching turns by θ - 2θ³/3 instead of θ = ω dt, which bled
  /// 2θ²/3 of the spin per substep (a tenth of a 10 rad/s spin per second at 480 substeps/s).
  void predict(const Positions& x, const Positions& v, std::span<const double> inv_mass, double dt, const Vec3& g_dt2,
               Positions& predicted) const;
  Index size() const { return static_cast<Index>(begin.size()); }
};

/// Every material constraint of a scene: one batch per entry of `material_constraints()` that has
/// constraints in the scene, plus shape matching of rigid bodies. The built-in entries cover
/// - cloth, shell: edge lengths (`stretch`, stretch_compliance) + dihedral bending on interior edges
///   (`dihedral_bending`, bend_compliance);
/// - strand: segment lengths (`stretch`) + turning-angle bending (`strand_bending`, bend_compliance);
/// - tet_solid: volume (volume_compliance) + deviatoric (shear_compliance) per tet (`tet_elasticity`);
/// - rigid: shape matching only (edge constraints would be redundant with the exact projection);
/// - particles, obstacle: none.
/// One `solve` is one sweep: the batches by `ConstraintBatch::sweep_rank` (stretch, bending, strand
/// bending, tets, then registered ones), then shape matching last so that rigid bodies leave every
/// sweep exactly rigid.
///
/// Schedule. Constraints that share no dynamic vertex, directly or through other constraints, form
/// separate islands (connected components; in practice the objects). A small island (no colour of
/// it exceeds the parallel grain of its batch, so colour-by-colour it would run on one thread
/// anyway) is one task that runs its constraints serially in colour order; the small islands run in
/// parallel. Large islands keep the colour-by-colour parallel loops. Each dynamic vertex sees the
/// same updates in the same order as in `solve_by_colour`, so both give bit-identical results, for
/// any thread count, while small scenes pay one parallel loop per sweep instead of one per colour and
/// a scene of several small bodies uses every thread.
class MaterialSystem {
 public:
  MaterialSystem() = default;  ///< an empty system (no constraints)
  /// `params.objects` must be parallel to `topo.objects`; rest shapes are `state.rest`, and kinematic
  /// vertices are those with `state.inv_mass == 0` at construction (the colouring depends on them).
  /// Throws ccfr::Error when a material enables a constraint that is not registered or sets
  /// parameters it does not accept.
  MaterialSystem(const Topology& topo, const SimState& state, const SimulationParams& params);
  MaterialSystem(MaterialSystem&&) noexcept;
  MaterialSystem& operator=(MaterialSystem&&) noexcept;
  ~MaterialSystem();

  void reset_multipliers();
  /// One sweep over all batches (island schedule, see above). x, inv_mass: #V.
  void solve(Positions& x, std::span<const double> inv_mass, double dt);
  /// The same sweep, every colour of every batch over the whole scene in turn (each colour a parallel
  /// loop): the reference schedule, bit-identical to `solve`.
  void solve_by_colour(Positions& x, std::span<const double> inv_mass, double dt);

  struct Counts {
    Index distance = 0, bending = 0, strand_bending = 0, tet_volume = 0, tet_deviatoric = 0, rigid_bodies = 0;
    Index colours = 0;        ///< colours summed over the coloured batches
    Index small_islands = 0;  ///< islands solved as one serial task each (in parallel with each other)
    Index large_islands = 0;  ///< islands solved colour by colour
    /// Constraints of every batch in sweep order, by registered name (built-ins included).
    std::vector<std::pair<std::string, Index>> by_name;
  };
  Counts counts() const;

  /// The batch of the material constraint `name`, or nullptr when the scene has none.
  const ConstraintBatch* batch(std::string_view name) const;
  /// The built-in batches (empty when the scene has no such constraint).
  const DistanceBatch& distance() const;
  const BendingBatch& bending() const;
  const StrandBendingBatch& strand_bending() const;
  const TetBatch& tets() const;
  const ShapeMatchingBatch& rigid() const { return rigid_; }

 private:
  /// The constraints of one batch that belong to small islands, grouped by island (colour order kept
  /// within an island): island i owns order[row_start[i], row_start[i+1]).
  struct IslandOrder {
    std::vector<Index> order;
    std::vector<Index> row_start;  ///< #small islands + 1
    std::span<const Index> island(Index i) const {
      return std::span<const Index>(order).subspan(static_cast<size_t>(row_start[i]),
                                                   static_cast<size_t>(row_start[i + 1] - row_start[i]));
    }
  };
  /// One registered constraint's batch with its share of the island schedule.
  struct Stage {
    std::string name;
    std::unique_ptr<ConstraintBatch> batch;
    IslandOrder small;  ///< its constraints in small islands
    Colouring large;    ///< its colouring restricted to the constraints of large islands
  };
  void build_schedule(Index num_vertices, std::span<const double> inv_mass);
  template <class B>
  const B& builtin(std::string_view name) const;

  std::vector<Stage> stages_;  ///< in sweep order
  ShapeMatchingBatch rigid_;
  Index small_islands_ = 0, large_islands_ = 0;
};

}  // namespace ccfr
