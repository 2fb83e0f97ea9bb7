#include "ccfr/solvers/material_system.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

// ---- MaterialSystem -----------------------------------------------------------------------------

MaterialSystem::MaterialSystem(MaterialSystem&&) noexcept = default;
MaterialSystem& MaterialSystem::operator=(MaterialSystem&&) noexcept = default;
MaterialSystem::~MaterialSystem() = default;

MaterialSystem::MaterialSystem(const Topology& topo, const SimState& state, const SimulationParams& params) {
  if (params.objects.size() != topo.objects.size())
    throw std::logic_error("MaterialSystem: params.objects has " + std::to_string(params.objects.size()) +
                           " entries for " + std::to_string(topo.objects.size()) + " objects");
  const MaterialConstraintRegistry& registry = material_constraints();
  // A material may only enable registered constraints that take parameters (the scene loader's
  // schema checks the same; scenes built in code come here directly).
  for (size_t oi = 0; oi < topo.objects.size(); ++oi)
    for (const auto& [name, values] : params.objects[oi].material.constraints) {
      const auto* e = registry.find(name);
      if (!e || e->params.empty()) {
        std::string known;
        for (const auto& k : registry.entries())
          if (!k.params.empty()) known += (known.empty() ? "" : ", ") + k.name;
        throw Error("object '" + topo.objects[oi].name + "': its material enables " +
                    (e ? "material constraint '" + name + "', which takes no parameters and is always on"
                       : "unknown material constraint '" + name + "'") +
                    " (constraints set per material: " + (known.empty() ? std::string("none") : known) + ")");
      }
    }

  const Index nv = topo.num_vertices();
  for (const auto& e : registry.entries()) {
    // Values from the material's keys or its section: every object for a constraint on for every
    // material (its defaults where the material gives none), else only where the section is set.
    const bool every = !e.params.empty() && on_for_every_material(e);
    std::vector<ParamValues> complete(topo.objects.size());
    MaterialContext ctx{topo, state, params, std::vector<const ParamValues*>(topo.objects.size(), nullptr)};
    for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
      const auto& given = params.objects[oi].material.constraints;
      const auto it = given.find(e.name);
      if (it == given.end() && !every) continue;
      complete[oi] = complete_params(e.params, it == given.end() ? ParamValues{} : it->second,
                                     "material constraint '" + e.name + "' of object '" + topo.objects[oi].name + "'");
      ctx.object_params[oi] = &complete[oi];
    }
    auto batch = e.make(complete_params(e.params, {}, "material constraint '" + e.name + "'"), ctx);
    if (!batch) continue;
    batch->finalize(nv, state.inv_mass);
    stages_.push_back({e.name, std::move(batch), {}, {}});
  }
  std::stable_sort(stages_.begin(), stages_.end(),
                   [](const Stage& a, const Stage& b) { return a.batch->sweep_rank() < b.batch->sweep_rank(); });

  for (const auto& o : topo.objects)
    if (o.kind == ObjectKind::rigid && o.num_vertices() > 0)
      rigid_.add(o.vertex_begin, o.vertex_end, state.rest, state.inv_mass);
  build_schedule(nv, state.inv_mass);
}

namespace {

/// Union-find over vertices with path halving.
struct Islands {
  std::vector<Index> parent;
  explicit Islands(Index n) : parent(static_cast<size_t>(n)) {
    for (Index i = 0; i < n; ++i) parent[i] = i;
  }
  Index find(Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(Index a, Index b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

void MaterialSystem::build_schedule(Index nv, std::span<const double> inv_mass) {
  // Islands: dynamic vertices joined by constraints. Kinematic vertices are never written, so they
  // join nothing; a constraint with only kinematic vertices belongs to the key of its first vertex.
  Islands uf(nv);
  for (const Stage& s : stages_) {
    const std::span<const Index> ids = s.batch->vertex_ids();
    const int arity = s.batch->arity();
    for (Index c = 0; c < s.batch->size(); ++c) {
      Index first = -1;
      for (int a = 0; a < arity; ++a) {
        const Index v = ids[c * arity + a];
        if (inv_mass[v] == 0.0) continue;
        if (first < 0)
          first = v;
        else
          uf.unite(first, v);
      }
    }
  }
  auto key = [&](const ConstraintBatch& batch, Index c) {
    const std::span<const Index> ids = batch.vertex_ids();
    const int arity = batch.arity();
    for (int a = 0; a < arity; ++a)
      if (inv_mass[ids[c * arity + a]] != 0.0) return uf.find(ids[c * arity + a]);
    return ids[c * arity];
  };

  // Island ids in order of first appearance (batches in sweep order, constraints in colour order).
  std::vector<Index> island_of_key(static_cast<size_t>(nv), -1);
  Index num_islands = 0;
  std::vector<char> large;
  std::vector<double> cost;
  std::vector<Index> colour_count;  // per island, constraints in the current colour
  for (const Stage& s : stages_) {
    const ConstraintBatch& batch = *s.batch;
    const Colouring& col = batch.colouring;
    const Index grain = batch.grain();
    const double unit_cost = batch.unit_cost();
    for (Index k = 0; k < col.colours(); ++k) {
      std::vector<Index> touched;
      for (Index t = col.row_start[k]; t < col.row_start[k + 1]; ++t) {
        Index& id = island_of_key[key(batch, col.order[t])];
        if (id < 0) {
          id = num_islands++;
          large.push_back(0);
          cost.push_back(0.0);
          colour_count.push_back(0);
        }
        if (colour_count[id]++ == 0) touched.push_back(id);
        cost[id] += unit_cost;
      }
      for (const Index id : touched) {
        // Beyond the grain the colour-by-colour loop would split this island's colour into tasks.
        if (colour_count[id] > grain) large[id] = 1;
        colour_count[id] = 0;
      }
    }
  }

  // Small islands numbered by decreasing cost (ties by first appearance): the order does not change
  // the result, only the load balance.
  std::vector<Index> small;
  for (Index i = 0; i < num_islands; ++i)
    if (!large[i]) small.push_back(i);
  std::stable_sort(small.begin(), small.end(), [&](Index a, Index b) { return cost[a] > cost[b]; });
  std::vector<Index> small_index(static_cast<size_t>(num_islands), -1);
  for (size_t s = 0; s < small.size(); ++s) small_index[small[s]] = static_cast<Index>(s);
  small_islands_ = static_cast<Index>(small.size());
  large_islands_ = num_islands - small_islands_;

  for (Stage& s : stages_) {
    const ConstraintBatch& batch = *s.batch;
    const Colouring& col = batch.colouring;
    IslandOrder& by_island = s.small;
    Colouring& large_col = s.large;
    by_island.row_start.assign(static_cast<size_t>(small_islands_) + 1, 0);
    by_island.order.clear();
    large_col = Colouring{};
    large_col.row_start.push_back(0);
    for (Index t = 0; t < static_cast<Index>(col.order.size()); ++t) {
      const Index si = small_index[island_of_key[key(batch, col.order[t])]];
      if (si >= 0) ++by_island.row_start[si + 1];
    }
    for (Index si = 0; si < small_islands_; ++si) by_island.row_start[si + 1] += by_island.row_start[si];
    by_island.order.resize(static_cast<size_t>(by_island.row_start.back()));
    std::vector<Index> cursor(by_island.row_start.begin(), by_island.row_start.end() - 1);
    for (Index k = 0; k < col.colours(); ++k) {
      for (Index t = col.row_start[k]; t < col.row_start[k + 1]; ++t) {
        const Index c = col.order[t];
        const Index si = small_index[island_of_key[key(batch, c)]];
        if (si >= 0)
          by_island.order[cursor[si]++] = c;
        else
          large_col.order.push_back(c);
      }
      const Index n = static_cast<Index>(large_col.order.size());
      if (n > large_col.row_start.back()) large_col.row_start.push_back(n);
    }
  }
}

void MaterialSystem::reset_multipliers() {
  for (Stage& s : stages_) s.batch->reset_multipliers();
}

void MaterialSystem::solve(Positions& x, std::span<const double> inv_mass, double dt) {
  // Small islands: one serial task each, in parallel. They share no dynamic vertex with each other
  // or with the large islands, so neither the task order nor the thread count changes the result.
  parallel_for(
      small_islands_,
      [&](Index lo, Index hi) {
        for (Index i = lo; i < hi; ++i)
          for (Stage& s : stages_) s.batch->solve_in_order(s.small.island(i), x, inv_mass, dt);
      },
      1);
  for (Stage& s : stages_) s.batch->solve(s.large, x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

void MaterialSystem::solve_by_colour(Positions& x, std::span<const double> inv_mass, double dt) {
  for (Stage& s : stages_) s.batch->solve(x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

const ConstraintBatch* MaterialSystem::batch(std::string_view name) const {
  for (const Stage& s : stages_)
    if (s.name == name) return s.batch.get();
  return nullptr;
}

MaterialSystem::Counts MaterialSystem::counts() const {
  Counts c;
  const auto size_of = [this](std::string_view name) -> Index {
    const ConstraintBatch* b = batch(name);
    return b ? b->size() : 0;
  };
  c.distance = size_of("stretch");
  c.bending = size_of("dihedral_bending");
  c.strand_bending = size_of("strand_bending");
  c.tet_volume = size_of("tet_elasticity");
  c.tet_deviatoric = size_of("tet_elasticity");
  c.rigid_bodies = rigid_.size();
  for (const Stage& s : stages_) {
    c.colours += s.batch->colouring.colours();
    c.by_name.emplace_back(s.name, s.batch->size());
  }
  c.small_islands = small_islands_;
  c.large_islands = large_islands_;
  return c;
}

}  // namespace ccfr
