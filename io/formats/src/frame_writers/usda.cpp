// `usda`: usd/scene.usda, one prim per object, the topology once and `points.timeSamples` keyed by
// frame number (Blender, Houdini, usdview); written whole after the last frame.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include "../builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

/// A USD prim name: [A-Za-z_][A-Za-z0-9_]*, unique in the scene.
std::string prim_name(const std::string& name, std::set<std::string>& used) {
  std::string s;
  for (unsigned char c : name) s += std::isalnum(c) || c == '_' ? static_cast<char>(c) : '_';
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) s = "_" + s;
  std::string u = s;
  for (int k = 1; !used.insert(u).second; ++k) u = s + "_" + std::to_string(k);
  return u;
}

/// The USDA samples file of a run with neither obj nor pc2: "CCFRUSD1", the vertex count (uint32),
/// then per frame its number (int32) and 3 n float32 positions, appended as the frames come.
constexpr char kUsdaSamplesMagic[8] = {'C', 'C', 'F', 'R', 'U', 'S', 'D', '1'};
fs::path usda_samples_path(const fs::path& dir) { return dir / "usd" / "scene.usda.samples"; }

void start_usda_samples(const fs::path& dir, std::uint32_t n) {
  make_dir(dir / "usd");
  std::ofstream out(usda_samples_path(dir), std::ios::binary | std::ios::trunc);
  out.write(kUsdaSamplesMagic, sizeof kUsdaSamplesMagic);
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  if (!out) throw Error("cannot write '" + usda_samples_path(dir).string() + "'");
}

/// The samples of `frames` from DIR's USDA samples file, in that order; throws naming the file if
/// it is missing, of another vertex count, or lacks one of them.
std::vector<std::vector<float>> read_usda_samples(const fs::path& dir, const std::vector<int>& frames,
                                                  std::uint32_t n) {
  const fs::path p = usda_samples_path(dir);
  std::ifstream in(p, std::ios::binary);
  char magic[8];
  std::uint32_t count = 0;
  if (!in || !in.read(magic, sizeof magic) || !std::equal(magic, magic + 8, kUsdaSamplesMagic) ||
      !in.read(reinterpret_cast<char*>(&count), sizeof count))
    throw Error("cannot resume '" + dir.string() + "': its USDA layer is rebuilt from '" + p.string() +
                "' (output.formats has neither obj nor pc2), which is missing or not a ccfr samples file: run again");
  if (count != n)
    throw Error("cannot resume: '" + p.string() + "' holds " + std::to_string(count) + " vertices, the run has " +
                std::to_string(n));
  std::map<int, std::vector<float>> by_frame;
  std::int32_t frame = 0;
  std::vector<float> s(3 * static_cast<size_t>(n));
  while (in.read(reinterpret_cast<char*>(&frame), sizeof frame) &&
         in.read(reinterpret_cast<char*>(s.data()), static_cast<std::streamsize>(s.size() * sizeof(float))))
    by_frame[frame] = s;  // a frame cut short by a kill is not whole and is left out
  std::vector<std::vector<float>> out;
  for (int f : frames) {
    const auto it = by_frame.find(f);
    if (it == by_frame.end())
      throw Error("cannot resume: '" + p.string() + "' has no sample of frame " + std::to_string(f) +
                  ", written before the checkpoint");
    out.push_back(it->second);
  }
  return out;
}

class UsdaSink final : public FrameSink {
 public:
  UsdaSink(const Topology& topo, double fps, bool keep_samples) : topo_(topo), fps_(fps), keep_(keep_samples) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    frames_.push_back(frame);
    auto& s = samples_.emplace_back(3 * x.size());
    for (size_t v = 0; v < x.size(); ++v)
      for (int k = 0; k < 3; ++k) s[3 * v + k] = static_cast<float>(x[v][k]);
    if (!keep_) return;
    if (!started_) start_usda_samples(dir, static_cast<std::uint32_t>(x.size()));
    started_ = true;
    std::ofstream out(usda_samples_path(dir), std::ios::binary | std::ios::app);
    const std::int32_t f = frame;
    out.write(reinterpret_cast<const char*>(&f), sizeof f);
    out.write(reinterpret_cast<const char*>(s.data()), static_cast<std::streamsize>(s.size() * sizeof(float)));
    out.flush();
    if (!out) throw Error("cannot write '" + usda_samples_path(dir).string() + "'");
  }
  int resume_order() const override { return 0; }
  int saved_precision() const override { return keep_ ? 1 : 0; }
  // Read whole before any sink changes a file (resume() below starts the samples file again).
  FramePositions saved_positions(const fs::path& dir, const std::vector<int>& frames) override {
    auto samples = std::make_shared<std::vector<std::vector<float>>>(
        read_usda_samples(dir, frames, static_cast<std::uint32_t>(topo_.num_vertices())));
    return [samples](size_t k, int) {
      const std::vector<float>& s = (*samples)[k];
      Positions x(s.size() / 3);
      for (size_t v = 0; v < x.size(); ++v) x[v] = Vec3(s[3 * v], s[3 * v + 1], s[3 * v + 2]);
      return x;
    };
  }
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    // The samples file is written again from the frames read back, as the uninterrupted run did.
    if (keep_) start_usda_samples(dir, static_cast<std::uint32_t>(topo_.num_vertices()));
    started_ = true;
    FrameSink::resume(dir, before);
  }
  void finish(const fs::path& dir) override {
    if (frames_.empty()) return;
    std::string s = "#usda 1.0\n(\n    defaultPrim = \"ccfr\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n";
    s += "    startTimeCode = " + std::to_string(frames_.front()) + "\n";
    s += "    endTimeCode = " + std::to_string(frames_.back()) + "\n";
    char fps[40];
    std::snprintf(fps, sizeof fps, "%.17g", fps_);
    s += std::string("    timeCodesPerSecond = ") + fps + "\n    framesPerSecond = " + fps + "\n)\n\n";
    s += "def Xform \"ccfr\"\n{\n";
    std::set<std::string> used;
    char buf[128];
    auto points = [&](const std::vector<float>& p, const ObjectInfo& o) {
      s += "[";
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        const int n = std::snprintf(buf, sizeof buf, "%s(%.9g, %.9g, %.9g)", v == o.vertex_begin ? "" : ", ", p[3 * v],
                                    p[3 * v + 1], p[3 * v + 2]);
        s.append(buf, static_cast<size_t>(n));
      }
      s += "]";
    };
    auto ints = [&](const std::vector<Index>& a) {
      s += "[";
      for (size_t k = 0; k < a.size(); ++k) s += (k ? ", " : "") + std::to_string(a[k]);
      s += "]";
    };
    for (const ObjectInfo& o : topo_.objects) {
      const bool curves = o.polyline_end > o.polyline_begin, particles = o.kind == ObjectKind::particles;
      s += std::string("    def ") +
           (curves      ? "BasisCurves"
            : particles ? "Points"
                        : "Mesh") +
           " \"" + prim_name(o.name, used) + "\"\n    {\n";
      if (curves) {
        std::vector<Index> counts, idx;
        for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
          const auto row = topo_.polylines.row(l);
          counts.push_back(static_cast<Index>(row.size()));
        }
        s += "        uniform token type = \"linear\"\n        int[] curveVertexCounts = ";
        ints(counts);
        s += "\n";
      } else if (!particles) {
        std::vector<Index> counts(static_cast<size_t>(o.face_end - o.face_begin), 3), idx;
        for (Index f = o.face_begin; f < o.face_end; ++f)
          for (int k = 0; k < 3; ++k) idx.push_back(topo_.faces[f][k] - o.vertex_begin);
        s += "        int[] faceVertexCounts = ";
        ints(counts);
        s += "\n        int[] faceVertexIndices = ";
        ints(idx);
        s += "\n        uniform token subdivisionScheme = \"none\"\n";
      }
      s += "        custom string ccfr:name = \"" + escaped(o.name) + "\"\n";
      s += "        custom string ccfr:kind = \"" + std::string(to_string(o.kind)) + "\"\n";
      s += "        point3f[] points = ";
      points(samples_.front(), o);
      s += "\n        point3f[] points.timeSamples = {\n";
      for (size_t k = 0; k < frames_.size(); ++k) {
        s += "            " + std::to_string(frames_[k]) + ": ";
        points(samples_[k], o);
        s += ",\n";
      }
      s += "        }\n    }\n";
    }
    s += "}\n";
    make_dir(dir / "usd");
    write_file_atomic(dir / "usd" / "scene.usda", s);
  }

 private:
  static std::string escaped(const std::string& in) {
    std::string o;
    for (char c : in) o += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
    return o;
  }
  const Topology& topo_;
  double fps_;
  bool keep_ = false;     ///< keep the samples file (keeps_samples)
  bool started_ = false;  ///< the samples file was started by this sink
  std::vector<int> frames_;
  std::vector<std::vector<float>> samples_;
};

/// A resumable run writing neither obj nor pc2 has no other copy of its frames to rebuild the
/// layer from (it is written whole at the end), so the layer keeps its samples on disk as it goes.
bool keeps_samples(const FrameSinkContext& ctx) {
  auto has = [&](const char* f) { return std::find(ctx.formats.begin(), ctx.formats.end(), f) != ctx.formats.end(); };
  return ctx.resumable && !has("obj") && !has("pc2");
}

}  // namespace

void register_frame_writer_usda(FrameWriterRegistry& registry) {
  registry.add({"usda", "usd/scene.usda, time-sampled points", {}, [](const ParamValues&, const FrameSinkContext& ctx) {
                  return std::make_unique<UsdaSink>(ctx.topo, ctx.fps, keeps_samples(ctx));
                }});
}

}  // namespace ccfr::io
