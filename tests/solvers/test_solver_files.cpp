// One file per built-in contact solver, named by its key (docs/extending.md, "A contact solver
// inside ccfr: one file"): the registry holds exactly the files of solvers/src/contact/, in the
// order of their names, each registering the key it is named by.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/solvers/contact_solver.hpp"

namespace fs = std::filesystem;

TEST(SolverFiles, EveryFileUnderContactIsTheRegisteredSolverOfItsName) {
  std::vector<std::string> keys;
  for (const auto& e : fs::directory_iterator(fs::path(CCFR_SOURCE_DIR) / "solvers" / "src" / "contact")) {
    if (e.path().extension() != ".cpp") continue;
    const std::string key = e.path().stem().string();
    keys.push_back(key);
    std::ifstream in(e.path());
    std::stringstream text;
    text << in.rdbuf();
    // The file defines its registration function and registers its own key (directly or through
    // region_projection_entry).
    EXPECT_NE(text.str().find("void register_contact_solver_" + key + "("), std::string::npos) << e.path();
    EXPECT_NE(text.str().find("\"" + key + "\""), std::string::npos) << e.path();
  }
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(ccfr::registered_contact_solvers(), keys);
  for (const std::string& key : keys) EXPECT_NE(ccfr::make_contact_solver(key, {}), nullptr) << key;
}
