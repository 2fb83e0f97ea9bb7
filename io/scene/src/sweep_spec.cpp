#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <map>
#include <set>

#include "ccfr/core/error.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/io/sweep_spec.hpp"
#include "ccfr/io/user_file.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "scene_schema.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

// What a sweep value loads as: a number however written (1.0e-2 and 0.01 alike), else its text.
std::string value_key(const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0') return "s" + v;
  char b[40];
  return "n" + std::string(b, std::to_chars(b, b + sizeof b, x).ptr);
}

class SpecReader {
 public:
  explicit SpecReader(fs::path file) : file_(std::move(file)), label_(file_.string()) {}

  /// `n` may be a node looked up and not found: the error then has no line (0).
  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& msg) const {
    throw ConfigError(label_, key, !n.IsDefined() || n.Mark().is_null() ? 0 : n.Mark().line + 1, msg);
  }
  /// The key of a map entry under `key`: a key path, so text; null, a list or a map names nothing.
  std::string key_path(const YAML::Node& k, const std::string& key) const {
    if (!k.IsScalar() || k.Scalar().empty())
      fail(k, key, "expected a key path as a map key, not null, a list or a map");
    return k.Scalar();
  }
  std::string scalar(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a value, not a list or map");
    return n.Scalar();
  }
  int integer(const YAML::Node& n, const std::string& key, int lo) const {
    const std::string s = scalar(n, key);
    size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || s.empty()) fail(n, key, "expected an integer, got '" + s + "'");
    if (v < lo) fail(n, key, "must be >= " + std::to_string(lo) + ", got " + s);
    return v;
  }
  std::vector<std::string> list(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence()) fail(n, key, "expected a list");
    if (n.size() == 0) fail(n, key, "is an empty list");
    std::vector<std::string> out;
    for (size_t i = 0; i < n.size(); ++i) out.push_back(scalar(n[i], key + "[" + std::to_string(i) + "]"));
    return out;
  }
  /// yaml-cpp keeps both entries of a key given twice and `n[key]` finds the first: one of them
  /// would be ignored without a word.
  void no_duplicate_keys(const YAML::Node& n, const std::string& key) const {
    if (n.IsSequence())
      for (size_t i = 0; i < n.size(); ++i) no_duplicate_keys(n[i], key + "[" + std::to_string(i) + "]");
    if (!n.IsMap()) return;
    std::set<std::string> seen;
    for (const auto& kv : n) {
      const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      const std::string path = key.empty() ? k : key + "." + k;
      if (!seen.insert(k).second)
        fail(kv.first, path, "duplicate key '" + k + "' (given twice in one map: one would be ignored)");
      no_duplicate_keys(kv.second, path);
    }
  }
  void only(const YAML::Node& n, const std::string& key, const std::set<std::string>& known) const {
    if (!n.IsMap()) fail(n, key, "expected a map");
    for (const auto& kv : n) {
      const std::string k = kv.first.Scalar();
      if (!known.count(k)) {
        std::string list;
        for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
        fail(kv.first, key.empty() ? k : key + "." + k, "unknown key '" + k + "'; known: " + list);
      }
    }
  }

 private:
  fs::path file_;
  std::string label_;
};

// Characters kept in a cell id as they are; others become '_'.
std::string id_part(const std::string& s) {
  std::string o;
  for (char c : s)
    o += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '=' || c == '+') ? c : '_';
  return o;
}

}  // namespace

std::vector<SweepCell> expand_sweep(const std::vector<fs::path>& configs, const std::vector<std::string>& solvers,
                                    const std::vector<std::string>& keys,
                                    const std::vector<std::vector<std::string>>& cases,
                                    const std::vector<std::string>& set, int frames, bool solver_ids_only) {
  std::vector<SweepCell> cells;
  const std::vector<std::string> solver_list = solvers.empty() ? std::vector<std::string>{""} : solvers;
  const std::vector<std::vector<std::string>> case_list =
      cases.empty() ? std::vector<std::vector<std::string>>{{}} : cases;
  std::set<std::string> ids;
  for (const auto& cfg : configs)
    for (const auto& solver : solver_list)
      for (const auto& values : case_list) {
        SweepCell c;
        c.config = cfg;
        c.scene = cfg.stem().string();
        c.solver = solver;
        c.overrides = set;
        if (frames >= 0) c.overrides.push_back("time.frames=" + std::to_string(frames));
        if (!solver.empty()) c.overrides.push_back("contact.solver=" + solver);
        std::string id =
            solver_ids_only ? id_part(solver) : id_part(c.scene) + "__" + id_part(solver.empty() ? "scene" : solver);
        for (size_t k = 0; k < keys.size(); ++k) {
          c.params.emplace_back(keys[k], values[k]);
          c.overrides.push_back(keys[k] + "=" + values[k]);
          id += "__" + id_part(keys[k] + "=" + values[k]);
        }
        if (!ids.insert(id).second)
          throw Error("two cells of the sweep would share the id '" + id +
                      "' (the same scene file name, solver and values twice); rename a scene or drop the duplicate");
        c.id = id;
        cells.push_back(std::move(c));
      }
  return cells;
}

double parse_slurm_duration(const std::string& text) {
  // Fields as unsigned integers; any other character, an empty field or a missing one is invalid.
  const auto fields = [](const std::string& t, char sep) {
    std::vector<long> out;
    size_t b = 0;
    while (true) {
      const size_t e = t.find(sep, b);
      const std::string f = t.substr(b, e == std::string::npos ? std::string::npos : e - b);
      if (f.empty() || f.size() > 9 || f.find_first_not_of("0123456789") != std::string::npos)
        return std::vector<long>{};
      out.push_back(std::stol(f));
      if (e == std::string::npos) return out;
      b = e + 1;
    }
  };
  const size_t dash = text.find('-');
  if (dash != std::string::npos) {  // D-H, D-H:MM, D-H:MM:SS
    const auto d = fields(text.substr(0, dash), ':');
    const auto h = fields(text.substr(dash + 1), ':');
    if (d.size() != 1 || h.empty() || h.size() > 3) return -1.0;
    const double hms[3] = {static_cast<double>(h[0]), h.size() > 1 ? double(h[1]) : 0.0,
                           h.size() > 2 ? double(h[2]) : 0.0};
    return ((d[0] * 24.0 + hms[0]) * 60.0 + hms[1]) * 60.0 + hms[2];
  }
  const auto f = fields(text, ':');
  switch (f.size()) {
    case 1:
      return f[0] * 60.0;  // minutes
    case 2:
      return f[0] * 60.0 + f[1];  // MM:SS
    case 3:
      return (f[0] * 60.0 + f[1]) * 60.0 + f[2];  // H:MM:SS
    default:
      return -1.0;
  }
}

namespace {

// configs: the scene files (relative to the spec's folder), each of which must exist.
void read_configs(const SpecReader& r, const YAML::Node& root, SweepSpec& s) {
  if (!root["configs"]) r.fail(root, "configs", "is required: the scene files of the sweep");
  for (const auto& c : r.list(root["configs"], "configs")) {
    fs::path p = fs::path(c).is_absolute() ? fs::path(c) : s.file.parent_path() / c;
    p = p.lexically_normal();
    if (!fs::is_regular_file(p)) r.fail(root["configs"], "configs", "scene file '" + p.string() + "' does not exist");
    s.configs.push_back(p);
  }
}

// solvers: registered contact solvers only; absent, each scene keeps its own.
void read_solvers(const SpecReader& r, const YAML::Node& root, SweepSpec& s) {
  if (!root["solvers"]) return;
  s.solvers = r.list(root["solvers"], "solvers");
  for (size_t i = 0; i < s.solvers.size(); ++i)
    if (!contact_solvers().find(s.solvers[i])) {
      std::string known;
      for (const auto& n : registered_contact_solvers()) known += (known.empty() ? "" : ", ") + n;
      r.fail(root["solvers"][i], "solvers[" + std::to_string(i) + "]",
             "unknown contact solver '" + s.solvers[i] + "'; registered: " + known);
    }
}

// combine: how the parameter lists make cases, product (the default) or zip; `cases` are listed
// one by one, so combine beside them would be ignored.
std::string read_combine(const SpecReader& r, const YAML::Node& root) {
  std::string combine = "product";
  if (root["combine"]) {
    combine = r.scalar(root["combine"], "combine");
    if (combine != "product" && combine != "zip")
      r.fail(root["combine"], "combine", "must be product or zip, got '" + combine + "'");
    if (root["cases"] && !root["parameters"])
      r.fail(root["combine"], "combine",
             "applies only with parameters (how their lists make cases); cases are listed one by one: drop combine");
  }
  return combine;
}

// zip: case i takes value i of every list, so the lists must be of one length. No lists: one
// case that sets nothing, as product gives.
std::vector<std::vector<std::string>> zip_cases(const SpecReader& r, const YAML::Node& p,
                                                const std::vector<std::string>& keys,
                                                const std::vector<std::vector<std::string>>& values) {
  if (values.empty()) return {{}};
  std::vector<std::vector<std::string>> cases;
  for (size_t k = 1; k < values.size(); ++k)
    if (values[k].size() != values[0].size())
      r.fail(p[keys[k]], "parameters." + keys[k],
             "combine: zip needs lists of one length: " + std::to_string(values[k].size()) + " values, '" + keys[0] +
                 "' has " + std::to_string(values[0].size()));
  for (size_t i = 0; i < values[0].size(); ++i) {
    std::vector<std::string> c;
    for (const auto& v : values) c.push_back(v[i]);
    cases.push_back(c);
  }
  return cases;
}

// product: every combination of the lists' values, the first key's outermost.
std::vector<std::vector<std::string>> product_cases(const std::vector<std::vector<std::string>>& values) {
  std::vector<std::vector<std::string>> cases = {{}};
  for (const auto& v : values) {
    std::vector<std::vector<std::string>> next;
    for (const auto& c : cases)
      for (const auto& x : v) {
        next.push_back(c);
        next.back().push_back(x);
      }
    cases = std::move(next);
  }
  return cases;
}

// The first row that loads as an earlier one (values however written) as {earlier, later}, else
// {0, 0}: two such rows would run identical cells.
std::pair<size_t, size_t> repeated_row(const std::vector<std::vector<std::string>>& rows) {
  std::map<std::string, size_t> seen;
  for (size_t i = 0; i < rows.size(); ++i) {
    std::string key;
    for (const auto& v : rows[i]) key += value_key(v) + '\n';
    const auto [at, fresh] = seen.emplace(key, i);
    if (!fresh) return {at->second, i};
  }
  return {0, 0};
}

// A value repeated in one list of a grid, or in every list at once for zip (a repeated case).
void refuse_repeated_values(const SpecReader& r, const YAML::Node& p, const std::vector<std::string>& keys,
                            const std::vector<std::vector<std::string>>& values,
                            const std::vector<std::vector<std::string>>& cases, bool zip) {
  for (size_t k = 0; k < (zip ? std::min<size_t>(1, keys.size()) : keys.size()); ++k) {
    std::vector<std::vector<std::string>> rows;
    for (const auto& v : values[k]) rows.push_back({v});
    const auto [was, i] = repeated_row(zip ? cases : rows);
    if (i != 0)
      r.fail(p[keys[k]][i], "parameters." + keys[k] + "[" + std::to_string(i) + "]",
             "'" + values[k][i] + "' is the value of [" + std::to_string(was) + "] ('" + values[k][was] + "') again" +
                 (zip ? " in every list" : "") + ": its cells would be identical; drop one");
  }
}

// parameters: a map of key path -> list of values, whose lists make the cases by `combine`.
void read_parameters(const SpecReader& r, const YAML::Node& p, const std::string& combine, SweepSpec& s) {
  if (!p.IsMap()) r.fail(p, "parameters", "expected a map of key.path: [values]");
  std::vector<std::vector<std::string>> values;
  for (const auto& kv : p) {
    const std::string key = r.key_path(kv.first, "parameters");
    s.parameter_keys.push_back(key);
    values.push_back(r.list(kv.second, "parameters." + key));
  }
  s.cases = combine == "zip" ? zip_cases(r, p, s.parameter_keys, values) : product_cases(values);
  refuse_repeated_values(r, p, s.parameter_keys, values, s.cases, combine == "zip");
}

// cases: a list of maps key path -> value, every one with the keys of cases[0] in its order, no
// two alike; [{}] sets nothing (one case, as no cases).
void read_cases(const SpecReader& r, const YAML::Node& cs, SweepSpec& s) {
  if (!cs.IsSequence() || cs.size() == 0) r.fail(cs, "cases", "expected a non-empty list of maps key.path: value");
  for (size_t i = 0; i < cs.size(); ++i) {
    const std::string key = "cases[" + std::to_string(i) + "]";
    if (!cs[i].IsMap()) r.fail(cs[i], key, "expected a map key.path: value");
    std::vector<std::string> keys, vals;
    for (const auto& kv : cs[i])
      keys.push_back(r.key_path(kv.first, key)), vals.push_back(r.scalar(kv.second, key + "." + keys.back()));
    if (i == 0) s.parameter_keys = keys;
    if (keys != s.parameter_keys) r.fail(cs[i], key, "every case must set the same keys in the same order as cases[0]");
    s.cases.push_back(vals);
  }
  const auto [was, i] = repeated_row(s.cases);
  if (i != 0)
    r.fail(cs[i], "cases[" + std::to_string(i) + "]",
           "repeats cases[" + std::to_string(was) + "] (the same values): its cells would be identical; drop one");
}

// set, frames, audit_stride and cell_time_limit: what every cell runs with.
void read_cell_settings(const SpecReader& r, const YAML::Node& root, SweepSpec& s) {
  if (const YAML::Node st = root["set"]) {
    if (!st.IsMap()) r.fail(st, "set", "expected a map key.path: value");
    for (const auto& kv : st) {
      const std::string k = r.key_path(kv.first, "set");
      s.set.push_back(k + "=" + r.scalar(kv.second, "set." + k));
    }
  }
  if (root["frames"]) s.frames = r.integer(root["frames"], "frames", 0);
  if (root["audit_stride"]) s.audit_stride = r.integer(root["audit_stride"], "audit_stride", 1);
  if (const YAML::Node t = root["cell_time_limit"]) {
    const std::string text = r.scalar(t, "cell_time_limit");
    s.cell_time_limit_s = parse_slurm_duration(text);
    if (!(s.cell_time_limit_s > 0.0))
      r.fail(t, "cell_time_limit",
             "expected a positive duration as Slurm writes it (45 minutes: 45, 45:00 or 0:45:00; also D-H:MM:SS), "
             "got '" +
                 text + "'");
  }
}

// resources: what each Slurm array task asks for.
void read_resources(const SpecReader& r, const YAML::Node& root, SweepSpec& s) {
  if (const YAML::Node res = root["resources"]) {
    r.only(res, "resources", {"cpus_per_task", "time", "memory", "partition", "account"});
    if (res["cpus_per_task"]) s.resources.cpus_per_task = r.integer(res["cpus_per_task"], "resources.cpus_per_task", 1);
    if (res["time"]) s.resources.time = r.scalar(res["time"], "resources.time");
    if (res["memory"]) s.resources.memory = r.scalar(res["memory"], "resources.memory");
    if (res["partition"]) s.resources.partition = r.scalar(res["partition"], "resources.partition");
    if (res["account"]) s.resources.account = r.scalar(res["account"], "resources.account");
  }
}

// Every cell's scene with its overrides goes through the schema now (keys, types, ranges), so a
// bad `parameters` or `set` key stops the sweep before any cell runs, not when each cell starts.
void check_cells(const SpecReader& r, const YAML::Node& root, const SweepSpec& s) {
  for (size_t ci = 0; ci < s.cells.size(); ++ci) {
    const SweepCell& c = s.cells[ci];
    try {
      check_scene_keys(c.config, c.overrides);
    } catch (const Error& e) {
      // Blame the spec entry whose override the message names, else the cell's scene.
      const std::string msg = e.what();
      const auto* ce = dynamic_cast<const ConfigError*>(&e);
      // An override's error reads "command line (--set k=v): 'k': ..."; in a spec there is no command line.
      const std::string shown =
          ce && ce->file().rfind("command line", 0) == 0 ? "'" + ce->key_path() + "': " + ce->detail() : msg;
      // An override is to blame when the message quotes it, or when the failing key is the
      // override's key or a section above it (contact.exact_projection for
      // contact.exact_projection.anything, a section the chosen solver does not have).
      const std::string kp = ce ? ce->key_path() : std::string();
      auto blamed = [&](const std::string& k) {
        return msg.find(k + "=") != std::string::npos ||
               (!kp.empty() && (k == kp || k.rfind(kp + ".", 0) == 0 || kp.rfind(k + ".", 0) == 0));
      };
      YAML::Node at = root["configs"];
      std::string key = "configs";
      for (const auto& [k, v] : c.params) {
        if (!blamed(k)) continue;
        if (root["parameters"]) {
          at = root["parameters"][k], key = "parameters." + k;
        } else {  // cases are the innermost loop of the cells (expand_sweep)
          const size_t i = ci % s.cases.size();
          at = root["cases"][i][k], key = "cases[" + std::to_string(i) + "]." + k;
        }
      }
      for (const auto& kv : root["set"] ? root["set"] : YAML::Node())
        if (blamed(kv.first.Scalar())) at = kv.first, key = "set." + kv.first.Scalar();
      r.fail(at, key, "cell '" + c.id + "': " + shown);
    }
  }
}

}  // namespace

SweepSpec load_sweep_spec(const fs::path& file) {
  SweepSpec s;
  s.file = fs::absolute(file).lexically_normal();
  const SpecReader r(s.file);
  const YAML::Node root =
      parse_bounded_yaml(read_user_file(s.file, "sweep spec", kMaxSceneFileBytes), s.file.string(), "sweep spec");
  r.no_duplicate_keys(root, "");
  r.only(root, "",
         {"configs", "solvers", "parameters", "combine", "cases", "set", "frames", "audit_stride", "cell_time_limit",
          "resources"});
  read_configs(r, root, s);
  read_solvers(r, root, s);
  const std::string combine = read_combine(r, root);
  if (root["parameters"] && root["cases"])
    r.fail(root["cases"], "cases", "give either parameters (a grid) or cases (a list), not both");
  if (const YAML::Node p = root["parameters"])
    read_parameters(r, p, combine, s);
  else if (const YAML::Node cs = root["cases"])
    read_cases(r, cs, s);
  read_cell_settings(r, root, s);
  read_resources(r, root, s);
  s.cells = expand_sweep(s.configs, s.solvers, s.parameter_keys, s.cases, s.set, s.frames);
  check_cells(r, root, s);
  return s;
}

}  // namespace ccfr::io
