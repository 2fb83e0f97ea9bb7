#pragma once
/// @file material_system.hpp
/// `MaterialSystem`: the batch of every registered material constraint (material_constraint.hpp; the
/// built-ins in ccfr/solvers/materials/<key>.hpp) and shape matching (shape_matching.hpp) for a
/// scene, scheduled by islands and colours, and swept.
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
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/params.hpp"
#include "ccfr/solvers/shape_matching.hpp"

namespace ccfr {

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
  /// The shape matching of the scene's rigid bodies (not a registered constraint).
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

  std::vector<Stage> stages_;  ///< in sweep order
  ShapeMatchingBatch rigid_;
  Index small_islands_ = 0, large_islands_ = 0;
};

}  // namespace ccfr
