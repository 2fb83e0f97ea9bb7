#include "ccfr/io/run_json.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/io/output.hpp"  // version(), git_commit()

namespace ccfr::io {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::string format_run_json(const RunMeta& meta, const RunProgress& progress, const std::string& config_json) {
  // The key order is the file's: a change here changes the bytes of every run.json.
  Json j;
  j["ccfr"] = {{"version", version()}, {"git_commit", git_commit()}};
  j["scene"] = meta.scene;
  j["solver"] = meta.solver;
  j["broad_phase"] = meta.broad_phase;
  j["radius"] = meta.contact.radius;
  j["offset"] = meta.contact.offset;
  j["repulsion_range"] = meta.contact.repulsion_range;
  j["fps"] = meta.fps;
  j["threads"] = meta.threads;
  j["command_line"] = meta.command_line;
  if (!meta.argv.empty()) j["argv"] = meta.argv;
  j["start_time"] = progress.start_time;
  j["end_time"] = progress.end_time ? Json(*progress.end_time) : Json(nullptr);
  j["status"] = progress.status;
  j["frames_written"] = progress.frames_written;
  if (!progress.resumed_json.empty()) j["resumed"] = Json::parse(progress.resumed_json);
  if (!progress.stop_json.empty()) j["stop"] = Json::parse(progress.stop_json);
  j["vertices"] = progress.vertices;
  if (meta.memory_estimate > 0)
    j["memory"] = {{"estimate_bytes", meta.memory_estimate},
                   {"limit_bytes", meta.memory_limit},
                   {"peak_resident_bytes", progress.peak_resident_bytes}};
  if (meta.scene_fingerprint != 0) {
    char fp[24];
    std::snprintf(fp, sizeof fp, "%016llx", static_cast<unsigned long long>(meta.scene_fingerprint));
    j["scene_fingerprint"] = fp;
  }
  if (const auto& ip = meta.initial_proximity) {
    j["initial_proximity"] = {{"adjacent_kept", ip->adjacent_kept},
                              {"reduced_offset_pairs", ip->reduced_offset},
                              {"min_reduced_offset", ip->min_reduced_offset},
                              {"intersecting_pairs", ip->intersecting_pairs},
                              {"intersecting_excluded", ip->intersecting_excluded},
                              {"shortest_edge", std::isfinite(ip->shortest_edge) ? Json(ip->shortest_edge) : Json()}};
  }
  // The resolved configuration is already JSON: embed it as such (a string only if it is not).
  Json config = Json::parse(config_json, nullptr, /*allow_exceptions=*/false);
  j["config"] = config.is_discarded() ? Json(config_json) : std::move(config);
  // Invalid UTF-8 (a byte string from the scene file) is replaced rather than aborting the run.
  return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

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

namespace {

/// Typed access to one JSON object with errors naming the file and the key path.
struct Reader {
  const fs::path& file;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw Error("'" + file.string() + "': '" + key + "' " + what);
  }
  const Json* find(const Json& obj, const char* key) const {
    if (!obj.is_object()) return nullptr;
    const auto it = obj.find(key);
    return it == obj.end() || it->is_null() ? nullptr : &*it;
  }
  double number(const Json& obj, const char* key, const std::string& path) const {
    const Json* v = find(obj, key);
    if (!v) fail(path, "is missing");
    if (!v->is_number()) fail(path, "is not a number");
    return v->get<double>();
  }
  template <class T>
  void optional_number(const Json& obj, const char* key, const std::string& path, T& out) const {
    if (const Json* v = find(obj, key)) {
      if (!v->is_number()) fail(path, "is not a number");
      out = v->get<T>();
    }
  }
  void optional_string(const Json& obj, const char* key, const std::string& path, std::string& out) const {
    if (const Json* v = find(obj, key)) {
      if (!v->is_string()) fail(path, "is not a string");
      out = v->get<std::string>();
    }
  }
};

}  // namespace

RunInfo parse_run_json(std::string_view text, const fs::path& file) {
  Json n = Json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (n.is_discarded()) throw Error("'" + file.string() + "' is not valid JSON");
  if (!n.is_object()) throw Error("'" + file.string() + "' is not a JSON object");
  const Reader rd{file};
  RunInfo info;
  info.has_run_json = true;
  RunMeta& m = info.meta;
  RunProgress& p = info.progress;
  try {
    rd.optional_string(n, "scene", "scene", m.scene);
    rd.optional_string(n, "solver", "solver", m.solver);
    rd.optional_string(n, "broad_phase", "broad_phase", m.broad_phase);
    m.contact.radius = rd.number(n, "radius", "radius");
    m.contact.offset = rd.number(n, "offset", "offset");
    m.contact.repulsion_range = rd.number(n, "repulsion_range", "repulsion_range");
    m.fps = rd.number(n, "fps", "fps");
    rd.optional_number(n, "threads", "threads", m.threads);
    rd.optional_string(n, "command_line", "command_line", m.command_line);
    if (const Json* a = rd.find(n, "argv")) {
      if (!a->is_array()) rd.fail("argv", "is not an array");
      for (const Json& s : *a) {
        if (!s.is_string()) rd.fail("argv", "holds a value that is not a string");
        m.argv.push_back(s.get<std::string>());
      }
    }
    rd.optional_string(n, "start_time", "start_time", p.start_time);
    if (rd.find(n, "end_time")) {
      p.end_time.emplace();
      rd.optional_string(n, "end_time", "end_time", *p.end_time);
    }
    // A status that is not a string (none has been written so far) is left empty, as before.
    if (const Json* s = rd.find(n, "status"); s && s->is_string()) p.status = s->get<std::string>();
    rd.optional_number(n, "frames_written", "frames_written", p.frames_written);
    if (const Json* r = rd.find(n, "resumed")) p.resumed_json = r->dump();
    if (const Json* s = rd.find(n, "stop")) p.stop_json = s->dump();
    rd.optional_number(n, "vertices", "vertices", p.vertices);
    if (const Json* mem = rd.find(n, "memory")) {
      m.memory_estimate = rd.number(*mem, "estimate_bytes", "memory.estimate_bytes");
      rd.optional_number(*mem, "limit_bytes", "memory.limit_bytes", m.memory_limit);
      rd.optional_number(*mem, "peak_resident_bytes", "memory.peak_resident_bytes", p.peak_resident_bytes);
    }
    if (const Json* fp = rd.find(n, "scene_fingerprint")) {
      if (!fp->is_string()) rd.fail("scene_fingerprint", "is not a string");
      const std::string s = fp->get<std::string>();
      std::size_t used = 0;
      try {
        m.scene_fingerprint = std::stoull(s, &used, 16);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != s.size() || s.empty()) rd.fail("scene_fingerprint", "is not a hexadecimal number: '" + s + "'");
    }
    if (const Json* ip = rd.find(n, "initial_proximity")) {
      InitialProximity& q = m.initial_proximity.emplace();
      const std::string pre = "initial_proximity.";
      rd.optional_number(*ip, "adjacent_kept", pre + "adjacent_kept", q.adjacent_kept);
      rd.optional_number(*ip, "reduced_offset_pairs", pre + "reduced_offset_pairs", q.reduced_offset);
      rd.optional_number(*ip, "min_reduced_offset", pre + "min_reduced_offset", q.min_reduced_offset);
      rd.optional_number(*ip, "intersecting_pairs", pre + "intersecting_pairs", q.intersecting_pairs);
      rd.optional_number(*ip, "intersecting_excluded", pre + "intersecting_excluded", q.intersecting_excluded);
      // Written as null when there is no deformable edge (infinity has no JSON form).
      q.shortest_edge = std::numeric_limits<double>::infinity();
      rd.optional_number(*ip, "shortest_edge", pre + "shortest_edge", q.shortest_edge);
    }

    // The resolved scene (run.json `config`): friction, the output settings and the objects.
    const Json* config = rd.find(n, "config");
    if (config && config->is_object()) {
      if (const Json* fr = rd.find(*config, "contact"); fr && (fr = rd.find(*fr, "friction"))) {
        rd.optional_number(*fr, "static", "config.contact.friction.static", m.contact.friction_static);
        rd.optional_number(*fr, "kinetic", "config.contact.friction.kinetic", m.contact.friction_kinetic);
      }
      if (const Json* out = rd.find(*config, "output")) {
        long every = m.every;
        rd.optional_number(*out, "every", "config.output.every", every);
        m.every = static_cast<int>(std::max(1L, every));
        if (const Json* f = rd.find(*out, "frames"); f && f->is_boolean()) m.frames = f->get<bool>();
        if (const Json* f = rd.find(*out, "formats"); f && f->is_array() && !f->empty()) {
          std::vector<std::string> names;
          for (const Json& s : *f) {
            if (!s.is_string()) rd.fail("config.output.formats", "holds a value that is not a string");
            names.push_back(s.get<std::string>());
          }
          try {
            m.formats = parse_output_formats(names);
          } catch (const std::exception& e) {
            rd.fail("config.output.formats", std::string("is not a list of formats: ") + e.what());
          }
        }
      }
      if (const Json* objects = rd.find(*config, "objects"); objects && objects->is_array())
        for (const Json& o : *objects) {
          const Json* kind_j = rd.find(o, "kind");
          const Json* name_j = rd.find(o, "name");
          if (!kind_j || !kind_j->is_string() || !name_j || !name_j->is_string()) continue;
          const std::string kind = kind_j->get<std::string>(), name = name_j->get<std::string>();
          if (kind == "obstacle") info.obstacles.push_back(name);
          // An obstacle read from an OBJ sequence (`animation`) may deform; every other obstacle is
          // its frame-0 shape moved rigidly. A rigid body with pins follows them: scripted.
          const bool animated = rd.find(o, "animation") != nullptr;
          const Json* pins = rd.find(o, "pins");
          const bool pinned = pins && pins->is_array() && !pins->empty();
          if (kind == "obstacle") info.objects.push_back({name, !animated, true});
          if (kind == "rigid") info.objects.push_back({name, true, pinned});
        }
    }
  } catch (const nlohmann::json::exception& e) {
    // A number out of its field's range (a negative frames_written read as long is fine; a
    // fraction where an integer is expected is converted): what is left is a malformed file.
    throw Error("'" + file.string() + "' is malformed: " + e.what());
  }
  return info;
}

RunInfo read_run_info(const fs::path& dir, bool require_run_json) {
  if (!fs::is_directory(dir)) throw Error("run directory '" + dir.string() + "' does not exist");
  const fs::path rj = dir / "run.json";
  RunInfo info;
  if (fs::exists(rj)) {
    std::ifstream in(rj, std::ios::binary);
    if (!in) throw Error("cannot read '" + rj.string() + "'");
    std::ostringstream text;
    text << in.rdbuf();
    info = parse_run_json(text.str(), rj);
  } else if (require_run_json) {
    throw Error("'" + rj.string() + "' is missing (not a ccfr run directory?)" + previous_run_note(dir));
  }
  info.dir = dir;
  info.frames = list_frames(dir);
  return info;
}

}  // namespace ccfr::io
