#pragma once
/// @file csr.hpp
/// Compressed sparse rows: `row_start` has #rows+1 entries, row i is indices[row_start[i], row_start[i+1]).
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

struct Csr {
  std::vector<Index> row_start{0};
  std::vector<Index> indices;

  Index rows() const { return static_cast<Index>(row_start.size()) - 1; }
  std::span<const Index> row(Index i) const {
    return {indices.data() + row_start[i], static_cast<size_t>(row_start[i + 1] - row_start[i])};
  }

  /// Builds the transpose-style incidence "row -> items" from items that each name up to
  /// `Arity` rows (e.g. faces -> vertex-to-face lists). Two passes: count, prefix sum, fill;
  /// within a row, items stay in increasing order.
  template <int Arity>
  static Csr incidence(Index num_rows, const std::vector<Eigen::Matrix<Index, Arity, 1>>& items) {
    Csr c;
    c.row_start.assign(static_cast<size_t>(num_rows) + 1, 0);
    for (const auto& it : items)
      for (int k = 0; k < Arity; ++k) ++c.row_start[it[k] + 1];
    for (Index i = 0; i < num_rows; ++i) c.row_start[i + 1] += c.row_start[i];
    c.indices.resize(static_cast<size_t>(c.row_start.back()));
    std::vector<Index> cursor(c.row_start.begin(), c.row_start.end() - 1);
    for (Index j = 0; j < static_cast<Index>(items.size()); ++j)
      for (int k = 0; k < Arity; ++k) c.indices[cursor[items[j][k]]++] = j;
    return c;
  }
};

}  // namespace ccfr
