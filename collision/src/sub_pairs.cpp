#include "sub_pairs.hpp"

namespace ccfr {

std::string_view to_string(ContactKind kind) {
  switch (kind) {
    case ContactKind::vf:
      return "vf";
    case ContactKind::ee:
      return "ee";
    case ContactKind::ve:
      return "ve";
    case ContactKind::vv:
      return "vv";
  }
  return "unknown";
}

namespace detail {

double sub_pair_distance_sq(const Topology& topo, const Positions& x, std::uint64_t key) {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 31) - 1;
  const auto kind = static_cast<ContactKind>(key >> 62);
  const Index a = static_cast<Index>((key >> 31) & kMask), b = static_cast<Index>(key & kMask);
  switch (kind) {
    case ContactKind::vf: {
      const Vec3i& f = topo.faces[b];
      return point_triangle(x[a], x[f[0]], x[f[1]], x[f[2]]).distance_sq;
    }
    case ContactKind::ee: {
      const Vec2i &e = topo.edges[a], &g = topo.edges[b];
      return edge_edge(x[e[0]], x[e[1]], x[g[0]], x[g[1]]).distance_sq;
    }
    case ContactKind::ve: {
      const Vec2i& e = topo.edges[b];
      return point_edge(x[a], x[e[0]], x[e[1]]).distance_sq;
    }
    case ContactKind::vv:
      return point_point_distance_sq(x[a], x[b]);
  }
  return 0.0;
}

}  // namespace detail
}  // namespace ccfr
