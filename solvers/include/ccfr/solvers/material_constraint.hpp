#pragma once
/// @file material_constraint.hpp
/// Material constraints as registered components. A material constraint is a batch of XPBD
/// constraints of one type (`ConstraintBatch`: the vertices of each constraint and the kernel that
/// solves a list of them), built for a scene by the factory registered under its name in
/// `material_constraints()`. `MaterialSystem` (material_system.hpp) builds every registered batch,
/// colours them, groups them into islands and sweeps them; it knows no constraint type by name.
///
/// The built-in entries (solvers/src/materials/, one file each, named by its key) are `stretch`
/// (edge lengths), `dihedral_bending`, `strand_bending` and `tet_elasticity`.
///
/// A constraint's parameters live in one of two places:
/// - its own section `materials.<material>.<name>`, which switches it on for that material's
///   objects (docs/extending.md):
///     static ccfr::Registration<ccfr::MaterialConstraintRegistry> reg(ccfr::material_constraints(), {...});
/// - keys of the material itself (`ParamSpec::from_material`): the constraint is on for every
///   material, and one key may feed several constraints. The built-ins register theirs this way
///   (`stretch.compliance` is `materials.<material>.stretch_compliance`; `dihedral_bending` and
///   `strand_bending` share `bend_compliance`).
/// Either way the factory reads the values from `MaterialContext::object_params`.
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

struct SimulationParams;
struct MaterialParams;

/// Greedy colouring of constraints given by their vertex lists (`arity` vertices each, flat array).
/// Returns the colours' row starts into `order` (constraints grouped by colour).
struct Colouring {
  std::vector<Index> order;      ///< constraint ids grouped by colour
  std::vector<Index> row_start;  ///< #colours + 1
  Index colours() const { return static_cast<Index>(row_start.size()) - 1; }
};
/// Constraints sharing a vertex with `inv_mass > 0` get different colours; kinematic vertices
/// (never written by a kernel) do not separate constraints.
Colouring colour_constraints(Index num_vertices, std::span<const Index> vertices, int arity,
                             std::span<const double> inv_mass);

/// Largest XPBD compliance a material key accepts (m/N, 1/(N m), 1/Pa): softer than any material
/// (the defaults are 0 to 0.1), and α / Δt² stays finite for every admissible Δt.
inline constexpr double kMaxCompliance = 1e6;

/// A colour of a batch is split into parallel tasks only beyond this many constraints (its
/// `grain()`); smaller colours run inline on the calling thread.
inline constexpr Index kConstraintGrain = 256;

/// A batch of XPBD constraints of one type. Its kernel (`solve_in_order`) applies one XPBD update
/// per constraint and writes only vertices with w > 0, so constraints of one colour (which share
/// no dynamic vertex) may run on different threads.
class ConstraintBatch {
 public:
  virtual ~ConstraintBatch() = default;

  virtual Index size() const = 0;  ///< number of constraints
  virtual int arity() const = 0;   ///< vertices per constraint
  /// The vertices of every constraint, one after another (#C × arity): colouring and islands.
  virtual std::span<const Index> vertex_ids() const = 0;
  virtual void reset_multipliers() = 0;
  /// The constraints `order` one after another on the calling thread (the kernel loop of every
  /// schedule). x, inv_mass: #V.
  virtual void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass,
                              double dt) = 0;
  /// Parallel grain of a colour (see kConstraintGrain).
  virtual Index grain() const { return kConstraintGrain; }
  /// Rough cost of one constraint relative to an edge length, used only to start the largest
  /// islands first (load balance; never the result).
  virtual double unit_cost() const { return 1.0; }
  /// Place in each Gauss-Seidel sweep: lower ranks run first, ties in registration order. The
  /// built-ins use 10 (stretch), 20 (dihedral bending), 30 (strand bending), 40 (tets); rigid
  /// shape matching always runs last.
  virtual int sweep_rank() const { return 100; }

  /// Colours the batch (call after the last constraint was added).
  void finalize(Index num_vertices, std::span<const double> inv_mass);
  /// One sweep over `colouring`: colours in sequence, each colour a parallel loop.
  void solve(Positions& x, std::span<const double> inv_mass, double dt) { solve(colouring, x, inv_mass, dt); }
  /// The same over `col`, a colouring of any subset of the constraints (grouped as in `colouring`).
  void solve(const Colouring& col, Positions& x, std::span<const double> inv_mass, double dt);

  Colouring colouring;
};

/// A batch whose constraints act on N vertices each, stored as `ids` (#C by N).
template <int N>
struct FixedArityBatch : ConstraintBatch {
  std::vector<Eigen::Matrix<Index, N, 1>> ids;

  Index size() const override { return static_cast<Index>(ids.size()); }
  int arity() const override { return N; }
  std::span<const Index> vertex_ids() const override {
    return {ids.empty() ? nullptr : ids.front().data(), ids.size() * N};
  }
};

/// What a material constraint's factory builds its batch from.
struct MaterialContext {
  const Topology& topo;
  const SimState& state;  ///< rest shapes are `state.rest`; kinematic vertices have inv_mass 0
  const SimulationParams& params;
  /// Per object: this constraint's parameters (complete, checked). For a constraint switched on
  /// by its section, nullptr where the material does not set it; for one on for every material
  /// (`on_for_every_material`), set for every object, except that a constraint without parameters
  /// sees nullptr everywhere.
  std::vector<const ParamValues*> object_params;

  const MaterialParams& material(Index object) const;
};

/// Factory arguments: the parameters' defaults (per-object values are in the context), the scene.
using MaterialConstraintRegistry = Registry<ConstraintBatch, const MaterialContext&>;

/// The registry of material constraints (kind "material constraint"). A factory may return
/// nullptr when the scene has nothing for it.
MaterialConstraintRegistry& material_constraints();

/// Whether `e` is on for every material: it takes no parameters, or every parameter is a key of
/// the material (`ParamSpec::material_key`). Otherwise a material switches it on with its section.
/// Throws ccfr::Error for an entry that mixes the two kinds.
bool on_for_every_material(const MaterialConstraintRegistry::Entry& e);

/// The material keys the constraints of `registry` read, each once, in registration order: the
/// spec of its first reader with `key` set to the material key. Throws ccfr::Error where two
/// constraints give one key different types, defaults or ranges.
std::vector<ParamSpec> material_keys(const MaterialConstraintRegistry& registry = material_constraints());

/// Sets the material key `key` of `m` (e.g. "bend_compliance") for every registered constraint
/// that reads it, as `materials.<m>.<key>` does in a scene file; the value is checked when the
/// scene's MaterialSystem is built. Throws ccfr::Error for a key no constraint reads.
void set_material_key(MaterialParams& m, std::string_view key, ParamValue value);

}  // namespace ccfr
