#include "ccfr/io/stats_csv.hpp"

#include <cctype>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "ccfr/core/error.hpp"

namespace ccfr::io {

const std::string& stats_header() {
  static const std::string h = [] {
    std::string s;
    for (const StatsColumn& c : kStatsColumns) (s += s.empty() ? "" : ",") += c.name;
    return s;
  }();
  return h;
}

std::string stats_cell(const StatsColumn& c, const FrameStats& s) {
  if (c.is_unknown(s)) return {};
  return c.visit(s, [&c](auto v) -> std::string {
    using T = decltype(v);
    char buf[400];  // %.6f of the largest double has 316 characters
    if constexpr (std::is_same_v<T, int>)
      std::snprintf(buf, sizeof buf, "%d", v);
    else if constexpr (std::is_same_v<T, std::int64_t>)
      std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(v));
    else if (c.format == StatsFormat::seconds)
      std::snprintf(buf, sizeof buf, "%.6f", v);
    else
      std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
  });
}

std::string stats_row(const FrameStats& s) {
  std::string row;
  for (const StatsColumn& c : kStatsColumns) {
    if (&c != kStatsColumns.data()) row += ',';
    row += stats_cell(c, s);
  }
  return row;
}

namespace {

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> out;
  for (size_t at = 0;;) {
    const size_t comma = line.find(',', at);
    out.push_back(line.substr(at, comma == std::string_view::npos ? std::string_view::npos : comma - at));
    if (comma == std::string_view::npos) return out;
    at = comma + 1;
  }
}

// Sets column C of S from CELL; false if CELL is not a value of the column.
bool set_cell(const StatsColumn& c, FrameStats& s, std::string_view cell) {
  if (cell.empty()) {
    if (c.unknown == StatsUnknown::never) return false;
    c.visit(s, [](auto& v) {
      using T = std::remove_reference_t<decltype(v)>;
      if constexpr (std::is_floating_point_v<T>)
        v = std::numeric_limits<T>::infinity();  // the default of a non-finite column (min_distance)
      else
        v = -1;
    });
    return true;
  }
  return c.visit(s, [cell](auto& v) {
    using T = std::remove_reference_t<decltype(v)>;
    if constexpr (std::is_floating_point_v<T>) {
      // strtod, not from_chars: it also reads the "inf" and "nan" that %g writes, as printf spells them.
      const std::string text(cell);
      char* end = nullptr;
      const double d = std::strtod(text.c_str(), &end);
      if (end != text.c_str() + text.size() || std::isspace(static_cast<unsigned char>(text[0]))) return false;
      v = d;
      return true;
    } else {
      T n{};
      const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), n);
      if (ec != std::errc() || end != cell.data() + cell.size()) return false;
      v = n;
      return true;
    }
  });
}

}  // namespace

StatsCsv parse_stats_csv(std::string_view text, const std::string& label) {
  StatsCsv out;
  std::vector<int> column_of;  // header field -> kStatsColumns index, -1: not a column ccfr knows
  size_t at = 0;
  for (int line_no = 1; at < text.size(); ++line_no) {
    const size_t nl = text.find('\n', at);
    std::string_view line = text.substr(at, nl == std::string_view::npos ? std::string_view::npos : nl - at);
    at = nl == std::string_view::npos ? text.size() : nl + 1;
    const auto fields = split_fields(line);
    if (line_no == 1) {
      for (std::string_view name : fields) {
        int k = -1;
        for (size_t i = 0; i < kStatsColumns.size(); ++i)
          if (kStatsColumns[i].name == name) k = static_cast<int>(i);
        if (k >= 0) out.present[static_cast<size_t>(k)] = true;
        column_of.push_back(k);
      }
      continue;
    }
    if (fields.size() != column_of.size()) break;
    FrameStats s;
    for (size_t f = 0; f < fields.size(); ++f) {
      if (column_of[f] < 0) continue;
      const StatsColumn& c = kStatsColumns[static_cast<size_t>(column_of[f])];
      if (set_cell(c, s, fields[f])) continue;
      const std::string where = label + ":" + std::to_string(line_no) + ": column '" + std::string(c.name) + "': ";
      if (fields[f].empty()) throw Error(where + "empty, but the column is always written");
      throw Error(where + "'" + std::string(fields[f]) + "' is not " +
                  (c.format == StatsFormat::integer ? "an integer" : "a number"));
    }
    out.rows.push_back(s);
  }
  return out;
}

StatsCsv read_stats_csv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error("cannot read '" + path.string() + "'");
  return parse_stats_csv(ss.str(), path.string());
}

std::string stats_columns_markdown() {
  std::string md = "| column | unit | meaning |\n|---|---|---|\n";
  for (const StatsColumn& c : kStatsColumns)
    md += "| `" + std::string(c.name) + "` | " + std::string(c.unit) + " | " + std::string(c.doc) + " |\n";
  return md;
}

}  // namespace ccfr::io
