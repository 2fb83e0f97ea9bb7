#pragma once
/// @file projector.hpp
/// Projection of a vertex's candidate position back into its convex collision-free region
/// (paper §3.2 and appendix Alg. projectOntoConvexRegion), behind one interface so contact
/// solvers can swap the method by name.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/core/types.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr {

/// Outcome of one projection.
enum class ProjectStatus : std::uint8_t {
  feasible,   ///< the candidate already satisfied every half-space; returned unchanged
  projected,  ///< moved onto (or just inside) the region; every half-space holds within tolerance
  halted,     ///< no convergence within the budget: fell back to the anchor (last feasible position)
  infeasible  ///< ended outside the region (empty region, NaN input, or a method that gave up) and says so
};

/// Short lowercase name of a status ("feasible", "projected", "halted", "infeasible").
std::string_view to_string(ProjectStatus status);

/// Result of projecting one vertex.
struct ProjectResult {
  Vec3 x = Vec3::Zero();  ///< the new position (absolute coordinates)
  ProjectStatus status = ProjectStatus::feasible;
  int iterations = 0;  ///< outer passes (Plesník), sweeps (successive projection), active-set size (exact)
  int active = 0;      ///< half-spaces violated by the candidate at entry
  /// Plesník only: its point was farther from the candidate than the anchor is (it keeps every
  /// violated plane as an equality, and nearly parallel planes meet far away), so `x` is the exact
  /// projector's answer instead (or the anchor if that failed). Always false for the other projectors.
  bool fell_back = false;
  /// Plesník only: the passes did not converge within max_iterations and `x` is the exact
  /// projector's answer (ProjectorParams::exact_fallback) instead of a halt at the anchor.
  bool rescued = false;
};

/// Parameters shared by all projectors; each projector reads the fields it needs.
/// All lengths are absolute, in scene units; normals are expected to be unit vectors.
struct ProjectorParams {
  /// ε of the paper's numerical treatment (§3.2): the projected point is pulled back by ε along
  /// the displacement from the anchor, so it lands strictly inside the region despite rounding.
  /// Used by `plesnik` and `exact`; 0 disables the retraction. Default 1e-6 as in the paper.
  double epsilon = 1e-6;
  /// Plesník outer passes (clarification 2): each pass projects onto the violated half-spaces and
  /// re-checks all of them; after this many passes without success the vertex halts at the anchor.
  /// Default 4, measured on 64k violated random regions with 1-16 planes (docs/perf/feasibility.md):
  /// 1 pass halts 5.3 % of them, 2 passes 3.5 %, 3 passes 0.9 %, 4 passes 0.68 %, and larger budgets
  /// only approach a floor of 0.46 % (cases that cycle) while the mean stays at 1.1 passes.
  int max_iterations = 4;
  /// Plesník only: when the passes do not converge, take the exact projection (ExactProjector)
  /// before halting. The anchor is feasible there, so the region is never empty and the exact
  /// answer exists; the vertex halts only if that fails too. false: halt at once (the paper).
  /// The causes of Plesník's halts in the paper's scenes are measured in docs/results.md ("Halting").
  bool exact_fallback = true;
  /// Denominators and ERO direction lengths below this are treated as zero: the new equation is
  /// linearly dependent on the stored ones and is skipped (Alg. orthogonalProjection, lines 4, 14, 21, 27).
  double redundancy_tolerance = 1e-12;
  /// A half-space counts as satisfied when its value is >= -feasibility_tolerance. Absorbs
  /// floating-point rounding in the re-checks; far below any physical offset ξ.
  double feasibility_tolerance = 1e-12;
  /// Cyclic sweeps of `successive_projection` over the half-spaces. Default 16, the value every
  /// scene run used (the scene schema and this struct once disagreed: 16 and 10).
  int sweeps = 16;
};

/// Projects a candidate position into the region
/// \f$ \mathcal{K} = \{\mathbf{x}' : (\mathbf{x}' - \mathbf{x}_a)\cdot\mathbf{n}_k + d_k \ge 0\ \forall k\} \f$
/// anchored at \f$\mathbf{x}_a\f$. Implementations are stateless and thread-safe.
class Projector {
 public:
  virtual ~Projector() = default;
  /// @param x_anchor   position the half-spaces were built at (the last feasible position)
  /// @param x_candidate position to project
  /// @param planes     the vertex's half-spaces (any order)
  virtual ProjectResult project(const Vec3& x_anchor, const Vec3& x_candidate,
                                std::span<const HalfSpace> planes) const = 0;
  /// The factory key of this projector.
  virtual std::string_view name() const = 0;
};

/// The registry of projectors: plesnik, successive_projection, exact. An entry's parameter specs
/// name the ProjectorParams fields it reads (defaults from ProjectorParams{}); the contact solvers
/// built on a projector expose those keys in their own scene-file section. The factory receives
/// the complete ProjectorParams; apply_projector_params() folds a solver's values into them.
using ProjectorRegistry = Registry<Projector, const ProjectorParams&>;
ProjectorRegistry& projectors();

/// `base` with the values of a projector's specs (max_iterations, redundancy_tolerance, sweeps)
/// set from `values`. @throws ccfr::Error for a key that is not a ProjectorParams field.
ProjectorParams apply_projector_params(ProjectorParams base, const ParamValues& values);

/// Creates a projector by key: "plesnik", "successive_projection", "exact" or a registered one.
/// @throws ccfr::Error for an unknown key (the message lists the valid ones) or invalid parameters.
std::unique_ptr<Projector> make_projector(std::string_view name, const ProjectorParams& params = {});

/// The registered keys, in registration order.
std::vector<std::string> projector_names();

/// Checks a parameter set. @throws ccfr::Error naming the first invalid field.
void validate(const ProjectorParams& params);

/// Counts of one batch projection (project_all). Vertex counts, except `iterations`.
struct BatchStats {
  Index violated = 0;    ///< vertices whose candidate violated their region at entry
  Index projected = 0;   ///< of those, vertices that ended with status projected
  Index remaining = 0;   ///< vertices whose output still violates a half-space by more than 1e-9 (or is NaN)
  Index halted = 0;      ///< vertices that fell back to their anchor (halting events)
  Index infeasible = 0;  ///< vertices reported infeasible
  Index fallbacks =
      0;              ///< vertices whose Plesník point was replaced by the exact projection (ProjectResult::fell_back)
  Index rescued = 0;  ///< vertices whose unconverged Plesník passes were replaced by the exact projection
  std::int64_t iterations = 0;  ///< sum of ProjectResult::iterations over the violated vertices

  BatchStats& operator+=(const BatchStats& o);
};

/// Projects every vertex with `inv_mass[v] > 0` whose candidate `x[v]` violates its region
/// (`regions.of(v)`, anchored at `anchor[v]`), in parallel, writing `x` in place. Kinematic
/// vertices (inverse mass 0) and vertices without half-spaces are left untouched. The result is
/// deterministic: vertices are independent and the counts are integers.
/// @param anchor   #V anchor positions (the positions the regions were built at)
/// @param x        #V candidate positions, overwritten with the projected ones
/// @param inv_mass #V inverse masses; an empty span means every vertex is dynamic
/// @param halted_marks #V flags set to 1 for each vertex that halted (empty: not recorded)
/// @throws std::invalid_argument when the array sizes do not match `regions.num_vertices()`
BatchStats project_all(const Projector& projector, const RegionSet& regions, const Positions& anchor, Positions& x,
                       std::span<const double> inv_mass, std::span<std::uint8_t> halted_marks = {});

/// Smallest constraint value \f$\min_k (\mathbf{x} - \mathbf{x}_a)\cdot\mathbf{n}_k + d_k\f$;
/// +infinity for no planes, NaN when `x` or a plane is not finite.
double min_value(const Vec3& x_anchor, const Vec3& x, std::span<const HalfSpace> planes);

/// True iff `!(min_value(x_anchor, x, planes) >= level)`: some plane's value is below `level`, or
/// one is NaN. Stops at the first such plane, which min_value cannot: a violating vertex of a dense
/// region (~150 planes, ~3 violated) is thus settled after about a quarter of them.
bool falls_below(const Vec3& x_anchor, const Vec3& x, std::span<const HalfSpace> planes, double level);

/// What every projector first learns about its input: the candidate relative to the anchor `q`,
/// the number of planes it violates (value < -tol), the smallest offset `d_min` and the largest
/// |d| or |q| (`scale`). `usable` is false when a position or a plane is not finite: nothing can
/// then be certified, and the vertex stays at its anchor as infeasible (unusable_input()).
/// `on_value(k, value)` is called with each plane's value at the candidate (inline: this runs on
/// every projection, so the values go straight where the caller needs them).
struct ScreenedInput {
  Vec3 q = Vec3::Zero();
  int violated = 0;
  double d_min = 0.0;
  double scale = 0.0;
  bool usable = true;
};
template <class OnValue>
inline ScreenedInput screen_input(const Vec3& x_anchor, const Vec3& x_candidate, std::span<const HalfSpace> planes,
                                  double tol, OnValue&& on_value) {
  ScreenedInput in;
  if (!x_candidate.allFinite() || !x_anchor.allFinite()) {
    in.usable = false;
    return in;
  }
  in.q = x_candidate - x_anchor;
  in.scale = in.q.norm();
  for (std::size_t k = 0; k < planes.size(); ++k) {
    const HalfSpace& h = planes[k];
    const double rho = h.n.dot(in.q) + h.d;
    if (rho != rho) {  // NaN: a non-finite plane, nothing can be certified
      in.usable = false;
      return in;
    }
    on_value(k, rho);
    if (rho < -tol) ++in.violated;
    in.d_min = h.d < in.d_min ? h.d : in.d_min;
    const double ad = h.d < 0 ? -h.d : h.d;
    in.scale = ad > in.scale ? ad : in.scale;
  }
  return in;
}
inline ScreenedInput screen_input(const Vec3& x_anchor, const Vec3& x_candidate, std::span<const HalfSpace> planes,
                                  double tol) {
  return screen_input(x_anchor, x_candidate, planes, tol, [](std::size_t, double) {});
}
/// The answer to unusable input: infeasible, at the anchor.
ProjectResult unusable_input(const Vec3& x_anchor);

}  // namespace ccfr
