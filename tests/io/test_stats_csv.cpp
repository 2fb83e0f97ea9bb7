// stats.csv from the column table kStatsColumns: the header and rows are byte for byte what the
// hand-written snprintf of io/src/output.cpp wrote before the table (main 5311d93; the literals
// below were printed by that code), the reader maps columns by name, and docs/output.md's column
// list is the table's.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/stats_csv.hpp"

using namespace ccfr;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Values chosen to exercise every format: the extremes of int and int64, NaN and ±inf, -0,
// rounding of %.6f and %.9g, and the "unknown" markers (-1 and other negatives, non-finite).
FrameStats extremes() {
  FrameStats b;
  b.frame = 2147483647, b.sim_time = 1.0 / 3.0, b.wall_s = 0.1234565, b.cpu_s = 12345.6789012;
  b.times.xpbd = 1e-7, b.times.broad = 2.5e-6, b.times.narrow = 3.0, b.times.resolution = 0.0000005;
  b.times.check = 1e9, b.times.audit = 7.25;
  b.candidates = 2147483647, b.constraints = -2147483647 - 1, b.violations_detected = 17, b.violations_remaining = 0;
  b.halted_vertices = 123456789, b.contact_vertices = 42, b.min_distance = 1e-300, b.penetrations = 0;
  b.clamped_vertices = 3, b.outer_iterations = 64, b.substeps_run = 8, b.projector_fallbacks = 5;
  b.projector_rescues = 6, b.halted_vertices_distinct = 0, b.contact_vertices_distinct = 2147483647;
  b.candidates_total = 9223372036854775807LL, b.detections_reused = 7, b.lag_mean = 6.02214076e23, b.lag_max = -0.0;
  return b;
}

FrameStats unknowns() {
  FrameStats c;
  c.min_distance = kNaN, c.penetrations = -5, c.halted_vertices_distinct = -1, c.contact_vertices_distinct = -2;
  c.candidates_total = -9223372036854775807LL - 1, c.lag_mean = 0.1, c.lag_max = 1.0 / 7.0;
  c.sim_time = -2.5e-10, c.wall_s = -0.0000004;
  return c;
}

FrameStats non_finite() {
  FrameStats d;
  d.penetrations = 2147483647, d.sim_time = 123456789012.0, d.lag_mean = kNaN, d.lag_max = kInf;
  d.min_distance = 0.0, d.wall_s = kInf;
  return d;
}

std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(StatsCsv, HeaderIsMainsByteForByte) {
  EXPECT_EQ(io::stats_header(),
            "frame,sim_time,wall_s,xpbd_s,broad_s,narrow_s,resolution_s,candidates,constraints,violations_detected,"
            "violations_remaining,halted_vertices,min_distance,penetrations,audit_s,outer_iterations,clamped_vertices,"
            "check_s,contact_vertices,substeps_run,projector_fallbacks,halted_vertices_distinct,"
            "contact_vertices_distinct,projector_rescues,candidates_total,detections_reused,cpu_s,lag_mean,lag_max,"
            "substeps_redone,serial_s,xpbd_serial_s,broad_serial_s,narrow_serial_s,resolution_serial_s,check_serial_s,"
            "substeps_halved");
}

TEST(StatsCsv, RowsAreMainsByteForByte) {
  // Default FrameStats: min_distance +inf and the -1 markers are empty cells.
  EXPECT_EQ(io::stats_row(FrameStats{}),
            "0,0,0.000000,0.000000,0.000000,0.000000,0.000000,0,0,0,0,0,,,0.000000,0,0,0.000000,0,0,0,,,0,0,0,"
            "0.000000,0,0,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0");
  EXPECT_EQ(io::stats_row(extremes()),
            "2147483647,0.333333333,0.123456,0.000000,0.000003,3.000000,0.000000,2147483647,-2147483648,17,0,"
            "123456789,1e-300,0,7.250000,64,3,1000000000.000000,42,8,5,0,2147483647,6,9223372036854775807,7,"
            "12345.678901,6.02214076e+23,-0,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0");
  // NaN min_distance and any negative count (not just -1) are empty, as main's `>= 0` tests were.
  EXPECT_EQ(
      io::stats_row(unknowns()),
      "0,-2.5e-10,-0.000000,0.000000,0.000000,0.000000,0.000000,0,0,0,0,0,,,0.000000,0,0,0.000000,0,0,0,,,0,"
      "-9223372036854775808,0,0.000000,0.1,0.142857143,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0");
  // Columns that cannot be unknown print nan and inf as printf does; min_distance 0 is a value.
  EXPECT_EQ(io::stats_row(non_finite()),
            "0,1.23456789e+11,inf,0.000000,0.000000,0.000000,0.000000,0,0,0,0,0,0,2147483647,0.000000,0,0,0.000000,"
            "0,0,0,,,0,0,0,0.000000,nan,inf,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0");
}

TEST(StatsCsv, HugeSecondsAreNotCutShort) {
  // Main wrote into a 512-byte buffer; %.6f of 1e300 alone is 308 characters, so two such cells were
  // cut. The table writes every cell whole.
  FrameStats s;
  s.wall_s = s.cpu_s = 1e300;
  const std::string row = io::stats_row(s);
  EXPECT_GT(row.size(), 600u);
  const io::StatsCsv back = io::parse_stats_csv(io::stats_header() + "\n" + row + "\n", "t.csv");
  ASSERT_EQ(back.rows.size(), 1u);
  EXPECT_EQ(back.rows[0].wall_s, 1e300);
  EXPECT_EQ(back.rows[0].cpu_s, 1e300);
}

TEST(StatsCsv, EveryColumnHasItsOwnMember) {
  // Setting one column through the table changes that column's cell only: no two columns share a
  // member (a copy-paste slip in the table would print one value twice).
  const std::string zero = io::stats_row(FrameStats{});
  for (size_t i = 0; i < kStatsColumns.size(); ++i) {
    FrameStats s;
    kStatsColumns[i].visit(s, [](auto& v) { v = 3; });
    std::set<size_t> changed;
    for (size_t j = 0; j < kStatsColumns.size(); ++j)
      if (io::stats_cell(kStatsColumns[j], s) != io::stats_cell(kStatsColumns[j], FrameStats{})) changed.insert(j);
    EXPECT_EQ(changed, std::set<size_t>{i}) << kStatsColumns[i].name;
  }
  static_assert(stats_column("frame") == 0 && stats_column("substeps_halved") == kStatsColumns.size() - 1);
}

TEST(StatsCsv, ReadBackEqualsWhatWasWritten) {
  const std::string text = io::stats_header() + "\n" + io::stats_row(extremes()) + "\n" + io::stats_row(unknowns()) +
                           "\n" + io::stats_row(non_finite()) + "\n";
  const io::StatsCsv back = io::parse_stats_csv(text, "stats.csv");
  for (size_t i = 0; i < kStatsColumns.size(); ++i) EXPECT_TRUE(back.has(i)) << kStatsColumns[i].name;
  ASSERT_EQ(back.rows.size(), 3u);
  // Written again, every row is the same text (%.6f and %.9g round, so compare the text).
  EXPECT_EQ(io::stats_row(back.rows[0]), io::stats_row(extremes()));
  EXPECT_EQ(io::stats_row(back.rows[1]), io::stats_row(unknowns()));
  EXPECT_EQ(io::stats_row(back.rows[2]), io::stats_row(non_finite()));
  EXPECT_EQ(back.rows[0].candidates_total, 9223372036854775807LL);
  EXPECT_EQ(back.rows[0].constraints, -2147483647 - 1);
  // Empty cells read as the markers: +inf, -1.
  EXPECT_EQ(back.rows[1].min_distance, kInf);
  EXPECT_EQ(back.rows[1].penetrations, -1);
  EXPECT_EQ(back.rows[1].halted_vertices_distinct, -1);
  EXPECT_EQ(back.rows[1].contact_vertices_distinct, -1);
  EXPECT_TRUE(std::isnan(back.rows[2].lag_mean));
  EXPECT_EQ(back.rows[2].lag_max, kInf);
}

TEST(StatsCsv, ReaderGoesByColumnName) {
  // An older ccfr's file (fewer columns, another order) and a newer one's (an unknown column).
  const io::StatsCsv old = io::parse_stats_csv(
      "wall_s,frame,future_column,halted_vertices\n"
      "0.5,3,x,7\n"
      "0.25,4,y,9\n"
      "0.125,5,z\n",  // cut mid-write: the rows end here
      "old.csv");
  EXPECT_TRUE(old.has(stats_column("frame")));
  EXPECT_TRUE(old.has(stats_column("wall_s")));
  EXPECT_FALSE(old.has(stats_column("lag_mean")));
  EXPECT_FALSE(old.has(stats_column("cpu_s")));
  ASSERT_EQ(old.rows.size(), 2u);
  EXPECT_EQ(old.rows[0].frame, 3);
  EXPECT_EQ(old.rows[0].wall_s, 0.5);
  EXPECT_EQ(old.rows[0].halted_vertices, 7);
  EXPECT_EQ(old.rows[1].frame, 4);
  EXPECT_EQ(old.rows[1].halted_vertices, 9);
  EXPECT_EQ(old.rows[1].lag_mean, FrameStats{}.lag_mean);  // missing column: the default
  EXPECT_EQ(old.rows[1].min_distance, kInf);

  // Degenerate input: nothing, a header alone.
  EXPECT_TRUE(io::parse_stats_csv("", "e.csv").rows.empty());
  const io::StatsCsv header_only = io::parse_stats_csv(io::stats_header() + "\n", "h.csv");
  EXPECT_TRUE(header_only.rows.empty());
  EXPECT_TRUE(header_only.has(stats_column("cpu_s")));
  EXPECT_TRUE(io::read_stats_csv(std::filesystem::path(CCFR_BINARY_DIR) / "no-such-dir" / "stats.csv").rows.empty());
}

TEST(StatsCsv, BadCellsNameFileLineAndColumn) {
  auto error_of = [](const std::string& text) {
    try {
      io::parse_stats_csv(text, "run/stats.csv");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("frame,wall_s\n1,0.5\n2,fast\n"), "run/stats.csv:3: column 'wall_s': 'fast' is not a number");
  EXPECT_EQ(error_of("frame,candidates\n1,2.5\n"), "run/stats.csv:2: column 'candidates': '2.5' is not an integer");
  // Beyond an int column's range.
  EXPECT_EQ(error_of("frame\n2147483648\n"), "run/stats.csv:2: column 'frame': '2147483648' is not an integer");
  EXPECT_EQ(error_of("frame,wall_s\n1,\n"),
            "run/stats.csv:2: column 'wall_s': empty, but the column is always written");
  EXPECT_EQ(error_of("frame,wall_s\n1, 0.5\n"), "run/stats.csv:2: column 'wall_s': ' 0.5' is not a number");
}

TEST(StatsCsv, DocsOutputMdListsTheTable) {
  const std::string doc = read_file(std::filesystem::path(CCFR_SOURCE_DIR) / "docs" / "output.md");
  const std::string begin =
      "<!-- begin: stats.csv columns generated by scripts/gen-cli-docs (ccfr help-markdown --stats-columns) -->\n";
  const size_t b = doc.find(begin), e = doc.find("<!-- end: stats.csv columns -->");
  ASSERT_NE(b, std::string::npos) << "docs/output.md lacks the stats.csv column markers";
  ASSERT_NE(e, std::string::npos);
  EXPECT_EQ(doc.substr(b + begin.size(), e - b - begin.size()), io::stats_columns_markdown())
      << "docs/output.md's stats.csv columns are stale: run scripts/gen-cli-docs";
  // A column that can be empty says so in its meaning.
  for (const StatsColumn& c : kStatsColumns)
    if (c.unknown != StatsUnknown::never) EXPECT_NE(c.doc.find("mpty"), std::string_view::npos) << c.name;
}
