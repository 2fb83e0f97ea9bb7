#include "plot_script.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <sstream>
#include <system_error>

#include "ccfr/core/process.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;

std::optional<fs::path> find_script(const std::string& name) {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("CCFR_SCRIPTS_DIR"); env != nullptr && *env != '\0') dirs.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path().parent_path() / "share" / "ccfr" / "scripts");
  dirs.push_back(fs::path(CCFR_SOURCE_DIR) / "scripts");
  for (const fs::path& d : dirs)
    if (fs::is_regular_file(d / name, ec)) return d / name;
  return std::nullopt;
}

namespace {
std::vector<fs::path> python_candidates() {
  std::vector<fs::path> out;
  auto add = [&out](const fs::path& p) {
    if (::access(p.c_str(), X_OK) == 0 && std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
  };
  // $CCFR_PYTHON alone when set: the user chose that interpreter.
  if (const char* env = std::getenv("CCFR_PYTHON"); env != nullptr && *env != '\0') {
    add(env);
    return out;
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream ss(path);
    for (std::string dir; std::getline(ss, dir, ':');)
      if (!dir.empty()) add(fs::path(dir) / "python3");
  }
  add("/usr/bin/python3");
  return out;
}
}  // namespace

bool run_plot_script(const std::string& name, const std::vector<std::string>& args, std::string& message,
                     bool show_output) {
  const auto script = find_script(name);
  if (!script) {
    message = name + " was not found (looked in $CCFR_SCRIPTS_DIR, <prefix>/share/ccfr/scripts and " +
              (fs::path(CCFR_SOURCE_DIR) / "scripts").string() + ")";
    return false;
  }
  // The first python3 that has matplotlib: $CCFR_PYTHON (only it, when set), else each python3 on PATH (a pyenv or venv
  // one may lack it), then Debian's /usr/bin/python3 (python3-matplotlib).
  const std::vector<fs::path> pythons = python_candidates();
  if (pythons.empty()) {
    const char* env = std::getenv("CCFR_PYTHON");
    message = env != nullptr && *env != '\0'
                  ? std::string("CCFR_PYTHON=") + env + " is not an executable"
                  : std::string("python3 is not on PATH (apt-get install python3 python3-matplotlib)");
    return false;
  }
  std::optional<fs::path> python;
  for (const fs::path& p : pythons)
    if (run_process({p.string(), "-c", "import matplotlib"}, "/dev/null") == 0) {
      python = p;
      break;
    }
  if (!python) {
    std::string tried;
    for (const fs::path& p : pythons) tried += (tried.empty() ? "" : ", ") + p.string();
    message = "matplotlib is not installed for python3 (tried " + tried + "; apt-get install python3-matplotlib)";
    return false;
  }
  std::vector<std::string> argv{python->string(), script->string()};
  argv.insert(argv.end(), args.begin(), args.end());
  const int rc = run_process(argv, show_output ? fs::path() : fs::path("/dev/null"));
  if (rc != 0) {
    message = script->string() + " failed (exit code " + std::to_string(rc) + ")";
    return false;
  }
  return true;
}

}  // namespace ccfr::app
