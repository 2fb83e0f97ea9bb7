// libFuzzer target: OBJ bytes -> ccfr::io::read_frame_obj and read_obj_mesh (frames read back by
// `ccfr audit` / `render`, meshes imported by scenes), and the same bytes as an OFF mesh
// (read_off_mesh; the corpus holds OFF seeds too). The readers take a path, so each input is
// written to one temporary file per process. A frame that reads without error must be
// self-consistent: every index in range, every object's ranges inside the global arrays.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "ccfr/io/obj.hpp"
#include "fuzz_support.hpp"

namespace fs = std::filesystem;

namespace {
const fs::path& input_file() {
  static const fs::path p = [] {
    const fs::path f = fs::temp_directory_path() / ("ccfr_fuzz_obj_" + std::to_string(::getpid()) + ".obj");
    std::atexit([] {
      std::error_code ec;
      fs::remove(input_file(), ec);
    });
    return f;
  }();
  return p;
}

void check(bool ok, const char* what) {
  if (!ok) ccfr::fuzz::finding("read_frame_obj", "an inconsistent frame", what);
}

void check_frame(const ccfr::io::Frame& fr) {
  const auto nv = static_cast<ccfr::Index>(fr.v.size());
  auto in_range = [&](ccfr::Index i) { return i >= 0 && i < nv; };
  for (const auto& f : fr.faces) check(in_range(f[0]) && in_range(f[1]) && in_range(f[2]), "face index out of range");
  for (const auto& l : fr.lines) {
    check(l.size() >= 2, "polyline with fewer than 2 vertices");
    for (auto i : l) check(in_range(i), "polyline index out of range");
  }
  for (auto i : fr.points) check(in_range(i), "point index out of range");
  for (const auto& o : fr.objects) {
    check(0 <= o.vertex_begin && o.vertex_begin <= o.vertex_end && o.vertex_end <= nv, "object vertex range");
    check(0 <= o.face_begin && o.face_begin <= o.face_end && o.face_end <= ccfr::Index(fr.faces.size()),
          "object face range");
    check(0 <= o.line_begin && o.line_begin <= o.line_end && o.line_end <= ccfr::Index(fr.lines.size()),
          "object line range");
    check(0 <= o.point_begin && o.point_begin <= o.point_end && o.point_end <= ccfr::Index(fr.points.size()),
          "object point range");
  }
}
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  ccfr::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  {
    std::ofstream out(input_file(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) return 0;  // disk trouble is not the reader's fault
  }
  ccfr::io::Frame fr;
  if (ccfr::fuzz::expect_ccfr_error("read_frame_obj", [&] { fr = ccfr::io::read_frame_obj(input_file()); }))
    check_frame(fr);
  ccfr::fuzz::expect_ccfr_error("read_obj_mesh", [&] { (void)ccfr::io::read_obj_mesh(input_file()); });
  ccfr::io::ObjMesh off;
  if (ccfr::fuzz::expect_ccfr_error("read_off_mesh", [&] { off = ccfr::io::read_off_mesh(input_file()); })) {
    const auto nv = static_cast<ccfr::Index>(off.v.size());
    for (const auto& f : off.f)
      for (int k = 0; k < 3; ++k)
        if (f[k] < 0 || f[k] >= nv) ccfr::fuzz::finding("read_off_mesh", "a mesh", "face index out of range");
    if (off.face_lines.size() != off.f.size()) ccfr::fuzz::finding("read_off_mesh", "a mesh", "face lines");
  }
  return 0;
}
