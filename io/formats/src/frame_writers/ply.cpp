// `ply`: frames/frame_N.ply, binary little-endian PLY per frame (float positions, triangles, strand
// segments as `edge` elements); read back by read_ply_positions.
#include <array>
#include <cstdint>
#include <fstream>

#include "../builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

// Binary PLY: float positions, triangle faces, strand segments as `edge` elements.
class PlySink final : public FrameSink {
 public:
  explicit PlySink(const Topology& topo) : topo_(topo) {
    for (Index l = 0; l < topo.polylines.rows(); ++l) {
      const auto row = topo.polylines.row(l);
      for (size_t k = 1; k < row.size(); ++k) segments_.push_back({row[k - 1], row[k]});
    }
  }
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    std::string s = "ply\nformat binary_little_endian 1.0\ncomment ccfr frame " + std::to_string(frame) + "\n";
    s += "element vertex " + std::to_string(x.size()) + "\nproperty float x\nproperty float y\nproperty float z\n";
    s += "element face " + std::to_string(topo_.faces.size()) + "\nproperty list uchar int vertex_indices\n";
    if (!segments_.empty())
      s += "element edge " + std::to_string(segments_.size()) + "\nproperty int vertex1\nproperty int vertex2\n";
    s += "end_header\n";
    s.reserve(s.size() + x.size() * 12 + topo_.faces.size() * 13 + segments_.size() * 8);
    for (const Vec3& p : x)
      for (int k = 0; k < 3; ++k) append_raw(s, static_cast<float>(p[k]));
    for (const Vec3i& f : topo_.faces) {
      append_raw(s, std::uint8_t{3});
      for (int k = 0; k < 3; ++k) append_raw(s, static_cast<std::int32_t>(f[k]));
    }
    for (const auto& e : segments_) {
      append_raw(s, static_cast<std::int32_t>(e[0]));
      append_raw(s, static_cast<std::int32_t>(e[1]));
    }
    make_dir(dir / "frames");
    write_file_atomic(dir / "frames" / frame_name(frame, "ply"), s);
  }
  // One file per frame: the frames before the checkpoint are already as an uninterrupted run left them.
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    keep_frames_before(dir / "frames", "ply", before);
  }
  void check_resume(const fs::path& dir, const ResumedFrames& before) override {
    check_frames_before(dir / "frames", "ply", before);
  }

 private:
  const Topology& topo_;
  std::vector<std::array<Index, 2>> segments_;
};

}  // namespace

void register_frame_writer_ply(FrameWriterRegistry& registry) {
  registry.add({"ply", "frames/frame_N.ply (binary, float)", {}, [](const ParamValues&, const FrameSinkContext& ctx) {
                  return std::make_unique<PlySink>(ctx.topo);
                }});
}

Positions read_ply_positions(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open '" + path.string() + "'");
  std::string line;
  long nv = -1;
  bool binary = false;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) nv = std::stol(line.substr(15));
    if (line == "format binary_little_endian 1.0") binary = true;
  }
  if (nv < 0 || !binary) throw Error(path.string() + ": not a binary little-endian PLY with a vertex element");
  Positions x(static_cast<size_t>(nv));
  for (auto& p : x) {
    float c[3];
    if (!in.read(reinterpret_cast<char*>(c), sizeof c)) throw Error(path.string() + ": truncated vertex data");
    p = Vec3(c[0], c[1], c[2]);
  }
  return x;
}

}  // namespace ccfr::io
