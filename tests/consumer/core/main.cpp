// ccfr::core alone: a quad of two triangles, its edges and vertex-face incidence against the
// values counted by hand.
#include <ccfr/core/topology.hpp>

#include <cstdio>
#include <vector>

static bool row_is(const ccfr::Csr& c, ccfr::Index i, const std::vector<ccfr::Index>& want) {
  const auto r = c.row(i);
  return std::vector<ccfr::Index>(r.begin(), r.end()) == want;
}

int main() {
  using namespace ccfr;
  TopologyBuilder tb;
  tb.add_object("quad", ObjectKind::cloth, 4, {Vec3i(0, 1, 2), Vec3i(0, 2, 3)});
  const Topology t = tb.finish();
  // 4 sides and the diagonal 0-2; vertices 0 and 2 are on both faces, 1 on the first, 3 on the second.
  const bool ok = t.num_edges() == 5 && t.vertex_faces.rows() == 4 && row_is(t.vertex_faces, 0, {0, 1}) &&
                  row_is(t.vertex_faces, 1, {0}) && row_is(t.vertex_faces, 2, {0, 1}) &&
                  row_is(t.vertex_faces, 3, {1}) && tet_boundary({Vec4i(0, 1, 2, 3)}).size() == 4;
  std::printf("edges %d, faces of vertex 0: %zu\n", static_cast<int>(t.num_edges()), t.vertex_faces.row(0).size());
  if (!ok) {
    std::printf("FAILED: the quad's topology differs from the hand count\n");
    return 1;
  }
  std::printf("consumer ok\n");
  return 0;
}
