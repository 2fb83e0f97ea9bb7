#include "ccfr/io/run_info.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "ccfr/core/error.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

std::vector<fs::path> list_frames(const fs::path& dir) {
  std::vector<fs::path> frames;
  const fs::path fdir = dir / "frames";
  if (!fs::is_directory(fdir)) return frames;
  for (const auto& e : fs::directory_iterator(fdir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("frame_", 0) == 0 && e.path().extension() == ".obj") frames.push_back(e.path());
  }
  std::sort(frames.begin(), frames.end());  // zero-padded names sort in frame order
  return frames;
}

RunInfo read_run_info(const fs::path& dir, bool require_run_json) {
  if (!fs::is_directory(dir)) throw Error("run directory '" + dir.string() + "' does not exist");
  RunInfo info;
  info.dir = dir;
  info.frames = list_frames(dir);
  const fs::path rj = dir / "run.json";
  if (!fs::exists(rj)) {
    if (require_run_json) throw Error("'" + rj.string() + "' is missing (not a ccfr run directory?)");
    return info;
  }
  try {
    // JSON is valid YAML flow syntax, so yaml-cpp reads run.json directly.
    const YAML::Node n = YAML::LoadFile(rj.string());
    auto num = [&](const char* key) {
      if (!n[key]) throw Error("'" + rj.string() + "' has no '" + key + "'");
      return n[key].as<double>();
    };
    info.scene = n["scene"] ? n["scene"].as<std::string>() : "";
    info.solver = n["solver"] ? n["solver"].as<std::string>() : "";
    info.radius = num("radius");
    info.offset = num("offset");
    info.repulsion_range = num("repulsion_range");
    info.fps = num("fps");
    info.has_run_json = true;
    if (n["status"] && n["status"].IsScalar()) info.status = n["status"].as<std::string>();
    if (n["frames_written"] && n["frames_written"].IsScalar()) info.frames_written = n["frames_written"].as<long>();
    // The resolved scene (run.json `config`): the renderer frames its pictures on what is not an obstacle.
    if (n["config"] && n["config"].IsMap() && n["config"]["objects"] && n["config"]["objects"].IsSequence())
      for (const YAML::Node& o : n["config"]["objects"]) {
        if (!o.IsMap() || !o["kind"] || !o["kind"].IsScalar() || !o["name"] || !o["name"].IsScalar()) continue;
        const std::string kind = o["kind"].as<std::string>(), name = o["name"].as<std::string>();
        if (kind == "obstacle") info.obstacles.push_back(name);
        // An obstacle read from an OBJ sequence (`animation`) may deform; every other obstacle is
        // its frame-0 shape moved rigidly. A rigid body with pins follows them: scripted.
        const bool animated = o["animation"] && !o["animation"].IsNull();
        const bool pinned = o["pins"] && o["pins"].IsSequence() && o["pins"].size() > 0;
        if (kind == "obstacle") info.objects.push_back({name, !animated, true});
        if (kind == "rigid") info.objects.push_back({name, true, pinned});
      }
    if (n["config"] && n["config"].IsMap() && n["config"]["output"] && n["config"]["output"].IsMap() &&
        n["config"]["output"]["every"] && n["config"]["output"]["every"].IsScalar())
      info.output_every = std::max(1L, n["config"]["output"]["every"].as<long>());
  } catch (const YAML::Exception& e) {
    throw Error("'" + rj.string() + "' is not valid JSON: " + e.msg);
  }
  return info;
}

}  // namespace ccfr::io
