#pragma once
/// @file csr.hpp
/// Compressed sparse rows: `offsets` has #rows+1 entries, row i is indices[offsets[i], offsets[i+1]).
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

struct Csr {
  std::vector<Index> offsets{0};
  std::vector<Index> indices;

  Index rows() const { return static_cast<Index>(offsets.size()) - 1; }
  std::span<const Index> row(Index i) const {
    return {indices.data() + offsets[i], static_cast<size_t>(offsets[i + 1] - offsets[i])};
  }

  /// Builds the transpose-style incidence "row -> items" from items that each name up to
  /// `Arity` rows (e.g. faces -> vertex-to-face lists). Two passes: count, prefix sum, fill;
  /// within a row, items stay in increasing order.
  template <int Arity>
  static Csr incidence(Index num_rows, const std::vector<Eigen::Matrix<Index, Arity, 1>>& items) {
    Csr c;
    c.offsets.assign(static_cast<size_t>(num_rows) + 1, 0);
    for (const auto& it : items)
      for (int k = 0; k < Arity; ++k) ++c.offsets[it[k] + 1];
    for (Index i = 0; i < num_rows; ++i) c.offsets[i + 1] += c.offsets[i];
    c.indices.resize(static_cast<size_t>(c.offsets.back()));
    std::vector<Index> cursor(c.offsets.begin(), c.offsets.end() - 1);
    for (Index j = 0; j < static_cast<Index>(items.size()); ++j)
      for (int k = 0; k < Arity; ++k) c.indices[cursor[items[j][k]]++] = j;
    return c;
  }
};

}  // namespace ccfr
