#pragma once
/// @file region_assembly.hpp
/// Narrow-phase stage 4 (private): the half-spaces of every contact (Alg. NarrowPhase lines 10, 26
/// and 41; Eq. 3) written to the RegionSet's CSR.
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr::detail {

/// Where the planes go: reused between passes to avoid reallocating millions of entries.
struct AssemblyBuffers {
  std::vector<Index> block_cursor;   ///< #blocks by #V plane counts, then write cursors
  std::vector<Index> plane_sources;  ///< per plane: 4 · contact + vertex slot (when recorded)
  bool record_sources = false;
  /// The large records and references of a substep's first pass, kept constructed through its
  /// small held-back passes (resize_for_overwrite with a spare).
  std::vector<RegionRecord> spare_records;
  std::vector<std::uint32_t> spare_refs;
};

/// Gives each movable vertex of side A of each of `contacts` the plane (n, s_A G) and each of side
/// B (−n, s_B G), G = φ − K_A − K_B the gap
/// left once kinematic vertices (`kinematic_step`, #V or empty) have moved; mixed_pair_record()
/// where that split cannot hold. A vertex's planes are in contact order for any thread count.
/// Throws ccfr::Error past the region's 32-bit plane references.
void assemble_regions(Index nv, const Positions& x, std::span<const double> inv_mass,
                      std::span<const Vec3> kinematic_step, std::span<const ContactPair> contacts,
                      AssemblyBuffers& work, RegionSet& regions);

}  // namespace ccfr::detail
