#pragma once
/// @file params.hpp
/// Typed, validated parameters of a simulation. Solvers see only these structs, never YAML;
/// io/ fills them from a scene file (defaults documented in docs/config.md, generated from the schema).
#include <algorithm>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "ccfr/core/contact_model.hpp"
#include "ccfr/core/registry.hpp"
#include "ccfr/core/types.hpp"
#include "ccfr/solvers/kinematics.hpp"

namespace ccfr {

struct TimeParams {
  double fps = 60.0;  ///< frames per second; frame time Δt_frame = 1/fps
  int frames = 120;   ///< frames to simulate
  int substeps = 10;  ///< substeps per frame; Δt = Δt_frame / substeps
  /// Nominal outer iterations per substep (paper Alg. "simulation loop", line 3); a substep stops
  /// after the first pass in which no vertex is held back by r, and iteration_bound() caps it.
  int iterations = 4;
  /// Outer iterations continue past `iterations` while some vertex has not reached its intended
  /// advance (the paper's convergence check), up to this many; 0 means 4 · iterations.
  int max_iterations = 0;
  int xpbd_sweeps = 1;  ///< material constraint sweeps per outer iteration
  Vec3 gravity = Vec3(0, -9.81, 0);
  double damping = 0.0;  ///< fraction of velocity removed per second (0: none)
  /// Outer iterations stop once no vertex is held back by r by more than tol · r. A cut below it is
  /// kept every substep, so a vertex whose step grows by less than tol · r per substep (a ball
  /// rolling at r per substep at its top, 1e-6 of r per substep of gravity) is held at r per
  /// substep for good: the default leaves only rounding.
  double advance_tolerance = 1e-6;
  /// Also stop once the step bound cut at most this fraction of the pass's total intended advance
  /// (sum over movable vertices), even if a few vertices are still held back; 0 keeps the
  /// per-vertex rule alone. A handful of whipping vertices then does not cost the whole scene
  /// another pass; they keep their clamped step (counted in clamped_vertices).
  double advance_shortfall = 0.0;
  /// What the outer iterations after a substep's first one solve again.
  enum class Continuation {
    full,       ///< the whole scene: detection, response and projection for every vertex (the paper)
    held_back,  ///< only the vertices the step bound held back in the pass before; the rest stay put
  };
  Continuation continuation = Continuation::full;
  /// Most pieces a substep may be split into when a scripted step exceeds r or the intended
  /// advance exceeds what the outer iterations can cover ((max_iterations - 1) · r); see Simulation.
  int max_subdivision = 64;
  /// The effective bound of outer iterations.
  /// 4 · iterations in 64 bits, capped to int (the schema bounds iterations so the cap never acts).
  int iteration_bound() const {
    return max_iterations > 0
               ? std::max(max_iterations, iterations)
               : static_cast<int>(std::min<long long>(4LL * iterations, std::numeric_limits<int>::max()));
  }
};

enum class AuditMode { off, every_frame, every_substep };

/// What a substep that ends with pairs closer than their offset does.
enum class ViolationPolicy {
  automatic,  ///< error for solvers that guarantee separation (ccfr, exact_projection), warn for the baselines
  error,      ///< stop the run before the frame is written (non-zero exit)
  warn,       ///< log at error level, count in stats.csv and go on (ablations of the baselines)
};

/// The contact section: the contact model (r, ξ, δ, friction; one owner, shared with collision
/// detection and the audit) plus the choice of solver and the settings every solver shares.
struct ContactParams : ContactModel {
  std::string solver = "ccfr";  ///< contact solver (a name in contact_solvers())
  /// The solver's own parameters (`contact.<solver>.*`, the keys of its registry entry); keys not
  /// set take the registered defaults, keys the solver does not declare are an error.
  ParamValues solver_params;
  double stiffness = 1e4;           ///< k: repulsion stiffness, XPBD compliance 1/k
  double visibility_width = 0.0;    ///< δ_v: occlusion smoothstep width (0: δ)
  double epsilon = 1e-4;            ///< ε relative to ξ: projectors retract by ε ξ (absolute 1e-6 at ξ = 0.01)
  bool analytic_obstacles = false;  ///< obstacles with an analytic shape also collide through their SDF
  /// Contact carries momentum between its two sides: inelastic contact on the candidate positions
  /// (ContactResponse::separate) and region planes split by the motion it leaves (split_by_motion). false (default):
  /// the paper's response (repulsion within δ) and mass-share planes. Off by default (docs/feasibility.md, "Why it is
  /// not the default yet"); a cloth or strand with static pins is held by its tethers.
  bool momentum = false;
  /// Free islands keep their momentum (on by default; region-projection solvers, in scenes where no obstacle collides
  /// through its distance function, contact.analytic_obstacles): bodies close to one another with
  /// nothing pinned or scripted among them are carried together before each pass, and the pieces that touch only one
  /// another (or nothing) get back, by one rigid motion, the linear momentum the projection took and the angular
  /// momentum of the substep's start (docs/feasibility.md, "A free island keeps its momentum"). false: the paper's
  /// projection alone, which takes the momentum of whatever it holds.
  bool free_islands = true;
  /// With `momentum`: every pinned cloth and strand gets long-range attachments (Tethers), each
  /// movable vertex at most (1 + tether_slack) times its rest geodesic distance from its pins,
  /// enforced in the material sweeps and as a cap of the momentum response's pushes.
  bool tethers = true;
  double tether_slack = 0.02;  ///< s: a tether's length over its rest geodesic distance, minus 1
  /// Each pair's plane may turn toward the candidates' closest-point direction where that keeps the
  /// anchors apart by the offset and cuts the candidates less (turn_by_motion): bodies and cloth
  /// slide over tessellated surfaces instead of being lifted or held at their vertices.
  bool sliding = true;
  /// f in [0, 1]: each outer iteration gives each vertex its own reach min(r, max(f r, δ) + 2 |step|)
  /// instead of r (adaptive_vertex_reach; region-projection solvers): detection pairs primitives
  /// within the sum of their reaches plus ξ, so slow vertices test fewer pairs. 0 (default): the
  /// paper's uniform r.
  double adaptive_reach = 0.0;
  ViolationPolicy on_violation = ViolationPolicy::automatic;  ///< see ViolationPolicy
};

/// The collision section: which broad phase, and its own parameters (`collision.<broad_phase>.*`).
struct DetectionParams {
  std::string broad_phase = "bvh";  ///< broad phase (a name in broad_phases())
  ParamValues broad_phase_params;   ///< keys of its registry entry; defaults for the rest
  /// Skin of the sub-pair list kept between detection passes, in units of r
  /// (CollisionDetector::set_reuse_skin); 0 (the default) runs the broad phase in every pass. Off
  /// by default: it paid on a resting card stack and nowhere else measured (docs/collision.md).
  double reuse_skin = 0.0;
};

struct DebugParams {
  AuditMode audit = AuditMode::off;
  double audit_tolerance = 1e-6;  ///< audit flags pairs closer than (1 - tol) ξ (as `ccfr audit`)
};

struct OutputParams {
  bool frames = true;         ///< write frames/frame_*.obj
  int every = 1;              ///< write every k-th frame (frame 0 always)
  int checkpoint_every = 10;  ///< checkpoint every k-th frame and on SIGINT/SIGTERM (0: never)
  /// output.formats: obj, ply, vtu, pc2, usda (docs/interop.md); empty means obj only.
  std::vector<std::string> formats;
};

struct MaterialParams {
  double density = 0.1;    ///< kg/m² (cloth, shell), kg/m (strand), kg/m³ (solids, rigid), kg per particle
  double friction = -1.0;  ///< per-object friction override (<0: use contact.friction)
  /// Parameters of registered material constraints, by constraint name; values missing here take
  /// their defaults (material_constraint.hpp). The built-ins read the material's keys
  /// (`stretch_compliance` is `constraints["stretch"]["compliance"]`, `bend_compliance` is
  /// `compliance` of both `dihedral_bending` and `strand_bending`, `volume_compliance` and
  /// `shear_compliance` are `tet_elasticity`'s); a constraint with a section of its own is on only
  /// where its entry is set (`materials.<name>.<constraint>` in YAML).
  std::map<std::string, ParamValues> constraints;
};

/// Analytic shape of an obstacle, used for SDF collision when contact.analytic_obstacles is on.
struct AnalyticShape {
  enum class Type { none, sphere, plane, box, cylinder } type = Type::none;
  Vec3 center = Vec3::Zero();                              ///< rest position of the shape's centre
  Vec3 half_extent = Vec3::Zero();                         ///< box half sizes
  double radius = 0.0;                                     ///< sphere / cylinder radius
  double half_height = 0.0;                                ///< cylinder half height (axis y in the shape's rest frame)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< rest orientation
};

/// A set of pinned vertices (local indices of their object) with an optional scripted motion.
struct PinGroup {
  std::vector<Index> vertices;
  Motion motion;
};

struct ObjectParams {
  MaterialParams material;
  std::vector<PinGroup> pins;
  Motion motion;  ///< obstacles: whole-object scripted motion
  Vec3 initial_velocity = Vec3::Zero();
  AnalyticShape shape;
};

struct SimulationParams {
  std::string scene_name;
  TimeParams time;
  ContactParams contact;
  DetectionParams collision;
  DebugParams debug;
  OutputParams output;
  std::vector<ObjectParams> objects;  ///< parallel to Topology::objects
};

}  // namespace ccfr
