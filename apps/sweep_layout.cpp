// DIR/sweep.json: written from a SweepLayout (keeping the Slurm jobs an earlier write recorded)
// and read back, refusing a file that ccfr sweep did not write.
#include "sweep_layout.hpp"

#include <fstream>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

Json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return Json();
  Json j = Json::parse(in, nullptr, false);
  return j.is_discarded() ? Json() : j;
}

void write_sweep(const SweepLayout& s) {
  fs::create_directories(s.dir / "logs");
  const Json old = read_json(s.dir / "sweep.json");
  Json j;
  j["ccfr"] = {{"version", io::version()}, {"git_commit", io::git_commit()}};
  j["spec"] = s.spec.empty() ? Json(nullptr) : Json(s.spec.string());
  j["parameters"] = s.parameter_keys;
  j["audit_stride"] = s.audit_stride;
  if (s.cell_time_limit_s > 0.0) j["cell_time_limit_s"] = s.cell_time_limit_s;
  j["resources"] = {{"cpus_per_task", s.resources.cpus_per_task},
                    {"time", s.resources.time},
                    {"memory", s.resources.memory},
                    {"partition", s.resources.partition},
                    {"account", s.resources.account}};
  Json cells = Json::array();
  for (const auto& c : s.cells) {
    Json params = Json::object();
    for (const auto& [k, v] : c.params) params[k] = v;
    cells.push_back({{"id", c.id},
                     {"config", c.config.string()},
                     {"scene", c.scene},
                     {"solver", c.solver},
                     {"params", params},
                     {"overrides", c.overrides}});
  }
  j["cells"] = cells;
  j["slurm_jobs"] = old.is_object() && old.contains("slurm_jobs") ? old["slurm_jobs"] : Json::array();
  io::write_file_atomic(s.dir / "sweep.json", j.dump(2) + "\n");
}

SweepLayout read_sweep(const fs::path& dir) {
  const Json j = read_json(dir / "sweep.json");
  if (!j.is_object() || !j.contains("cells"))
    throw Error("'" + dir.string() + "' is not a sweep directory (no sweep.json written by ccfr sweep)");
  SweepLayout s;
  s.dir = dir;
  // at(), not operator[]: a const Json's operator[] on a missing key is undefined behaviour, and a
  // sweep.json edited by hand ({"cells": 5}) must be an error naming the file.
  try {
    s.spec = j.at("spec").is_string() ? fs::path(j.at("spec").get<std::string>()) : fs::path();
    s.parameter_keys = j.at("parameters").get<std::vector<std::string>>();
    s.audit_stride = j.at("audit_stride").get<int>();
    s.cell_time_limit_s = j.value("cell_time_limit_s", 0.0);  // absent in sweeps before it existed
    const Json& r = j.at("resources");
    s.resources = {r.at("cpus_per_task").get<int>(), r.at("time").get<std::string>(), r.at("memory").get<std::string>(),
                   r.at("partition").get<std::string>(), r.at("account").get<std::string>()};
    if (!j.at("cells").is_array()) throw Error("\"cells\" is not a list");
    for (const auto& c : j.at("cells")) {
      io::SweepCell cell;
      cell.id = c.at("id").get<std::string>();
      cell.config = c.at("config").get<std::string>();
      cell.scene = c.at("scene").get<std::string>();
      cell.solver = c.at("solver").get<std::string>();
      for (const auto& [k, v] : c.at("params").items()) cell.params.emplace_back(k, v.get<std::string>());
      cell.overrides = c.at("overrides").get<std::vector<std::string>>();
      s.cells.push_back(std::move(cell));
    }
  } catch (const Json::exception& e) {
    throw Error("'" + (dir / "sweep.json").string() + "' is damaged (not as ccfr sweep wrote it): " + e.what());
  } catch (const Error& e) {
    throw Error("'" + (dir / "sweep.json").string() + "' is damaged (not as ccfr sweep wrote it): " + e.what());
  }
  return s;
}

}  // namespace ccfr::app
