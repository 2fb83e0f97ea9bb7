// One file per built-in broad phase, named by its key (docs/extending.md, "A broad phase: one
// file"): the registry holds exactly the files of collision/src/broad_phase/, in the order of their
// names, each registering the key it is named by, and each builds a broad phase of that name.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/collision/broad_phase.hpp"

namespace fs = std::filesystem;

TEST(BroadPhaseFiles, EveryFileUnderBroadPhaseIsTheRegisteredBroadPhaseOfItsName) {
  std::vector<std::string> keys;
  for (const auto& e : fs::directory_iterator(fs::path(CCFR_SOURCE_DIR) / "collision" / "src" / "broad_phase")) {
    if (e.path().extension() != ".cpp") continue;
    const std::string key = e.path().stem().string();
    keys.push_back(key);
    std::ifstream in(e.path());
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_NE(text.str().find("void register_broad_phase_" + key + "("), std::string::npos) << e.path();
    EXPECT_NE(text.str().find("{\"" + key + "\""), std::string::npos) << e.path();
  }
  ASSERT_FALSE(keys.empty());
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(ccfr::broad_phase_names(), keys);
  for (const std::string& key : keys) {
    const auto bp = ccfr::make_broad_phase(key, {});
    ASSERT_NE(bp, nullptr) << key;
    EXPECT_EQ(bp->name(), key);
  }
}
