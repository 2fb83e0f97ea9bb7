#pragma once
/// @file stats_csv.hpp
/// stats.csv written and read back by column name, both from the column table kStatsColumns
/// (ccfr/solvers/frame_stats.hpp), and docs/output.md's column list generated from it.
#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/solvers/frame_stats.hpp"

namespace ccfr::io {

/// The stats.csv header, in column order.
const std::string& stats_header();
/// One cell of column C: `%d`/`%lld`, `%.6f` (seconds) or `%.9g` (real); empty when unknown.
std::string stats_cell(const StatsColumn& c, const FrameStats& s);
/// One stats.csv row (no trailing newline).
std::string stats_row(const FrameStats& s);

/// A stats.csv read back by column name.
struct StatsCsv {
  /// Which of kStatsColumns the header has: a file of an older ccfr lacks the newer columns (their
  /// members keep FrameStats' defaults); a header column the table does not know is skipped.
  std::array<bool, kStatsColumns.size()> present{};
  std::vector<FrameStats> rows;
  /// True if the file has column I (`has(stats_column("lag_mean"))`: a misspelt name does not compile).
  bool has(std::size_t i) const { return present.at(i); }
};

/// Parses stats.csv TEXT; LABEL names it in errors. Rows end at the first one with another number
/// of fields than the header (the last row of a killed run, cut mid-write). An empty cell of a
/// column that can be unknown reads as its marker (min_distance +inf, counts -1). Throws
/// ccfr::Error "LABEL:LINE: column 'NAME': ..." for a cell that is not a number of its column's
/// type, or empty where the column is always known.
StatsCsv parse_stats_csv(std::string_view text, const std::string& label);
/// Reads PATH with parse_stats_csv; a missing file is a run without rows (no columns, no rows).
StatsCsv read_stats_csv(const std::filesystem::path& path);

/// The Markdown table of docs/output.md's "stats.csv columns" (`| column | unit | meaning |`).
std::string stats_columns_markdown();

}  // namespace ccfr::io
