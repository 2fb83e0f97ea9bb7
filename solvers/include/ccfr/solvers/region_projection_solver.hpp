#pragma once
/// @file region_projection_solver.hpp
/// RegionProjectionSolver: per-vertex convex regions projected onto by a Projector, the solver of
/// the keys `ccfr` (Plesník's projection with halting, the paper), `exact_projection` (the exact
/// Euclidean projection) and `successive_projection` (naive cyclic projection, related work).
#include <memory>
#include <string>

#include "ccfr/feasibility/projector.hpp"
#include "ccfr/solvers/detecting_solver.hpp"
#include "ccfr/solvers/motion_planes.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"

namespace ccfr {

/// Projects every vertex that left its region back onto it with a Projector.
class RegionProjectionSolver final : public DetectingSolver {
 public:
  /// `solver_name` is the registry name; `projector_name` one of projector_names(); `params` the
  /// values of the projector's own specs (e.g. plesnik's max_iterations), folded into its ProjectorParams.
  RegionProjectionSolver(std::string solver_name, std::string projector_name, ParamValues params = {});
  std::string_view name() const override { return name_; }
  void initialize(const Topology& topo, const SimState& state, const SimulationParams& params) override;
  SolveResult resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;
  /// The contact response of every vertex but those of unpinned rigid bodies (their pose solve has its own).
  void respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;
  bool clamps_to_radius() const override { return true; }
  bool takes_vertex_reach() const override { return true; }
  bool guarantees_separation() const override { return projector_name_ != "successive_projection"; }
  void vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                          std::vector<std::uint8_t>& halted) const override;
  /// Close sub-pairs (DetectingSolver) plus rigid-body vertices off their body's rigid placement.
  std::optional<Index> count_outside(const Positions& x, const Positions& anchor, const SimState& state,
                                     StepContext& ctx) const override;

 protected:
  /// The scene's inverse masses with unpinned rigid bodies masked, as respond() passes them.
  std::span<const double> response_mass(const SimState& state) override;

 private:
  /// The bodies' answer to the impulses of separate() (contact.momentum): see the definition.
  void react_bodies(Positions& x);
  /// resolve()'s second stage: the unpinned rigid bodies' pose solves against the placed vertices.
  void place_bodies(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx,
                    std::span<const double> projected_mass, SolveResult& r);
  /// place_bodies()' pose solves under contact.momentum, with the vertices a body both pushes and
  /// leaves carried by its motion where their other planes allow (mark_carried).
  RigidEnforceStats enforce_carrying(Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                     const StepContext& ctx, std::span<const double> projected_mass,
                                     std::span<const Vec3> cores, const RigidContactOptions& options);
  /// Fills ends_ (where each vertex ends a carrying round) and returns each body's longest step.
  std::vector<double> place_ends(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                 const StepContext& ctx, std::span<const RigidMotion> motion);
  /// Whether the plane `ref` (RegionSet::refs) of a carried vertex holds for its move from `from`
  /// to `to` (enforce_carrying), the other side at `ends` (where each vertex ends the pass; one of
  /// inverse mass 0 gives no room by retreating). A pair one rigid motion moves whole needs a gap
  /// of `shrink` times its offset (1/cos(θ/2) - 1 for the body's turn θ).
  /// Whether the contact of plane source `source` (contact × 4 + vertex) joins two unpinned bodies,
  /// answered by answer_pairs() in the last respond().
  bool paired(size_t source) const;
  /// The impulse (kg m) answer_pairs() gave that contact, times the source vertex's |w|.
  double paired_press(size_t source) const;
  bool carried_plane_holds(std::uint32_t ref, const Positions& anchor, std::span<const Vec3> ends,
                           std::span<const double> inv_mass, const Vec3& from, const Vec3& to, double shrink) const;
  /// The pair of plane `ref` of a vertex carried by `body`: if its every vertex is `body`'s or
  /// movable, of no rigid body and not carried by another body, those not yet carried join
  /// `carried` (their positions `x` into `projected`), so that the pair moves whole; whether any did.
  bool carry_along(std::uint32_t ref, Index body, std::span<const double> projected_mass, const Positions& x,
                   std::vector<Index>& carried, std::vector<Vec3>& projected);
  std::string name_, projector_name_;
  ParamValues projector_params_;
  std::unique_ptr<Projector> projector_;
  RigidBodies rigid_;     ///< rigid bodies, whose correction is taken as a rigid motion
  Positions candidates_;  ///< the candidates before the pose solves (the other sides' motion)
  /// Per body, in the last respond(): the move of its centre by the impulses of the contacts it
  /// gave way in (react_bodies); its core's prediction moves with it in resolve().
  std::vector<Vec3> reaction_shift_;
  /// Per contact, in the last respond() under contact.momentum: the impulse (kg m) answer_pairs()
  /// gave a pair of two unpinned bodies, which press each other with it (their friction's bound).
  std::vector<double> pair_pressed_;
  /// Per contact, with pair_pressed_: 1 where its sides lie on two unpinned bodies (their plane is
  /// split by the motion answer_pairs() left them).
  std::vector<std::uint8_t> pair_answered_;
  std::vector<double> later_;               ///< per vertex: placed after the projection (an unpinned rigid body's)
  std::vector<Index> vertex_body_;          ///< per vertex: its unpinned rigid body, or -1 (with later_)
  std::vector<Index> carrier_;              ///< per vertex: the body carrying it this pass, or -1
  Positions ends_;                          ///< per vertex: where it ends a carrying round
  std::vector<double> other_inverse_mass_;  ///< per contact: a rigid other side's generalized inverse mass
  /// Per contact, from respond(): its answering body (-1: none), the arm from the body's centre to
  /// its closest point and the direction the body gives way; per body its inverse mass and world
  /// inverse inertia (frames at the anchor). separate() couples the body's contacts through them.
  std::vector<Index> answering_body_;
  std::vector<Vec3> answering_arm_, answering_away_;
  std::vector<double> body_inv_mass_;
  std::vector<Eigen::Matrix3d> body_inv_inertia_;
  std::vector<double> free_mask_;  ///< inverse masses with unpinned rigid bodies' vertices at 0 (not projected alone)
  std::vector<std::uint8_t> halted_;    ///< #V: halted during frame `halted_frame_`
  std::vector<HeldSplit> held_splits_;  ///< the pass's sides held at their old plane (split_by_motion)
  std::vector<double> free_split_;      ///< #V: projected inverse masses in the pass's free islands, else 0
  int halted_frame_ = -1;
};

}  // namespace ccfr
