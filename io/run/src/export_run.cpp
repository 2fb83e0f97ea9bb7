#include "ccfr/io/export_run.hpp"

#include <algorithm>
#include <memory>
#include <string>
#include <system_error>

#include "ccfr/core/error.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_audit.hpp"
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

int export_run(const fs::path& run_dir, const std::vector<std::string>& formats, const fs::path& out_dir,
               const std::string& command) {
  read_run_info(run_dir, /*require_run_json=*/true);  // a run folder, before its lock is taken
  // The run's own writer (`ccfr run`, a resume) holds this lock while it writes the folder.
  const DirLock run_lock = DirLock::acquire(run_dir, command);
  const RunInfo info = read_run_info(run_dir, /*require_run_json=*/true);
  if (info.frames.empty()) throw Error("run '" + run_dir.string() + "' has no frames/frame_*.obj to export");
  // A hole would shift every later frame in a PC2 or USDA file (Blender's frame 2 showing frame 3).
  check_frame_sequence(run_dir, 0, info.meta.every, "export writes");
  const fs::path out = out_dir.empty() ? run_dir : out_dir;
  const bool into_run = fs::exists(out) && fs::equivalent(out, run_dir);
  if (!into_run && fs::exists(out / "run.json"))
    throw Error("'" + out.string() +
                "' is another run's folder (it holds run.json): export would overwrite what "
                "that run wrote; give --out a folder of its own");
  // What the run wrote itself carries what the OBJ frames cannot give back (VTU's distance,
  // half_spaces and halted arrays; PLY and USDA written at full rate): never replaced.
  if (into_run && info.meta.frames)
    for (const std::string& f : formats)
      if (f != "obj" && std::find(info.meta.formats.begin(), info.meta.formats.end(), f) != info.meta.formats.end())
        throw Error("run '" + run_dir.string() + "' wrote " + f +
                    " itself (output.formats), with data its OBJ frames cannot rebuild; export would replace it: "
                    "give --out another folder");
  const DirLock out_lock = into_run ? DirLock() : DirLock::acquire(out, command);
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
                        !into_run;  // in the run directory they are already there
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
