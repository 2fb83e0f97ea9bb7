// Shell helpers of the sweep backends (sweep_shell.hpp): quoting, capturing a command's output,
// this executable's path.
#include "sweep_shell.hpp"

#include <sys/wait.h>

#include <cstdio>

namespace ccfr::app {

namespace fs = std::filesystem;

std::pair<int, std::string> capture(const std::string& cmd) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

std::string single_quote(const std::string& a) {
  std::string o = "'";
  for (char c : a) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

fs::path self_exe() { return fs::read_symlink("/proc/self/exe"); }

}  // namespace ccfr::app
