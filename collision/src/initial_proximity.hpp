#pragma once
/// @file initial_proximity.hpp
/// Narrow-phase stage 2 (private): what the initial configuration decides for the whole run
/// (paper §4.1, clarification 5). Sub-pairs of primitive pairs that cross are excluded; sub-pairs
/// closer than ξ keep contact with a reduced offset, fixed for mesh neighbours and raised toward ξ
/// for the others.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/contact_model.hpp"
#include "ccfr/core/topology.hpp"

namespace ccfr::detail {

/// Sub-pairs recorded in the initial configuration, each with a slot: kExcluded (never tested in
/// the run) or the index of its reduced offset. One CSR per kind (row = first canonical id, sorted
/// second ids): a lookup touches one short contiguous row, which keeps the millions of lookups of
/// a fine cloth in cache far better than a hash table over 64-bit keys. Safe for concurrent reads.
class InitialPairTable {
 public:
  static constexpr Index kExcluded = -1;  ///< slot of a sub-pair excluded for the run
  static constexpr Index kAbsent = -2;    ///< find() of a sub-pair not in the table

  /// Replaces the table by (sub_pair_key, slot) entries. A key given twice keeps its smallest
  /// slot, so an exclusion wins over a reduced offset.
  void assign(std::vector<std::pair<std::uint64_t, Index>> entries);
  /// The slot of a sub-pair (canonical ids), or kAbsent. Inline: the narrow phase looks up
  /// millions of sub-pairs per pass. Rows are short (the sub-pairs closer than ξ around one vertex
  /// or edge), so a linear scan of the sorted row beats a binary search up to a few dozen entries.
  Index find(ContactKind kind, Index a, Index b) const {
    const Rows& r = rows_[static_cast<size_t>(kind)];
    if (a + 1 >= static_cast<Index>(r.row_start.size())) return kAbsent;
    const Index* base = r.cols.data();
    const Index* first = base + r.row_start[a];
    const Index* last = base + r.row_start[a + 1];
    if (last - first > kLinearScan) {
      first = std::lower_bound(first, last, b);
    } else {
      for (; first != last && *first < b; ++first) {
      }
    }
    return first != last && *first == b ? r.slots[static_cast<size_t>(first - base)] : kAbsent;
  }
  bool excluded(ContactKind kind, Index a, Index b) const { return find(kind, a, b) == kExcluded; }
  size_t size() const { return size_; }
  size_t num_excluded() const { return excluded_; }

 private:
  struct Rows {
    std::vector<Index> row_start, cols, slots;
  };
  static constexpr std::ptrdiff_t kLinearScan = 32;
  std::array<Rows, 4> rows_;
  size_t size_ = 0, excluded_ = 0;
};

/// The initial configuration's verdicts and the reduced offsets, the detector's only state that
/// changes during a run. Offsets are in m; a slot indexes reduced_key, reduced_offset and
/// reduced_fixed alike.
struct InitialPairs {
  InitialPairTable table;
  InitialProximity proximity;
  std::vector<std::uint64_t> reduced_key;   ///< per slot: the sub-pair's key (sub_pair_key)
  std::vector<double> reduced_offset;       ///< per slot: current offset, never lowered, at most ξ
  std::vector<std::uint8_t> reduced_fixed;  ///< per slot: mesh neighbours, offset never raised
  std::vector<Index> active;                ///< slots whose offset is below ξ and may rise, ascending

  /// The sub-pair's current offset: `xi`, or its reduced offset while that is below ξ.
  double offset(ContactKind kind, Index a, Index b, double xi) const;
  /// Raises the active offsets to min(ξ, (1 − m) d) at the (feasible) positions x and drops those
  /// that reached ξ. One slot per task: independent of the thread count.
  void raise(const Topology& topo, const Positions& x, double xi);
  /// Restores offsets saved from a run on the same initial configuration (checkpoints); throws
  /// ccfr::Error on another count, a non-finite value, or one outside [initial value, ξ].
  void restore(std::span<const double> offsets, double xi);

  /// What raise() can change from here on: the active slots and their offsets (few, once the
  /// run's first contacts have parted).
  struct Mark {
    std::vector<Index> active;
    std::vector<double> offset;  ///< per entry of `active`
  };
  /// Records the mark (an attempt at a substep that may be solved again from its start).
  void mark(Mark& m) const;
  /// Puts the offsets and the active list back where mark() found them: the raises of an
  /// abandoned attempt, made at positions the run never reached, are undone.
  void roll_back(const Mark& m);
};

/// Runs the broad phase at `initial` (pairs between obstacle primitives left out, the candidates
/// kept in `candidates`) and decides every sub-pair's fate: crossings, close pairs, adjacency,
/// then the log lines and warnings.
InitialPairs find_initial_pairs(const Topology& topo, const CollisionPrimitives& prims, BroadPhase& broad,
                                const Positions& initial, const ContactModel& params,
                                std::vector<IndexPair>& candidates);

}  // namespace ccfr::detail
