// Every numeric key of the scene schema driven with extreme values (0, -1, 1e-300, 1e300, inf,
// nan, 2^31 - 1, 2^63) through load and one frame: each ends in a ccfr::Error or a sane frame,
// never another exception, a signal or a frame that runs on (issue 55: iterations 536870912
// crashed, substeps 2147483647 ran unbounded).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

const char* kScene = R"(scene: extremes
time: {fps: 60, frames: 1, substeps: 2, iterations: 2}
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [0.2, 0.2], resolution: [3, 3]}
    transform: {translate: [0, 0.05, 0]}
  - name: floor
    kind: obstacle
    shape: {type: plane, size: 1}
)";

// The number and integer keys of the reference table, as --set paths (objects[] -> objects.0,
// materials.<name> -> materials.default), with the solver their section belongs to.
struct Key {
  std::string path, solver;
};

std::vector<Key> numeric_keys() {
  std::vector<Key> keys;
  std::istringstream table(io::config_reference_markdown());
  const std::regex row(R"(^\| `([^`]+)` \| (number|integer) \|)");
  const std::vector<std::string> solvers = {
      "ccfr", "exact_projection", "successive_projection", "toi_clamp", "post_process", "ogc", "dat", "none"};
  for (std::string line; std::getline(table, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, row)) continue;
    std::string p = m[1];
    p = std::regex_replace(p, std::regex(R"(\[\])"), ".0");
    p = std::regex_replace(p, std::regex(R"(<name>)"), "default");
    Key k{p, ""};
    for (const auto& s : solvers)
      if (p.rfind("contact." + s + ".", 0) == 0) k.solver = s;
    keys.push_back(k);
  }
  return keys;
}

}  // namespace

TEST(ExtremeValues, EveryNumericKeyEndsInAnErrorOrASaneFrame) {
  const std::vector<Key> keys = numeric_keys();
  ASSERT_GT(keys.size(), 60u);
  const test::ExpectWarnings warnings;  // extreme values warn (capped speeds, clamped radii)
  const std::vector<std::string> values = {"0",    "-1",   "1e-300",     "1e300",
                                           ".inf", ".nan", "2147483647", "9223372036854775808"};
  int loaded = 0, stepped = 0;
  for (const Key& k : keys)
    for (const std::string& v : values) {
      SCOPED_TRACE(k.path + "=" + v);
      std::vector<std::string> sets{k.path + "=" + v};
      if (!k.solver.empty()) sets.push_back("contact.solver=" + k.solver);
      std::optional<io::LoadedScene> s;
      try {
        s = io::load_scene_text(kScene, "scene.yaml", ".", sets);
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()), "") << "an error without a message";
        continue;
      } catch (const std::exception& e) {
        ADD_FAILURE() << "not a ccfr::Error: " << e.what();
        continue;
      }
      ++loaded;
      try {
        Simulation sim(std::move(s->scene));
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        sim.set_cancel([deadline] { return std::chrono::steady_clock::now() > deadline; });
        sim.step_frame();
        ++stepped;
      } catch (const FrameInterrupted& e) {
        ADD_FAILURE() << "one frame ran past 10 s: " << e.what();
      } catch (const Error&) {
        // A clear error (non-finite position, a broken guarantee, a solver's own range) is fine.
      } catch (const std::exception& e) {
        ADD_FAILURE() << "not a ccfr::Error: " << e.what();
      }
    }
  std::printf("%zu keys x %zu values: %d loaded, %d stepped one frame\n", keys.size(), values.size(), loaded, stepped);
  EXPECT_GT(loaded, 50);
  EXPECT_GT(stepped, 50);
}
