// `pc2`: blender/*.pc2, one point cache per object, with the first frame as OBJ and a manifest for
// scripts/import_blender.py (Blender's Mesh Cache modifier).
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

/// A file name for an object: index and the name with anything but [A-Za-z0-9_-] replaced.
std::string file_stem(size_t index, const std::string& name) {
  char prefix[16];
  std::snprintf(prefix, sizeof prefix, "%03zu_", index);
  std::string s = prefix;
  for (unsigned char c : name) s += std::isalnum(c) || c == '_' || c == '-' ? static_cast<char>(c) : '_';
  return s;
}

/// What resume needs of a PC2 cache written by Pc2Sink: the samples it holds whole (its header's
/// count, as far as the file is that long), or why it is not one of this run's (`problem`).
struct Pc2Header {
  int count = 0;
  std::string problem;
};

Pc2Header read_pc2_header(const fs::path& p, Index nv) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {0, "'" + p.string() + "' is missing"};
  char h[32];
  if (!in.read(h, sizeof h) || std::memcmp(h, "POINTCACHE2\0", 12) != 0)
    return {0, "'" + p.string() + "' does not start with a PC2 header"};
  std::int32_t version = 0, points = 0, count = 0;
  std::memcpy(&version, h + 12, 4);
  std::memcpy(&points, h + 16, 4);
  std::memcpy(&count, h + 28, 4);
  if (version != 1 || points != nv)
    return {0, "'" + p.string() + "' holds " + std::to_string(points) + " points per sample, the object has " +
                   std::to_string(nv)};
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  if (ec) return {0, "cannot read '" + p.string() + "': " + ec.message()};
  const long long whole = nv > 0 ? static_cast<long long>((size - 32) / (12 * static_cast<std::uintmax_t>(nv))) : count;
  return {static_cast<int>(std::min<long long>(std::max(count, 0), whole)), ""};
}

/// Sample `k` of the PC2 caches of `blender` (one per object), as positions of the whole run.
Positions read_pc2_sample(const fs::path& blender, const Topology& topo, size_t k) {
  Positions x(static_cast<size_t>(topo.num_vertices()), Vec3::Zero());
  for (size_t i = 0; i < topo.objects.size(); ++i) {
    const ObjectInfo& o = topo.objects[i];
    const fs::path p = blender / (file_stem(i, o.name) + ".pc2");
    const Pc2Header h = read_pc2_header(p, o.num_vertices());
    if (!h.problem.empty()) throw Error("cannot resume: " + h.problem);
    if (static_cast<size_t>(h.count) <= k)
      throw Error("cannot resume: '" + p.string() + "' holds " + std::to_string(h.count) + " whole samples, sample " +
                  std::to_string(k) + " is needed");
    std::ifstream in(p, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(32 + k * 12 * static_cast<size_t>(o.num_vertices())));
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
      float c[3];
      if (!in.read(reinterpret_cast<char*>(c), sizeof c)) throw Error("cannot read '" + p.string() + "'");
      x[v] = Vec3(c[0], c[1], c[2]);
    }
  }
  return x;
}

class Pc2Sink final : public FrameSink {
 public:
  Pc2Sink(const Topology& topo, double fps, int every) : topo_(topo), fps_(fps), every_(every) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    const fs::path b = dir / "blender";
    if (samples_ == 0) {
      make_dir(b);
      write_frame_obj(b / "first_frame.obj", topo_, x);
      nlohmann::ordered_json m;
      m["fps"] = fps_;
      m["every"] = every_;
      m["first_frame"] = "first_frame.obj";
      m["start_frame"] = frame;
      auto& objs = m["objects"] = nlohmann::ordered_json::array();
      for (size_t i = 0; i < topo_.objects.size(); ++i) {
        const ObjectInfo& o = topo_.objects[i];
        objs.push_back({{"name", o.name},
                        {"kind", std::string(to_string(o.kind))},
                        {"pc2", file_stem(i, o.name) + ".pc2"},
                        {"vertex_begin", o.vertex_begin},
                        {"vertex_end", o.vertex_end}});
        std::string h("POINTCACHE2\0", 12);
        append_raw(h, std::int32_t{1});
        append_raw(h, static_cast<std::int32_t>(o.num_vertices()));
        append_raw(h, static_cast<float>(frame));
        append_raw(h, static_cast<float>(every_));
        append_raw(h, std::int32_t{0});
        write_file_atomic(b / (file_stem(i, o.name) + ".pc2"), h);
      }
      write_file_atomic(b / "manifest.json", m.dump(2) + "\n");
    }
    for (size_t i = 0; i < topo_.objects.size(); ++i) {
      const ObjectInfo& o = topo_.objects[i];
      std::string s;
      s.reserve(12 * static_cast<size_t>(o.num_vertices()));
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v)
        for (int k = 0; k < 3; ++k) append_raw(s, static_cast<float>(x[v][k]));
      append(b / (file_stem(i, o.name) + ".pc2"), s, samples_ + 1, o.num_vertices());
    }
    ++samples_;
  }
  // The caches are appended sample by sample: cut back to the samples before the checkpoint
  // (count first, so the file never counts more than it holds), or, if they are not whole, written
  // again from the frames on disk.
  int resume_order() const override { return 1; }
  int saved_precision() const override { return 1; }
  FramePositions saved_positions(const fs::path& dir, const std::vector<int>&) override {
    return [b = dir / "blender", &topo = topo_](size_t k, int) { return read_pc2_sample(b, topo, k); };
  }
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    samples_ = 0;
    if (before.frames.empty()) return;
    const fs::path b = dir / "blender";
    const int n = static_cast<int>(before.frames.size());
    std::string problem;
    std::error_code ec;
    for (const char* f : {"manifest.json", "first_frame.obj"})
      if (problem.empty() && !fs::is_regular_file(b / f, ec)) problem = "'" + (b / f).string() + "' is missing";
    for (size_t i = 0; i < topo_.objects.size() && problem.empty(); ++i) {
      const fs::path p = b / (file_stem(i, topo_.objects[i].name) + ".pc2");
      const Pc2Header h = read_pc2_header(p, topo_.objects[i].num_vertices());
      problem = h.problem;
      if (problem.empty() && h.count < n)
        problem = "'" + p.string() + "' holds " + std::to_string(h.count) + " whole samples, the run had written " +
                  std::to_string(n) + " frames before its checkpoint of frame " + std::to_string(before.last);
    }
    if (problem.empty()) {
      for (size_t i = 0; i < topo_.objects.size(); ++i) {
        const fs::path p = b / (file_stem(i, topo_.objects[i].name) + ".pc2");
        const std::int32_t count = n;
        const int fd = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
        const bool ok = fd >= 0 && ::pwrite(fd, &count, sizeof count, 28) == sizeof count &&
                        ::ftruncate(fd, 32 + static_cast<off_t>(n) * 12 * topo_.objects[i].num_vertices()) == 0;
        const int err = errno;
        if (fd >= 0) ::close(fd);
        if (!ok) throw Error("cannot write '" + p.string() + "': " + std::strerror(err));
      }
      samples_ = n;
      return;
    }
    if (!before.positions)
      throw Error("cannot resume: " + problem + "; without OBJ frames (output.formats has no obj) the point caches " +
                  "cannot be rebuilt: run again");
    replay_frames({this}, dir, before.frames, before.positions, before.fps, false);
  }

 private:
  /// Appends one sample after the `samples_` already counted, then raises the header's count: a
  /// file cut short by a crash holds whole samples up to its count.
  void append(const fs::path& p, const std::string& bytes, int count, Index nv) {
    const int fd = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
    auto fail = [&](int err) {
      if (fd >= 0) ::close(fd);
      throw Error("cannot write '" + p.string() + "': " + std::strerror(err));
    };
    if (fd < 0) fail(errno);
    const off_t at = 32 + static_cast<off_t>(samples_) * 12 * nv;
    if (::pwrite(fd, bytes.data(), bytes.size(), at) != static_cast<ssize_t>(bytes.size())) fail(errno ? errno : EIO);
    const std::int32_t n = count;
    if (::pwrite(fd, &n, sizeof n, 28) != sizeof n) fail(errno ? errno : EIO);
    if (::close(fd) != 0) fail(errno);
  }

  const Topology& topo_;
  double fps_;
  int every_;
  int samples_ = 0;
};

}  // namespace

void register_frame_writer_pc2(FrameWriterRegistry& registry) {
  registry.add({"pc2",
                "blender/*.pc2 point caches + first_frame.obj (Blender Mesh Cache)",
                {},
                [](const ParamValues&, const FrameSinkContext& ctx) {
                  return std::make_unique<Pc2Sink>(ctx.topo, ctx.fps, ctx.every);
                }});
}

}  // namespace ccfr::io
