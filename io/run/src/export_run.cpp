#include "ccfr/io/export_run.hpp"

#include <algorithm>
#include <memory>
#include <string>
#include <system_error>

#include "ccfr/core/error.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_json.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

void make_dir(const fs::path& d) {
  std::error_code ec;
  fs::create_directories(d, ec);
  if (ec) throw Error("cannot create directory '" + d.string() + "': " + ec.message());
}

}  // namespace

int export_run(const fs::path& run_dir, const std::vector<std::string>& formats, const fs::path& out_dir) {
  const RunInfo info = read_run_info(run_dir, /*require_run_json=*/true);
  if (info.frames.empty()) throw Error("run '" + run_dir.string() + "' has no frames/frame_*.obj to export");
  const fs::path out = out_dir.empty() ? run_dir : out_dir;
  make_dir(out);
  const Frame first = read_frame_obj(info.frames.front());
  const Topology topo = topology_from_frame(first, info.frames.front());
  const double fps = info.meta.fps > 0 ? info.meta.fps : 60.0;
  auto number = [](const fs::path& p) { return std::stoi(p.stem().string().substr(6)); };
  const int every = info.frames.size() > 1 ? std::max(1, number(info.frames[1]) - number(info.frames[0])) : 1;
  std::vector<std::unique_ptr<FrameSink>> sinks;
  std::vector<FrameSink*> raw;
  // The OBJ frames are what is exported: copied as they are, not written again from the topology
  // read back.
  const bool copy_obj = std::find(formats.begin(), formats.end(), "obj") != formats.end() &&
                        !fs::equivalent(out, run_dir);  // in the run directory they are already there
  if (copy_obj) make_dir(out / "frames");
  for (const std::string& f : formats)
    if (f != "obj")
      raw.push_back(sinks.emplace_back(make_frame_sink(f, FrameSinkContext{topo, fps, every, {}, false})).get());
  std::vector<int> numbers;
  for (const fs::path& p : info.frames) numbers.push_back(number(p));
  replay_frames(
      raw, out, numbers,
      [&](size_t k, int) {
        const fs::path& p = info.frames[k];
        Frame fr = k == 0 ? first : read_frame_obj(p);
        if (!same_structure(first, fr))
          throw Error(p.string() + ": its objects or elements differ from " + info.frames.front().string());
        if (copy_obj) fs::copy_file(p, out / "frames" / p.filename(), fs::copy_options::overwrite_existing);
        return std::move(fr.v);
      },
      fps, /*velocities=*/true);
  for (auto& s : sinks) s->finish(out);
  return static_cast<int>(info.frames.size());
}

}  // namespace ccfr::io
