// `obj`: frames/frame_N.obj, the exact positions (what `ccfr audit`, `ccfr render`, `ccfr export`
// and a resume read back).
#include <string>
#include <system_error>

#include "../builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

class ObjSink final : public FrameSink {
 public:
  ObjSink(const Topology& topo, std::uint64_t fingerprint) : topo_(topo), fingerprint_(fingerprint) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    make_dir(dir / "frames");
    write_frame_obj(dir / "frames" / frame_name(frame, "obj"), topo_, x, fingerprint_);
  }
  int saved_precision() const override { return 2; }
  FramePositions saved_positions(const fs::path& dir, const std::vector<int>&) override {
    return [dir, &topo = topo_](size_t, int frame) {
      const fs::path p = dir / "frames" / frame_name(frame, "obj");
      Frame fr = read_frame_obj(p);
      if (static_cast<Index>(fr.v.size()) != topo.num_vertices())
        throw Error("cannot resume: '" + p.string() + "' has " + std::to_string(fr.v.size()) +
                    " vertices, the run has " + std::to_string(topo.num_vertices()));
      return std::move(fr.v);
    };
  }
  // The frames after the checkpoint go (any number of digits); those before stay as they are: a
  // missing one is no gap to refuse, run.json's frames_written counts the OBJ frames on disk.
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir / "frames", ec)) {
      const std::string n = e.path().filename().string();
      if (n.size() < 11 || n.rfind("frame_", 0) != 0 || e.path().extension() != ".obj") continue;
      const std::string digits = n.substr(6, n.size() - 10);
      if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) continue;
      if (std::stol(digits) <= before.last) continue;
      std::error_code rec;
      fs::remove(e.path(), rec);
      if (rec) throw Error("cannot remove '" + e.path().string() + "': " + rec.message());
    }
  }

 private:
  const Topology& topo_;
  std::uint64_t fingerprint_;
};

}  // namespace

void register_frame_writer_obj(FrameWriterRegistry& registry) {
  registry.add({"obj",
                "frames/frame_N.obj (exact, what `ccfr audit` reads)",
                {},
                [](const ParamValues&, const FrameSinkContext& ctx) {
                  return std::make_unique<ObjSink>(ctx.topo, ctx.scene_fingerprint);
                }});
}

}  // namespace ccfr::io
