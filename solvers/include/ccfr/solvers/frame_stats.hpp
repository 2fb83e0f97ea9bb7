#pragma once
/// @file frame_stats.hpp
/// FrameStats, one row of stats.csv, and the one table of its columns (kStatsColumns) that
/// stats.csv's header and rows, the Python stats dict, the readers of stats.csv and docs/output.md
/// are all generated from: adding a column is one member and one row of the table.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include "ccfr/core/timer.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

/// One row of stats.csv.
struct FrameStats {
  int frame = 0;
  double sim_time = 0.0;
  double wall_s = 0.0;
  /// CPU seconds of the whole process during the frame, summed over its threads (at most about
  /// wall_s times the thread count): the work of the frame independent of how many cores ran it.
  double cpu_s = 0.0;
  /// The part of wall_s outside parallel loops (SerialStopwatch): Amdahl's serial time.
  double serial_s = 0.0;
  StageTimes times;
  Index candidates = 0;            ///< largest broad-phase pair count of the frame
  Index constraints = 0;           ///< largest half-space / contact-constraint count of the frame
  Index violations_detected = 0;   ///< summed over all resolution passes of the frame
  Index violations_remaining = 0;  ///< largest count left after a substep's last pass
  Index halted_vertices = 0;       ///< summed over all resolution passes (halting events)
  /// Vertices with at least one contact (half-space or contact pair), summed over all resolution
  /// passes: the paper's "collision points"; halting in percent is 100 halted / contact_vertices.
  Index contact_vertices = 0;
  double min_distance = std::numeric_limits<double>::infinity();  ///< closest pair seen by detection
  Index penetrations = -1;                                        ///< audit count (-1: audit off)
  Index clamped_vertices = 0;                                     ///< vertices held back by the step bound r (summed)
  int outer_iterations = 0;  ///< outer iterations run in the frame (summed over substeps)
  int substeps_run = 0;      ///< substeps actually run, after automatic subdivision
  /// Substeps solved a second time from their start with contact.momentum's response because
  /// their passes ended with pairs inside their offsets (a push the fixed planes cannot pass on),
  /// and once more with push_through where the run would still stop (each solve counts).
  int substeps_redone = 0;
  /// Substeps that still ended with pairs inside their offsets, where the run would stop, and were
  /// solved again as two halves (Simulation::kSqueezeHalvings).
  int substeps_halved = 0;
  /// Plesník projections replaced by the exact projection because they landed farther from the
  /// candidate than the anchor (summed over the resolution passes; 0 for other projectors).
  Index projector_fallbacks = 0;
  /// Vertices whose unconverged Plesník passes took the exact projection instead of halting
  /// (summed over the resolution passes; 0 for other projectors or with exact_fallback off).
  Index projector_rescues = 0;
  /// Distinct vertices that halted at least once in the frame (-1: the solver does not track it).
  Index halted_vertices_distinct = -1;
  /// Distinct movable vertices with a contact in at least one of the frame's passes (-1: not
  /// tracked). The per-frame halting ratio is halted_vertices_distinct / contact_vertices_distinct.
  Index contact_vertices_distinct = -1;
  /// Broad-phase pairs summed over the frame's detection passes (one per outer iteration of every
  /// substep): the work of a frame, where `candidates` is its largest single pass.
  std::int64_t candidates_total = 0;
  /// Detection passes of the frame that evaluated the kept sub-pair list instead of running the
  /// broad phase (collision.reuse_skin); they add nothing to candidates_total.
  int detections_reused = 0;
  /// How far the contact handling kept vertices from their unconstrained step: per substep and
  /// movable vertex, |x_end - x_material|, x_material the material (XPBD) solve from the prediction
  /// and x_end where the substep left it. Mean over the movable vertices, averaged over the frame's
  /// substeps (m). It includes the contact response every solver shares (repulsion, friction);
  /// what differs between solvers is what their resolution holds back (stalling, damping).
  double lag_mean = 0.0;
  double lag_max = 0.0;  ///< the largest such distance of one vertex in the frame (m)
};

/// How a stats.csv cell is written.
enum class StatsFormat : std::uint8_t {
  integer,  ///< `%d` (an int member) or `%lld` (an std::int64_t member)
  seconds,  ///< `%.6f`: a clock reading, the only cells that differ between two runs of a scene
  real,     ///< `%.9g`
};

/// When a column's value is unknown; its stats.csv cell is then empty.
enum class StatsUnknown : std::uint8_t {
  never,       ///< always known
  non_finite,  ///< NaN or ±inf (min_distance: no pair came within range)
  negative,    ///< below 0 (-1: not measured, or not tracked by the solver)
};

/// What the Python stats dict holds for an unknown value (the CSV cell is empty either way).
enum class StatsPython : std::uint8_t {
  value,  ///< the value itself (inf, -1): what the dict has always held for these columns
  none,   ///< None
};

/// One stats.csv column: its name, how it is written, and the FrameStats member it holds.
struct StatsColumn {
  template <class T>
  using Ref = T& (*)(FrameStats&);
  std::string_view name;
  StatsFormat format;
  StatsUnknown unknown;
  StatsPython python;
  std::string_view unit;  ///< "s", "m", "count", or "" (the frame number)
  std::string_view doc;   ///< Markdown, the "meaning" cell of docs/output.md
  std::variant<Ref<int>, Ref<std::int64_t>, Ref<double>> ref;

  /// The member this column holds (`int`, `std::int64_t` or `double`), by visit.
  template <class F>
  decltype(auto) visit(FrameStats& s, F&& f) const {
    return std::visit([&](auto r) -> decltype(auto) { return f(r(s)); }, ref);
  }
  template <class F>
  decltype(auto) visit(const FrameStats& s, F&& f) const {
    // Read only: the accessors take a mutable FrameStats so that the readers can fill one.
    return std::visit([&](auto r) -> decltype(auto) { return f(std::as_const(r(const_cast<FrameStats&>(s)))); }, ref);
  }
  /// True when the value is unknown (its cell is empty).
  bool is_unknown(const FrameStats& s) const {
    return visit(s, [this](auto v) {
      if (unknown == StatsUnknown::negative) return v < 0;
      if constexpr (std::is_floating_point_v<decltype(v)>)
        return unknown == StatsUnknown::non_finite && !std::isfinite(v);
      return false;
    });
  }
};

// The member of a column: a captureless lambda whose return type is the member's own, so a member
// of a type the table cannot write (float, unsigned, ...) is a compile error.
#define CCFR_STATS_REF(member) +[](FrameStats& s) -> auto& { return s.member; }

/// Every stats.csv column, in file order (the order is part of the format: do not reorder, append).
inline constexpr auto kStatsColumns = std::to_array<StatsColumn>({
    {"frame", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "", "frame number (1 = first simulated)",
     CCFR_STATS_REF(frame)},
    {"sim_time", StatsFormat::real, StatsUnknown::never, StatsPython::value, "s",
     "simulated time at the end of the frame", CCFR_STATS_REF(sim_time)},
    {"wall_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s", "wall time of the frame",
     CCFR_STATS_REF(wall_s)},
    {"xpbd_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "material constraints + contact response and friction (the paper's \"XPBD\")", CCFR_STATS_REF(times.xpbd)},
    {"broad_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "box update, refit and pair query (\"Broad Phase\")", CCFR_STATS_REF(times.broad)},
    {"narrow_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "closest points, half-spaces, contact list (\"Narrow Phase\")", CCFR_STATS_REF(times.narrow)},
    {"resolution_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the contact solver's resolve alone (\"Resolution\"): projection, and for rigid bodies the "
     "refit and line search",
     CCFR_STATS_REF(times.resolution)},
    {"candidates", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "largest broad-phase pair count of the frame", CCFR_STATS_REF(candidates)},
    {"constraints", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "largest number of half-spaces of the frame", CCFR_STATS_REF(constraints)},
    {"violations_detected", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "vertices found outside their region, summed over all resolution passes of the frame",
     CCFR_STATS_REF(violations_detected)},
    {"violations_remaining", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "what the audit would count at the positions a substep really ends with (largest over the "
     "frame's substeps): detected sub-pairs whose exact distance is below (1 − "
     "`debug.audit_tolerance`) times their offset, plus rigid-body vertices off their body's "
     "rigid placement. Recounted after the step bound and the analytic-obstacle push. Under "
     "`contact.on_violation: error` (the default for `ccfr` and `exact_projection`) a non-zero "
     "count stops the run before the frame is written",
     CCFR_STATS_REF(violations_remaining)},
    {"halted_vertices", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "projection fallbacks to the anchor (halting events), summed over the frame's resolution "
     "passes (a vertex that halts in 3 of the 8 passes counts 3). Rigid bodies (unpinned) are "
     "never projected per vertex: their only halting event is the whole body put back at its "
     "anchor pose when its pose solve and line search find no admissible pose, and then each "
     "of its vertices counts once for that pass. Distinct vertices: `halted_vertices_distinct`",
     CCFR_STATS_REF(halted_vertices)},
    {"min_distance", StatsFormat::real, StatsUnknown::non_finite, StatsPython::value, "m",
     "closest pair seen by detection during the frame (empty if none within range)", CCFR_STATS_REF(min_distance)},
    {"penetrations", StatsFormat::integer, StatsUnknown::negative, StatsPython::none, "count",
     "exact-audit count (intersections + crossings + pairs closer than (1 - tol) ξ) when "
     "`debug.audit` is on; empty otherwise",
     CCFR_STATS_REF(penetrations)},
    {"audit_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s", "time of that audit",
     CCFR_STATS_REF(times.audit)},
    {"outer_iterations", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "outer iterations run, summed over the substeps: `time.iterations` per substep as in the "
     "paper, more (up to `time.max_iterations`) while a vertex is held back by r, fewer when "
     "every vertex arrived early",
     CCFR_STATS_REF(outer_iterations)},
    {"clamped_vertices", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "vertices still held back by the step bound r when a substep's outer iterations ran out "
     "(their intended advance was not reached: the speed was capped; a warning names the "
     "object once), summed over substeps",
     CCFR_STATS_REF(clamped_vertices)},
    {"check_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "what the substep loop adds around the resolve: analytic-obstacle push, finite checks, "
     "step bound, recount of `violations_remaining`",
     CCFR_STATS_REF(times.check)},
    {"contact_vertices", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "movable vertices with at least one contact, summed over the resolution passes (the "
     "paper's \"collision points\"); 100 · `halted_vertices` / `contact_vertices` is the halting "
     "share per pass, averaged over the frame's passes. Distinct vertices: "
     "`contact_vertices_distinct`",
     CCFR_STATS_REF(contact_vertices)},
    {"substeps_run", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "substeps actually run: `time.substeps` unless automatic subdivision split some (scripted "
     "steps above r, or free-flight advance above (max_iterations − 1) r; at most "
     "`time.max_subdivision` pieces each)",
     CCFR_STATS_REF(substeps_run)},
    {"projector_fallbacks", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "`ccfr` only: Plesník results that landed farther from the candidate than the anchor and "
     "were replaced by the exact projection (docs/feasibility.md), summed over the resolution "
     "passes",
     CCFR_STATS_REF(projector_fallbacks)},
    {"halted_vertices_distinct", StatsFormat::integer, StatsUnknown::negative, StatsPython::value, "count",
     "distinct vertices that halted at least once during the frame (rigid bodies: the vertices "
     "of a body put back whole at its anchor pose in at least one pass, each once); empty for "
     "solvers that do not track it (`toi_clamp`, `none`), 0 for `post_process`",
     CCFR_STATS_REF(halted_vertices_distinct)},
    {"contact_vertices_distinct", StatsFormat::integer, StatsUnknown::negative, StatsPython::value, "count",
     "distinct movable vertices with a contact in at least one of the frame's passes; the "
     "per-frame halting share of docs/results.md is 100 · `halted_vertices_distinct` / "
     "`contact_vertices_distinct`. Empty for `toi_clamp` and `none`",
     CCFR_STATS_REF(contact_vertices_distinct)},
    {"projector_rescues", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "`ccfr` only: projections whose Plesník passes did not converge within "
     "`contact.ccfr.max_iterations` and that took the exact projection instead of halting "
     "(`contact.ccfr.exact_fallback`, on by default), summed over the resolution passes",
     CCFR_STATS_REF(projector_rescues)},
    {"candidates_total", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "broad-phase pairs summed over every detection pass of the frame (one per outer iteration "
     "of each substep) that ran the broad phase; `candidates` is the largest single pass. A "
     "pass that builds the kept sub-pair list (`collision.reuse_skin`) uses boxes grown by "
     "s/2, so its count is larger than a plain pass's; a pass that reuses the list adds "
     "nothing. Set `collision.reuse_skin: 0` to count every pass with the paper's boxes. The "
     "paper's \"up to 8.3 M collision candidates\" does not say which of the two it counts",
     CCFR_STATS_REF(candidates_total)},
    {"detections_reused", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "detection passes of the frame that evaluated the kept sub-pair list instead of running "
     "the broad phase (`collision.reuse_skin`, docs/collision.md); their contacts equal a "
     "fresh pass's exactly",
     CCFR_STATS_REF(detections_reused)},
    {"cpu_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "CPU time of the whole process during the frame, summed over its threads (at most about "
     "`wall_s` times `--threads`): the frame's work independent of the core count. "
     "docs/results.md sets it against the paper's wall time times its 8 cores",
     CCFR_STATS_REF(cpu_s)},
    {"lag_mean", StatsFormat::real, StatsUnknown::never, StatsPython::value, "m",
     "how far the contact handling kept the vertices from their unconstrained step: in every "
     "substep, for each movable vertex, the distance between where the material (XPBD) solve "
     "from the prediction put it and where the substep left it; the mean over the movable "
     "vertices, averaged over the frame's substeps. It includes the contact response every "
     "solver shares (repulsion within δ, friction), so it is not zero in resting contact; what "
     "differs between solvers is what their resolution holds back: a vertex halted at its "
     "anchor, a trust region that also stops tangential motion (docs/methods.md)",
     CCFR_STATS_REF(lag_mean)},
    {"lag_max", StatsFormat::real, StatsUnknown::never, StatsPython::value, "m",
     "the largest of those distances of one vertex in the frame", CCFR_STATS_REF(lag_max)},
    {"substeps_redone", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "solves of the frame's substeps repeated from their start because their passes ended with "
     "pairs inside their offsets (solvers that guarantee separation): with the `contact.momentum` "
     "response (under `contact.momentum: false`), for a vertex pushed by a scripted obstacle "
     "toward a movable one whose region the fixed dividing planes leave empty; and, where the run "
     "would still stop, once more with the pushes passed on through resting pairs "
     "(docs/feasibility.md, \"Momentum through contact\"). 0 where every substep ended clean",
     CCFR_STATS_REF(substeps_redone)},
    {"serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `wall_s` spent outside parallel loops: time no extra core shortens (Amdahl's "
     "serial part; at `--threads 1`, `serial_s / wall_s` is the serial fraction s and 1 / (s + "
     "(1 - s) / p) the speed-up p threads can give at most). The stages' shares follow",
     CCFR_STATS_REF(serial_s)},
    {"xpbd_serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `xpbd_s` outside parallel loops", CCFR_STATS_REF(times.xpbd_serial)},
    {"broad_serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `broad_s` outside parallel loops", CCFR_STATS_REF(times.broad_serial)},
    {"narrow_serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `narrow_s` outside parallel loops", CCFR_STATS_REF(times.narrow_serial)},
    {"resolution_serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `resolution_s` outside parallel loops", CCFR_STATS_REF(times.resolution_serial)},
    {"check_serial_s", StatsFormat::seconds, StatsUnknown::never, StatsPython::value, "s",
     "the part of `check_s` outside parallel loops", CCFR_STATS_REF(times.check_serial)},
    {"substeps_halved", StatsFormat::integer, StatsUnknown::never, StatsPython::value, "count",
     "substeps of the frame that still ended with pairs inside their "
     "offsets after `substeps_redone`'s further solves, where the run would stop, and were solved "
     "again from their start as two halves of half the step (each through the same solves): a "
     "pile squeezed by a turning obstacle, whose pushes the shorter steps make smaller "
     "(docs/feasibility.md, \"Momentum through contact\"). 0 where every substep ended clean",
     CCFR_STATS_REF(substeps_halved)},
});

#undef CCFR_STATS_REF

/// The position of column NAME in kStatsColumns; a name that is not a column does not compile.
consteval std::size_t stats_column(std::string_view name) {
  for (std::size_t i = 0; i < kStatsColumns.size(); ++i)
    if (kStatsColumns[i].name == name) return i;
  throw "not a stats.csv column";  // not a constant expression: the call does not compile
}

namespace detail {
// The table's invariants, checked when it compiles: unique names, a format that fits the member
// (integer for int and int64, seconds/real for double), unknown markers that fit the type.
consteval bool stats_columns_consistent() {
  for (std::size_t i = 0; i < kStatsColumns.size(); ++i) {
    const StatsColumn& c = kStatsColumns[i];
    const bool is_double = std::holds_alternative<StatsColumn::Ref<double>>(c.ref);
    if (c.name.empty() || c.doc.empty() || is_double == (c.format == StatsFormat::integer)) return false;
    if ((c.unknown == StatsUnknown::non_finite && !is_double) || (c.unknown == StatsUnknown::negative && is_double))
      return false;
    if (c.unknown == StatsUnknown::never && c.python == StatsPython::none) return false;
    for (std::size_t j = 0; j < i; ++j)
      if (kStatsColumns[j].name == c.name) return false;
  }
  return true;
}
}  // namespace detail
static_assert(detail::stats_columns_consistent(),
              "kStatsColumns: duplicate name, or a format or unknown marker "
              "that does not fit its member");

}  // namespace ccfr
