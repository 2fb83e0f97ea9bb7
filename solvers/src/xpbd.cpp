#include "ccfr/solvers/xpbd.hpp"

#include <algorithm>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

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

void DistanceBatch::add(Index i, Index j, double rest_length, double alpha) {
  ids.emplace_back(i, j);
  rest.push_back(rest_length);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void DistanceBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void DistanceBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Index i = ids[c][0], j = ids[c][1];
    xpbd::solve_distance(x[i], x[j], w[i], w[j], rest[c], compliance[c] * inv_dt2, lambda[c]);
  }
}

}  // namespace ccfr
