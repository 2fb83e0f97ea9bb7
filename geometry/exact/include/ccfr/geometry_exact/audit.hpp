#pragma once
/// @file audit.hpp
/// The penetration audit: certifies that a sequence of configurations of a scene is free of
/// intersections and keeps every pair of primitives at least (1 - tol) xi apart, with exact
/// predicates. See docs/audit.md.
///
/// Checked per configuration, over candidates from a BVH (boxes grown by report_range xi / 2),
/// never over all pairs:
/// - triangle-triangle intersections between faces that share no vertex (exact, touching counts);
/// - strand segments through triangles (segment-triangle, sharing no vertex);
/// - distance sub-pairs sharing no vertex: vertex-face and edge-edge for every primitive, plus
///   vertex-edge and vertex-vertex where a particle is involved (for meshes and strands these are
///   already covered: the distance of two triangles or segments is attained at a vertex-face or
///   edge-edge pair). A sub-pair is *close* if its exact distance is below (1 - tol) xi.
/// Initial proximity, fixed at construction from the reference (frame 0), by the same rule as the
/// simulation (design clarification 5, corrected; ccfr/geometry/adjacency.hpp):
/// - sub-pairs closer than xi there that are topologically adjacent (joined by a path of at most
///   kAdjacencyRadiusInOffsets xi along the mesh edges) are excluded;
/// - triangle pairs and segment-triangle pairs intersecting there are excluded from the
///   intersection tests, and their sub-pairs from the distance tests;
/// - every other sub-pair closer than xi there is checked against its own offset
///   (1 - kInitialOffsetMargin) d0, raised by raise_offsets() toward xi as the pair separates.
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::exact {

struct AuditOptions {
  double offset = 0.0;     ///< xi, the minimum separation the simulation promises (scene units)
  double tolerance = 0.0;  ///< relative slack: a sub-pair is close if its distance < (1 - tolerance) xi
  int max_examples = 5;    ///< offending pairs kept per frame for messages
  /// The minimum distance is reported over sub-pairs within report_range xi (>= 1); larger values
  /// widen the candidate search (boxes grow by report_range xi / 2) and cost time.
  double report_range = 1.5;
  /// Per object of the topology (empty: every object deformable): a combination of kRigidObject
  /// and kScriptedObject (docs/audit.md, "Rigid and scripted objects").
  std::vector<std::uint8_t> object_roles;
  /// A rigid object counts as rigid in a configuration while every vertex lies within this
  /// fraction of its reference extent (bounding-box diagonal) of the best rigid fit.
  double rigid_tolerance = 1e-9;
};

/// The object's shape must stay a rigid transform of the reference (a rigid body, an obstacle
/// moved rigidly): while it does, its pairs with itself are unchanged but for round-off and are not
/// tested; when it does not, the deformation is a violation and its pairs are tested.
inline constexpr std::uint8_t kRigidObject = 1;
/// The object is moved by the scene, not by the solver (an obstacle, a rigid body driven by pins):
/// pairs between two such objects are a scene error, reported apart and never a violation.
inline constexpr std::uint8_t kScriptedObject = 2;

/// One offending pair, for messages.
struct AuditExample {
  enum class Kind {
    triangle_triangle,
    segment_triangle,
    vertex_face,
    edge_edge,
    vertex_edge,
    vertex_vertex,
    rigid_deformation
  };
  Kind kind = Kind::triangle_triangle;
  /// Face / edge / vertex ids in the Topology, by kind (first, second); rigid_deformation: the
  /// vertex farthest from the rigid fit and its object.
  Index a = -1, b = -1;
  double distance = 0.0;         ///< distance (double kernels); 0 for intersections; the deviation
  std::string object;            ///< rigid_deformation: the object's name
  std::string describe() const;  ///< e.g. "vertex 12 - face 340 at distance 0.00091"
};

const char* to_string(AuditExample::Kind kind);

struct FrameAudit {
  Index triangle_intersections = 0;  ///< intersecting triangle pairs sharing no vertex
  Index segment_crossings = 0;       ///< strand segments through triangles
  Index close_pairs = 0;             ///< sub-pairs closer than (1 - tol) xi
  /// Rigid objects (AuditOptions::object_roles) whose shape is no longer a rigid transform of the
  /// reference: violations.
  Index rigid_deformations = 0;
  /// Intersections, crossings and close pairs between two scripted objects: a scene error, not a
  /// violation (no solver moves either side).
  Index scene_pairs = 0;
  std::vector<AuditExample> scene_examples;  ///< up to max_examples of them
  /// Minimum distance (double kernels) over the checked, non-excluded sub-pairs within
  /// report_range xi of each other; +infinity if there is none.
  double min_distance = std::numeric_limits<double>::infinity();
  Index checked_pairs = 0;             ///< non-excluded distance sub-pairs within report_range xi
  std::vector<AuditExample> examples;  ///< up to max_examples offending pairs, in a deterministic order

  /// Intersections + crossings + close pairs: the `penetrations` stats column.
  Index penetrations() const { return triangle_intersections + segment_crossings + close_pairs + rigid_deformations; }
  bool clean() const { return penetrations() == 0; }
};

/// Audits configurations of one scene against the reference configuration given at construction.
/// audit() is const and may run concurrently (each call runs in parallel inside); raise_offsets()
/// mutates the reduced offsets, so a sequence is audited in order with audit_next().
class PenetrationAudit {
 public:
  /// `reference`: #V positions of frame 0 (or the rest state), used for the exclusions.
  /// Throws ccfr::Error on a size mismatch, non-finite positions, or xi <= 0 / tol outside [0, 1).
  PenetrationAudit(Topology topology, const Positions& reference, AuditOptions options);

  /// Audits one configuration (#V positions). Throws ccfr::Error on a size mismatch or a
  /// non-finite coordinate (naming the vertex).
  FrameAudit audit(const Positions& x) const;
  /// Raises the reduced offsets of pairs that started closer than xi to
  /// min(xi, max(offset, (1 - kInitialOffsetMargin) d)) at the distances d in x (a configuration
  /// that was audited: a later one is checked against the raised offsets).
  void raise_offsets(const Positions& x);
  /// audit(x), then raise_offsets(x): for the frames of a run, in order.
  FrameAudit audit_next(const Positions& x);
  /// The current reduced offsets, in key order: the audit's only state that changes (checkpoints).
  const std::vector<double>& reduced_offsets() const { return reduced_offset_; }
  /// Restores reduced_offsets() of an audit of the same reference. Throws ccfr::Error on another
  /// count, a non-finite value, or an offset below its initial value or above xi.
  void restore_reduced_offsets(std::span<const double> offsets);

  const Topology& topology() const { return topo_; }
  const AuditOptions& options() const { return opt_; }
  /// Sub-pairs excluded because they are closer than xi in the reference and topologically adjacent.
  Index excluded_close_pairs() const;
  /// Sub-pairs closer than xi in the reference, not adjacent: checked against a reduced offset.
  Index reduced_offset_pairs() const { return static_cast<Index>(reduced_key_.size()); }
  /// The offset a sub-pair key is checked against now: xi, its reduced offset, or -1 if excluded.
  double pair_offset(std::uint64_t key) const;
  /// Triangle pairs and segment-triangle pairs excluded because they intersect in the reference.
  Index excluded_intersections() const { return static_cast<Index>(excluded_tt_.size() + excluded_st_.size()); }

 private:
  struct Scan;
  struct CloseKey {
    std::uint64_t key;
    double distance;
  };
  FrameAudit run(const Positions& x, bool reference_pass, std::vector<CloseKey>* close_keys,
                 std::vector<std::uint64_t>* tt_keys, std::vector<std::uint64_t>* st_keys) const;
  /// The vertices of a sub-pair (side A first, then side B); returns the count on side A.
  int sub_pair_vertices(std::uint64_t key, Index (&v)[5], int& n) const;
  double key_distance_sq(std::uint64_t key, const Positions& x) const;

  Topology topo_;
  AuditOptions opt_;
  Positions reference_;                    ///< kept only when some object is rigid (its rigid fits start from it)
  std::vector<std::uint8_t> vertex_role_;  ///< #V: 0 no primitive, 1 mesh/strand vertex, 2 particle
  std::vector<std::uint8_t> strand_edge_;  ///< #E: 1 if the edge is a strand segment
  /// Sorted keys of excluded pairs: (type << 62) | (first << 31) | second, with a canonical
  /// order of the two ids per type (vertex before face/edge; the smaller id first for like pairs).
  std::vector<std::uint64_t> excluded_close_;  ///< adjacent close sub-pairs and sub-pairs of crossing pairs
  std::vector<std::uint64_t> excluded_tt_, excluded_st_;
  /// Sub-pairs closer than xi in the reference, not adjacent: sorted keys and current offsets.
  /// Per object: 1 if rigid and still a rigid transform of the reference in `x`, else 0.
  std::vector<std::uint8_t> rigid_now(const Positions& x, FrameAudit* report) const;
  std::vector<std::uint64_t> reduced_key_;
  std::vector<double> reduced_offset_;
  Index adjacent_excluded_ = 0;
};

}  // namespace ccfr::exact
