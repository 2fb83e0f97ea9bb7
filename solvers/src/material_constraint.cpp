// The material-constraint registry and the coloured sweep every batch shares. The built-in entries
// are the files of solvers/src/materials/, each named by its key, added here on first use
// (builtin_materials.hpp).
#include "ccfr/solvers/material_constraint.hpp"

#include <algorithm>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/params.hpp"

#include "builtin_materials.hpp"

namespace ccfr {

void ConstraintBatch::finalize(Index num_vertices, std::span<const double> inv_mass) {
  colouring = colour_constraints(num_vertices, vertex_ids(), arity(), inv_mass);
}

void ConstraintBatch::solve(const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  const std::span<const Index> order(col.order);
  const Index grain = this->grain();
  for (Index k = 0; k < col.colours(); ++k) {
    const Index b = col.row_start[k], e = col.row_start[k + 1];
    parallel_for(
        e - b,
        [&](Index lo, Index hi) {
          solve_in_order(order.subspan(static_cast<size_t>(b + lo), static_cast<size_t>(hi - lo)), x, w, dt);
        },
        grain);
  }
}

const MaterialParams& MaterialContext::material(Index object) const { return params.objects[object].material; }

MaterialConstraintRegistry& material_constraints() {
  static MaterialConstraintRegistry registry = [] {
    MaterialConstraintRegistry r("material constraint");
#define CCFR_BUILTIN_MATERIAL_CONSTRAINT(key) register_material_constraint_##key(r);
#include "builtin_material_constraints.inc"
#undef CCFR_BUILTIN_MATERIAL_CONSTRAINT
    return r;
  }();
  return registry;
}

bool on_for_every_material(const MaterialConstraintRegistry::Entry& e) {
  size_t keyed = 0;
  for (const auto& p : e.params) keyed += p.material_key.empty() ? 0 : 1;
  if (keyed != 0 && keyed != e.params.size())
    throw Error("material constraint '" + e.name +
                "': either every parameter is a key of the material (ParamSpec::from_material) or none is");
  return keyed == e.params.size();
}

std::vector<ParamSpec> material_keys(const MaterialConstraintRegistry& registry) {
  std::vector<ParamSpec> keys;
  for (const auto& e : registry.entries()) {
    if (e.params.empty() || !on_for_every_material(e)) continue;
    for (const auto& p : e.params) {
      ParamSpec spec = p;
      spec.key = p.material_key;
      const auto same = std::find_if(keys.begin(), keys.end(), [&](const ParamSpec& k) { return k.key == spec.key; });
      if (same == keys.end()) {
        keys.push_back(std::move(spec));
        continue;
      }
      if (same->type != spec.type || same->default_value != spec.default_value || same->min != spec.min ||
          same->max != spec.max || same->min_open != spec.min_open || same->max_open != spec.max_open ||
          same->choices != spec.choices)
        throw Error("material constraint '" + e.name + "': its parameter '" + p.key + "' reads the material key '" +
                    spec.key + "', which another constraint declares with another type, default or range");
    }
  }
  return keys;
}

void set_material_key(MaterialParams& m, std::string_view key, ParamValue value) {
  bool read = false;
  for (const auto& e : material_constraints().entries())
    for (const auto& p : e.params)
      if (p.material_key == key) {
        m.constraints[e.name].set(p.key, value);
        read = true;
      }
  if (read) return;
  std::string known;
  for (const ParamSpec& k : material_keys()) known += (known.empty() ? "" : ", ") + k.key;
  throw Error("no material constraint reads the material key '" + std::string(key) + "' (keys read: " + known + ")");
}

Colouring colour_constraints(Index num_vertices, std::span<const Index> vertices, int arity,
                             std::span<const double> inv_mass) {
  const Index n = static_cast<Index>(vertices.size()) / arity;
  std::vector<Index> colour(static_cast<size_t>(n), 0);
  // Per vertex, a bitmask of colours already used by its constraints (spill to a vector beyond 64).
  std::vector<std::vector<bool>> used(static_cast<size_t>(num_vertices));
  Index num_colours = 0;
  for (Index c = 0; c < n; ++c) {
    Index k = 0;
    for (;; ++k) {
      bool free = true;
      for (int a = 0; a < arity && free; ++a) {
        const Index v = vertices[c * arity + a];
        // Kinematic vertices are never written: they do not constrain the colouring.
        if (inv_mass[v] == 0.0) continue;
        const auto& u = used[v];
        if (k < static_cast<Index>(u.size()) && u[k]) free = false;
      }
      if (free) break;
    }
    colour[c] = k;
    num_colours = std::max(num_colours, k + 1);
    for (int a = 0; a < arity; ++a) {
      auto& u = used[vertices[c * arity + a]];
      if (static_cast<Index>(u.size()) <= k) u.resize(static_cast<size_t>(k) + 1, false);
      u[k] = true;
    }
  }
  Colouring out;
  out.row_start.assign(static_cast<size_t>(num_colours) + 1, 0);
  for (Index c = 0; c < n; ++c) ++out.row_start[colour[c] + 1];
  for (Index k = 0; k < num_colours; ++k) out.row_start[k + 1] += out.row_start[k];
  out.order.resize(static_cast<size_t>(n));
  std::vector<Index> cursor(out.row_start.begin(), out.row_start.end() - 1);
  for (Index c = 0; c < n; ++c) out.order[cursor[colour[c]]++] = c;
  return out;
}

}  // namespace ccfr
