// ccfr::formats alone: an OBJ frame written and read back gives the same object, positions and
// faces.
#include <ccfr/core/topology.hpp>
#include <ccfr/io/obj.hpp>

#include <cstdio>
#include <filesystem>

int main(int argc, char** argv) {
  using namespace ccfr;
  TopologyBuilder tb;
  tb.add_object("quad", ObjectKind::cloth, 4, {Vec3i(0, 1, 2), Vec3i(0, 2, 3)});
  const Topology topo = tb.finish();
  const Positions x = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 0.25, 1), Vec3(0, -0.5, 1)};
  const std::filesystem::path file = std::filesystem::path(argc > 1 ? argv[1] : ".") / "quad.obj";
  io::write_frame_obj(file, topo, x);
  const io::Frame f = io::read_frame_obj(file);
  bool same = f.v.size() == x.size() && f.faces.size() == 2 && f.objects.size() == 1 && f.objects[0].name == "quad";
  for (size_t i = 0; same && i < x.size(); ++i) same = f.v[i] == x[i];
  same = same && f.faces[0] == Vec3i(0, 1, 2) && f.faces[1] == Vec3i(0, 2, 3);
  std::printf("read back %zu vertices, %zu faces from %s\n", f.v.size(), f.faces.size(), file.string().c_str());
  if (!same) {
    std::printf("FAILED: the frame read back differs from the one written\n");
    return 1;
  }
  std::printf("consumer ok\n");
  return 0;
}
