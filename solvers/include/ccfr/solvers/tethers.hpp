#pragma once
/// @file tethers.hpp
/// Long-range attachments (Kim, Chentanez and Müller 2012) of the cloths and strands held by static
/// pins: a movable vertex a rest geodesic distance L from a pinned vertex p may be at most
/// (1 + slack) L from p, the bound a sheet or strand stretched by at most the slack obeys whatever
/// its deformation (contact.tethers, docs/feasibility.md "Tethers").
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

struct SimulationParams;

class Tethers {
 public:
  Tethers() = default;
  /// With contact.momentum and contact.tethers (none otherwise), the tethers of every cloth and
  /// strand object of `params` with pin groups that do not move, slack s = contact.tether_slack:
  /// per movable vertex and group, on a flat sheet the 4 nearest pins by their straight rest
  /// distance (the geodesic on a convex sheet), otherwise the nearest along the object's rest edges
  /// (multi-source Dijkstra: a strand's arc length, on a curved sheet a path never shorter than the
  /// geodesic); each of length (1 + s) times that distance. Static pins rest where they
  /// started, so each vertex's balls share its rest position: their intersection is never empty.
  Tethers(const Topology& topo, const SimState& state, const SimulationParams& params);

  bool empty() const { return pin_.empty(); }
  /// Vertex v's tethers: the pinned vertices and the lengths (m); empty spans for an untethered one.
  std::span<const Index> pins(Index v) const { return row(pin_, v); }
  std::span<const double> lengths(Index v) const { return row(length_, v); }
  /// Moves each tethered movable vertex (inv_mass > 0) outside a tether to the nearest point of the
  /// intersection of its tethers' balls (exact for up to 8 tethers; beyond, or where the balls no
  /// longer meet, cyclic projection onto each ball in turn, at most 16 rounds). Returns how many vertices moved.
  /// Deterministic for any thread count.
  Index enforce(Positions& x, std::span<const double> inv_mass) const;
  /// enforce() for vertex v alone; true if it moved (the caller owns x[v]).
  bool cap(Positions& x, Index v) const;
  /// |P_T d̂|²: the share of a motion along d that vertex v, held on the spheres of the tethers it
  /// has reached at x (|x_v - x_p| >= (1 - 1e-9) L), can still take, P_T the projection onto their
  /// normals' orthogonal complement; 1 with none reached, 0 for d = 0.
  double share(const Positions& x, Index v, const Vec3& d) const;

 private:
  template <class T>
  std::span<const T> row(const std::vector<T>& values, Index v) const {
    if (v < 0 || v + 1 >= static_cast<Index>(start_.size())) return {};
    return std::span<const T>(values).subspan(static_cast<size_t>(start_[v]),
                                              static_cast<size_t>(start_[v + 1] - start_[v]));
  }

  std::vector<Index> start_;    ///< #V + 1: vertex v's tethers are [start_[v], start_[v+1])
  std::vector<Index> pin_;      ///< per tether: the pinned vertex
  std::vector<double> length_;  ///< per tether (m)
};

}  // namespace ccfr
