#pragma once
/// @file contact_sink.hpp
/// The detection pass's policy for ClosestPoints (sub_pairs.hpp): the exclusion look-up, the range
/// check φ < 2r and the contact record, and the list when one is being built (reuse_list.hpp).
/// Header-only so that everything but the distance kernels inlines into the candidate loop and the
/// contact is built in place: this bookkeeping cost more instructions than the kernels themselves.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "initial_proximity.hpp"
#include "reuse_list.hpp"
#include "sub_pairs.hpp"

namespace ccfr::detail {

/// Below this distance (m) the closest points coincide numerically: the pair touches or
/// intersects and has no usable normal.
inline constexpr double kMinNormalDistance = 1e-12;

/// Records each sub-pair within range that has a movable vertex as a contact (one buffer per
/// chunk); the half-spaces are derived from the contacts afterwards (region_assembly.hpp).
struct ContactPolicy {
  static constexpr bool kCullFar = true;
  std::span<const double> w;  ///< inverse masses (#V)
  const InitialPairTable& table;
  const std::vector<double>& reduced;  ///< current offset per reduced slot (m)
  const std::uint8_t* fixed;           ///< per reduced slot: mesh neighbours (InitialPairs::reduced_fixed)
  double xi;
  double reach_m, reach_sq_m;  ///< 2r + ξ and its square
  std::vector<ContactPair>& contacts;
  /// When building the list: every sub-pair within `list_reach` (2r + ξ + s) that has a movable
  /// vertex goes there, and the pre-filters use `list_reach`.
  std::vector<ListedSubPair>* list = nullptr;
  double list_reach = 0.0, list_reach_sq = 0.0;
  Index within = 0, degenerate = 0, excluded = 0, reduced_contacts = 0;

  /// Adds this policy's counters to a pass's statistics.
  void add_to(DetectionStats& stats) const {
    stats.pairs_within_range += within;
    stats.excluded_initial += excluded;
    stats.degenerate += degenerate;
    stats.reduced_offset += reduced_contacts;
  }
  /// Per vertex (#V, m), or null: how far each vertex may move in this pass (contact.adaptive_reach,
  /// contact.momentum's last pass); a sub-pair is then in range within ρ_A + ρ_B + ξ, ρ a side's
  /// largest vertex reach, instead of 2r + ξ. Never set while a list is built (detect() does not
  /// list in such a pass).
  const double* vertex_reach = nullptr;

  /// ρ_A + ρ_B + ξ of the sub-pair `v` (side A then side B, unused -1).
  double vertex_pair_reach(ContactKind kind, const std::array<Index, 4>& v) const {
    const int na = side_a_size(kind), n = sub_pair_size(kind);
    double ra = vertex_reach[v[0]], rb = vertex_reach[v[na]];
    for (int k = 1; k < na; ++k) ra = std::max(ra, vertex_reach[v[k]]);
    for (int k = na + 1; k < n; ++k) rb = std::max(rb, vertex_reach[v[k]]);
    return ra + rb + xi;
  }
  /// Reach of the conservative pre-filters: the list's when building it, else the contacts'.
  double pair_reach(ContactKind kind, const std::array<Index, 4>& v) const {
    if (list) return list_reach;
    return vertex_reach ? vertex_pair_reach(kind, v) : reach_m;
  }
  /// False (counted) for a sub-pair excluded for the run; else its slot, kAbsent for ξ.
  bool admit(ContactKind kind, Index a, Index b, Index& slot) {
    slot = table.find(kind, a, b);
    if (slot != InitialPairTable::kExcluded) return true;
    ++excluded;
    return false;
  }
  /// Alg. NarrowPhase lines 7/22/38: φ = ‖x_A − x_B‖ − ξ < 2r ⇔ ‖x_A − x_B‖ < 2r + ξ (ρ_A + ρ_B + ξ
  /// under an adaptive reach); then the
  /// movable check and the degenerate-distance check. Returns the distance, or a negative value
  /// when the sub-pair yields no contact. A reduced offset only shrinks the range, so the reach of
  /// ξ is conservative for it. Lists the sub-pair first when a list is being built.
  double accept(ContactKind kind, Index a, Index b, Index slot, const std::array<Index, 4>& v, double dist_sq) {
    const int n = sub_pair_size(kind);
    const bool movable = w[v[0]] > 0.0 || w[v[1]] > 0.0 || (n > 2 && w[v[2]] > 0.0) || (n > 3 && w[v[3]] > 0.0);
    if (!movable) return -1.0;  // nothing here can move: nothing to constrain
    if (list && dist_sq < list_reach_sq) list->push_back(ListedSubPair::make(kind, a, b, slot, dist_sq));
    if (dist_sq >= (vertex_reach ? square(vertex_pair_reach(kind, v)) : reach_sq_m)) return -1.0;
    ++within;
    const double dist = std::sqrt(dist_sq);
    if (dist < kMinNormalDistance) {
      ++degenerate;
      return -1.0;
    }
    return dist;
  }
  void emit(ContactKind kind, Index, Index, Index slot, const std::array<Index, 4>& v, const std::array<double, 4>& wts,
            const Vec3& pa, const Vec3& pb, double dist) {
    const double offset = slot >= 0 ? reduced[static_cast<size_t>(slot)] : xi;
    const bool neighbours = slot >= 0 && fixed && fixed[slot];
    // Built whole in place: a default-constructed record overwritten field by field cost a
    // second write of its 96 bytes. n from B to A (lines 9/25/40).
    contacts.push_back(ContactPair{kind, neighbours, v, wts, (pa - pb) / dist, dist, offset});
    reduced_contacts += offset < xi;
  }
};

/// Sums the sub-pair counters of one chunk's pass into the pass's statistics.
inline void add_counts(DetectionStats& total, const DetectionStats& part) {
  total.pairs_within_range += part.pairs_within_range;
  total.excluded_initial += part.excluded_initial;
  total.degenerate += part.degenerate;
  total.reduced_offset += part.reduced_offset;
}

/// The detection pass's ClosestPoints: sink of visit_sub_pairs and evaluator of listed sub-pairs.
using ContactSink = ClosestPoints<ContactPolicy>;

/// The policy for one chunk of a pass at 2r + ξ (`params`), writing to `contacts`.
inline ContactPolicy contact_policy(std::span<const double> inv_mass, const InitialPairs& initial,
                                    const ContactModel& params, std::vector<ContactPair>& contacts) {
  const double reach = 2.0 * params.radius + params.offset;
  return ContactPolicy{inv_mass,      initial.table, initial.reduced_offset, initial.reduced_fixed.data(),
                       params.offset, reach,         reach * reach,          contacts};
}

}  // namespace ccfr::detail
